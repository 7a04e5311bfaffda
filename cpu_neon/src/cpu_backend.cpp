// SPDX-License-Identifier: MIT
#include "modrt/cpu/cpu_backend.h"
#include "modrt/feedback_policy.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "modrt/cpu/cpu_drt.h"
#include "modrt/cpu/kernels.h"

namespace modrt::cpu {
namespace {

class CpuBackend final : public Backend {
 public:
  CpuBackend(const Level& level, CpuLevelRuntime runtime, const CpuBackendOptions& options)
      : level_(level),
        rt_(std::move(runtime)),
        description_(std::string("cpu ") + isa_name(rt_.isa())),
        lightmap_(rt_.sizes().lightmap, 0.0f),
        atlas_(rt_.sizes().atlas, 0.0f),
        probes_(options.probes ? rt_.sizes().probes : 0, 0.0f),
        rho_(rt_.sizes().ld, 0.0f),
        timing_(options.timing) {}

  BackendKind kind() const override { return BackendKind::cpu; }
  const char* description() const override { return description_.c_str(); }
  const LevelBufferSizes& sizes() const override { return rt_.sizes(); }

  Status update(std::span<const float> ld) override {
    times_ = BackendStageTimes{};
    const Clock::time_point t0 = Clock::now();
    if (drt_) {
      if (Status s = rt_.evaluate(ld, base_); !s.ok()) return s;
      stage(times_.lightmap, t0);
      if (!rho_c_.empty()) c_ = c_direct_;  // a new first bounce: the clutter's direct light only
      return finish_drt();
    }
    if (Status s = rt_.evaluate(ld, lightmap_); !s.ok()) return s;
    stage(times_.lightmap, t0);
    // Skipping left every b, r and tile as it was (a repeated ld): the atlas and probes on hand
    // are this frame's, so nothing more runs (Backend's evaluations_skipped, as GLES).
    if (updated_ && rt_.skip_options().enabled && rt_.skip_stats().tiles_written == 0) {
      count_evaluation();
      ++evaluations_.evaluations_skipped;
      return Status::success();
    }
    return finish();
  }
  std::span<const float> output_data(BackendOutput output) const override {
    if (output == BackendOutput::atlas) return atlas_;  // zeros before the first update
    return {};
  }
  const BackendStageTimes& stage_times() const override { return times_; }
  void set_timing(bool on) override { timing_ = on; }
  BackendEvaluationStats evaluation_stats() const override { return evaluations_; }
  Status set_albedo(std::span<const float> albedo, float max_albedo) override {
    if (Status s = rt_.set_albedo(albedo, max_albedo); !s.ok()) return s;
    // The clutter path runs the feedback itself (see multi_bounce_step), so it keeps the same
    // clamped albedo as the level runtime.
    rho_max_ = clamp_albedo(albedo, max_albedo, rho_).rho_max;
    has_albedo_ = true;
    return Status::success();
  }
  Status multi_bounce_step(std::span<const float> ld_direct) override {
    if (!updated_)
      return Status::error(ErrorCode::invalid_argument, "cpu: multi_bounce_step: call update first");
    times_ = BackendStageTimes{};
    const Clock::time_point t0 = Clock::now();
    if (drt_) {
      // The feedback reads the lightmap with the DRT delta, but the level runtime must write
      // the MRT part into base_: with skipping on it keeps unchanged tiles in place, and
      // lightmap_'s would carry last frame's delta. Same kernel as CpuLevelRuntime's step.
      if (!has_albedo_)
        return Status::error(ErrorCode::invalid_argument, "cpu: multi_bounce_step: call set_albedo first");
      if (Status s = validate_light_signal(ld_direct, lightmap_.size() / 3, "ld_direct"); !s.ok()) return s;
      const float ld_max = largest_light(ld_direct);
      if (!rho_c_.empty()) {  // the clutter's indirect light of the last evaluation, fed back
        if (Status s = drt_->clutter_lightmap(rt_.b(), {}, clutter_indirect_); !s.ok()) return s;
        if (Status s = drt_->clutter_add_cc(c_, clutter_indirect_); !s.ok()) return s;
        drt_clutter_feedback(clutter_ld_, rho_c_, clutter_indirect_,
                             drt_feedback_bound(ld_max, rho_max_, clutter_ld_max_, rho_c_max_), clutter_fed_);
        if (Status s = drt_->compute_c(clutter_fed_, c_); !s.ok()) return s;
      }
      feedback_rgb(rt_.isa(), ld_direct.data(), rho_.data(), lightmap_.data(),
                   feedback_energy_bound(ld_max, rho_max_), ld_feedback_.data(), ld_direct.size());
      if (Status s = rt_.evaluate(ld_feedback_, base_); !s.ok()) return s;
      stage(times_.lightmap, t0);
      return finish_drt();
    }
    if (Status s = rt_.multi_bounce_step(ld_direct, lightmap_); !s.ok()) return s;
    stage(times_.lightmap, t0);
    return finish();
  }
  Status read_lightmap(std::span<float> out) override { return copy("lightmap", lightmap_, out); }
  Status read_atlas(std::span<float> out) override { return copy("atlas", atlas_, out); }
  Status read_probes(std::span<float> out) override {
    if (probes_.empty())
      return Status::error(ErrorCode::invalid_argument,
                           "cpu: no probes: the dictionary has none, or CpuBackendOptions::probes is off");
    return copy("probes", probes_, out);
  }
  // Computed on request from the kept b and r, so frames that never read it pay nothing.
  Status read_vector_lightmap(std::span<float> out) override {
    if (!updated_) return Status::error(ErrorCode::invalid_argument, "cpu: read before the first update");
    if (Status s = rt_.compute_vector_irradiance(out); !s.ok()) return s;
    return drt_ ? drt_->apply_vector(rt_.b(), c_, out) : Status::success();  // DRT §5 (dUb_vec, dUc_vec)
  }

