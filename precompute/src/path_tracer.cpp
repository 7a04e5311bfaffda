// SPDX-License-Identifier: MIT
#include "modrt/precompute/path_tracer.h"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/sampling.h"

namespace modrt::precompute {

double relative_noise_floor(const IndirectEstimate& estimate) {
  double se2 = 0, v2 = 0;
  for (std::size_t i = 0; i < estimate.value.size() && i < estimate.standard_error.size(); ++i) {
    se2 += double(estimate.standard_error[i]) * estimate.standard_error[i];
    v2 += double(estimate.value[i]) * estimate.value[i];
  }
  return v2 > 0 ? std::sqrt(se2 / v2) : 0.0;
}

DirectRadiance level_direct_radiance(const LevelScene& scene, const LevelDescription& description,
                                     int light_samples) {
  std::vector<std::vector<glm::dvec3>> points(description.lights.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    sphere_light_points(description.lights[i].position, description.lights[i].radius, light_samples,
                        points[i]);
  const SurfaceAlbedo albedo = level_surface_albedo(scene, description);
  // The texels' footprint of the hit's block bounds the falloff as in ld (light_policy.h).
  const std::vector<double> texel_area = level_texel_areas(scene.level());
  return [&scene, &description, points, albedo, texel_area](const LevelHit& hit, const glm::dvec3& x,
                                                            const glm::dvec3& n) {
    auto occluded = [&](const glm::dvec3& a, const glm::dvec3& b) { return scene.occluded(a, b); };
    const double area = hit.block >= 0 ? texel_area[std::size_t(hit.block)] : 0.0;
    glm::dvec3 sum(0.0);
    for (std::size_t i = 0; i < description.lights.size(); ++i) {
      const LightDescription& l = description.lights[i];
      sum += l.color * sphere_light_E_over_pi(x, n, SphereLight{l.position, l.radius, l.intensity}, points[i],
                                              area, occluded);
    }
    return albedo(hit) * sum;
  };
}

SurfaceAlbedo level_surface_albedo(const LevelScene& scene, const LevelDescription& description) {
  return [&scene, &description](const LevelHit& hit) {
    if (hit.clutter >= 0) return scene.clutter()[std::size_t(hit.clutter)].albedo;
    const LevelBlock& b = scene.level().blocks[std::size_t(hit.block)];
    return description.blocks[std::size_t(hit.block)]
        .albedo[std::size_t(rotate_face(hit.face, b.quarter_turns))];
  };
}

std::vector<glm::dvec3> level_light_centres(const LevelDescription& description) {
  std::vector<glm::dvec3> centres;
  for (const LightDescription& l : description.lights) centres.push_back(l.position);
  return centres;
}

namespace {

// A surface point found by a ray: its hit record, position and the face normal (sign as
// the geometry gives it; callers orient it).
struct SurfacePoint {
  LevelHit hit;
  glm::dvec3 position, normal;
};

// Whether `source` sees y: the same test decides which points a light-vertex ray can
// produce and, for path vertices, whether that technique could have produced them, so the
// MIS weights are consistent. The target is pulled back a little from the surface so the
// float ray does not hit the surface it ends on.
bool sees(const LevelScene& scene, const glm::dvec3& source, const glm::dvec3& y) {
  return !scene.occluded(source, source + (y - source) * (1.0 - 1e-4));
}

// Area density (per unit area at y) with which one light-vertex sample produces y: the
// mean over sources of cos_y / (4 pi d^2), for the sources that see y. `ny` is y's normal
// (either sign).
double light_vertex_density(const LevelScene& scene, std::span<const glm::dvec3> sources, const glm::dvec3& y,
                            const glm::dvec3& ny) {
  double density = 0.0;
  for (const glm::dvec3& c : sources) {
    const glm::dvec3 w = c - y;
    const double d2 = glm::dot(w, w);
    if (d2 <= 1e-300) continue;
    const double cos_y = std::abs(glm::dot(ny, w)) / std::sqrt(d2);
    if (cos_y <= 0.0 || !sees(scene, c, y)) continue;
    density += cos_y / (4.0 * std::numbers::pi * d2);
  }
  return density / double(std::max<std::size_t>(sources.size(), 1));
}

// Area density with which the cosine-weighted direction from (x, nx) first hits y:
// cos_x cos_y / (pi d^2).
double cosine_density(const glm::dvec3& x, const glm::dvec3& nx, const glm::dvec3& y, const glm::dvec3& ny) {
  const glm::dvec3 w = y - x;
  const double d2 = glm::dot(w, w);
  if (d2 <= 1e-300) return 0.0;
  const double d = std::sqrt(d2);
  const double cos_x = glm::dot(nx, w) / d;
  if (cos_x <= 0.0) return 0.0;
  return cos_x * std::abs(glm::dot(ny, w)) / d / (std::numbers::pi * d2);
}

}  // namespace

Status validate_path_tracer_settings(const PathTracerSettings& s) {
  const struct {
    const char* name;
    int value, lo;
    std::int64_t hi;
  } counts[] = {{"paths", s.paths, 1, kMaxSettingsRays},
                {"bounces", s.bounces, 0, kMaxPathBounces},
                {"light_samples", s.light_samples, 1, kMaxSettingsLightSamples}};
  for (const auto& c : counts)
    if (c.value < c.lo || std::int64_t(c.value) > c.hi)
      return Status::error(ErrorCode::invalid_argument,
                           std::string("path tracer settings: ") + c.name + " = " + std::to_string(c.value) +
                               ": must be in [" + std::to_string(c.lo) + ", " + std::to_string(c.hi) + "]");
  return Status::success();
}

IndirectEstimate trace_indirect(const LevelScene& scene, std::span<const glm::dvec3> positions,
                                std::span<const glm::dvec3> normals, const DirectRadiance& direct,
                                const SurfaceAlbedo& albedo, const PathTracerSettings& settings) {
  const std::size_t count = positions.size();
  IndirectEstimate out;
  out.value.assign(3 * count, 0.0f);
  out.standard_error.assign(3 * count, 0.0f);
  const std::span<const glm::dvec3> sources = settings.light_vertex_sources;
  if (Status s = validate_path_tracer_settings(settings); !s.ok()) throw std::invalid_argument(s.message());
  const int paths = settings.paths;
  auto surface_point = [&](const glm::dvec3& origin, const glm::dvec3& dir) {
    SurfacePoint p;
    p.hit = scene.intersect(origin, dir);
    if (p.hit.block < 0) return p;
    p.position = origin + p.hit.t * dir;
    p.normal = scene.hit_normal(p.hit);
    return p;
  };
  // MIS weight of a point y seen from (x, nx), for either technique (balance heuristic,
  // one sample each): f / (p_cos + p_light) = radiance * p_cos / (p_cos + p_light).
  auto cosine_weight = [&](const glm::dvec3& x, const glm::dvec3& nx, const SurfacePoint& y) {
    if (sources.empty()) return 1.0;
    const double pc = cosine_density(x, nx, y.position, y.normal);
    const double pl = light_vertex_density(scene, sources, y.position, y.normal);
    return pc + pl > 0.0 ? pc / (pc + pl) : 1.0;
  };
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, count, 4), [&](const tbb::blocked_range<std::size_t>& range) {
        std::vector<glm::dvec2> strata, light_strata;
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          Rng rng(settings.seed, i);
          stratified_square(paths, rng, strata);
          if (!sources.empty()) stratified_square(paths, rng, light_strata);
          glm::dvec3 sum(0.0), sum2(0.0);
          for (int p = 0; p < paths; ++p) {
            // One path: the radiance arriving at point i along a cosine-distributed direction.
            glm::dvec3 x = positions[i], n = normals[i], throughput(1.0), radiance(0.0);
            glm::dvec2 u = strata[std::size_t(p)];
            for (int segment = 0; segment < settings.bounces; ++segment) {
              if (!sources.empty()) {
                // Light-vertex sample: y = first hit of a ray from a source, joined to x. The
                // source must light the side of y that faces x.
                const std::size_t source =
                    std::min(sources.size() - 1, std::size_t(rng.next_double() * double(sources.size())));
                const glm::dvec2 s = segment == 0 ? light_strata[std::size_t(p)] : rng.next_dvec2();
                const glm::dvec3& c = sources[source];
                SurfacePoint y = surface_point(c, uniform_sphere(s));
                if (y.hit.block >= 0 && sees(scene, c, y.position)) {
                  if (glm::dot(y.normal, x - y.position) < 0.0) y.normal = -y.normal;
                  if (glm::dot(y.normal, c - y.position) > 0.0 && glm::dot(n, y.position - x) > 0.0 &&
                      sees(scene, x, y.position))
                    radiance += cosine_weight(x, n, y) * throughput * direct(y.hit, y.position, y.normal);
                }
              }
              glm::dvec3 t, b;
              tangent_frame(n, t, b);
              const glm::dvec3 dir = to_world(cosine_hemisphere(u), t, b, n);
              SurfacePoint y = surface_point(x, dir);
              if (y.hit.block < 0) break;  // left the level
              if (glm::dot(y.normal, dir) > 0.0) y.normal = -y.normal;
              // Cosine-weighted sampling: the estimator of E/pi is the radiance itself (times
              // its MIS weight when light vertices share the estimate).
              radiance += cosine_weight(x, n, y) * throughput * direct(y.hit, y.position, y.normal);
              throughput *= albedo(y.hit);
              if (throughput.x + throughput.y + throughput.z <= 0.0) break;
              x = y.position;
              n = y.normal;
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

CameraHits camera_hits(const LevelScene& scene, const glm::dvec3& eye, const glm::dvec3& target,
                       const glm::dvec3& up, double vertical_fov_degrees, int width, int height) {
  CameraHits cam;
  cam.width = width;
  cam.height = height;
  const std::size_t count = std::size_t(width) * std::size_t(height);
  cam.hit.resize(count);
  cam.position.resize(count);
  cam.normal.resize(count);
  const glm::dvec3 forward = glm::normalize(target - eye);
  const glm::dvec3 right = glm::normalize(glm::cross(forward, up));
  const glm::dvec3 true_up = glm::cross(right, forward);
  const double half = std::tan(vertical_fov_degrees * std::numbers::pi / 360.0);
  const double aspect = double(width) / double(height);
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int py = rows.begin(); py != rows.end(); ++py)
      for (int px = 0; px < width; ++px) {
        const double sx = (2.0 * (px + 0.5) / width - 1.0) * half * aspect;
        const double sy = (1.0 - 2.0 * (py + 0.5) / height) * half;
        const glm::dvec3 dir = glm::normalize(forward + sx * right + sy * true_up);
        const std::size_t k = std::size_t(py) * std::size_t(width) + std::size_t(px);
        cam.hit[k] = scene.intersect(eye, dir);
        if (cam.hit[k].block < 0) continue;
        cam.position[k] = eye + cam.hit[k].t * dir;
        glm::dvec3 nrm = scene.hit_normal(cam.hit[k]);
        cam.normal[k] = glm::dot(nrm, dir) > 0.0 ? -nrm : nrm;
      }
  });
  return cam;
}

}  // namespace modrt::precompute
