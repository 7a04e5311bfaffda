// SPDX-License-Identifier: MIT
#include "modrt/level_runtime.h"

#include <algorithm>
#include <string>
#include <vector>

#include "modrt/level_dirty.h"
#include "modrt/operator_limits.h"

namespace modrt {
namespace {

Status mismatch(const std::string& what) {
  return Status::error(ErrorCode::invalid_argument, "level does not match the dictionary: " + what +
                                                        ": rebuild the level against this dictionary");
}

bool has_size(const Matrix& m, std::size_t rows, std::size_t cols) {
  return m.rows == rows && m.cols == cols && m.data.size() == rows * cols;
}

}  // namespace

LevelBufferSizes level_buffer_sizes(const Level& level, const Dictionary& dict) {
  LevelBufferSizes s;
  s.ld = s.lightmap = 3 * std::size_t(level.sample_count);
  s.b = 3 * std::size_t(level.kb) * level.blocks.size();
  s.r = 3 * std::size_t(level.kr) * level.slots.size();
  s.atlas = 3 * std::size_t(level.atlas.width) * std::size_t(level.atlas.height);
  const std::size_t probes_per_block = dict.shapes.empty() ? 0 : dict.shapes[0].Ubvol.rows;
  s.probes = 3 * probes_per_block * level.blocks.size();
  s.vector_lightmap = 12 * std::size_t(level.sample_count);
  return s;
}

Status check_level_matches(const Level& level, const Dictionary& dict) {
  if (std::uint32_t(level.res) != dict.settings.res || level.kb != level_b_stride(dict, level) ||
      level.kr != dict.interfaces.Ur.cols)
    return Status::error(
        ErrorCode::invalid_argument,
        "level was built for res " + std::to_string(level.res) + ", kb " + std::to_string(level.kb) +
            ", kr " + std::to_string(level.kr) + " but the dictionary (and its shaped sets) have res " +
            std::to_string(dict.settings.res) + ", kb " + std::to_string(level_b_stride(dict, level)) +
            ", kr " + std::to_string(dict.interfaces.Ur.cols) + ": rebuild the level");
  return Status::success();
}

void level_compute_block_b(const Level& level, const Dictionary& dict, std::span<const float> ld,
                           std::size_t block, std::span<float> b) {
  const LevelBlock& blk = level.blocks[block];
  const Matrix& Td_b = block_operators(dict, level, blk).Td_b;
  float* bi = b.data() + 3 * std::size_t(level.kb) * block;
  reference_gemv_rgb(Td_b, ld.data() + 3 * std::size_t(blk.sample_offset), bi, false);
  std::fill(bi + 3 * std::size_t(Td_b.rows), bi + 3 * std::size_t(level.kb), 0.0f);  // past its modes
}

void level_compute_slot_r(const Level& level, const LevelDependencies& deps, std::span<const float> b,
                          std::size_t slot, std::span<float> r) {
  float* rs = r.data() + 3 * std::size_t(level.kr) * slot;
  std::fill(rs, rs + 3 * std::size_t(level.kr), 0.0f);
  for (std::uint32_t m : deps.records_of_slot(slot)) {
    const ResponseRecord& rec = level.records[m];
    reference_gemv_rgb(rec.T, b.data() + 3 * std::size_t(level.kb) * rec.source_block, rs, true);
  }
}

void level_compute_tile(const Level& level, const Dictionary& dict, const LevelDependencies& deps,
                        std::span<const float> b, std::span<const float> r, std::size_t block,
                        std::span<float> lightmap) {
  const LevelBlock& blk = level.blocks[block];
  float* dst = lightmap.data() + 3 * std::size_t(blk.sample_offset);
  reference_gemv_rgb(block_operators(dict, level, blk).Ub, b.data() + 3 * std::size_t(level.kb) * block, dst,
                     false);
  const Matrix& Ur = dict.interfaces.Ur;
  for (std::uint32_t s : deps.slots_of_block(block)) {
    const ResponseSlot& slot = level.slots[s];
    const float* rs = r.data() + 3 * std::size_t(level.kr) * s;
    for (std::uint32_t row = 0; row < Ur.rows; ++row) {
      const std::int32_t sample = slot.ur_row_to_sample[row];
      if (sample < 0) continue;
      const float* u = Ur.data.data() + std::size_t(row) * Ur.cols;
      double acc[3] = {0, 0, 0};
      for (std::uint32_t k = 0; k < Ur.cols; ++k)
        for (int c = 0; c < 3; ++c) acc[c] += double(u[k]) * rs[3 * k + c];
      for (int c = 0; c < 3; ++c) dst[3 * std::size_t(sample) + c] += float(acc[c]);
    }
  }
  clamp_lightmap({dst, 3 * std::size_t(blk.sample_count)});  // the lightmap policy (reference_runtime.h)
}

void level_compute_block_probes(const Level& level, const Dictionary& dict, const LevelDependencies& deps,
                                std::span<const float> b, std::span<const float> r, std::size_t block,
                                std::span<float> probes) {
  const std::size_t per_block = 3 * std::size_t(dict.shapes[0].Ubvol.rows);
  float* dst = probes.data() + per_block * block;
  reference_gemv_rgb(block_operators(dict, level, level.blocks[block]).Ubvol,
                     b.data() + 3 * std::size_t(level.kb) * block, dst, false);
  for (std::uint32_t s : deps.slots_of_block(block))
    reference_gemv_rgb(level.probe_response[std::size_t(level.slots[s].entry_face)],
                       r.data() + 3 * std::size_t(level.kr) * s, dst, true);
}

Status level_compute_b(const Level& level, const Dictionary& dict, std::span<const float> ld,
                       std::span<float> b) {
  if (Status s = validate_light_signal(ld, level.sample_count, "ld"); !s.ok()) return s;
  if (b.size() != 3 * std::size_t(level.kb) * level.blocks.size())
    return Status::error(ErrorCode::invalid_argument, "b: wrong size");
  for (std::size_t i = 0; i < level.blocks.size(); ++i) level_compute_block_b(level, dict, ld, i, b);
  return Status::success();
}

void level_compute_r(const Level& level, std::span<const float> b, std::span<float> r) {
  const LevelDependencies deps = level_dependencies(level);
  for (std::size_t s = 0; s < level.slots.size(); ++s) level_compute_slot_r(level, deps, b, s, r);
}

void level_compute_lightmap(const Level& level, const Dictionary& dict, std::span<const float> b,
                            std::span<const float> r, std::span<float> lightmap) {
  const LevelDependencies deps = level_dependencies(level);
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    level_compute_tile(level, dict, deps, b, r, i, lightmap);
}

Status level_evaluate(const Level& level, const Dictionary& dict, std::span<const float> ld,
                      std::span<float> b, std::span<float> r, std::span<float> lightmap) {
  return level_evaluate(level, dict, level_dependencies(level), ld, b, r, lightmap);
}

Status level_evaluate(const Level& level, const Dictionary& dict, const LevelDependencies& deps,
                      std::span<const float> ld, std::span<float> b, std::span<float> r,
                      std::span<float> lightmap) {
  if (Status s = level_compute_b(level, dict, ld, b); !s.ok()) return s;
  for (std::size_t s = 0; s < level.slots.size(); ++s) level_compute_slot_r(level, deps, b, s, r);
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    level_compute_tile(level, dict, deps, b, r, i, lightmap);
  return Status::success();
}

Result<MultiBounceReport> level_multi_bounce(const Level& level, const Dictionary& dict,
                                             std::span<const float> ld_direct, std::span<const float> albedo,
                                             const MultiBounceSettings& settings, std::span<float> b,
                                             std::span<float> r, std::span<float> lightmap) {
  Result<FeedbackClamp> clamp = prepare_feedback(ld_direct, albedo, level.sample_count, settings);
  if (!clamp.ok()) return clamp.status();
  MultiBounceReport report;
  report.albedo_clamped = clamp->albedo_clamped;
  report.energy_bound = clamp->energy_bound;
  std::vector<float> ld(ld_direct.begin(), ld_direct.end()), b_prev(b.size());
  const LevelDependencies deps = level_dependencies(level);
  if (Status s = level_evaluate(level, dict, deps, ld, b, r, lightmap); !s.ok()) return s;
  for (int it = 1; it <= settings.max_iterations; ++it) {
    report.value_clamped |= apply_feedback(clamp.value(), ld_direct, lightmap, ld);
    std::copy(b.begin(), b.end(), b_prev.begin());
    if (Status s = level_evaluate(level, dict, deps, ld, b, r, lightmap); !s.ok()) return s;
    report.iterations = it;
    if (feedback_converged(b, b_prev, settings.tolerance)) {
      report.converged = true;
      break;
    }
  }
  return report;
}

void level_fill_atlas(const Level& level, std::span<const float> lightmap, std::span<float> atlas) {
  std::fill(atlas.begin(), atlas.end(), 0.0f);
  for (std::size_t s = 0; s < level.atlas.sample_texel.size(); ++s)
    for (int c = 0; c < 3; ++c) atlas[3 * std::size_t(level.atlas.sample_texel[s]) + c] = lightmap[3 * s + c];
  for (const PaddingRecord& p : level.atlas.padding)
    for (int c = 0; c < 3; ++c) atlas[3 * std::size_t(p.dst) + c] = atlas[3 * std::size_t(p.src) + c];
}

void level_compute_probes(const Level& level, const Dictionary& dict, std::span<const float> b,
                          std::span<const float> r, std::span<float> probes) {
  const LevelDependencies deps = level_dependencies(level);
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    level_compute_block_probes(level, dict, deps, b, r, i, probes);
}

Status check_level_vector_operators(const Level& level, const Dictionary& dict) {
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    if (blk.shape < 0 || std::size_t(blk.shape) >= dict.shapes.size() ||
        (blk.shaped >= 0 && std::size_t(blk.shaped) >= level.shaped.size()))
      return Status::error(ErrorCode::invalid_argument,
                           "vector irradiance: block " + std::to_string(i) + " has no dictionary shape");
    if (!has_size(block_operators(dict, level, blk).Ub_vec, 4 * std::size_t(blk.sample_count),
                  block_kb(dict, level, blk)))
      return Status::error(ErrorCode::invalid_argument, "vector irradiance: block " + std::to_string(i) +
                                                            ": the dictionary has no Ub_vec of 4n x kb");
  }
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    if (!has_size(level.vector_response[std::size_t(slot.entry_face)], 4 * slot.ur_row_to_sample.size(),
                  level.kr))
      return Status::error(ErrorCode::invalid_argument, "vector irradiance: slot " + std::to_string(s) +
                                                            ": the level has no vector response of 4n x kr "
                                                            "(dictionary without Ur_vec?)");
  }
  return Status::success();
}