  Status set_clutter(const DrtOperators* drt) override {
    if (!drt || drt->empty()) {
      drt_.reset();
      drt_sizes_ = {};
      base_ = {}, c_ = {}, c_direct_ = {}, clutter_ld_ = {}, clutter_direct_ = {}, clutter_lightmap_ = {};
      ld_feedback_ = {}, rho_c_ = {}, clutter_indirect_ = {}, clutter_fed_ = {};
      updated_ = false;
      return Status::success();
    }
    if (Status s = check_probe_grid(*drt); !s.ok()) return s;
    Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(level_, *drt, rt_.isa());
    if (!rt.ok()) return rt.status();
    drt_.emplace(std::move(rt).value());
    drt_sizes_ = drt_->sizes();
    base_.assign(lightmap_.size(), 0.0f);
    ld_feedback_.assign(lightmap_.size(), 0.0f);
    c_.assign(drt_sizes_.c, 0.0f);
    c_direct_ = c_;
    rho_c_.clear();
    clutter_ld_.assign(drt_sizes_.clutter_ld, 0.0f);
    clutter_direct_.clear();
    clutter_lightmap_.assign(drt_sizes_.clutter_lightmap, 0.0f);
    updated_ = false;  // the results on hand are without this clutter
    return Status::success();
  }
  Status set_clutter_light(std::span<const float> clutter_ld,
                           std::span<const float> clutter_direct) override {
    if (!drt_) return Status::error(ErrorCode::invalid_argument, "cpu: set_clutter_light: no clutter set");
    const std::size_t n = drt_sizes_.clutter_ld;
    if (clutter_ld.size() != n || (!clutter_direct.empty() && clutter_direct.size() != n))
      return Status::error(ErrorCode::invalid_argument,
                           "cpu: set_clutter_light: clutter_ld has " + std::to_string(clutter_ld.size()) +
                               " floats and clutter_direct " + std::to_string(clutter_direct.size()) +
                               ", expected " + std::to_string(n) + " (clutter_direct may be empty)");
    if (Status s = validate_light_signal(clutter_ld, n / 3, "clutter_ld"); !s.ok()) return s;
    if (!clutter_direct.empty())
      if (Status s = validate_light_signal(clutter_direct, n / 3, "clutter_direct"); !s.ok()) return s;
    clutter_ld_.assign(clutter_ld.begin(), clutter_ld.end());
    clutter_ld_max_ = clutter_ld.empty() ? 0.0f : *std::max_element(clutter_ld.begin(), clutter_ld.end());
    clutter_direct_.assign(clutter_direct.begin(), clutter_direct.end());
    if (Status s = drt_->compute_c(clutter_ld_, c_direct_); !s.ok()) return s;
    c_ = c_direct_;
    return Status::success();
  }
  Status set_clutter_albedo(std::span<const float> clutter_albedo, float max_albedo) override {
    if (!drt_) return Status::error(ErrorCode::invalid_argument, "cpu: set_clutter_albedo: no clutter set");
    if (Status s = check_max_albedo(max_albedo, "cpu: set_clutter_albedo"); !s.ok()) return s;
    if (!clutter_albedo.empty())
      if (Status s = validate_light_signal(clutter_albedo, drt_sizes_.clutter_texels, "clutter_albedo");
          !s.ok())
        return s;
    rho_c_.assign(clutter_albedo.begin(), clutter_albedo.end());
    c_ = c_direct_;  // without feedback c stays the direct light's (update() keeps it then)
    rho_c_max_ = clamp_albedo(rho_c_, max_albedo, rho_c_).rho_max;
    clutter_indirect_.assign(rho_c_.empty() ? 0 : drt_sizes_.clutter_lightmap, 0.0f);
    clutter_fed_.assign(rho_c_.empty() ? 0 : drt_sizes_.clutter_ld, 0.0f);
    return Status::success();
  }
  const DrtBufferSizes& clutter_sizes() const override { return drt_sizes_; }
  // Computed on request from the kept b and c (DRT §5, C_b vector).
  Status read_clutter_vector_lightmap(std::span<float> out) override {
    if (!drt_)
      return Status::error(ErrorCode::invalid_argument, "cpu: read_clutter_vector_lightmap: no clutter set");
    if (!updated_) return Status::error(ErrorCode::invalid_argument, "cpu: read before the first update");
    return drt_->clutter_vector_lightmap(rt_.b(), c_, out);
  }
  Status read_clutter_lightmap(std::span<float> out) override {
    if (!drt_)
      return Status::error(ErrorCode::invalid_argument, "cpu: read_clutter_lightmap: no clutter set");
    return copy("clutter lightmap", clutter_lightmap_, out);
  }

