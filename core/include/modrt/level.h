// SPDX-License-Identifier: MIT
// modrt — a built level: the run-time form of a LevelDescription (architecture.md §4, MRT §6.2–6.3).
//
// Every block keeps its samples in the canonical order of its dictionary shape (cube.h
// SampleLayout), so the shape's Td_b, Ub, ... apply unchanged; `quarter_turns` maps the
// canonical block onto the world grid. Level-wide signals (ld, lightmap) concatenate the
// blocks' samples: block i owns [sample_offset, sample_offset + sample_count).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/dictionary.h"

namespace modrt {

// Albedo of a face that the level's author did not colour (level JSON's `default_albedo`).
inline constexpr double kDefaultFaceAlbedo = 0.7;

struct LevelBlock {
  int shape = 0;  // dictionary shape index (the block's face mask, canonicalised)
  // The block's operators: -1 = its dictionary shape's (a cube's); otherwise an index into
  // Level::shaped, operators baked for the block's proportions (MRT §8). Look them up with
  // block_operators() below.
  int shaped = -1;
  int quarter_turns = 0;  // world = rotate(canonical, quarter_turns)
  glm::ivec3 cell{0};
  std::array<glm::dvec3, 8> corners{};      // world corners (x + 2y + 4z), see level_description.h
  std::array<int, kFaceCount> neighbour{};  // per canonical face: connected block, or -1
  std::uint32_t sample_offset = 0;
  std::uint32_t sample_count = 0;
  // Diffuse reflectance (linear RGB, each channel in [0, 1]) per *canonical* face: the
  // authored albedo of world face rotate_face(f, quarter_turns). Every sample of a face
  // reflects its face's albedo (level_sample_albedo, level_geometry.h).
  std::array<glm::vec3, kFaceCount> albedo = uniform_face_albedo(float(kDefaultFaceAlbedo));

  static std::array<glm::vec3, kFaceCount> uniform_face_albedo(float a) {
    std::array<glm::vec3, kFaceCount> out{};
    for (glm::vec3& v : out) v = glm::vec3(a);
    return out;
  }
};

// r(slot) = sum over records of T * b(source); slot = light entering `block` through its
// canonical side face `entry_face` (MRT §6.3: Trlf_r R... Rb_rlf concatenated and summed).
struct ResponseSlot {
  std::uint32_t block = 0;
  int entry_face = 0;
  // Ur row -> block sample: for each row of Ur (dead-end samples), the sample of `block`
  // it lands on after rotating -Z onto entry_face, or -1 where that face is missing.
  std::vector<std::int32_t> ur_row_to_sample;
};

struct ResponseRecord {
  std::uint32_t source_block = 0;
  std::uint32_t slot = 0;
  Matrix T;  // kr x kb
};

// One lightmap texel copied to another in the padded atlas (MRT §6.2, [Loos et al. 2011]).
struct PaddingRecord {
  std::uint32_t dst;  // atlas texel index (y * width + x)
  std::uint32_t src;
};

struct LightmapAtlas {
  int width = 0, height = 0;
  int tile = 0;  // res + 2 (1-texel padding on each side)
  // Atlas texel of each level sample (the unpadded interior of its face's tile).
  std::vector<std::uint32_t> sample_texel;
  // Tile origin (top-left padded texel) per block and canonical face; -1 when missing.
  std::vector<std::array<std::int32_t, kFaceCount>> tile_origin_x, tile_origin_y;
  std::vector<PaddingRecord> padding;
};

// Operators baked for a box that is not a cube (MRT §8, Figure 12), shared by every block of
// the level whose dictionary shape and (quantised) proportions they were baked for.
struct ShapedOperators {
  int shape = 0;           // dictionary shape (face mask) of the blocks that use them
  glm::vec3 extent{1.0f};  // the canonical box's edge lengths (x, y, z), geometric mean 1
  // Sizes as the dictionary shape's but for the modes: Ub's columns (block_kb) may be more
  // than the dictionary's kb (precompute's shaped_mode_factor); Rb_rlf for its missing side faces.
  ShapeOperators operators;
};

struct Level {
  int res = 0;
  // kb: the stride of b, the most modes of any operator set the level's blocks use (the
  // dictionary's kb, or more where shaped sets carry more modes: block_kb below). Block i's b
  // is 3 kb floats at 3 kb i; a block with fewer modes leaves the rest of its stride zero.
  std::uint32_t kb = 0, kr = 0;
  std::vector<LevelBlock> blocks;
  std::uint32_t sample_count = 0;
  std::vector<ResponseSlot> slots;
  std::vector<ResponseRecord> records;  // sorted by slot
  // Urvol turned so that light enters through canonical side face e (probe positions
  // permuted, SH9 rotated): 9 g^3 x kr per side face, empty for floor and ceiling.
  std::array<Matrix, kFaceCount> probe_response;
  // Ur_vec turned so that light enters through canonical side face e: 4n(dead end) x kr per
  // side face, rows in the dead end's sample order (placed by ur_row_to_sample), OHLSH
  // coefficients in the frame of the face each row lands on; empty for floor and ceiling.
  std::array<Matrix, kFaceCount> vector_response;
  LightmapAtlas atlas;
  std::vector<ShapedOperators> shaped;  // LevelBlock::shaped indexes these
};

// The level's operator sets on a dictionary: the dictionary's shapes [0, shapes.size()), then
// the level's shaped operators. Backends upload and index operators by this set index, so a
// shaped block costs what a cube block costs.
inline std::size_t operator_set_count(const Dictionary& dict, const Level& level) {
  return dict.shapes.size() + level.shaped.size();
}
inline std::size_t operator_set(const Dictionary& dict, const LevelBlock& block) {
  return block.shaped < 0 ? std::size_t(block.shape) : dict.shapes.size() + std::size_t(block.shaped);
}
inline const ShapeOperators& operator_set_at(const Dictionary& dict, const Level& level, std::size_t set) {
  return set < dict.shapes.size() ? dict.shapes[set] : level.shaped[set - dict.shapes.size()].operators;
}
inline const ShapeOperators& block_operators(const Dictionary& dict, const Level& level,
                                             const LevelBlock& block) {
  return operator_set_at(dict, level, operator_set(dict, block));
}
// What Level::kb must be: the dictionary's kb or the most modes of a shaped set, if more.
inline std::uint32_t level_b_stride(const Dictionary& dict, const Level& level) {
  std::uint32_t kb = dict.settings.kb;
  for (const ShapedOperators& s : level.shaped) kb = s.operators.Ub.cols > kb ? s.operators.Ub.cols : kb;
  return kb;
}
// The modes of block's b (its operator set's Ub columns): a shaped set baked for a long box
// keeps more modes than a cube's (ShapedOperators; the b of every block is level.kb wide).
inline std::uint32_t block_kb(const Dictionary& dict, const Level& level, const LevelBlock& block) {
  return block_operators(dict, level, block).Ub.cols;
}

}  // namespace modrt