Status level_compute_vector_irradiance(const Level& level, const Dictionary& dict, std::span<const float> b,
                                       std::span<const float> r, std::span<float> vector_lightmap) {
  const LevelBufferSizes sizes = level_buffer_sizes(level, dict);
  if (b.size() != sizes.b || r.size() != sizes.r || vector_lightmap.size() != sizes.vector_lightmap)
    return Status::error(ErrorCode::invalid_argument,
                         "vector irradiance: b, r or vector lightmap has the wrong size");
  if (Status s = check_level_vector_operators(level, dict); !s.ok()) return s;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    reference_gemv_rgb(block_operators(dict, level, blk).Ub_vec, b.data() + 3 * std::size_t(level.kb) * i,
                       vector_lightmap.data() + 12 * std::size_t(blk.sample_offset), false);
  }
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    const Matrix& U = level.vector_response[std::size_t(slot.entry_face)];
    const float* rs = r.data() + 3 * std::size_t(level.kr) * s;
    float* dst = vector_lightmap.data() + 12 * std::size_t(level.blocks[slot.block].sample_offset);
    for (std::size_t row = 0; row < slot.ur_row_to_sample.size(); ++row) {
      const std::int32_t sample = slot.ur_row_to_sample[row];
      if (sample < 0) continue;
      for (std::size_t i = 0; i < 4; ++i) {
        const float* u = U.data.data() + (4 * row + i) * U.cols;
        double acc[3] = {0, 0, 0};
        for (std::uint32_t k = 0; k < U.cols; ++k)
          for (int c = 0; c < 3; ++c) acc[c] += double(u[k]) * rs[3 * k + c];
        for (int c = 0; c < 3; ++c) dst[3 * (4 * std::size_t(sample) + i) + std::size_t(c)] += float(acc[c]);
      }
    }
  }
  return Status::success();
}

