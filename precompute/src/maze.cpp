// SPDX-License-Identifier: MIT
// modrt precompute — procedural maze levels and presets (docs/level-format.md).
#include "modrt/precompute/maze.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <unordered_map>
#include <vector>

#include <glm/vec2.hpp>

namespace modrt::precompute {
namespace {

// SplitMix64 (Steele, Lea, Flood 2014): a tiny, portable, well-mixed generator. All ranges
// are derived from its bits by integer arithmetic, so mazes are identical on every
// platform and standard library.
std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() { return splitmix64(state_); }
  // Uniform in [0, n), n >= 1, unbiased (rejection of the short last interval).
  std::uint64_t below(std::uint64_t n) {
    const std::uint64_t threshold = (0 - n) % n;  // = 2^64 mod n
    for (;;) {
      const std::uint64_t x = next();
      if (x >= threshold) return x % n;
    }
  }
  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t state_;
};

// A stateless stream for values attached to a place (lattice vertex, block face), so that
// they do not depend on generation order.
Rng place_rng(std::uint64_t seed, std::uint64_t salt, std::int64_t a, std::int64_t b, std::int64_t c) {
  std::uint64_t s = seed ^ (salt * 0xD1B54A32D192ED03ull);
  for (const std::int64_t v : {a, b, c}) {
    s ^= std::uint64_t(v) + 0x9E3779B97F4A7C15ull + (s << 6) + (s >> 2);
    splitmix64(s);
  }
  return Rng(s);
}

constexpr std::uint64_t kSaltWarp = 1, kSaltColour = 2;

// Preset seeds (chosen by inspecting candidate layouts: branching, compact, several dead ends).
constexpr std::uint64_t kMaze11Seed = 7;
constexpr std::uint64_t kMaze41Seed = 2;

std::uint64_t key2(int x, int z) {
  return (std::uint64_t(std::uint32_t(x)) << 32) | std::uint64_t(std::uint32_t(z));
}

// The four side faces and their grid steps in (x, z).
struct Side {
  int face;
  int dx, dz;
};
constexpr Side kSides[4] = {{kFaceNegX, -1, 0}, {kFacePosX, 1, 0}, {kFaceNegZ, 0, -1}, {kFacePosZ, 0, 1}};

constexpr glm::dvec3 kGrey{0.7, 0.7, 0.7};
constexpr glm::dvec3 kFloorGrey{0.6, 0.6, 0.6};
constexpr glm::dvec3 kRed{0.8, 0.12, 0.1};
constexpr glm::dvec3 kGreen{0.12, 0.6, 0.15};
constexpr glm::dvec3 kBlue{0.12, 0.2, 0.75};

FaceMask without(FaceMask mask, int face) { return FaceMask(mask & ~(1u << face)); }

LightDescription light_at(const glm::dvec3& position) {
  LightDescription l;
  l.position = position;
  l.radius = 0.05;
  l.color = glm::dvec3(1.0);
  l.intensity = 1.0;
  return l;
}

glm::dvec3 block_centre(const LevelDescription& level, const BlockDescription& b) {
  return trilinear(block_corners(level, b), glm::dvec3(0.5));
}

std::string fmt_g(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

BlockDescription grey_block(int x, int z, FaceMask faces) {
  BlockDescription b;
  b.cell = {x, 0, z};
  b.faces = faces;
  b.albedo.fill(kGrey);
  b.albedo[kFaceNegY] = kFloorGrey;
  return b;
}

}  // namespace

Result<LevelDescription> generate_maze(const MazeSettings& s) {
  if (s.blocks < 1 || s.blocks > kMaxMazeBlocks)
    return Status::error(ErrorCode::invalid_argument, "maze: blocks = " + std::to_string(s.blocks) +
                                                          " must be in [1, " +
                                                          std::to_string(kMaxMazeBlocks) + "]");
  if (!(s.loop_fraction >= 0.0 && s.loop_fraction <= 1.0))
    return Status::error(ErrorCode::invalid_argument,
                         "maze: loop_fraction = " + fmt_g(s.loop_fraction) + " must be in [0, 1]");
  if (!(s.warp >= 0.0 && s.warp <= 0.25))
    return Status::error(
        ErrorCode::invalid_argument,
        "maze: warp = " + fmt_g(s.warp) + " must be in [0, 0.25] (larger jitter can fold blocks)");

  const std::size_t n = std::size_t(s.blocks);
  Rng rng(s.seed);
  std::vector<glm::ivec2> cells;  // (x, z) per block, in growth order
  std::vector<FaceMask> faces;
  cells.reserve(n);
  faces.reserve(n);
  std::unordered_map<std::uint64_t, int> in_maze;
  in_maze.reserve(2 * n);
  std::vector<glm::ivec2> frontier;  // cells adjacent to the maze, not in it
  std::unordered_map<std::uint64_t, std::size_t> frontier_pos;
  frontier_pos.reserve(4 * n);

  const auto add_cell = [&](glm::ivec2 c) {
    const int index = int(cells.size());
    cells.push_back(c);
    faces.push_back(kAllFaces);
    in_maze.emplace(key2(c.x, c.y), index);
    for (const Side& side : kSides) {
      const glm::ivec2 nb{c.x + side.dx, c.y + side.dz};
      const std::uint64_t k = key2(nb.x, nb.y);
      if (in_maze.count(k) || frontier_pos.count(k)) continue;
      frontier_pos.emplace(k, frontier.size());
      frontier.push_back(nb);
    }
    return index;
  };
  const auto open = [&](int a, int b, int face) {  // carve the passage a --face--> b
    faces[std::size_t(a)] = without(faces[std::size_t(a)], face);
    faces[std::size_t(b)] = without(faces[std::size_t(b)], face ^ 1);
  };

  // Randomised growth: attach a random frontier cell to a random maze neighbour (a
  // spanning tree of passages), until the maze has n cells.
  add_cell({0, 0});
  while (cells.size() < n) {
    const std::size_t pick = std::size_t(rng.below(frontier.size()));
    const glm::ivec2 c = frontier[pick];
    frontier_pos.erase(key2(c.x, c.y));
    if (pick + 1 != frontier.size()) {
      frontier[pick] = frontier.back();
      frontier_pos[key2(frontier[pick].x, frontier[pick].y)] = pick;
    }
    frontier.pop_back();

    int nb_index[4], nb_face[4], count = 0;
    for (const Side& side : kSides) {
      const auto it = in_maze.find(key2(c.x + side.dx, c.y + side.dz));
      if (it == in_maze.end()) continue;
      nb_index[count] = it->second;
      nb_face[count] = side.face;
      ++count;
    }
    const int choice = int(rng.below(std::uint64_t(count)));
    const int index = add_cell(c);
    open(index, nb_index[choice], nb_face[choice]);
  }

  // Loops: open some of the remaining walls between adjacent maze cells.
  if (s.loop_fraction > 0.0) {
    for (std::size_t i = 0; i < n; ++i) {
      for (const Side& side : {kSides[1], kSides[3]}) {  // +X, +Z: each pair once
        const auto it = in_maze.find(key2(cells[i].x + side.dx, cells[i].y + side.dz));
        if (it == in_maze.end() || !face_present(faces[i], side.face)) continue;
        if (rng.uniform() < s.loop_fraction) open(int(i), it->second, side.face);
      }
    }
  }

  LevelDescription level;
  level.name = "maze (" + std::to_string(n) + " blocks, seed " + std::to_string(s.seed) +
               (s.loop_fraction > 0.0 ? ", loops " + fmt_g(s.loop_fraction) : std::string()) +
               (s.warp > 0.0 ? ", warp " + fmt_g(s.warp) : std::string()) + ")";
  level.cell_size = 1.0;
  level.blocks.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    BlockDescription b = grey_block(cells[i].x, cells[i].y, faces[i]);
    if (!s.coloured_walls) {
      b.albedo.fill(kGrey);
    } else {
      for (const Side& side : kSides) {
        if (!face_present(b.faces, side.face)) continue;
        Rng r = place_rng(s.seed, kSaltColour, std::int64_t(i), side.face, 0);
        const std::uint64_t roll = r.below(100);
        b.albedo[std::size_t(side.face)] = roll < 12 ? kRed : roll < 24 ? kGreen : roll < 36 ? kBlue : kGrey;
      }
    }
    if (s.warp > 0.0) {
      // Jitter every lattice vertex (shared by up to 4 blocks) in x and z within a disc of
      // radius warp: an edge then turns by at most 30 degrees and keeps half its length
      // (warp <= 0.25), so the trilinear map stays well inside orientation-preserving.
      b.warped = true;
      for (int k = 0; k < 8; ++k) {
        const int vx = b.cell.x + (k & 1), vy = b.cell.y + ((k >> 1) & 1), vz = b.cell.z + ((k >> 2) & 1);
        Rng r = place_rng(s.seed, kSaltWarp, vx, vy, vz);
        double jx, jz;
        do {
          jx = 2.0 * r.uniform() - 1.0;
          jz = 2.0 * r.uniform() - 1.0;
        } while (jx * jx + jz * jz > 1.0);
        b.corners[std::size_t(k)] = glm::dvec3(vx + s.warp * jx, vy, vz + s.warp * jz) * level.cell_size;
      }
    }
    level.blocks.push_back(b);
  }
  level.lights.push_back(light_at(block_centre(level, level.blocks.front())));
  if (n >= 10) level.lights.push_back(light_at(block_centre(level, level.blocks.back())));

