// modrt precompute — level build (SPEC §4, MRT §6.2–6.3, §7.2): connectivity, the sparse
// block matrix Tb->r by breadth-first propagation through interfaces, and the padded
// lightmap atlas with its padding records.
#pragma once

#include <vector>

#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/level_description.h"

namespace modrt::precompute {

struct LevelBuildSettings {
  int dmax = 8;  // maximum number of interfaces a path crosses (MRT §6.3)
};

// Fails when the level does not validate or the dictionary has no interface operators.
Result<Level> build_level(const LevelDescription& description, const Dictionary& dict,
                          const LevelBuildSettings& settings = {});

// World position and (inward) normal of every level sample: the canonical texel centre,
// rotated onto the grid and mapped through the block's trilinear warp.
struct LevelSampleGeometry {
  std::vector<glm::dvec3> position;
  std::vector<glm::dvec3> normal;
  std::vector<int> block;  // owning block per sample
  std::vector<int> face;   // canonical face per sample
};
LevelSampleGeometry level_sample_geometry(const Level& level);

// World-space point of canonical block coordinates p in block `b`.
glm::dvec3 block_to_world(const LevelBlock& b, const glm::dvec3& p);
// Unit inward normal of canonical face `face` of block `b` at face coordinates (u, v),
// through the block's trilinear warp.
glm::dvec3 block_face_normal(const LevelBlock& b, int face, double u, double v);

}  // namespace modrt::precompute
