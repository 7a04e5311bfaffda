// SPDX-License-Identifier: MIT
// modrt precompute — ground truth: a diffuse path tracer on the real (warped) level
// geometry (architecture.md §8). It estimates multi-bounce indirect irradiance E_ind / pi at any
// surface points — the level's lightmap texels or a camera's primary hits — for the same
// direct-light model as the runtime (sphere / point lights with shadows), with a per-point
// standard error so every error figure can state its own noise floor.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/level_description.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/status.h"

namespace modrt::precompute {

struct PathTracerSettings {
  int paths = 256;        // paths per point (stratified first direction)
  int bounces = 8;        // indirect bounces: 1 = light reflected once (F ld), ...
  int light_samples = 8;  // visibility points per sphere light at every path vertex
  std::uint64_t seed = 7;
  // Light-vertex connections, for lights whose reflected light is a small bright spot (a
  // light close to a wall) that cosine-weighted paths rarely hit. At every path vertex x,
  // one ray leaves a randomly chosen centre of `light_vertex_sources` in a uniform direction;
  // its first hit y is joined to x by a shadow ray and brings back y's direct radiance.
  // That sample and the cosine direction's hit are combined by the balance heuristic
  // (multiple importance sampling, Veach §9.2), so the estimate stays unbiased for any
  // sources; where a source sees nothing the paths alone carry the estimate. Empty: cosine
  // paths only.
  std::vector<glm::dvec3> light_vertex_sources;
};

struct IndirectEstimate {
  std::vector<float> value;  // E_ind / pi, RGB interleaved (3 per point)
  // Of each value: sample std / sqrt(paths), as for independent paths. The first direction
  // is stratified, so the true error is smaller: this is a conservative bound.
  std::vector<float> standard_error;
};

// The estimate's noise floor as a relative L2 error: RMS standard error / RMS value (0 for
// an all-zero estimate); conservative, like standard_error.
double relative_noise_floor(const IndirectEstimate& estimate);

// Outgoing *direct* diffuse radiance at a surface point: albedo * E_direct / pi for the
// runtime's light model. Replaceable so analytic cases (furnace, one emitting face) can be
// set up exactly.
using DirectRadiance =
    std::function<glm::dvec3(const LevelHit& hit, const glm::dvec3& position, const glm::dvec3& normal)>;
// Albedo at a surface point (RGB).
using SurfaceAlbedo = std::function<glm::dvec3(const LevelHit& hit)>;

// The runtime's light model on the level's geometry and per-face albedo.
DirectRadiance level_direct_radiance(const LevelScene& scene, const LevelDescription& description,
                                     int light_samples);
SurfaceAlbedo level_surface_albedo(const LevelScene& scene, const LevelDescription& description);
// The centres of the description's lights, as light-vertex sources.
std::vector<glm::dvec3> level_light_centres(const LevelDescription& description);

// paths in [1, kMaxSettingsRays], bounces in [0, kMaxPathBounces], light_samples in
// [1, kMaxSettingsLightSamples] (dictionary.h); invalid_argument naming the setting.
inline constexpr int kMaxPathBounces = 1024;
Status validate_path_tracer_settings(const PathTracerSettings& settings);

// E_ind / pi at each (position, normal): cosine-weighted paths of `bounces` segments; the
// radiance a segment brings back is direct(y) + albedo(y) * (the next segment's estimate).
// With light-vertex sources, each segment's direct(y) is shared with a light-vertex sample
// by MIS (see PathTracerSettings). Throws std::invalid_argument for settings that fail
// validate_path_tracer_settings.
IndirectEstimate trace_indirect(const LevelScene& scene, std::span<const glm::dvec3> positions,
                                std::span<const glm::dvec3> normals, const DirectRadiance& direct,
                                const SurfaceAlbedo& albedo, const PathTracerSettings& settings);

// A pinhole camera's primary hits (for image-space references). Pixels that see nothing
// get hit.block = -1.
struct CameraHits {
  int width = 0, height = 0;
  std::vector<LevelHit> hit;
  std::vector<glm::dvec3> position, normal;
};
CameraHits camera_hits(const LevelScene& scene, const glm::dvec3& eye, const glm::dvec3& target,
                       const glm::dvec3& up, double vertical_fov_degrees, int width, int height);

}  // namespace modrt::precompute
