// SPDX-License-Identifier: MIT
#include "modrt/reference_backend.h"

#include <algorithm>
#include <string>
#include <vector>

#include "modrt/feedback_policy.h"
#include "modrt/level_dirty.h"
#include "modrt/level_runtime.h"
#include "modrt/reference_runtime.h"
#include "modrt/staged_backend.h"

namespace modrt {
namespace {

class ReferenceBackend final : public StagedBackend {
 public:
  ReferenceBackend(const Level& level, const Dictionary& dict, const ReferenceBackendOptions& options)
      : StagedBackend(level, dict, StagedBackendOptions{options.probes, options.skip_unchanged}, "reference"),
        deps_(level_dependencies(level)),
        ld_(sizes().ld, 0.0f),
        b_(sizes().b, 0.0f),
        r_(sizes().r, 0.0f),
        base_(sizes().lightmap, 0.0f),
        lightmap_(sizes().lightmap, 0.0f),
        atlas_(sizes().atlas, 0.0f),
        probes_(has_probes() ? sizes().probes : 0, 0.0f) {
    feedback_.rho.assign(sizes().ld, 0.0f);
  }

  BackendKind kind() const override { return BackendKind::reference; }
  const char* description() const override { return "reference scalar"; }
  std::span<const float> output_data(BackendOutput output) const override {
    return output == BackendOutput::atlas ? std::span<const float>(atlas_) : std::span<const float>{};
  }

 protected:
  Status stage_ld(std::span<const float> ld, const StageWork& work) override {
    for (std::size_t i = 0; i < level().blocks.size(); ++i)
      if (work.blocks[i]) {
        const std::size_t first = 3 * std::size_t(level().blocks[i].sample_offset);
        const std::size_t count = 3 * std::size_t(level().blocks[i].sample_count);
        std::copy_n(ld.begin() + first, count, ld_.begin() + first);
      }
    return Status::success();
  }
  Status stage_albedo(std::span<const float> rho) override {
    std::copy(rho.begin(), rho.end(), feedback_.rho.begin());
    return Status::success();
  }
  // ld = ld_direct + rho min(max(lightmap, 0), bound) (reference_runtime.h's apply_feedback).
  Status stage_feedback(std::span<const float> ld_direct, float bound) override {
    feedback_.energy_bound = bound;
    apply_feedback(feedback_, ld_direct, lightmap_, ld_);
    return Status::success();
  }
  Status stage_b(const StageWork& work) override {
    for (std::size_t i = 0; i < level().blocks.size(); ++i)
      if (work.blocks[i]) level_compute_block_b(level(), dict(), ld_, i, b_);
    return Status::success();
  }
  bool stage_solve_available() const override { return true; }
  Status stage_solve(const ReducedFeedback& op, ReducedSolver& solver, std::span<float> x, bool warm,
                     const ReducedSolveSettings& settings, ReducedSolveReport& report) override {
    // With clutter the unknowns are b then c (reduced_feedback.h), c0 = Td_c clutter_ld.
    const std::size_t nb = b_.size();
    const bool with_clutter = op.clutter.drt != nullptr;
    if (!warm) std::copy(b_.begin(), b_.end(), x.begin());
    reference_reduced_rhs(level(), op, b_, solver.rhs().first(nb));
    reduced_clutter_start(op, nb, cl_.c_direct, x, solver.rhs(), warm);
    if (!with_clutter && settings.incremental) {
      r_delta_.resize(r_.size());
      report = solver.solve_incremental(
          [&](std::span<const float> d, std::span<const std::uint8_t> blocks, std::span<float> y,
              std::span<float> r) {
            reference_apply_reduced_feedback_delta(level(), deps_, op, d, blocks, y, r, r_delta_);
          },
          x, op.contraction, settings, warm);
      std::copy(x.begin(), x.begin() + std::ptrdiff_t(nb), b_.begin());
      std::copy(solver.r().begin(), solver.r().end(), r_.begin());  // Tb->r of the solve's x_a
      return Status::success();
    }
    report = solver.solve(
        [&](std::span<const float> in, std::span<float> out) {
          reference_apply_reduced_feedback(level(), deps_, op, in, r_, out);
          if (with_clutter) reference_apply_reduced_clutter(level(), op, in, out, reduced_clutter_scratch());
        },
        x, op.contraction, settings, warm);
    std::copy(x.begin(), x.begin() + std::ptrdiff_t(nb), b_.begin());  // r_: the last application's
    if (with_clutter) std::copy(x.begin() + std::ptrdiff_t(nb), x.end(), cl_.c.begin());
    return Status::success();
  }
  Status stage_r(const StageWork& work) override {
    for (std::size_t s = 0; s < level().slots.size(); ++s)
      if (work.slots[s]) level_compute_slot_r(level(), deps_, b_, s, r_);
    return Status::success();
  }
  Status stage_tiles(const StageWork& work) override {
    for (std::size_t i = 0; i < level().blocks.size(); ++i)
      if (work.tiles[i]) level_compute_tile(level(), dict(), deps_, b_, r_, i, base_);
    if (!clutter()) std::copy(base_.begin(), base_.end(), lightmap_.begin());
    return Status::success();
  }
  // architecture.md §6: lightmap = base + dUb b + dUc c, clamped as every lightmap.
  Status stage_deltas(const StageWork&) override {
    std::copy(base_.begin(), base_.end(), lightmap_.begin());
    drt_apply(level(), *clutter(), b_, cl_.c, lightmap_);
    drt_apply_gather(*clutter(), ld_, cl_.radiance(), lightmap_);
    clamp_lightmap(lightmap_);
    return Status::success();
  }
  // The whole atlas from the lightmap: exact for the visible blocks under the camera skip too
  // (their tiles and their padding neighbours' are current).
  bool stage_camera_skip_available() const override { return true; }
  Status stage_atlas(const StageWork&) override {
    level_fill_atlas(level(), lightmap_, atlas_);
    return Status::success();
  }
  bool stage_probe_skip_available() const override { return true; }
  std::span<const float> stage_probes_data() const override { return probes_; }
  Status stage_probes(const StageWork& work) override {
    for (std::size_t i = 0; i < level().blocks.size(); ++i)
      if (work.tiles[i]) level_compute_block_probes(level(), dict(), deps_, b_, r_, i, probes_);
    if (clutter()) drt_apply_probes(*clutter(), b_, cl_.c, probes_);  // Udyn b + Udyn_c c
    return Status::success();
  }
  Status read_output(StageOutput output, std::span<float> out) override {
    switch (output) {
      case StageOutput::lightmap: std::copy(lightmap_.begin(), lightmap_.end(), out.begin()); break;
      case StageOutput::atlas: std::copy(atlas_.begin(), atlas_.end(), out.begin()); break;
      case StageOutput::probes: std::copy(probes_.begin(), probes_.end(), out.begin()); break;
      case StageOutput::vector_lightmap:
        if (Status s = level_compute_vector_irradiance(level(), dict(), b_, r_, out); !s.ok()) return s;
        if (clutter()) drt_apply_vector(level(), *clutter(), b_, cl_.c, out);  // DRT §5 (dUb_vec, dUc_vec)
        break;
      case StageOutput::clutter_lightmap:
        std::copy(cl_.clutter_lightmap.begin(), cl_.clutter_lightmap.end(), out.begin());
        break;
      case StageOutput::clutter_vector_lightmap:
        drt_clutter_vector_lightmap(*clutter(), b_, cl_.c, out);
        break;
    }
    return Status::success();
  }