Status check_level_operators(const Level& level, const Dictionary& dict) {
  if (Status s = check_level_matches(level, dict); !s.ok()) return s;
  const std::size_t kb = level.kb, kr = level.kr;
  std::size_t probes = dict.shapes.empty() ? 0 : dict.shapes[0].Ubvol.rows;
  std::size_t offset = 0;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    const std::string name = "block " + std::to_string(i);
    if (blk.shape < 0 || std::size_t(blk.shape) >= dict.shapes.size())
      return mismatch(name + " uses shape " + std::to_string(blk.shape) + ", the dictionary has " +
                      std::to_string(dict.shapes.size()));
    if (blk.shaped < -1 || (blk.shaped >= 0 && std::size_t(blk.shaped) >= level.shaped.size()))
      return mismatch(name + " uses shaped operators " + std::to_string(blk.shaped) + ", the level has " +
                      std::to_string(level.shaped.size()));
    const ShapeOperators& op = block_operators(dict, level, blk);
    const std::size_t n = blk.sample_count, kb_block = op.Ub.cols;
    if (kb_block == 0 || kb_block > kb || !has_size(op.Td_b, kb_block, n) || !has_size(op.Ub, n, kb_block) ||
        (probes > 0 && !has_size(op.Ubvol, probes, kb_block)))
      return mismatch(name + ": shape " + std::to_string(blk.shape) + " operators are not " +
                      std::to_string(kb_block) + " (at most kb " + std::to_string(kb) + ") x " +
                      std::to_string(n) + " samples");
    if (blk.sample_offset != offset) return mismatch(name + ": sample offsets are not contiguous");
    offset += n;
  }
  if (offset != level.sample_count) return mismatch("block sample counts do not add up to the level's");
  const Matrix& Ur = dict.interfaces.Ur;
  if (!level.slots.empty() && Ur.data.size() != std::size_t(Ur.rows) * Ur.cols)
    return mismatch("dictionary Ur is malformed");
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    const std::string name = "slot " + std::to_string(s);
    if (slot.block >= level.blocks.size() || slot.ur_row_to_sample.size() != Ur.rows)
      return mismatch(name + ": block or Ur row map out of range");
    const std::uint32_t n = level.blocks[slot.block].sample_count;
    for (std::int32_t m : slot.ur_row_to_sample)
      if (m >= std::int32_t(n)) return mismatch(name + ": Ur row maps past the block's samples");
    if (slot.entry_face < 0 || slot.entry_face >= kFaceCount) return mismatch(name + ": bad entry face");
    if (probes > 0 && !has_size(level.probe_response[std::size_t(slot.entry_face)], probes, kr))
      return mismatch(name + ": probe response is not " + std::to_string(probes) + " x " +
                      std::to_string(kr));
  }
  for (std::size_t i = 0; i < level.records.size(); ++i) {
    const ResponseRecord& rec = level.records[i];
    if (rec.source_block >= level.blocks.size() || rec.slot >= level.slots.size() ||
        !has_size(rec.T, kr, block_kb(dict, level, level.blocks[rec.source_block])))
      return mismatch("record " + std::to_string(i) + " is out of range or not kr x its source block's kb");
  }
  const std::size_t texels =
      std::size_t(std::max(level.atlas.width, 0)) * std::size_t(std::max(level.atlas.height, 0));
  if (!level.atlas.sample_texel.empty() && level.atlas.sample_texel.size() != level.sample_count)
    return mismatch("atlas sample_texel does not cover the level's samples");
  for (std::uint32_t t : level.atlas.sample_texel)
    if (t >= texels) return mismatch("atlas sample texel out of range");
  for (const PaddingRecord& p : level.atlas.padding)
    if (p.dst >= texels || p.src >= texels) return mismatch("atlas padding record out of range");
  // Padding copies tile interiors into padding texels, never padding into padding: then the
  // records of one block can run apart from the others' (atlas_block_padding, the camera skip).
  if (!level.atlas.padding.empty()) {
    std::vector<std::uint8_t> interior(texels, 0);
    for (std::uint32_t t : level.atlas.sample_texel) interior[t] = 1;
    for (std::size_t m = 0; m < level.atlas.padding.size(); ++m) {
      const PaddingRecord& p = level.atlas.padding[m];
      if (!interior[p.src] || interior[p.dst])
        return mismatch("atlas padding record " + std::to_string(m) +
                        " does not copy a sample texel into a padding texel");
    }
  }
  // Sizes are valid: bound the amplification ld -> outputs so that no update overflows.
  return check_level_gain(level, dict);
}

}  // namespace modrt
