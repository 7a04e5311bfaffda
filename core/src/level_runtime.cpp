#include "modrt/level_runtime.h"

#include <algorithm>
#include <string>
#include <vector>

namespace modrt {
namespace {

// out[3r + c] (+)= sum_k A(r, k) in[3k + c], double accumulation.
void gemv_rgb(const Matrix& A, const float* in, float* out, bool accumulate) {
  for (std::uint32_t row = 0; row < A.rows; ++row) {
    const float* a = A.data.data() + std::size_t(row) * A.cols;
    double acc[3] = {0, 0, 0};
    for (std::uint32_t k = 0; k < A.cols; ++k) {
      acc[0] += double(a[k]) * in[3 * k + 0];
      acc[1] += double(a[k]) * in[3 * k + 1];
      acc[2] += double(a[k]) * in[3 * k + 2];
    }
    for (int c = 0; c < 3; ++c) out[3 * row + c] = float((accumulate ? out[3 * row + c] : 0.0) + acc[c]);
  }
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
  return s;
}

Status check_level_matches(const Level& level, const Dictionary& dict) {
  if (std::uint32_t(level.res) != dict.settings.res || level.kb != dict.settings.kb ||
      level.kr != dict.interfaces.Ur.cols)
    return Status::error(ErrorCode::invalid_argument,
                         "level was built for res " + std::to_string(level.res) + ", kb " + std::to_string(level.kb) +
                             ", kr " + std::to_string(level.kr) + " but the dictionary has res " +
                             std::to_string(dict.settings.res) + ", kb " + std::to_string(dict.settings.kb) +
                             ", kr " + std::to_string(dict.interfaces.Ur.cols) + ": rebuild the level");
  return Status::success();
}

Status level_compute_b(const Level& level, const Dictionary& dict, std::span<const float> ld, std::span<float> b) {
  if (Status s = validate_light_signal(ld, level.sample_count, "ld"); !s.ok()) return s;
  if (b.size() != 3 * std::size_t(level.kb) * level.blocks.size())
    return Status::error(ErrorCode::invalid_argument, "b: wrong size");
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    gemv_rgb(dict.shapes[std::size_t(blk.shape)].Td_b, ld.data() + 3 * std::size_t(blk.sample_offset),
             b.data() + 3 * std::size_t(level.kb) * i, false);
  }
  return Status::success();
}

void level_compute_r(const Level& level, std::span<const float> b, std::span<float> r) {
  std::fill(r.begin(), r.end(), 0.0f);
  for (const ResponseRecord& rec : level.records)
    gemv_rgb(rec.T, b.data() + 3 * std::size_t(level.kb) * rec.source_block,
             r.data() + 3 * std::size_t(level.kr) * rec.slot, true);
}

void level_compute_lightmap(const Level& level, const Dictionary& dict, std::span<const float> b,
                            std::span<const float> r, std::span<float> lightmap) {
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    gemv_rgb(dict.shapes[std::size_t(blk.shape)].Ub, b.data() + 3 * std::size_t(level.kb) * i,
             lightmap.data() + 3 * std::size_t(blk.sample_offset), false);
  }
  const Matrix& Ur = dict.interfaces.Ur;
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    const float* rs = r.data() + 3 * std::size_t(level.kr) * s;
    float* dst = lightmap.data() + 3 * std::size_t(level.blocks[slot.block].sample_offset);
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
}

Status level_evaluate(const Level& level, const Dictionary& dict, std::span<const float> ld, std::span<float> b,
                      std::span<float> r, std::span<float> lightmap) {
  if (Status s = level_compute_b(level, dict, ld, b); !s.ok()) return s;
  level_compute_r(level, b, r);
  level_compute_lightmap(level, dict, b, r, lightmap);
  return Status::success();
}

Result<MultiBounceReport> level_multi_bounce(const Level& level, const Dictionary& dict,
                                             std::span<const float> ld_direct, std::span<const float> albedo,
                                             const MultiBounceSettings& settings, std::span<float> b,
                                             std::span<float> r, std::span<float> lightmap) {
  const std::size_t n = level.sample_count;
  if (Status s = validate_light_signal(ld_direct, n, "ld_direct"); !s.ok()) return s;
  if (Status s = validate_light_signal(albedo, n, "albedo"); !s.ok()) return s;
  if (!(settings.max_albedo >= 0.0f && settings.max_albedo < 1.0f) || settings.max_iterations < 1)
    return Status::error(ErrorCode::invalid_argument,
                         "level_multi_bounce: settings.max_albedo must be in [0, 1) and max_iterations >= 1");
  MultiBounceReport report;
  std::vector<float> rho(albedo.begin(), albedo.end());
  float rho_max = 0.0f;
  for (float& v : rho) {
    if (v > settings.max_albedo) {
      v = settings.max_albedo;
      report.albedo_clamped = true;
    }
    rho_max = std::max(rho_max, v);
  }
  report.energy_bound = *std::max_element(ld_direct.begin(), ld_direct.end()) / (1.0f - rho_max);
  std::vector<float> ld(ld_direct.begin(), ld_direct.end()), b_prev(b.size());
  if (Status s = level_evaluate(level, dict, ld, b, r, lightmap); !s.ok()) return s;
  for (int it = 1; it <= settings.max_iterations; ++it) {
    for (std::size_t i = 0; i < ld.size(); ++i) {
      float l = std::max(lightmap[i], 0.0f);
      if (l > report.energy_bound) {
        l = report.energy_bound;
        report.value_clamped = true;
      }
      ld[i] = ld_direct[i] + rho[i] * l;
    }
    std::copy(b.begin(), b.end(), b_prev.begin());
    if (Status s = level_evaluate(level, dict, ld, b, r, lightmap); !s.ok()) return s;
    report.iterations = it;
    float delta = 0.0f, scale = 0.0f;
    for (std::size_t k = 0; k < b.size(); ++k) {
      delta = std::max(delta, std::abs(b[k] - b_prev[k]));
      scale = std::max(scale, std::abs(b[k]));
    }
    if (delta <= settings.tolerance * scale) {
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
  const std::size_t per_block = 3 * std::size_t(dict.shapes[0].Ubvol.rows);
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    gemv_rgb(dict.shapes[std::size_t(level.blocks[i].shape)].Ubvol, b.data() + 3 * std::size_t(level.kb) * i,
             probes.data() + per_block * i, false);
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    gemv_rgb(level.probe_response[std::size_t(slot.entry_face)], r.data() + 3 * std::size_t(level.kr) * s,
             probes.data() + per_block * slot.block, true);
  }
}

}  // namespace modrt
