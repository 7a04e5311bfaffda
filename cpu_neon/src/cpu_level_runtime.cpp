#include "modrt/cpu/cpu_level_runtime.h"

#include <algorithm>
#include <string>

#include "modrt/cpu/kernels.h"
#include "modrt/reference_runtime.h"

namespace modrt::cpu {
namespace {

Status wrong_size(const char* what, std::size_t got, std::size_t expected) {
  return Status::error(ErrorCode::invalid_argument, std::string(what) + ": has " + std::to_string(got) +
                                                        " floats, expected " + std::to_string(expected));
}

}  // namespace

Result<CpuLevelRuntime> CpuLevelRuntime::create(const Level& level, const Dictionary& dict,
                                                const CpuRuntimeOptions& options) {
  const Isa isa = options.isa.value_or(active_isa());
  if (!isa_supported(isa))
    return Status::error(ErrorCode::invalid_argument,
                         std::string("cpu runtime: ISA ") + isa_name(isa) + " is not supported by this build or CPU");
  if (options.threads != 1)
    return Status::error(ErrorCode::invalid_argument, "cpu runtime: threads must be 1 (no thread pool yet)");
  if (Status s = check_level_operators(level, dict); !s.ok()) return s;

  CpuLevelRuntime rt;
  rt.level_ = &level;
  rt.dict_ = &dict;
  rt.isa_ = isa;
  rt.sizes_ = level_buffer_sizes(level, dict);
  for (const LevelBlock& blk : level.blocks) rt.max_block_samples_ = std::max<std::size_t>(rt.max_block_samples_, blk.sample_count);
  rt.b_.assign(rt.sizes_.b, 0.0f);
  rt.b_planar_.assign(rt.sizes_.b, 0.0f);
  rt.r_.assign(rt.sizes_.r, 0.0f);
  rt.r_planar_.assign(rt.sizes_.r, 0.0f);
  rt.ld_planar_.assign(3 * rt.max_block_samples_, 0.0f);
  rt.rho_.assign(rt.sizes_.ld, 0.0f);
  rt.ld_feedback_.assign(rt.sizes_.ld, 0.0f);
  return rt;
}

Status CpuLevelRuntime::evaluate(std::span<const float> ld, std::span<float> lightmap) {
  const Level& level = *level_;
  const Dictionary& dict = *dict_;
  if (Status s = validate_light_signal(ld, level.sample_count, "ld"); !s.ok()) return s;
  if (lightmap.size() != sizes_.lightmap) return wrong_size("lightmap", lightmap.size(), sizes_.lightmap);
  const std::size_t kb = level.kb, kr = level.kr;

  // Step 2: b = Td_b ld, block by block through one planar ld scratch; b kept planar too.
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    const std::size_t n = blk.sample_count;
    const Matrix& Td_b = dict.shapes[std::size_t(blk.shape)].Td_b;
    deinterleave_rgb(ld.data() + 3 * std::size_t(blk.sample_offset), n, ld_planar_.data(), n);
    gemv_rgb(isa_, Td_b.data.data(), kb, n, n, ld_planar_.data(), n, b_.data() + 3 * kb * i, false);
    deinterleave_rgb(b_.data() + 3 * kb * i, kb, b_planar_.data() + 3 * kb * i, kb);
  }

  // Step 4: r = sum over records of T b(source).
  std::fill(r_.begin(), r_.end(), 0.0f);
  for (const ResponseRecord& rec : level.records)
    gemv_rgb(isa_, rec.T.data.data(), kr, kb, kb, b_planar_.data() + 3 * kb * rec.source_block, kb,
             r_.data() + 3 * kr * rec.slot, true);
  for (std::size_t s = 0; s < level.slots.size(); ++s)
    deinterleave_rgb(r_.data() + 3 * kr * s, kr, r_planar_.data() + 3 * kr * s, kr);

