// SPDX-License-Identifier: MIT
// modrt precompute — the actual (warped) geometry of a built level as one Embree scene,
// and the references computed on it: direct light from sphere lights with shadows, and the
// exact one-bounce indirect light F_level ld (architecture.md §8: no low rank, no modularity).
#pragma once

#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "modrt/drt.h"
#include "modrt/level.h"
#include "modrt/level_description.h"
#include "modrt/level_geometry.h"
#include "modrt/precompute/level_build.h"

namespace modrt::precompute {

struct LevelHit {
  int block = -1;  // -1: nothing hit (the ray left the level)
  int face = -1;   // canonical face of that block
  double u = 0, v = 0, t = 0;
  // >= 0: the ray hit clutter object `clutter` (of LevelScene::clutter()); then `block` is
  // its owning block, `face` the box face and (u, v) the clutter face coordinates (drt.h),
  // or for a mesh object `face` the triangle and (u, v) its barycentrics.
  int clutter = -1;
};

class LevelScene {
 public:
  // Every present face is tessellated into `subdivisions`^2 bilinear cells (2 triangles
  // each) of its trilinear warp; throws std::runtime_error when Embree fails.
  LevelScene(const Level& level, int subdivisions);
  // The same walls plus clutter boxes and meshes (DRT), two-sided so that points inside a box see its
  // inside; with no objects this is the constructor above.
  LevelScene(const Level& level, int subdivisions, std::span<const ClutterObject> clutter);
  ~LevelScene();
  LevelScene(const LevelScene&) = delete;
  LevelScene& operator=(const LevelScene&) = delete;

  LevelHit intersect(const glm::dvec3& origin, const glm::dvec3& dir, double t_near = 1e-6) const;
  bool occluded(const glm::dvec3& origin, const glm::dvec3& target, double t_near = 1e-6) const;
  // occluded() for an origin on or in block `block`, the same answer, without a ray when the
  // segment stays inside one straight run of unwarped blocks joined through missing faces (a
  // box with no wall inside; a level without clutter only). In a long straight corridor every
  // shadow ray would otherwise walk the BVH along the whole corridor (issue 18, item 10).
  bool occluded_from(int block, const glm::dvec3& origin, const glm::dvec3& target,
                     double t_near = 1e-6) const;
  // intersect() for many directions from one origin, traced as 8-wide coherent packets
  // (the gathers of DRT trace 1024 rays per texel); out[i] is the hit of dirs[i].
  void intersect_many(const glm::dvec3& origin, std::span<const glm::dvec3> dirs, std::span<LevelHit> out,
                      double t_near = 1e-6) const;

  const Level& level() const { return level_; }
  const LevelSampleGeometry& samples() const { return samples_; }
  const std::vector<ClutterObject>& clutter() const { return clutter_; }
  // Unit normal at a hit: the wall's inward normal or the clutter face's outward normal.
  glm::dvec3 hit_normal(const LevelHit& hit) const;

 private:
  struct Impl;
  LevelHit make_hit(unsigned geom_id, unsigned prim_id, float u, float v, float t_far) const;
  std::unique_ptr<Impl> impl_;
  const Level& level_;
  LevelSampleGeometry samples_;
  std::vector<ClutterObject> clutter_;
};

// Per block, the footprint area of its texels (light_policy.h block_texel_area): the floor of
// the inverse-square falloff of lights near them.
std::vector<double> level_texel_areas(const Level& level);

// ld = albedo * E / pi at every level sample for the given lights (RGB, 3N), with shadow
// rays against the whole level (`light_samples` points per sphere light).
// `progress`, when set, is called with the fraction done (0 to 1) at most once every 0.5 s,
// from whichever thread finished the work (calls are serialised), and once with 1 at the end.
std::vector<float> level_direct_light(const LevelScene& scene, std::span<const LightDescription> lights,
                                      std::span<const float> albedo, int light_samples,
                                      const std::function<void(double)>& progress = {});

// E_ind / pi = F_level ld at every level sample by `rays` cosine-weighted stratified gather
// rays; hits sample ld bilinearly on the hit face's texel grid (RGB, 3N).
std::vector<float> level_one_bounce(const LevelScene& scene, std::span<const float> ld, int rays,
                                    std::uint64_t seed);

}  // namespace modrt::precompute
