#include "modrt/cpu/cpu_level_runtime.h"

#include <algorithm>
#include <string>
#include <system_error>

#include "modrt/cpu/kernels.h"
#include "modrt/reference_runtime.h"
#include "thread_pool.h"

namespace modrt::cpu {
namespace {

Status wrong_size(const char* what, std::size_t got, std::size_t expected) {
  return Status::error(ErrorCode::invalid_argument, std::string(what) + ": has " + std::to_string(got) +
                                                        " floats, expected " + std::to_string(expected));
}

// CSR of `count` groups: begin has count + 1 entries, items lists each group's members in
// increasing order. group_of(m) names the group of member m < members.
template <class GroupOf>
void build_csr(std::size_t count, std::size_t members, GroupOf group_of, std::vector<std::uint32_t>& begin,
               std::vector<std::uint32_t>& items) {
  begin.assign(count + 1, 0);
  for (std::size_t m = 0; m < members; ++m) ++begin[group_of(m) + 1];
  for (std::size_t g = 0; g < count; ++g) begin[g + 1] += begin[g];
  items.assign(members, 0);
  std::vector<std::uint32_t> fill(begin.begin(), begin.end() - 1);
  for (std::size_t m = 0; m < members; ++m) items[fill[group_of(m)]++] = std::uint32_t(m);
}

}  // namespace

CpuLevelRuntime::CpuLevelRuntime(CpuLevelRuntime&&) noexcept = default;
CpuLevelRuntime& CpuLevelRuntime::operator=(CpuLevelRuntime&&) noexcept = default;
CpuLevelRuntime::~CpuLevelRuntime() = default;

template <class F>
void CpuLevelRuntime::parallel_for(std::size_t count, F& f) const {
  if (!pool_) {
    for (std::size_t i = 0; i < count; ++i) f(i, 0);
    return;
  }
  pool_->run(
      count, [](void* ctx, std::size_t i, int thread) { (*static_cast<F*>(ctx))(i, thread); }, &f);
}

Result<CpuLevelRuntime> CpuLevelRuntime::create(const Level& level, const Dictionary& dict,
                                                const CpuRuntimeOptions& options) {
  const Isa isa = options.isa.value_or(active_isa());
  if (!isa_supported(isa))
    return Status::error(ErrorCode::invalid_argument, std::string("cpu runtime: ISA ") + isa_name(isa) +
                                                          " is not supported by this build or CPU");
  if (options.threads < 1 || options.threads > 256)
    return Status::error(ErrorCode::invalid_argument,
                         "cpu runtime: threads must be in [1, 256], got " + std::to_string(options.threads));
  if (Status s = check_level_operators(level, dict); !s.ok()) return s;

  CpuLevelRuntime rt;
  rt.level_ = &level;
  rt.dict_ = &dict;
  rt.isa_ = isa;
  rt.threads_ = options.threads;
  rt.sizes_ = level_buffer_sizes(level, dict);
  for (const LevelBlock& blk : level.blocks)
    rt.max_block_samples_ = std::max<std::size_t>(rt.max_block_samples_, blk.sample_count);
  rt.b_.assign(rt.sizes_.b, 0.0f);
  rt.b_planar_.assign(rt.sizes_.b, 0.0f);
  rt.r_.assign(rt.sizes_.r, 0.0f);
  rt.r_planar_.assign(rt.sizes_.r, 0.0f);
  rt.ld_planar_.assign(3 * rt.max_block_samples_ * std::size_t(options.threads), 0.0f);
  rt.rho_.assign(rt.sizes_.ld, 0.0f);
  rt.ld_feedback_.assign(rt.sizes_.ld, 0.0f);
  build_csr(
      level.slots.size(), level.records.size(),
      [&](std::size_t m) { return std::size_t(level.records[m].slot); }, rt.slot_record_begin_,
      rt.slot_records_);
  build_csr(
      level.blocks.size(), level.slots.size(),
      [&](std::size_t m) { return std::size_t(level.slots[m].block); }, rt.block_slot_begin_,
      rt.block_slots_);
  if (options.threads > 1) {
    try {
      rt.pool_ = std::make_unique<ThreadPool>(options.threads);
    } catch (const std::system_error& e) {
      return Status::error(ErrorCode::invalid_argument,
                           std::string("cpu runtime: cannot start threads: ") + e.what());
    }
  }
  return rt;
}

Status CpuLevelRuntime::evaluate(std::span<const float> ld, std::span<float> lightmap) {
  const Level& level = *level_;
  if (Status s = validate_light_signal(ld, level.sample_count, "ld"); !s.ok()) return s;
  if (lightmap.size() != sizes_.lightmap) return wrong_size("lightmap", lightmap.size(), sizes_.lightmap);

  auto b_phase = [&](std::size_t i, int thread) { compute_block_b(i, ld, thread); };
  parallel_for(level.blocks.size(), b_phase);
  auto lightmap_phase = [&](std::size_t i, int) { compute_block_lightmap(i, lightmap); };
  parallel_for(level.blocks.size(), lightmap_phase);
  return Status::success();
}

// Step 2 for block i: b_i = Td_b ld_i through thread's planar ld scratch; b_i kept planar too.
void CpuLevelRuntime::compute_block_b(std::size_t i, std::span<const float> ld, int thread) {
  const LevelBlock& blk = level_->blocks[i];
  const std::size_t n = blk.sample_count, kb = level_->kb;
  const Matrix& Td_b = dict_->shapes[std::size_t(blk.shape)].Td_b;
  float* scratch = ld_planar_.data() + 3 * max_block_samples_ * std::size_t(thread);
  deinterleave_rgb(ld.data() + 3 * std::size_t(blk.sample_offset), n, scratch, n);
  gemv_rgb(isa_, Td_b.data.data(), kb, n, n, scratch, n, b_.data() + 3 * kb * i, false);
  deinterleave_rgb(b_.data() + 3 * kb * i, kb, b_planar_.data() + 3 * kb * i, kb);
}

// Steps 4, 3 and 5 for the tile of block i: r of every slot entering i (records in level
// order), then lightmap_i = Ub b_i, += Ur r_s scattered onto each slot's entry face.
void CpuLevelRuntime::compute_block_lightmap(std::size_t i, std::span<float> lightmap) {
  const Level& level = *level_;
  const std::size_t kb = level.kb, kr = level.kr;
  float* tile = lightmap.data() + 3 * std::size_t(level.blocks[i].sample_offset);
  for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
    const std::size_t s = block_slots_[j];
    float* r = r_.data() + 3 * kr * s;
    std::fill(r, r + 3 * kr, 0.0f);
    for (std::uint32_t q = slot_record_begin_[s]; q < slot_record_begin_[s + 1]; ++q) {
      const ResponseRecord& rec = level.records[slot_records_[q]];
      gemv_rgb(isa_, rec.T.data.data(), kr, kb, kb, b_planar_.data() + 3 * kb * rec.source_block, kb, r,
               true);
    }
    deinterleave_rgb(r, kr, r_planar_.data() + 3 * kr * s, kr);
  }
  const Matrix& Ub = dict_->shapes[std::size_t(level.blocks[i].shape)].Ub;
  gemv_rgb(isa_, Ub.data.data(), Ub.rows, kb, kb, b_planar_.data() + 3 * kb * i, kb, tile, false);
  const Matrix& Ur = dict_->interfaces.Ur;
  for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
    const std::size_t s = block_slots_[j];
    gemv_rgb_scatter(isa_, Ur.data.data(), Ur.rows, kr, kr, level.slots[s].ur_row_to_sample.data(),
                     r_planar_.data() + 3 * kr * s, kr, tile);
  }
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
  if (!has_albedo_)
    return Status::error(ErrorCode::invalid_argument, "multi_bounce_step: call set_albedo first");
  if (Status s = validate_light_signal(ld_direct, level_->sample_count, "ld_direct"); !s.ok()) return s;
  if (lightmap.size() != sizes_.lightmap) return wrong_size("lightmap", lightmap.size(), sizes_.lightmap);
  const float ld_max = ld_direct.empty() ? 0.0f : *std::max_element(ld_direct.begin(), ld_direct.end());
  const float bound = ld_max / (1.0f - rho_max_);
  const bool clamped = feedback_rgb(isa_, ld_direct.data(), rho_.data(), lightmap.data(), bound,
                                    ld_feedback_.data(), ld_direct.size());
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
  auto probe_phase = [&](std::size_t i, int) {
    float* out = probes.data() + per_block * i;
    const Matrix& Ubvol = dict_->shapes[std::size_t(level.blocks[i].shape)].Ubvol;
    gemv_rgb(isa_, Ubvol.data.data(), Ubvol.rows, kb, kb, b_planar_.data() + 3 * kb * i, kb, out, false);
    for (std::uint32_t j = block_slot_begin_[i]; j < block_slot_begin_[i + 1]; ++j) {
      const std::size_t s = block_slots_[j];
      const Matrix& P = level.probe_response[std::size_t(level.slots[s].entry_face)];
      gemv_rgb(isa_, P.data.data(), P.rows, kr, kr, r_planar_.data() + 3 * kr * s, kr, out, true);
    }
  };
  parallel_for(level.blocks.size(), probe_phase);
  return Status::success();
}

}  // namespace modrt::cpu
