#include "modrt/precompute/path_tracer.h"

#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/sampling.h"

namespace modrt::precompute {
namespace {

void tangent_frame(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
  const glm::dvec3 helper = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  t = glm::normalize(glm::cross(helper, n));
  b = glm::cross(n, t);
}

}  // namespace

DirectRadiance level_direct_radiance(const LevelScene& scene, const LevelDescription& description, int light_samples) {
  std::vector<std::vector<glm::dvec3>> points(description.lights.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    sphere_light_points(description.lights[i].position, description.lights[i].radius, light_samples, points[i]);
  const SurfaceAlbedo albedo = level_surface_albedo(scene, description);
  return [&scene, &description, points, albedo](const LevelHit& hit, const glm::dvec3& x, const glm::dvec3& n) {
    auto occluded = [&](const glm::dvec3& a, const glm::dvec3& b) { return scene.occluded(a, b); };
    glm::dvec3 sum(0.0);
    for (std::size_t i = 0; i < description.lights.size(); ++i) {
      const LightDescription& l = description.lights[i];
      sum += l.color * sphere_light_E_over_pi(x, n, SphereLight{l.position, l.radius, l.intensity}, points[i], occluded);
    }
    return albedo(hit) * sum;
  };
}

SurfaceAlbedo level_surface_albedo(const LevelScene& scene, const LevelDescription& description) {
  return [&scene, &description](const LevelHit& hit) {
    const LevelBlock& b = scene.level().blocks[std::size_t(hit.block)];
    return description.blocks[std::size_t(hit.block)].albedo[std::size_t(rotate_face(hit.face, b.quarter_turns))];
  };
}

IndirectEstimate trace_indirect(const LevelScene& scene, std::span<const glm::dvec3> positions,
                                std::span<const glm::dvec3> normals, const DirectRadiance& direct,
                                const SurfaceAlbedo& albedo, const PathTracerSettings& settings) {
  const std::size_t count = positions.size();
  IndirectEstimate out;
  out.value.assign(3 * count, 0.0f);
  out.standard_error.assign(3 * count, 0.0f);
  const Level& level = scene.level();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 4), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<glm::dvec2> strata;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      Rng rng(settings.seed, i);
      stratified_square(settings.paths, rng, strata);
      glm::dvec3 sum(0.0), sum2(0.0);
      for (const glm::dvec2& first : strata) {
        // One path: the radiance arriving at point i along a cosine-distributed direction.
        glm::dvec3 x = positions[i], n = normals[i], throughput(1.0), radiance(0.0);
        glm::dvec2 u = first;
        for (int segment = 0; segment < settings.bounces; ++segment) {
          glm::dvec3 t, b;
          tangent_frame(n, t, b);
          const glm::dvec3 dir = to_world(cosine_hemisphere(u), t, b, n);
          const LevelHit hit = scene.intersect(x, dir);
          if (hit.block < 0) break;  // left the level
          const glm::dvec3 y = x + hit.t * dir;
          glm::dvec3 ny = block_face_normal(level.blocks[std::size_t(hit.block)], hit.face, hit.u, hit.v);
          if (glm::dot(ny, dir) > 0.0) ny = -ny;
          // Cosine-weighted sampling: the estimator of E/pi is the radiance itself.
          radiance += throughput * direct(hit, y, ny);
          throughput *= albedo(hit);
          if (throughput.x + throughput.y + throughput.z <= 0.0) break;
          x = y;
          n = ny;
          u = {rng.next_double(), rng.next_double()};
        }
        sum += radiance;
        sum2 += radiance * radiance;
      }
      const double N = settings.paths;
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

CameraHits camera_hits(const LevelScene& scene, const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up,
                       double vertical_fov_degrees, int width, int height) {
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
        glm::dvec3 nrm = block_face_normal(scene.level().blocks[std::size_t(cam.hit[k].block)], cam.hit[k].face,
                                           cam.hit[k].u, cam.hit[k].v);
        cam.normal[k] = glm::dot(nrm, dir) > 0.0 ? -nrm : nrm;
      }
  });
  return cam;
}

}  // namespace modrt::precompute