 private:
  // U_dyn operators must be for the dictionary's probe grid (the probes this backend computes).
  Status check_probe_grid(const DrtOperators& drt) const {
    bool any = false;
    for (const DrtObjectOperators& o : drt.objects) any |= !o.Udyn.empty() || !o.Udyn_c.empty();
    if (!any || probes_.empty() ||
        std::size_t(27) * drt.probes_per_block * level_.blocks.size() == probes_.size())
      return Status::success();
    return Status::error(
        ErrorCode::invalid_argument,
        "cpu: the U_dyn operators are for " + std::to_string(drt.probes_per_block) +
            " probes per block, the dictionary's grid has " +
            std::to_string(probes_.size() / 27 / std::max<std::size_t>(level_.blocks.size(), 1)));
  }
  using Clock = std::chrono::steady_clock;
  // Adds the time since `since` to `field` when timing is on; returns now.
  Clock::time_point stage(std::uint64_t& field, Clock::time_point since) const {
    if (!timing_) return since;
    const Clock::time_point now = Clock::now();
    field += std::uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(now - since).count());
    return now;
  }
  // One evaluation of the level runtime: its skip counters (per evaluation) into the totals.
  void count_evaluation() {
    const std::uint64_t blocks = level_.blocks.size(), slots = level_.slots.size();
    BackendEvaluationStats& e = evaluations_;
    ++e.evaluations;
    if (!rt_.skip_options().enabled) {
      e.blocks_computed += blocks, e.slots_computed += slots, e.tiles_written += blocks;
      return;
    }
    const CpuSkipStats& s = rt_.skip_stats();
    e.blocks_computed += s.blocks_computed + s.blocks_dark;
    e.blocks_kept += s.blocks_kept;
    e.slots_computed += slots - s.slots_kept;
    e.slots_kept += s.slots_kept;
    e.tiles_written += s.tiles_written;
    e.tiles_kept += s.tiles_skipped;
  }
  Status finish() {
    updated_ = true;
    count_evaluation();
    Clock::time_point t = Clock::now();
    if (Status s = rt_.fill_atlas(lightmap_, atlas_); !s.ok()) return s;
    t = stage(times_.atlas, t);
    if (probes_.empty()) return Status::success();
    if (Status s = rt_.compute_probes(probes_); !s.ok()) return s;
    if (drt_)
      if (Status s = drt_->apply_probes(rt_.b(), c_, probes_); !s.ok()) return s;  // DRT §5 (U_dyn)
    stage(times_.probes, t);
    return Status::success();
  }
  // architecture.md §5 step 7 after steps 2-5: lightmap = base + dUb b + dUc c, then the clutter lightmap
  // Cb b + Cc c + direct.
  Status finish_drt() {
    const Clock::time_point t = Clock::now();
    std::copy(base_.begin(), base_.end(), lightmap_.begin());
    if (Status s = drt_->apply(rt_.b(), c_, lightmap_); !s.ok()) return s;
    clamp_nonnegative(rt_.isa(), lightmap_.data(), lightmap_.size());  // the lightmap policy, as core
    if (Status s = drt_->clutter_lightmap(rt_.b(), clutter_direct_, clutter_lightmap_); !s.ok()) return s;
    if (Status s = drt_->clutter_add_cc(c_, clutter_lightmap_); !s.ok()) return s;
    // The clutter lightmap is a lightmap: clamped at 0 (core's drt_evaluate_clutter_lightmap).
    clamp_nonnegative(rt_.isa(), clutter_lightmap_.data(), clutter_lightmap_.size());
    stage(times_.drt, t);
    return finish();
  }
  Status copy(const char* what, const std::vector<float>& from, std::span<float> to) const {
    if (to.size() != from.size())
      return Status::error(ErrorCode::invalid_argument, std::string("cpu: ") + what + ": has " +
                                                            std::to_string(to.size()) + " floats, expected " +
                                                            std::to_string(from.size()));
    if (!updated_) return Status::error(ErrorCode::invalid_argument, "cpu: read before the first update");
    std::copy(from.begin(), from.end(), to.begin());
    return Status::success();
  }

