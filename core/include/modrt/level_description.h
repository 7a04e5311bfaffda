// SPDX-License-Identifier: MIT
// modrt — the authored description of a level (architecture.md §4, MRT §6.2): blocks on a grid,
// optionally warped by their 8 corners, with per-face presence and albedo, plus lights.
// This is the input of the level build; the JSON file format is documented in
// docs/level-format.md and parsed by precompute/ (modrt::precompute::load_level_json).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/cube.h"
#include "modrt/status.h"

namespace modrt {

inline constexpr int kLevelFormatVersion = 1;

struct BlockDescription {
  glm::ivec3 cell{0};          // integer grid cell; the block nominally spans cell..cell+1 (times cell_size)
  FaceMask faces = kAllFaces;  // present faces in world orientation (bit f = face f, cube.h numbering)
  bool warped = false;         // corners below are used instead of the grid cell's cube
  // World positions of the canonical cube corners, index = x + 2*y + 4*z for corner (x, y, z)
  // in {0,1}^3; the block interior is the trilinear image of [0,1]^3.
  std::array<glm::dvec3, 8> corners{};
  std::array<glm::dvec3, kFaceCount> albedo{};  // linear RGB per face, each channel in [0, 1]
  std::string name;                             // optional, for messages
};

struct LightDescription {
  glm::dvec3 position{0.5};
  double radius = 0.05;    // 0 = point light
  glm::dvec3 color{1.0};   // linear RGB, multiplies intensity
  double intensity = 1.0;  // radiant intensity (W/sr) at color (1,1,1)
};

struct LevelDescription {
  int version = kLevelFormatVersion;
  std::string name;
  double cell_size = 1.0;  // world size of one grid cell
  std::vector<BlockDescription> blocks;
  std::vector<LightDescription> lights;
};

// Plausible level geometry (validate_level, and the JSON parser for cell_size). The
// precompute's ray queries use absolute offsets of 1e-6 world units (LevelScene's t_near)
// and Embree works in float: below kMinCellSize those offsets exceed a thousandth of a cell
// (at 1e-20 they jumped over the geometry and every shadow vanished); at kMaxCellSize the
// largest level (2^20 cells per axis) stays near 1e12, far inside what Embree accepts
// (|coordinates| < 1.8e19). A warped corner lies within kMaxWarpOffsetCells cell sizes of
// its grid cell's corner: long blocks (the stress suite's 100:1:1) and shears pass, a corner
// at 1e300 does not, and the level's extent keeps the same margin from Embree's limit.
inline constexpr double kMinCellSize = 1e-3;
inline constexpr double kMaxCellSize = 1e6;
inline constexpr double kMaxWarpOffsetCells = 1024.0;

// The unwarped corners of a grid cell: (cell + (x, y, z)) * cell_size.
std::array<glm::dvec3, 8> grid_cell_corners(const glm::ivec3& cell, double cell_size);
// Corners actually used for a block (warped corners or its grid cell's cube).
std::array<glm::dvec3, 8> block_corners(const LevelDescription& level, const BlockDescription& block);
// Trilinear map of canonical block coordinates p in [0,1]^3 to world space.
glm::dvec3 trilinear(const std::array<glm::dvec3, 8>& corners, const glm::dvec3& p);

// Index of the block sharing face `face` of block `index` (the grid neighbour), or -1.
// Connected when both blocks have that shared face missing.
struct LevelConnectivity {
  std::vector<std::array<int, kFaceCount>> neighbour;   // grid neighbour per face, -1 if none
  std::vector<std::array<bool, kFaceCount>> connected;  // shared face missing on both sides
};

// Checks a level and computes its connectivity. Errors (invalid_argument) name the block
// (index and name) and the problem: two blocks in one cell; a shared face missing on one
// side only; floor or ceiling missing (not in the 2D dictionary); albedo outside [0,1] or
// non-finite; non-finite or degenerate/inverted warp corners (trilinear Jacobian
// determinant <= 1e-6 * cell_size^3 anywhere on the 3x3x3 lattice); warped neighbours whose
// shared face corners disagree; a warp corner more than kMaxWarpOffsetCells cell sizes from
// its grid corner; bad version; non-finite light; cell_size outside [kMinCellSize,
// kMaxCellSize].
Result<LevelConnectivity> validate_level(const LevelDescription& level);

}  // namespace modrt
