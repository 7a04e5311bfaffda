// SPDX-License-Identifier: MIT
#include "modrt/cpu/cpu_backend.h"

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "modrt/cpu/cpu_drt.h"
#include "modrt/cpu/kernels.h"
#include "modrt/staged_backend.h"

#include "fp_env.h"

namespace modrt::cpu {
namespace {

// CpuLevelRuntime's stages under core's StagedBackend: the runtime computes b, r and the tiles
// of what the pipeline marks (r and the tiles fused in one task per block, the r stage is
// empty), the atlas whole, the probes of the marked tiles; CpuDrtRuntime the DRT stages.
class CpuBackend final : public StagedBackend {
 public:
  CpuBackend(const Level& level, const Dictionary& dict, CpuLevelRuntime runtime,
             const CpuBackendOptions& options, bool skip_unchanged)
      : StagedBackend(level, dict, StagedBackendOptions{options.probes, skip_unchanged}, "cpu"),
        rt_(std::move(runtime)),
        description_(std::string("cpu ") + isa_name(rt_.isa())),
        lightmap_(sizes().lightmap, 0.0f),
        atlas_(sizes().atlas, 0.0f),
        probes_(has_probes() ? sizes().probes : 0, 0.0f),
        rho_(sizes().ld, 0.0f),
        ld_feedback_(sizes().ld, 0.0f),
        b0_(sizes().b, 0.0f) {
    set_timing(options.timing);
  }

  BackendKind kind() const override { return BackendKind::cpu; }
  const char* description() const override { return description_.c_str(); }
  std::span<const float> output_data(BackendOutput output) const override {
    if (output == BackendOutput::atlas) return atlas_;  // zeros before the first update
    return {};
  }

