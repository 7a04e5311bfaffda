// SPDX-License-Identifier: MIT
#include "modrt/level_io.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "binary_io.h"
#include "modrt/file_io.h"
#include "modrt/operator_limits.h"
#include "sealed_file.h"

namespace modrt {
namespace {

static_assert(kLevelFileHeaderBytes == binary::kSealedHeaderBytes);

const char* level_version_note(std::uint32_t version) {
  return version == 1   ? " (version 1 has no per-face albedo)"
         : version == 2 ? " (version 2 has no shaped operators)"
                        : "";
}

// Fields: res, kb, kr, blocks, samples, slots, records, shaped operator sets.
binary::SealedFormat level_file_format() {
  binary::SealedFormat f;
  f.magic = kLevelFileMagic;
  f.kind = "modrt level file";
  f.writer = "level";
  f.version = kLevelFileVersion;
  f.fields = 8;
  f.max_file_bytes = kMaxLevelFileBytes;
  f.rebuild = "rebuild the level with modrt-level --save";
  f.version_note = level_version_note;
  return f;
}

using binary::kMaxMatrixDimension;
using binary::Reader;
using binary::Writer;

// --- consistency of a Level on its own (no dictionary) ---

bool finite_matrix(const Matrix& m) {
  for (float v : m.data)
    if (!std::isfinite(v)) return false;
  return true;
}

Status invalid(ErrorCode code, const std::string& what, const std::string& problem) {
  return Status::error(code, what + ": " + problem);
}

Status check_level_structure(const Level& level, const std::string& what, ErrorCode code) {
  if (level.res == 0 && !level.blocks.empty()) return invalid(code, what, "res is 0");
  const std::size_t blocks = level.blocks.size();
  std::uint64_t offset = 0;
  for (std::size_t i = 0; i < blocks; ++i) {
    const LevelBlock& blk = level.blocks[i];
    const std::string name = "block " + std::to_string(i);
    if (blk.shape < 0 || blk.shape >= kDictionaryShapeCount)
      return invalid(code, what,
                     name + ": shape " + std::to_string(blk.shape) + " is not 0.." +
                         std::to_string(kDictionaryShapeCount - 1));
    if (blk.quarter_turns < 0 || blk.quarter_turns > 3)
      return invalid(code, what,
                     name + ": quarter_turns " + std::to_string(blk.quarter_turns) + " is not 0..3");
    for (int f = 0; f < kFaceCount; ++f)
      if (blk.neighbour[std::size_t(f)] < -1 || blk.neighbour[std::size_t(f)] >= std::int64_t(blocks))
        return invalid(code, what, name + ": neighbour of face " + std::to_string(f) + " is out of range");
    for (const glm::dvec3& c : blk.corners)
      if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z))
        return invalid(ErrorCode::non_finite, what, name + ": a corner is not finite");
    for (int f = 0; f < kFaceCount; ++f)
      for (int c = 0; c < 3; ++c) {
        const float a = blk.albedo[std::size_t(f)][c];
        const std::string field =
            name + ": albedo of face " + std::to_string(f) + " channel " + std::to_string(c);
        if (!std::isfinite(a)) return invalid(ErrorCode::non_finite, what, field + " is not finite");
        if (a < 0.0f || a > 1.0f) {
          char value[32];
          std::snprintf(value, sizeof value, "%.9g", double(a));
          return invalid(code, what, field + " is " + value + ", not in [0, 1]");
        }
      }
    if (blk.sample_offset != offset) return invalid(code, what, name + ": sample offsets are not contiguous");
    offset += blk.sample_count;
    if (blk.shaped < -1 || (blk.shaped >= 0 && std::size_t(blk.shaped) >= level.shaped.size()))
      return invalid(code, what,
                     name + ": shaped operators " + std::to_string(blk.shaped) +
                         " out of range (the level has " + std::to_string(level.shaped.size()) + ")");
    if (blk.shaped >= 0 && level.shaped[std::size_t(blk.shaped)].shape != blk.shape)
      return invalid(code, what,
                     name + ": shaped operators " + std::to_string(blk.shaped) +
                         " were baked for another dictionary shape");
  }
  for (std::size_t s = 0; s < level.shaped.size(); ++s) {
    const ShapedOperators& so = level.shaped[s];
    const std::string name = "shaped operators " + std::to_string(s);
    if (so.shape < 0 || so.shape >= kDictionaryShapeCount)
      return invalid(code, what,
                     name + ": shape " + std::to_string(so.shape) + " is not 0.." +
                         std::to_string(kDictionaryShapeCount - 1));
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(so.extent[a]) || !(so.extent[a] > 0.0f))
        return invalid(ErrorCode::non_finite, what, name + ": extent is not finite and > 0");
    const std::uint32_t n =
        std::uint32_t(face_count(dictionary_shape_mask(so.shape)) * level.res * level.res);
    const ShapeOperators& op = so.operators;
    // A shaped set keeps its own modes (Ub's columns), at most the level's kb (b's stride).
    const std::uint32_t kb = op.Ub.cols;
    if (kb == 0 || kb > level.kb)
      return invalid(code, what,
                     name + ": " + std::to_string(kb) + " modes, not 1.." + std::to_string(level.kb) +
                         " (the level's kb)");
    if (op.Ub.rows != n || op.Td_b.rows != kb || op.Td_b.cols != n || op.Limp.rows != n ||
        op.Limp.cols != kb || (!op.Ub_vec.empty() && (op.Ub_vec.rows != 4 * n || op.Ub_vec.cols != kb)) ||
        (!op.Ubvol.empty() && op.Ubvol.cols != kb))
      return invalid(code, what,
                     name + ": Ub, Td_b, Limp, Ub_vec or Ubvol is not sized for " + std::to_string(n) +
                         " samples and " + std::to_string(kb) + " modes");
    for (const Matrix* m : {&op.Ub, &op.Td_b, &op.Limp, &op.Ub_vec, &op.Ubvol})
      if (!finite_matrix(*m)) return invalid(ErrorCode::non_finite, what, name + ": NaN or Inf");
  }
  if (offset != level.sample_count)
    return invalid(code, what,
                   "block sample counts add up to " + std::to_string(offset) + ", the level has " +
                       std::to_string(level.sample_count));
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    const std::string name = "slot " + std::to_string(s);
    if (slot.block >= blocks)
      return invalid(code, what, name + ": block " + std::to_string(slot.block) + " out of range");
    if (slot.entry_face < 0 || slot.entry_face >= kFaceCount)
      return invalid(code, what, name + ": bad entry face");
    const std::int64_t n = level.blocks[slot.block].sample_count;
    for (std::int32_t m : slot.ur_row_to_sample)
      if (m < -1 || m >= n) return invalid(code, what, name + ": Ur row maps past the block's samples");
  }
  std::uint32_t cube_kb = 0, most_modes = 0;
  for (const ShapedOperators& so : level.shaped) most_modes = std::max(most_modes, so.operators.Ub.cols);
  for (std::size_t i = 0; i < level.records.size(); ++i) {
    const ResponseRecord& rec = level.records[i];
    const std::string name = "record " + std::to_string(i);
    if (rec.source_block >= blocks || rec.slot >= level.slots.size())
      return invalid(code, what, name + ": source block or slot out of range");
    if (i > 0 && rec.slot < level.records[i - 1].slot)
      return invalid(code, what, name + ": records are not sorted by slot");
    // T's columns are its source block's modes: a shaped set's own, else the dictionary's
    // (at most the level's kb; check_level_operators compares them with the dictionary).
    // Records from cube blocks all have the dictionary's modes.
    const LevelBlock& source = level.blocks[rec.source_block];
    if (source.shaped < 0 && cube_kb == 0) cube_kb = rec.T.cols;
    const std::uint32_t source_kb =
        source.shaped >= 0 ? level.shaped[std::size_t(source.shaped)].operators.Ub.cols : cube_kb;
    if (rec.T.rows != level.kr || rec.T.cols != source_kb || rec.T.cols == 0 || rec.T.cols > level.kb)
      return invalid(code, what,
                     name + ": T is " + std::to_string(rec.T.rows) + "x" + std::to_string(rec.T.cols) +
                         ", not kr x kb of its source block (kr " + std::to_string(level.kr) + ", kb " +
                         std::to_string(source_kb) + ", at most the level's " + std::to_string(level.kb) +
                         ")");
    most_modes = std::max(most_modes, rec.T.cols);
    if (!finite_matrix(rec.T)) return invalid(ErrorCode::non_finite, what, name + ": T has NaN or Inf");
  }
  // kb is b's stride, the most modes of any operator set: no wider than the operators it holds
  // show (check_level_operators compares a level without records or shaped sets with the
  // dictionary).
  if (most_modes > 0 && most_modes != level.kb)
    return invalid(code, what,
                   "kb " + std::to_string(level.kb) + " is not the most modes of the level's operators (" +
                       std::to_string(most_modes) + "): not kr x kb");
  for (int f = 0; f < kFaceCount; ++f) {
    if (!finite_matrix(level.probe_response[std::size_t(f)]))
      return invalid(ErrorCode::non_finite, what, "probe_response " + std::to_string(f) + " has NaN or Inf");
    if (!finite_matrix(level.vector_response[std::size_t(f)]))
      return invalid(ErrorCode::non_finite, what, "vector_response " + std::to_string(f) + " has NaN or Inf");
  }
  const LightmapAtlas& atlas = level.atlas;
  if (atlas.width < 0 || atlas.height < 0 || atlas.tile < 0 || atlas.width > (1 << 16) ||
      atlas.height > (1 << 16))
    return invalid(code, what,
                   "atlas size " + std::to_string(atlas.width) + "x" + std::to_string(atlas.height) +
                       " is out of range");
  const std::uint64_t texels = std::uint64_t(atlas.width) * std::uint64_t(atlas.height);
  if (!atlas.sample_texel.empty() && atlas.sample_texel.size() != level.sample_count)
    return invalid(code, what, "atlas sample_texel does not cover the level's samples");
  for (std::uint32_t t : atlas.sample_texel)
    if (t >= texels)
      return invalid(code, what, "atlas sample texel " + std::to_string(t) + " is outside the atlas");
  for (const PaddingRecord& p : atlas.padding)
    if (p.dst >= texels || p.src >= texels) return invalid(code, what, "atlas padding record out of range");
  const bool has_tiles = !atlas.tile_origin_x.empty() || !atlas.tile_origin_y.empty();
  if (has_tiles && (atlas.tile_origin_x.size() != blocks || atlas.tile_origin_y.size() != blocks))
    return invalid(code, what, "atlas tile origins do not have one entry per block");
  for (std::size_t i = 0; has_tiles && i < blocks; ++i)
    for (int f = 0; f < kFaceCount; ++f) {
      const std::int32_t x = atlas.tile_origin_x[i][std::size_t(f)],
                         y = atlas.tile_origin_y[i][std::size_t(f)];
      if ((x < 0) != (y < 0) || x < -1 || y < -1 ||
          (x >= 0 && (x + atlas.tile > atlas.width || y + atlas.tile > atlas.height)))
        return invalid(code, what,
                       "atlas tile of block " + std::to_string(i) + " face " + std::to_string(f) +
                           " lies outside the atlas");
    }
  // Finite; now plausible (operator_limits.h).
  return check_measures(measure_level_operators(level), what);
}

}  // namespace

