// SPDX-License-Identifier: MIT
// modrt — where a built level's samples and walls are in the world (architecture.md §4, MRT §6.2):
// the canonical block (cube.h) turned by its quarter turns and mapped through the trilinear
// warp of its 8 corners (level_description.h). Used at run time by the CPU direct-light
// evaluator and by precompute (Embree scene, references, path tracer).
#pragma once

#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/level.h"

namespace modrt {

// World-space point of canonical block coordinates p in [0,1]^3 of block `b`.
glm::dvec3 block_to_world(const LevelBlock& b, const glm::dvec3& p);
// Its inverse: canonical coordinates of world point x (Newton on the trilinear warp, 16 steps
// at most, starting from the block centre; outside [0,1]^3 for points outside the block).
glm::dvec3 world_to_block(const LevelBlock& b, const glm::dvec3& x);

// Unit inward normal of canonical face `face` of block `b` at face coordinates (u, v),
// through the block's trilinear warp (central differences of the map; exact for the
// unwarped grid, where each face is planar).
glm::dvec3 block_face_normal(const LevelBlock& b, int face, double u, double v);

// World position and unit inward normal of every level sample (the canonical texel centre
// of SampleLayout, mapped as above), in level sample order.
struct LevelSampleGeometry {
  std::vector<glm::dvec3> position;
  std::vector<glm::dvec3> normal;
  std::vector<int> block;  // owning block per sample
  std::vector<int> face;   // canonical face per sample
};
LevelSampleGeometry level_sample_geometry(const Level& level);

// Albedo of every level sample (3 x samples, RGB interleaved, in level sample order): its
// face's LevelBlock::albedo. The span form fills `out` (which must hold 3 x samples floats)
// without allocating.
std::vector<float> level_sample_albedo(const Level& level);
void level_sample_albedo(const Level& level, std::span<float> out);

// World area each level sample stands for: its texel's quad on the face (the four texel
// corners through block_to_world, two triangles), in level sample order. A unit cell's closed
// cube sums to 6; a stretched or warped block's faces to their own areas.
std::vector<double> level_sample_area(const Level& level);

// Per block, the mean of a per-sample RGB signal (3 floats per sample: ld, the indirect
// lightmap E/pi, ...) weighted by level_sample_area: 3 doubles per block (RGB), in block order,
// so that levels are compared block by block without images (modrt-level --stats). A block
// without samples (or of zero area) gets 0. signal must hold 3 x samples floats.
std::vector<double> level_block_means(const Level& level, std::span<const float> signal);

}  // namespace modrt
