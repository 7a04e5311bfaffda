// SPDX-License-Identifier: MIT
// modrt precompute — level build (architecture.md §4, MRT §6.2–6.3, §7.2): connectivity, the sparse
// block matrix Tb->r by breadth-first propagation through interfaces, and the padded
// lightmap atlas with its padding records.
#pragma once

#include <cstdint>

#include <vector>

#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/level_description.h"
#include "modrt/level_geometry.h"

namespace modrt::precompute {

class ShapedOperatorCache;

struct LevelBuildSettings {
  int dmax = 8;  // maximum number of interfaces a path crosses (MRT §6.3)
  // MRT §8, Figure 12: a block whose proportions are not a cube's gets operators baked for
  // its box (the prior and F re-traced on the stretched block) instead of the cube's under a
  // warp. A block connected to others needs its interfaces traced in its box too
  // (shaped_interfaces.h), which takes the dictionary's lightfield basis: without
  // `interface_basis` only blocks that connect to no other block get shaped operators
  // (docs/precompute.md "Shaped blocks"). false: every block uses its cube operators.
  bool shaped_operators = true;
  // The dictionary's reduced lightfield basis Hrlf (load_or_bake_interface_basis), or null.
  const Matrix* interface_basis = nullptr;
  // Proportions are quantised to 1/proportion_steps_per_octave of an octave (1 to 64): blocks
  // within half a step of a cube keep the cube's operators, and blocks of nearly equal
  // proportions share one bake. 8 steps: proportions within 4.4 %.
  int proportion_steps_per_octave = 8;
  // Bakes kept across builds (null: a cache for this build only); see shaped_operators.h.
  ShapedOperatorCache* shaped_cache = nullptr;
  // build_level refuses (resource_limit), before building, a level whose estimated size
  // exceeds this: per sample its run-time signals (ld, lightmap, albedo, atlas texel), per
  // response slot an upper bound on its Tb->r records (one per block within dmax interfaces).
  std::uint64_t memory_budget_bytes = std::uint64_t(4) << 30;  // 4 GiB
};

// dmax in [0, kMaxLevelDmax] (paths through more interfaces carry no light worth storing;
// modrt-level's --dmax has the same range); invalid_argument naming it. build_level checks it.
inline constexpr int kMaxLevelDmax = 64;
inline constexpr int kMaxProportionSteps = 64;
Status validate_level_build_settings(const LevelBuildSettings& settings);

// The estimate build_level compares with memory_budget_bytes (bytes).
std::uint64_t estimate_level_bytes(const LevelDescription& description, const Dictionary& dict,
                                   const LevelBuildSettings& settings = {});

// The level's geometry without operators: blocks (shape, orientation, corners, neighbours,
// albedo, samples) and the padded lightmap atlas at `res` texels per face side, exactly as
// build_level lays them out. What the proxy mapping (modrt/mesh_lightmap_uv.h) needs, so a
// scene importer can map meshes and write lightmap coordinates without a dictionary. Fails
// when the level does not validate or res is outside [1, kMaxSettingsRes].
Result<Level> build_level_layout(const LevelDescription& description, int res);

// Fails when the level does not validate or the dictionary has no interface operators.
Result<Level> build_level(const LevelDescription& description, const Dictionary& dict,
                          const LevelBuildSettings& settings = {});

// Sample and wall geometry moved to core (modrt/level_geometry.h) so the run-time CPU
// direct-light evaluator shares it; these names keep precompute's callers unchanged.
using modrt::block_face_normal;
using modrt::block_to_world;
using modrt::level_sample_geometry;
using modrt::LevelSampleGeometry;

}  // namespace modrt::precompute