Result<std::vector<std::byte>> serialize_level(const Level& level) {
  if (Status s = check_level_structure(level, "level", ErrorCode::invalid_argument); !s.ok()) return s;

  Writer body;
  for (const LevelBlock& blk : level.blocks) {
    body.i32(blk.shape);
    body.i32(blk.quarter_turns);
    body.i32(blk.cell.x);
    body.i32(blk.cell.y);
    body.i32(blk.cell.z);
    for (const glm::dvec3& c : blk.corners) {
      body.f64(c.x);
      body.f64(c.y);
      body.f64(c.z);
    }
    for (std::int32_t n : blk.neighbour) body.i32(n);
    body.u32(blk.sample_offset);
    body.u32(blk.sample_count);
    for (const glm::vec3& a : blk.albedo) {
      body.f32(a.r);
      body.f32(a.g);
      body.f32(a.b);
    }
  }
  for (const ResponseSlot& slot : level.slots) {
    body.u32(slot.block);
    body.i32(slot.entry_face);
    body.u32(std::uint32_t(slot.ur_row_to_sample.size()));
    for (std::int32_t m : slot.ur_row_to_sample) body.i32(m);
  }
  for (const ResponseRecord& rec : level.records) {
    body.u32(rec.source_block);
    body.u32(rec.slot);
    body.matrix(rec.T);
  }
  for (const Matrix& m : level.probe_response) body.matrix(m);
  for (const Matrix& m : level.vector_response) body.matrix(m);
  const LightmapAtlas& atlas = level.atlas;
  body.i32(atlas.width);
  body.i32(atlas.height);
  body.i32(atlas.tile);
  body.u32(std::uint32_t(atlas.sample_texel.size()));
  for (std::uint32_t t : atlas.sample_texel) body.u32(t);
  body.u32(atlas.tile_origin_x.empty() ? 0u : 1u);
  for (std::size_t i = 0; i < atlas.tile_origin_x.size(); ++i) {
    for (std::int32_t x : atlas.tile_origin_x[i]) body.i32(x);
    for (std::int32_t y : atlas.tile_origin_y[i]) body.i32(y);
  }
  body.u32(std::uint32_t(atlas.padding.size()));
  for (const PaddingRecord& p : atlas.padding) {
    body.u32(p.dst);
    body.u32(p.src);
  }
  for (const ShapedOperators& so : level.shaped) {
    body.i32(so.shape);
    for (int a = 0; a < 3; ++a) body.f32(so.extent[a]);
    for (const Matrix* m : {&so.operators.Ub, &so.operators.Td_b, &so.operators.Limp, &so.operators.Ub_vec,
                            &so.operators.Ubvol})
      body.matrix(*m);
  }
  if (!level.shaped.empty())
    for (const LevelBlock& blk : level.blocks) body.i32(blk.shaped);

  return binary::seal(level_file_format(),
                      {std::uint32_t(level.res), level.kb, level.kr, std::uint32_t(level.blocks.size()),
                       level.sample_count, std::uint32_t(level.slots.size()),
                       std::uint32_t(level.records.size()), std::uint32_t(level.shaped.size())},
                      body.bytes);
}

