// SPDX-License-Identifier: MIT
// modrt precompute — procedural test levels (docs/level-format.md): seeded random 2D
// mazes like the paper's (MRT §6.1, Table 3: an 11-block small and a 41-block large maze)
// and small hand-made presets.
#pragma once

#include <cstdint>

#include "modrt/level_description.h"
#include "modrt/status.h"

namespace modrt::precompute {

struct MazeSettings {
  int blocks = 11;             // number of blocks, >= 1 (at most kMaxMazeBlocks)
  std::uint64_t seed = 1;      // same settings + seed => identical level on every platform
  double loop_fraction = 0.0;  // in [0, 1]: probability of opening each extra wall between
                               // two adjacent maze cells not joined by the spanning tree
  double warp = 0.0;           // in [0, 0.25]: max corner jitter (x and z) as a fraction of
                               // the cell size; 0 = unwarped grid blocks
  bool coloured_walls = true;  // some red/green/blue walls (else every face grey 0.7)
};

inline constexpr int kMaxMazeBlocks = 1 << 20;

// A closed single-layer (y = 0) maze: exactly settings.blocks cells grown at random from
// cell (0,0,0) (block 0), joined by a spanning tree of passages (shared side faces missing
// on both sides) plus optional loops; every other side face is a wall; floor and ceiling
// always present. Warped mazes jitter the shared lattice vertices, so neighbours stay
// watertight. One light (radius 0.05, intensity 1) at the centre of block 0 at height 0.5,
// and one in the last block when blocks >= 10. cell_size = 1. The result passes
// validate_level. Errors (invalid_argument) for settings out of range.
Result<LevelDescription> generate_maze(const MazeSettings& settings);

// Two blocks along +Z, (0,0,0) and (0,0,1), joined through their shared face (block 0's
// +Z, block 1's -Z); all other faces closed. Red -X wall in block 0, green +X wall in
// block 1, light at the centre of block 0.
LevelDescription corridor_level();

// Three blocks forming an L: (0,0,0) -> (0,0,1) -> (1,0,1); red and green end walls,
// light at the centre of block 0.
LevelDescription l_corner_level();

// The presets "maze11" and "maze41" (the paper's small and large maze sizes, fixed seeds
// chosen for a branching layout; maze41 has a few loops). Other sizes use
// generate_maze({blocks, seed = 1}). Fails for blocks < 1 or > kMaxMazeBlocks.
Result<LevelDescription> maze_level(int blocks);

}  // namespace modrt::precompute
