// SPDX-License-Identifier: MIT
// modrt precompute (private) — the diffuse path-tracing estimator both ground-truth tracers run
// (path_tracer.h on a level's walls, mesh_path_tracer.h on triangle meshes), written once over
// a geometry: cosine-weighted paths, the direct radiance of every vertex (next-event estimation
// with shadow rays, the geometry's light model), light-vertex connections shared by MIS.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <span>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

#include "modrt/precompute/path_tracer.h"
#include "modrt/precompute/sampling.h"

namespace modrt::precompute::detail {

// A surface point found by a ray, or a point a path starts from: its hit record (the
// geometry's; a default-constructed one for a point on no known surface), position and the
// face normal (sign as the geometry gives it; the estimator orients it).
template <class Hit>
struct PathVertex {
  Hit hit{};
  glm::dvec3 position{0.0}, normal{0.0};
};

// What trace_paths asks of a geometry G (Vertex = PathVertex<G::Hit>):
//   bool trace(const Vertex& from, const glm::dvec3& dir, Vertex& to) const;
//       the first surface point along from.position + t dir (false: the ray left the scene)
//   bool sees(const Vertex& from, const Vertex& to) const;
//       whether the segment between them is free; the same test decides which points a
//       light-vertex ray can produce and, for path vertices, whether that technique could have
//       produced them, so the MIS weights are consistent
//   glm::dvec3 direct(const Vertex& y) const;   outgoing direct radiance at y (normal oriented)
//   glm::dvec3 albedo(const Vertex& y) const;

// Area density (per unit area at y) with which one light-vertex sample produces y: the mean
// over sources of cos_y / (4 pi d^2), for the sources that see y. y.normal may have either sign.
template <class G>
double light_vertex_density(const G& geometry, std::span<const glm::dvec3> sources,
                            const PathVertex<typename G::Hit>& y) {
  double density = 0.0;
  PathVertex<typename G::Hit> source;
  for (const glm::dvec3& c : sources) {
    const glm::dvec3 w = c - y.position;
    const double d2 = glm::dot(w, w);
    if (d2 <= 1e-300) continue;
    const double cos_y = std::abs(glm::dot(y.normal, w)) / std::sqrt(d2);
    source.position = c;
    if (cos_y <= 0.0 || !geometry.sees(source, y)) continue;
    density += cos_y / (4.0 * std::numbers::pi * d2);
  }
  return density / double(std::max<std::size_t>(sources.size(), 1));
}

// Area density with which the cosine-weighted direction from (x, nx) first hits y:
// cos_x cos_y / (pi d^2).
inline double cosine_density(const glm::dvec3& x, const glm::dvec3& nx, const glm::dvec3& y,
                             const glm::dvec3& ny) {
  const glm::dvec3 w = y - x;
  const double d2 = glm::dot(w, w);
  if (d2 <= 1e-300) return 0.0;
  const double d = std::sqrt(d2);
  const double cos_x = glm::dot(nx, w) / d;
  if (cos_x <= 0.0) return 0.0;
  return cos_x * std::abs(glm::dot(ny, w)) / d / (std::numbers::pi * d2);
}

// E_ind / pi at `count` points, start(i) giving point i as a path vertex (its unit normal on the
// side the paths leave): PathTracerSettings' paths of `bounces` segments, each bringing back
// direct(y) + albedo(y) * (the next segment's estimate). Settings already validated.
template <class G, class Start>
IndirectEstimate trace_paths(const G& geometry, std::size_t count, const Start& start,
                             const PathTracerSettings& settings) {
  using Vertex = PathVertex<typename G::Hit>;
  IndirectEstimate out;
  out.value.assign(3 * count, 0.0f);
  out.standard_error.assign(3 * count, 0.0f);
  const std::span<const glm::dvec3> sources = settings.light_vertex_sources;
  const int paths = settings.paths;
  // MIS weight of a point y seen from (x, nx), for either technique (balance heuristic,
  // one sample each): f / (p_cos + p_light) = radiance * p_cos / (p_cos + p_light).
  auto cosine_weight = [&](const glm::dvec3& x, const glm::dvec3& nx, const Vertex& y) {
    if (sources.empty()) return 1.0;
    const double pc = cosine_density(x, nx, y.position, y.normal);
    const double pl = light_vertex_density(geometry, sources, y);
    return pc + pl > 0.0 ? pc / (pc + pl) : 1.0;
  };
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, count, 4), [&](const tbb::blocked_range<std::size_t>& range) {
        std::vector<glm::dvec2> strata, light_strata;
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          Rng rng(settings.seed, i);
          stratified_square(paths, rng, strata);
          if (!sources.empty()) stratified_square(paths, rng, light_strata);
          const Vertex first = start(i);
          glm::dvec3 sum(0.0), sum2(0.0);
          for (int p = 0; p < paths; ++p) {
            // One path: the radiance arriving at point i along a cosine-distributed direction.
            Vertex x = first;
            glm::dvec3 throughput(1.0), radiance(0.0);
            glm::dvec2 u = strata[std::size_t(p)];
            for (int segment = 0; segment < settings.bounces; ++segment) {
              if (!sources.empty()) {
                // Light-vertex sample: y = first hit of a ray from a source, joined to x. The
                // source must light the side of y that faces x.
                const std::size_t source =
                    std::min(sources.size() - 1, std::size_t(rng.next_double() * double(sources.size())));
                const glm::dvec2 s = segment == 0 ? light_strata[std::size_t(p)] : rng.next_dvec2();
                Vertex c;
                c.position = sources[source];
                Vertex y;
                if (geometry.trace(c, uniform_sphere(s), y) && geometry.sees(c, y)) {
                  if (glm::dot(y.normal, x.position - y.position) < 0.0) y.normal = -y.normal;
                  if (glm::dot(y.normal, c.position - y.position) > 0.0 &&
                      glm::dot(x.normal, y.position - x.position) > 0.0 && geometry.sees(x, y))
                    radiance += cosine_weight(x.position, x.normal, y) * throughput * geometry.direct(y);
                }
              }
              glm::dvec3 t, b;
              tangent_frame(x.normal, t, b);
              const glm::dvec3 dir = to_world(cosine_hemisphere(u), t, b, x.normal);
              Vertex y;
              if (!geometry.trace(x, dir, y)) break;  // left the scene
              if (glm::dot(y.normal, dir) > 0.0) y.normal = -y.normal;
              // Cosine-weighted sampling: the estimator of E/pi is the radiance itself (times
              // its MIS weight when light vertices share the estimate).
              radiance += cosine_weight(x.position, x.normal, y) * throughput * geometry.direct(y);
              throughput *= geometry.albedo(y);
              if (throughput.x + throughput.y + throughput.z <= 0.0) break;
              x = y;
              u = {rng.next_double(), rng.next_double()};
            }
            sum += radiance;
            sum2 += radiance * radiance;
          }
          const double N = paths;
          for (int c = 0; c < 3; ++c) {
            const double mean = sum[c] / N;
            const double var = std::max(0.0, sum2[c] / N - mean * mean) * N / std::max(1.0, N - 1.0);
            out.value[3 * i + std::size_t(c)] = float(mean);
            out.standard_error[3 * i + std::size_t(c)] = float(std::sqrt(var / N));
          }
        }
      });
  return out;
}

// A pinhole camera's ray directions: pixel (px, py) of a width x height image, row 0 at the top.
struct PinholeCamera {
  glm::dvec3 forward, right, up;
  double half = 0.0, aspect = 1.0;
  int width = 0, height = 0;

  PinholeCamera(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up_hint,
                double vertical_fov_degrees, int w, int h)
      : forward(glm::normalize(target - eye)),
        right(glm::normalize(glm::cross(forward, up_hint))),
        up(glm::cross(right, forward)),
        half(std::tan(vertical_fov_degrees * std::numbers::pi / 360.0)),
        aspect(double(w) / double(h)),
        width(w),
        height(h) {}

  glm::dvec3 direction(int px, int py) const {
    const double sx = (2.0 * (px + 0.5) / width - 1.0) * half * aspect;
    const double sy = (1.0 - 2.0 * (py + 0.5) / height) * half;
    return glm::normalize(forward + sx * right + sy * up);
  }
};

}  // namespace modrt::precompute::detail