Status save_level(const std::string& path, const Level& level) {
  Result<std::vector<std::byte>> bytes = serialize_level(level);
  if (!bytes.ok()) return Status::error(bytes.status().code(), path + ": " + bytes.status().message());
  return write_file_atomic(path, bytes.value());
}

Result<Level> parse_level(std::span<const std::byte> bytes, const std::string& what) {
  auto error = [&](ErrorCode code, const std::string& problem) {
    return Status::error(code, what + ": " + problem);
  };
  binary::SealedFields header{};
  const Result<std::span<const std::byte>> body =
      binary::open_sealed(level_file_format(), bytes, what, header);
  if (!body.ok()) return body.status();
  const std::span<const std::byte> body_span = body.value();

  Level level;
  level.res = int(header[0]);
  level.kb = header[1];
  level.kr = header[2];
  const std::uint32_t block_count = header[3];
  level.sample_count = header[4];
  const std::uint32_t slot_count = header[5];
  const std::uint32_t record_count = header[6];
  const std::uint32_t shaped_count = header[7];
  if (level.res > 4096 || level.kb > kMaxMatrixDimension || level.kr > kMaxMatrixDimension)
    return error(ErrorCode::format_error, "res " + std::to_string(level.res) + ", kb " +
                                              std::to_string(level.kb) + " or kr " +
                                              std::to_string(level.kr) + " is out of range");

  Reader in(body_span, what);
  // Smallest encoded sizes bound the counts before anything is allocated.
  constexpr std::uint64_t kBlockBytes = kLevelFileBlockBytes;
  static_assert(kFaceCount == 6, "the block layout has 6 faces");
  if (in.fits("blocks", block_count, kBlockBytes)) level.blocks.resize(block_count);
  for (std::uint32_t i = 0; i < block_count && in.ok(); ++i) {
    LevelBlock& blk = level.blocks[i];
    const std::string f = "block " + std::to_string(i);
    blk.shape = in.i32(f + " shape");
    blk.quarter_turns = in.i32(f + " quarter_turns");
    blk.cell.x = in.i32(f + " cell");
    blk.cell.y = in.i32(f + " cell");
    blk.cell.z = in.i32(f + " cell");
    for (glm::dvec3& c : blk.corners) {
      c.x = in.f64(f + " corners");
      c.y = in.f64(f + " corners");
      c.z = in.f64(f + " corners");
    }
    for (std::int32_t& n : blk.neighbour) n = in.i32(f + " neighbour");
    blk.sample_offset = in.u32(f + " sample_offset");
    blk.sample_count = in.u32(f + " sample_count");
    for (glm::vec3& a : blk.albedo) {
      a.r = in.f32(f + " albedo");
      a.g = in.f32(f + " albedo");
      a.b = in.f32(f + " albedo");
    }
  }
  if (in.fits("slots", slot_count, 12)) level.slots.resize(slot_count);
  for (std::uint32_t s = 0; s < slot_count && in.ok(); ++s) {
    ResponseSlot& slot = level.slots[s];
    const std::string f = "slot " + std::to_string(s);
    slot.block = in.u32(f + " block");
    slot.entry_face = in.i32(f + " entry_face");
    const std::uint32_t n = in.u32(f + " ur_row_to_sample count");
    if (!in.fits(f + " ur_row_to_sample", n, 4)) break;
    slot.ur_row_to_sample.resize(n);
    for (std::int32_t& m : slot.ur_row_to_sample) m = in.i32(f + " ur_row_to_sample");
  }
  if (in.fits("records", record_count, 16)) level.records.resize(record_count);
  for (std::uint32_t r = 0; r < record_count && in.ok(); ++r) {
    ResponseRecord& rec = level.records[r];
    const std::string f = "record " + std::to_string(r);
    rec.source_block = in.u32(f + " source_block");
    rec.slot = in.u32(f + " slot");
    rec.T = in.matrix(f + " T");
  }
  for (int e = 0; e < kFaceCount; ++e)
    level.probe_response[std::size_t(e)] = in.matrix("probe_response " + std::to_string(e));
  for (int e = 0; e < kFaceCount; ++e)
    level.vector_response[std::size_t(e)] = in.matrix("vector_response " + std::to_string(e));
  LightmapAtlas& atlas = level.atlas;
  atlas.width = in.i32("atlas width");
  atlas.height = in.i32("atlas height");
  atlas.tile = in.i32("atlas tile");
  const std::uint32_t texel_count = in.u32("atlas sample_texel count");
  if (in.fits("atlas sample_texel", texel_count, 4)) {
    atlas.sample_texel.resize(texel_count);
    for (std::uint32_t& t : atlas.sample_texel) t = in.u32("atlas sample_texel");
  }
  const std::uint32_t has_tiles = in.u32("atlas tile origins flag");
  if (in.ok() && has_tiles > 1)
    in.fail("atlas tile origins flag", std::to_string(has_tiles) + " is not 0 or 1");
  if (has_tiles == 1 && in.fits("atlas tile origins", block_count, 8 * kFaceCount)) {
    atlas.tile_origin_x.resize(block_count);
    atlas.tile_origin_y.resize(block_count);
    for (std::uint32_t i = 0; i < block_count && in.ok(); ++i) {
      for (std::int32_t& x : atlas.tile_origin_x[i]) x = in.i32("atlas tile_origin_x");
      for (std::int32_t& y : atlas.tile_origin_y[i]) y = in.i32("atlas tile_origin_y");
    }
  }
  const std::uint32_t padding_count = in.u32("atlas padding count");
  if (in.fits("atlas padding", padding_count, 8)) {
    atlas.padding.resize(padding_count);
    for (PaddingRecord& p : atlas.padding) {
      p.dst = in.u32("atlas padding dst");
      p.src = in.u32("atlas padding src");
    }
  }
  // Smallest set: shape, extent and five empty matrices (8 bytes each).
  if (in.fits("shaped operators", shaped_count, 4 + 12 + 5 * 8)) level.shaped.resize(shaped_count);
  for (std::uint32_t s = 0; s < shaped_count && in.ok(); ++s) {
    ShapedOperators& so = level.shaped[s];
    const std::string f = "shaped operators " + std::to_string(s);
    so.shape = in.i32(f + " shape");
    for (int a = 0; a < 3; ++a) so.extent[a] = in.f32(f + " extent");
    so.operators.Ub = in.matrix(f + " Ub");
    so.operators.Td_b = in.matrix(f + " Td_b");
    so.operators.Limp = in.matrix(f + " Limp");
    so.operators.Ub_vec = in.matrix(f + " Ub_vec");
    so.operators.Ubvol = in.matrix(f + " Ubvol");
    if (so.shape >= 0 && so.shape < kDictionaryShapeCount)
      so.operators.face_mask = dictionary_shape_mask(so.shape);
  }
  if (shaped_count > 0 && in.fits("block shaped", block_count, 4))
    for (std::uint32_t i = 0; i < block_count && in.ok(); ++i)
      level.blocks[i].shaped = in.i32("block " + std::to_string(i) + " shaped");
  if (!in.ok()) return in.status();
  if (in.left() != 0)
    return error(ErrorCode::format_error,
                 std::to_string(in.left()) + " trailing bytes after the shaped operators");
  if (Status s = check_level_structure(level, what, ErrorCode::format_error); !s.ok()) return s;
  return level;
}

Result<Level> load_level(const std::string& path) {
  Result<std::vector<std::byte>> bytes = read_file(path, kMaxLevelFileBytes);
  if (!bytes.ok()) return bytes.status();
  return parse_level(bytes.value(), path);
}

}  // namespace modrt