 protected:
  Status stage_ld(std::span<const float> ld, const StageWork&) override {
    ld_ = ld;         // read in place by stage_b, within this evaluation
    if (gathers()) {  // the gather reads it after the evaluation too (the camera skip's catch-up)
      std::copy(ld.begin(), ld.end(), ld_gather_.begin());
      ld_ = ld_gather_;
    }
    return Status::success();
  }
  Status stage_albedo(std::span<const float> rho) override {
    std::copy(rho.begin(), rho.end(), rho_.begin());
    return Status::success();
  }
  Status stage_feedback(std::span<const float> ld_direct, float bound) override {
    const ScopedFlushDenormals flush(rt_.flush_denormals());
    feedback_rgb(rt_.isa(), ld_direct.data(), rho_.data(), lightmap_.data(), bound, ld_feedback_.data(),
                 ld_direct.size());
    ld_ = ld_feedback_;
    return Status::success();
  }
  Status stage_b(const StageWork& work) override {
    rt_.compute_b(ld_, work.blocks);
    b_blocks_ = work.blocks;
    return Status::success();
  }
  // The converged solve on this runtime's kernels and threads; b* becomes the runtime's b.
  bool stage_solve_available() const override { return true; }
  bool stage_solve_keeps_b0() const override { return true; }
  void stage_reduced_apply(const ReducedFeedback& op, std::span<const float> x,
                           std::span<float> out) override {
    rt_.apply_reduced_feedback(op, x, out);
  }
  Status stage_solve(const ReducedFeedback& op, ReducedSolver& solver, std::span<float> x, bool warm,
                     const ReducedSolveSettings& settings, ReducedSolveReport& report) override {
    // With clutter the unknowns are b then c (reduced_feedback.h), c0 = Td_c clutter_ld; the
    // DRT terms through this backend's DRT kernels, the rest of them in core.
    // b0 of the blocks the b stage computed; the others' are the last converged evaluation's.
    const std::span<const float> b = rt_.b();
    const std::size_t nb = b.size(), per_block = 3 * std::size_t(level().kb);
    for (std::size_t i = 0; i < b_blocks_.size(); ++i)
      if (b_blocks_[i])
        std::copy_n(b.begin() + std::ptrdiff_t(per_block * i), per_block,
                    b0_.begin() + std::ptrdiff_t(per_block * i));
    const bool with_clutter = op.clutter.drt != nullptr;
    if (!warm) std::copy(b0_.begin(), b0_.end(), x.begin());
    rt_.reduced_rhs(op, b0_, solver.rhs().first(nb));
    reduced_clutter_start(op, nb, cl_.c_direct, x, solver.rhs(), warm);
    if (!with_clutter && settings.incremental) {
      report = solver.solve_incremental(
          [&](std::span<const float> d, std::span<const std::uint8_t> blocks, std::span<float> y,
              std::span<float> r) { rt_.apply_reduced_feedback_delta(op, d, blocks, y, r); },
          x, op.contraction, settings, warm);
      rt_.finish_reduced_solve(x.first(nb), solver.r());
      return Status::success();
    }
    Status drt_status;
    report = solver.solve(
        [&](std::span<const float> in, std::span<float> out) {
          rt_.apply_reduced_feedback(op, in, out);
          if (with_clutter && drt_status.ok()) drt_status = apply_reduced_clutter(op, in, out);
        },
        x, op.contraction, settings, warm);
    if (!drt_status.ok()) return drt_status;
    rt_.finish_reduced_solve(x.first(nb));
    if (with_clutter) std::copy(x.begin() + std::ptrdiff_t(nb), x.end(), cl_.c.begin());
    return Status::success();
  }
  // The clutter's terms of G (reference_apply_reduced_clutter) with the CPU DRT kernels.
  Status apply_reduced_clutter(const ReducedFeedback& op, std::span<const float> x, std::span<float> out) {
    ReducedClutterScratch& scratch = reduced_clutter_scratch();
    const std::size_t nb = rt_.b().size();
    const std::span<const float> b = x.first(nb), c = x.subspan(nb, op.clutter.c_unknowns);
    reduced_clutter_clear(op, scratch);
    if (Status s = drt_->apply(b, c, scratch.delta); !s.ok()) return s;
    if (!op.clutter.rho_c.empty()) {
      if (Status s = drt_->clutter_lightmap(b, {}, scratch.indirect); !s.ok()) return s;
      if (Status s = drt_->clutter_add_cc(c, scratch.indirect); !s.ok()) return s;
    }
    reduced_clutter_feedback(level(), op, scratch, out);
    return Status::success();
  }
  Status stage_r(const StageWork&) override { return Status::success(); }  // in stage_tiles
  bool stage_padding_sources_available() const override { return true; }
  static_assert(CpuLevelRuntime::kPaddingSourcesOnly == kPaddingSourcesTile,
                "stage_tiles passes the camera skip's tile flags to compute_r_and_tiles");
  Status stage_tiles(const StageWork& work) override {
    rt_.compute_r_and_tiles(work.slots, work.tiles,
                            clutter() ? std::span<float>(base_) : std::span<float>(lightmap_));
    return Status::success();
  }
  // architecture.md §5 step 7: lightmap = base + dUb b + dUc c, clamped as every lightmap.
  Status stage_deltas(const StageWork&) override {
    std::copy(base_.begin(), base_.end(), lightmap_.begin());
    if (Status s = drt_->apply(rt_.b(), cl_.c, lightmap_); !s.ok()) return s;
    if (gathers())
      if (Status s = drt_->apply_gather(ld_, cl_.radiance(), lightmap_); !s.ok()) return s;
    clamp_nonnegative(rt_.isa(), lightmap_.data(), lightmap_.size());
    return Status::success();
  }
  // The whole atlas, or with the camera skip the interiors and rectangles it names.
  Status stage_atlas(const StageWork& work) override {
    if (work.atlas.empty() || (work.atlas_count == work.atlas.size() && work.everything))
      return rt_.fill_atlas(lightmap_, atlas_);
    rt_.fill_atlas_blocks(lightmap_, atlas_, work.tiles, work.atlas, atlas_padding());
    return Status::success();
  }
  bool stage_camera_skip_available() const override { return true; }
  bool stage_probe_skip_available() const override { return true; }
  std::span<const float> stage_probes_data() const override { return probes_; }
  Status stage_probes(const StageWork& work) override {
    rt_.compute_probes(work.tiles, probes_);
    return clutter() ? drt_->apply_probes(rt_.b(), cl_.c, probes_) : Status::success();  // DRT §5 (U_dyn)
  }
  Status read_output(StageOutput output, std::span<float> out) override {
    const auto copy = [&](const std::vector<float>& from) {
      std::copy(from.begin(), from.end(), out.begin());
      return Status::success();
    };
    switch (output) {
      case StageOutput::lightmap: return copy(lightmap_);
      case StageOutput::atlas: return copy(atlas_);
      case StageOutput::probes: return copy(probes_);
      case StageOutput::clutter_lightmap: return copy(cl_.clutter_lightmap);
      case StageOutput::vector_lightmap:  // on request from the kept b and r
        if (Status s = rt_.compute_vector_irradiance(out); !s.ok()) return s;
        return clutter() ? drt_->apply_vector(rt_.b(), cl_.c, out) : Status::success();  // DRT §5
      case StageOutput::clutter_vector_lightmap: return drt_->clutter_vector_lightmap(rt_.b(), cl_.c, out);
    }
    return Status::success();
  }