  const Level& level_;
  CpuLevelRuntime rt_;
  std::string description_;
  std::vector<float> lightmap_, atlas_, probes_;
  bool updated_ = false;
  // DRT (only with clutter): the MRT lightmap the level runtime writes, c, the clutter's light
  // and lightmap, the feedback ld; the albedo as clamped by set_albedo.
  std::optional<CpuDrtRuntime> drt_;
  DrtBufferSizes drt_sizes_;
  std::vector<float> base_, c_, clutter_ld_, clutter_direct_, clutter_lightmap_, ld_feedback_;
  // The clutter's feedback (set_clutter_albedo): c of its direct light alone, the clamped
  // clutter albedo, the last evaluation's Cb b + Cc c and the light fed back.
  std::vector<float> c_direct_, rho_c_, clutter_indirect_, clutter_fed_;
  float rho_c_max_ = 0.0f, clutter_ld_max_ = 0.0f;
  std::vector<float> rho_;
  float rho_max_ = 0.0f;
  bool has_albedo_ = false;
  bool timing_ = false;
  BackendStageTimes times_;
  BackendEvaluationStats evaluations_;
};

}  // namespace

Result<std::unique_ptr<Backend>> create_cpu_backend(const Level& level, const Dictionary& dict,
                                                    const CpuBackendOptions& options) {
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(level, dict, options.runtime);
  if (!rt.ok()) return rt.status();
  return std::unique_ptr<Backend>(new CpuBackend(level, std::move(rt).value(), options));
}

Result<std::unique_ptr<Backend>> create_cpu_backend(const Level& level, const Dictionary& dict,
                                                    const CpuRuntimeOptions& options) {
  CpuBackendOptions o;
  o.runtime = options;
  return create_cpu_backend(level, dict, o);
}

}  // namespace modrt::cpu