  Status stage_clutter_set(const DrtOperators* drt) override {
    cl_.allocate(drt ? drt_buffer_sizes(*drt) : DrtBufferSizes{});
    return Status::success();
  }
  Status stage_clutter_light(std::span<const float> clutter_ld,
                             std::span<const float> clutter_direct) override {
    cl_.set_light(clutter_ld, clutter_direct);
    if (Status s = drt_compute_c(*clutter(), cl_.clutter_ld, cl_.c_direct); !s.ok()) return s;
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
    return drt_compute_c(*clutter(), cl_.fed, cl_.c);
  }
  Status stage_clutter_lightmap() override {
    drt_evaluate_clutter_lightmap(*clutter(), b_, cl_.c, ld_, cl_.radiance(), cl_.clutter_direct,
                                  cl_.clutter_lightmap, cl_.indirect);
    return Status::success();
  }

 private:
  LevelDependencies deps_;
  // ld_: this evaluation's ld (the caller's for the dirty blocks, or the fed-back one);
  // base_: the MRT lightmap (Ub b + Ur r), lightmap_ with the DRT delta when there is clutter.
  std::vector<float> ld_, b_, r_, base_, lightmap_, atlas_, probes_;
  std::vector<float> r_delta_;  // the incremental solve's Tb->r d
  FeedbackClamp feedback_;      // the clamped albedo and the bound of the step
  ClutterBuffers cl_;
};

}  // namespace

Result<std::unique_ptr<Backend>> create_reference_backend(const Level& level, const Dictionary& dict,
                                                          const ReferenceBackendOptions& options) {
  if (Status s = check_level_operators(level, dict); !s.ok()) return s;
  return std::unique_ptr<Backend>(new ReferenceBackend(level, dict, options));
}

}  // namespace modrt
