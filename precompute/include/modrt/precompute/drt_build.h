// modrt precompute — the DRT operators of clutter objects (SPEC §6, [Loos et al. 2012]
// §4–5), traced with Embree against the level's walls and the implicit lighting Limp of the
// dictionary, in parallel over texels (oneTBB).
//
// Every object is traced against the walls and itself only, so objects are independent:
// moving one rebuilds its operators alone (rebuild_object) and the result equals a full
// build. Scene samples whose hemisphere cannot contain the object's bounding sphere are not
// traced, and rays that miss the sphere are not tested further; both are exact (no ray
// that can hit the box is skipped).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/drt.h"
#include "modrt/level.h"
#include "modrt/level_description.h"
#include "modrt/precompute/level_scene.h"

namespace modrt::precompute {

struct DrtBuildSettings {
  int rays = 1024;      // cosine-weighted stratified rays per scene sample and clutter texel
  int cb_modes = 5;     // modes kept of Cb's SVD (DRT §5: "5 x 16^2 values per clutter face")
  bool inpaint = true;  // DRT §5: samples inside clutter take their neighbours' shadowed Ub
  bool cull = true;     // bounding-sphere culling (exact; off only to test that it is)
  // dUb rows whose L2 norm is below this fraction of the object's largest row norm are
  // dropped (storage); a dropped row changes its sample by at most |row|_2 |b(block)|_2 per
  // channel. 0 keeps every row.
  double drop_tolerance = 0.0;
  std::uint64_t seed = 0x647274ull;
};

struct DrtBuildReport {
  std::size_t traced_samples = 0;  // scene samples that shot rays
  std::size_t culled_samples = 0;  // scene samples skipped by the bounding sphere
  std::size_t inside_samples = 0;  // scene samples inside clutter
  std::size_t inpainted_samples = 0;
  std::size_t dropped_rows = 0;  // dUb rows under drop_tolerance
  // Wall-clock seconds of the scene-sample pass (dUb, dUc, inpainting) and of the clutter
  // texel pass (Cb and its SVD), summed over objects.
  double scene_seconds = 0.0, clutter_seconds = 0.0;
};

class DrtBuilder {
 public:
  // Throws std::runtime_error when Embree fails (as LevelScene).
  DrtBuilder(const Level& level, const Dictionary& dict, const DrtBuildSettings& settings = {});

  // Validates the objects (validate_clutter) and the dictionary's Limp sizes.
  Result<DrtOperators> build(std::span<const ClutterObject> objects, DrtBuildReport* report = nullptr) const;
  Result<DrtObjectOperators> build_object(const ClutterObject& object,
                                          DrtBuildReport* report = nullptr) const;
  // Incremental: replaces drt.objects[index] by the operators of objects[index] (after it
  // moved); the other objects' operators are untouched.
  Status rebuild_object(std::span<const ClutterObject> objects, std::size_t index, DrtOperators& drt) const;

  const LevelScene& walls() const { return walls_; }

 private:
  const Level& level_;
  const Dictionary& dict_;
  DrtBuildSettings settings_;
  LevelScene walls_;
};

// Direct light on the clutter texels (albedo * E / pi, RGB, 3 per texel, objects in order),
// the light model of level_direct_light, shadowed by the walls and all clutter of `scene`.
std::vector<float> clutter_direct_light(const LevelScene& scene, std::span<const LightDescription> lights,
                                        int light_samples);

}  // namespace modrt::precompute