  if (Result<LevelConnectivity> valid = validate_level(level); !valid.ok())
    return Status::error(ErrorCode::internal_error,
                         "maze: generated level failed validation: " + valid.status().message());
  return level;
}

LevelDescription corridor_level() {
  LevelDescription level;
  level.name = "corridor2";
  BlockDescription a = grey_block(0, 0, without(kAllFaces, kFacePosZ));
  BlockDescription b = grey_block(0, 1, without(kAllFaces, kFaceNegZ));
  a.name = "south";
  b.name = "north";
  a.albedo[kFaceNegX] = kRed;
  b.albedo[kFacePosX] = kGreen;
  level.blocks = {a, b};
  level.lights.push_back(light_at({0.5, 0.5, 0.5}));
  return level;
}

LevelDescription l_corner_level() {
  LevelDescription level;
  level.name = "l_corner";
  BlockDescription a = grey_block(0, 0, without(kAllFaces, kFacePosZ));
  BlockDescription b = grey_block(0, 1, without(without(kAllFaces, kFaceNegZ), kFacePosX));
  BlockDescription c = grey_block(1, 1, without(kAllFaces, kFaceNegX));
  a.name = "start";
  b.name = "corner";
  c.name = "end";
  a.albedo[kFaceNegZ] = kRed;
  c.albedo[kFacePosX] = kGreen;
  level.blocks = {a, b, c};
  level.lights.push_back(light_at({0.5, 0.5, 0.5}));
  return level;
}

Result<LevelDescription> maze_level(int blocks) {
  MazeSettings s;
  s.blocks = blocks;
  if (blocks == 11) {
    s.seed = kMaze11Seed;
  } else if (blocks == 41) {
    s.seed = kMaze41Seed;
    s.loop_fraction = 0.15;
  }
  Result<LevelDescription> level = generate_maze(s);
  if (level.ok() && (blocks == 11 || blocks == 41)) level->name = "maze" + std::to_string(blocks);
  return level;
}

}  // namespace modrt::precompute