  Status stage_clutter_set(const DrtOperators* drt) override {
    if (!drt) {
      drt_.reset();
      base_ = {}, cl_ = {}, ld_gather_ = {};
      return Status::success();
    }
    Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(level(), *drt, rt_.isa());
    if (!rt.ok()) return rt.status();
    drt_.emplace(std::move(rt).value());
    base_.assign(lightmap_.size(), 0.0f);
    cl_.allocate(drt_->sizes());
    ld_gather_.assign(drt->has_gather() ? sizes().ld : 0, 0.0f);
    return Status::success();
  }
  Status stage_clutter_light(std::span<const float> clutter_ld,
                             std::span<const float> clutter_direct) override {
    cl_.set_light(clutter_ld, clutter_direct);
    if (Status s = drt_->compute_c(cl_.clutter_ld, cl_.c_direct); !s.ok()) return s;
    cl_.use_direct_light();
    return Status::success();
  }
  Status stage_clutter_albedo(std::span<const float>) override {
    cl_.use_direct_light();
    return Status::success();
  }
  // DRT §4.4: the clutter's indirect light of the last evaluation (cl_.indirect, kept by its
  // clutter lightmap stage) fed back.
  Status stage_clutter_c(ClutterCSource source, const ClutterFeedback& feedback) override {
    if (source == ClutterCSource::direct) {
      cl_.use_direct_light();
      return Status::success();
    }
    drt_clutter_feedback(cl_.clutter_ld, clutter_albedo(), cl_.indirect, feedback.bound(), cl_.fed);
    cl_.fed_back = true;
    return drt_->compute_c(cl_.fed, cl_.c);
  }
  // indirect = Cb b + Cc c (+ Gs x_s + Gt x_t), kept for the next feedback step; the lightmap
  // adds the direct light and is clamped at 0 (core's drt_evaluate_clutter_lightmap).
  Status stage_clutter_lightmap() override {
    if (Status s = drt_->clutter_lightmap(rt_.b(), {}, cl_.indirect); !s.ok()) return s;
    if (Status s = drt_->clutter_add_cc(cl_.c, cl_.indirect); !s.ok()) return s;
    if (gathers())
      if (Status s = drt_->clutter_add_gather(ld_, cl_.radiance(), cl_.indirect); !s.ok()) return s;
    std::copy(cl_.indirect.begin(), cl_.indirect.end(), cl_.clutter_lightmap.begin());
    if (!cl_.clutter_direct.empty())
      for (std::size_t i = 0; i < cl_.clutter_lightmap.size(); ++i)
        cl_.clutter_lightmap[i] += cl_.clutter_direct[i];
    clamp_nonnegative(rt_.isa(), cl_.clutter_lightmap.data(), cl_.clutter_lightmap.size());
    return Status::success();
  }

 private:
  CpuLevelRuntime rt_;
  std::string description_;
  std::vector<float> lightmap_, atlas_, probes_, rho_, ld_feedback_;
  std::span<const float> ld_;  // this evaluation's ld: the caller's, ld_feedback_ or ld_gather_
  // With the real-radiance gather (only then not empty): the caller's ld kept past the evaluation.
  std::vector<float> ld_gather_;
  bool gathers() const { return !ld_gather_.empty(); }
  // The converged solve's b0 = Td_b ld_direct per block (stage_solve_keeps_b0), and the blocks
  // whose b the last b stage computed.
  std::vector<float> b0_;
  std::span<const std::uint8_t> b_blocks_;
  // DRT (only with clutter): the MRT lightmap the runtime writes (base_) and the clutter's light.
  std::optional<CpuDrtRuntime> drt_;
  std::vector<float> base_;
  ClutterBuffers cl_;
};

}  // namespace

Result<std::unique_ptr<Backend>> create_cpu_backend(const Level& level, const Dictionary& dict,
                                                    const CpuBackendOptions& options) {
  // The backend skips exactly (StagedBackend's dirty sets); the approximate skips of
  // CpuSkipOptions are CpuLevelRuntime's own, with their error bounds.
  const CpuSkipOptions& skip = options.runtime.skip;
  if (skip.ld_epsilon != 0.0f || skip.dark_ld != 0.0f || skip.record_epsilon != 0.0f ||
      skip.r_epsilon != 0.0f)
    return Status::error(
        ErrorCode::invalid_argument,
        "cpu backend: CpuSkipOptions' ld_epsilon, dark_ld, record_epsilon and r_epsilon must be 0 "
        "(the backend skips exactly; approximate skipping is CpuLevelRuntime's)");
  CpuRuntimeOptions runtime = options.runtime;
  runtime.skip = CpuSkipOptions{};
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(level, dict, runtime);
  if (!rt.ok()) return rt.status();
  return std::unique_ptr<Backend>(new CpuBackend(level, dict, std::move(rt).value(), options, skip.enabled));
}

Result<std::unique_ptr<Backend>> create_cpu_backend(const Level& level, const Dictionary& dict,
                                                    const CpuRuntimeOptions& options) {
  CpuBackendOptions o;
  o.runtime = options;
  return create_cpu_backend(level, dict, o);
}

}  // namespace modrt::cpu