  // Steps 3 and 5: lightmap = Ub b, then += Ur r scattered onto each slot's entry face.
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    const Matrix& Ub = dict.shapes[std::size_t(blk.shape)].Ub;
    gemv_rgb(isa_, Ub.data.data(), Ub.rows, kb, kb, b_planar_.data() + 3 * kb * i, kb,
             lightmap.data() + 3 * std::size_t(blk.sample_offset), false);
  }
  const Matrix& Ur = dict.interfaces.Ur;
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    gemv_rgb_scatter(isa_, Ur.data.data(), Ur.rows, kr, kr, slot.ur_row_to_sample.data(),
                     r_planar_.data() + 3 * kr * s, kr,
                     lightmap.data() + 3 * std::size_t(level.blocks[slot.block].sample_offset));
  }
  return Status::success();
}

Status CpuLevelRuntime::set_albedo(std::span<const float> albedo, float max_albedo) {
  if (Status s = validate_light_signal(albedo, level_->sample_count, "albedo"); !s.ok()) return s;
  if (!(max_albedo >= 0.0f && max_albedo < 1.0f))
    return Status::error(ErrorCode::invalid_argument, "multi-bounce: max_albedo must be in [0, 1)");
  rho_max_ = 0.0f;
  for (std::size_t i = 0; i < albedo.size(); ++i) {
    rho_[i] = std::min(albedo[i], max_albedo);
    rho_max_ = std::max(rho_max_, rho_[i]);
  }
  has_albedo_ = true;
  return Status::success();
}

Status CpuLevelRuntime::multi_bounce_step(std::span<const float> ld_direct, std::span<float> lightmap,
                                          bool* value_clamped) {
  if (!has_albedo_) return Status::error(ErrorCode::invalid_argument, "multi_bounce_step: call set_albedo first");
  if (Status s = validate_light_signal(ld_direct, level_->sample_count, "ld_direct"); !s.ok()) return s;
  if (lightmap.size() != sizes_.lightmap) return wrong_size("lightmap", lightmap.size(), sizes_.lightmap);
  const float ld_max = ld_direct.empty() ? 0.0f : *std::max_element(ld_direct.begin(), ld_direct.end());
  const float bound = ld_max / (1.0f - rho_max_);
  const bool clamped =
      feedback_rgb(isa_, ld_direct.data(), rho_.data(), lightmap.data(), bound, ld_feedback_.data(), ld_direct.size());
  if (value_clamped) *value_clamped = clamped;
  return evaluate(ld_feedback_, lightmap);
}

Status CpuLevelRuntime::fill_atlas(std::span<const float> lightmap, std::span<float> atlas) const {
  if (lightmap.size() != sizes_.lightmap) return wrong_size("lightmap", lightmap.size(), sizes_.lightmap);
  if (atlas.size() != sizes_.atlas) return wrong_size("atlas", atlas.size(), sizes_.atlas);
  std::fill(atlas.begin(), atlas.end(), 0.0f);
  scatter_texels(level_->atlas.sample_texel, lightmap.data(), atlas.data());
  copy_padding(level_->atlas.padding, atlas.data());
  return Status::success();
}

Status CpuLevelRuntime::compute_probes(std::span<float> probes) const {
  if (probes.size() != sizes_.probes) return wrong_size("probes", probes.size(), sizes_.probes);
  const Level& level = *level_;
  if (probes.empty()) return Status::success();
  const std::size_t kb = level.kb, kr = level.kr;
  const std::size_t per_block = 3 * std::size_t(dict_->shapes[0].Ubvol.rows);
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const Matrix& Ubvol = dict_->shapes[std::size_t(level.blocks[i].shape)].Ubvol;
    gemv_rgb(isa_, Ubvol.data.data(), Ubvol.rows, kb, kb, b_planar_.data() + 3 * kb * i, kb,
             probes.data() + per_block * i, false);
  }
  for (std::size_t s = 0; s < level.slots.size(); ++s) {
    const ResponseSlot& slot = level.slots[s];
    const Matrix& P = level.probe_response[std::size_t(slot.entry_face)];
    gemv_rgb(isa_, P.data.data(), P.rows, kr, kr, r_planar_.data() + 3 * kr * s, kr,
             probes.data() + per_block * slot.block, true);
  }
  return Status::success();
}

}  // namespace modrt::cpu
