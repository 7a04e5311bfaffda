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
#include "path_kernel.h"

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

// The level's walls (and clutter) as the estimator's geometry (path_kernel.h).
struct LevelPathGeometry {
  using Hit = LevelHit;
  using Vertex = detail::PathVertex<LevelHit>;
  const LevelScene& scene;
  const DirectRadiance& direct_radiance;
  const SurfaceAlbedo& surface_albedo;

  bool trace(const Vertex& from, const glm::dvec3& dir, Vertex& to) const {
    to.hit = scene.intersect(from.position, dir);
    if (to.hit.block < 0) return false;
    to.position = from.position + to.hit.t * dir;
    to.normal = scene.hit_normal(to.hit);
    return true;
  }
  // The target is pulled back a little from the surface so the float ray does not hit the
  // surface it ends on.
  bool sees(const Vertex& from, const Vertex& to) const {
    return !scene.occluded(from.position, from.position + (to.position - from.position) * (1.0 - 1e-4));
  }
  glm::dvec3 direct(const Vertex& y) const { return direct_radiance(y.hit, y.position, y.normal); }
  glm::dvec3 albedo(const Vertex& y) const { return surface_albedo(y.hit); }
};

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
  if (Status s = validate_path_tracer_settings(settings); !s.ok()) throw std::invalid_argument(s.message());
  const LevelPathGeometry geometry{scene, direct, albedo};
  return detail::trace_paths(
      geometry, positions.size(),
      [&](std::size_t i) {
        detail::PathVertex<LevelHit> v;
        v.position = positions[i];
        v.normal = normals[i];
        return v;
      },
      settings);
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
  const detail::PinholeCamera camera(eye, target, up, vertical_fov_degrees, width, height);
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int py = rows.begin(); py != rows.end(); ++py)
      for (int px = 0; px < width; ++px) {
        const glm::dvec3 dir = camera.direction(px, py);
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
