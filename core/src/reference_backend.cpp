// SPDX-License-Identifier: MIT
#include "modrt/reference_backend.h"

#include <algorithm>
#include <string>
#include <vector>

#include "modrt/feedback_policy.h"
#include "modrt/level_dirty.h"
#include "modrt/level_runtime.h"
#include "modrt/reference_runtime.h"

namespace modrt {
namespace {

Status refused(const std::string& what) {
  return Status::error(ErrorCode::invalid_argument, "reference: " + what);
}

class ReferenceBackend final : public Backend {
 public:
  ReferenceBackend(const Level& level, const Dictionary& dict, const ReferenceBackendOptions& options)
      : level_(level),
        dict_(dict),
        options_(options),
        sizes_(level_buffer_sizes(level, dict)),
        dirty_(LevelDirtyTracker::create(level)),
        b_(sizes_.b, 0.0f),
        r_(sizes_.r, 0.0f),
        base_(sizes_.lightmap, 0.0f),
        lightmap_(sizes_.lightmap, 0.0f),
        atlas_(sizes_.atlas, 0.0f),
        probes_(options.probes ? sizes_.probes : 0, 0.0f),
        ld_feedback_(sizes_.ld, 0.0f) {
    feedback_.rho.assign(sizes_.ld, 0.0f);
  }

  BackendKind kind() const override { return BackendKind::reference; }
  const char* description() const override { return "reference scalar"; }
  const LevelBufferSizes& sizes() const override { return sizes_; }
  BackendEvaluationStats evaluation_stats() const override { return stats_; }
  std::span<const float> output_data(BackendOutput output) const override {
    return output == BackendOutput::atlas ? std::span<const float>(atlas_) : std::span<const float>{};
  }

  Status update(std::span<const float> ld) override {
    if (Status s = validate_light_signal(ld, level_.sample_count, "ld"); !s.ok()) return s;
    if (drt_ && !rho_c_.empty()) {
      c_ = c_direct_;  // a new first bounce: the clutter's direct light only
      dirty_.invalidate();
    }
    return evaluate(ld);
  }

  Status set_albedo(std::span<const float> albedo, float max_albedo) override {
    if (Status s = check_max_albedo(max_albedo, "reference: set_albedo"); !s.ok()) return s;
    if (Status s = validate_light_signal(albedo, level_.sample_count, "albedo"); !s.ok()) return s;
    rho_max_ = clamp_albedo(albedo, max_albedo, feedback_.rho).rho_max;
    has_albedo_ = true;
    return Status::success();
  }

  // ld = ld_direct + rho min(max(lightmap, 0), max(ld_direct) / (1 - max rho)), then a frame of it;
  // with the clutter's albedo its indirect light is fed back through c first (drt_multi_bounce).
  Status multi_bounce_step(std::span<const float> ld_direct) override {
    if (!has_albedo_) return refused("multi_bounce_step: call set_albedo first");
    if (!updated_) return refused("multi_bounce_step: call update first");
    if (Status s = validate_light_signal(ld_direct, level_.sample_count, "ld_direct"); !s.ok()) return s;
    const float ld_max = largest_light(ld_direct);
    if (drt_ && !rho_c_.empty()) {
      drt_clutter_lightmap(*drt_, b_, {}, clutter_indirect_);
      drt_clutter_add_cc(*drt_, c_, clutter_indirect_);
      drt_clutter_feedback(clutter_ld_, rho_c_, clutter_indirect_,
                           drt_feedback_bound(ld_max, rho_max_, clutter_ld_max_, rho_c_max_), clutter_fed_);
      if (Status s = drt_compute_c(*drt_, clutter_fed_, c_); !s.ok()) return s;
    }
    feedback_.energy_bound = feedback_energy_bound(ld_max, rho_max_);
    apply_feedback(feedback_, ld_direct, lightmap_, ld_feedback_);
    dirty_.invalidate();  // every block's ld changes
    if (Status s = evaluate(ld_feedback_); !s.ok()) return s;
    dirty_.invalidate();  // the next update compares with its own last ld, not this one
    return Status::success();
  }

  Status read_lightmap(std::span<float> out) override { return copy("lightmap", lightmap_, out); }
  Status read_atlas(std::span<float> out) override { return copy("atlas", atlas_, out); }
  Status read_probes(std::span<float> out) override {
    if (probes_.empty())
      return refused("no probes: the dictionary has none, or ReferenceBackendOptions::probes is off");
    return copy("probes", probes_, out);
  }
  Status read_vector_lightmap(std::span<float> out) override {
    if (!updated_) return refused("read before the first update");
    if (Status s = level_compute_vector_irradiance(level_, dict_, b_, r_, out); !s.ok()) return s;
    if (drt_) drt_apply_vector(level_, *drt_, b_, c_, out);  // DRT §5 (dUb_vec, dUc_vec)
    return Status::success();
  }

  Status set_clutter(const DrtOperators* drt) override {
    dirty_.invalidate();
    updated_ = false;  // the results on hand are not of this clutter
    if (!drt || drt->empty()) {
      drt_ = nullptr;
      drt_sizes_ = {};
      c_ = {}, c_direct_ = {}, clutter_ld_ = {}, clutter_direct_ = {}, clutter_lightmap_ = {};
      rho_c_ = {}, clutter_indirect_ = {}, clutter_fed_ = {};
      return Status::success();
    }
    if (Status s = check_drt_operators(level_, *drt); !s.ok()) return s;
    if (Status s = check_probe_grid(*drt); !s.ok()) return s;
    drt_ = drt;
    drt_sizes_ = drt_buffer_sizes(*drt);
    c_.assign(drt_sizes_.c, 0.0f);
    c_direct_ = c_;
    clutter_ld_.assign(drt_sizes_.clutter_ld, 0.0f);
    clutter_ld_max_ = 0.0f;
    clutter_direct_.clear();
    clutter_lightmap_.assign(drt_sizes_.clutter_lightmap, 0.0f);
    rho_c_.clear();
    clutter_indirect_.assign(drt_sizes_.clutter_lightmap, 0.0f);
    clutter_fed_.assign(drt_sizes_.clutter_ld, 0.0f);
    return Status::success();
  }
  Status set_clutter_light(std::span<const float> clutter_ld,
                           std::span<const float> clutter_direct) override {
    if (!drt_) return refused("set_clutter_light: no clutter set");
    const std::size_t n = drt_sizes_.clutter_ld;
    if (clutter_ld.size() != n || (!clutter_direct.empty() && clutter_direct.size() != n))
      return refused("set_clutter_light: clutter_ld has " + std::to_string(clutter_ld.size()) +
                     " floats and clutter_direct " + std::to_string(clutter_direct.size()) + ", expected " +
                     std::to_string(n) + " (clutter_direct may be empty)");
    if (Status s = validate_light_signal(clutter_ld, n / 3, "clutter_ld"); !s.ok()) return s;
    if (!clutter_direct.empty())
      if (Status s = validate_light_signal(clutter_direct, n / 3, "clutter_direct"); !s.ok()) return s;
    std::copy(clutter_ld.begin(), clutter_ld.end(), clutter_ld_.begin());
    clutter_ld_max_ = largest_light(clutter_ld);
    clutter_direct_.assign(clutter_direct.begin(), clutter_direct.end());
    if (Status s = drt_compute_c(*drt_, clutter_ld_, c_direct_); !s.ok()) return s;
    c_ = c_direct_;
    dirty_.invalidate();  // c changed whatever ld does
    return Status::success();
  }
  Status set_clutter_albedo(std::span<const float> clutter_albedo, float max_albedo) override {
    if (!drt_) return refused("set_clutter_albedo: no clutter set");
    if (Status s = check_max_albedo(max_albedo, "reference: set_clutter_albedo"); !s.ok()) return s;
    if (!clutter_albedo.empty())
      if (Status s = validate_light_signal(clutter_albedo, drt_sizes_.clutter_texels, "clutter_albedo");
          !s.ok())
        return s;
    rho_c_.assign(clutter_albedo.begin(), clutter_albedo.end());
    rho_c_max_ = clamp_albedo(rho_c_, max_albedo, rho_c_).rho_max;
    c_ = c_direct_;
    return Status::success();
  }
  const DrtBufferSizes& clutter_sizes() const override { return drt_sizes_; }
  Status read_clutter_vector_lightmap(std::span<float> out) override {
    if (!drt_) return refused("read_clutter_vector_lightmap: no clutter set");
    if (!updated_) return refused("read before the first update");
    if (out.size() != drt_sizes_.clutter_vector_lightmap)
      return refused("clutter vector lightmap: has " + std::to_string(out.size()) + " floats, expected " +
                     std::to_string(drt_sizes_.clutter_vector_lightmap));
    drt_clutter_vector_lightmap(*drt_, b_, c_, out);
    return Status::success();
  }
  Status read_clutter_lightmap(std::span<float> out) override {
    if (!drt_) return refused("read_clutter_lightmap: no clutter set");
    return copy("clutter lightmap", clutter_lightmap_, out);
  }

 private:
  // One evaluation of ld (validated): the stages over what changed, or nothing at all.
  Status evaluate(std::span<const float> ld) {
    const std::size_t blocks = level_.blocks.size(), slots = level_.slots.size();
    const bool all = !options_.skip_unchanged || !updated_;
    if (dirty_.mark(ld, all) == 0 && !all) {  // the results on hand are this frame's
      ++stats_.evaluations, ++stats_.evaluations_skipped;
      stats_.blocks_kept += blocks, stats_.slots_kept += slots, stats_.tiles_kept += blocks;
      return Status::success();
    }
    const LevelDependencies& deps = dirty_.dependencies();
    for (std::size_t i = 0; i < blocks; ++i)
      if (dirty_.blocks()[i]) level_compute_block_b(level_, dict_, ld, i, b_);
    for (std::size_t s = 0; s < slots; ++s)
      if (dirty_.slots()[s]) level_compute_slot_r(level_, deps, b_, s, r_);
    for (std::size_t i = 0; i < blocks; ++i)
      if (dirty_.tiles()[i]) {
        level_compute_tile(level_, dict_, deps, b_, r_, i, base_);
        if (!probes_.empty() && !drt_) level_compute_block_probes(level_, dict_, deps, b_, r_, i, probes_);
      }
    std::copy(base_.begin(), base_.end(), lightmap_.begin());
    if (drt_) {  // architecture.md §6: the deltas read every block's b, so they run whole
      drt_apply(level_, *drt_, b_, c_, lightmap_);
      clamp_lightmap(lightmap_);
      drt_evaluate_clutter_lightmap(*drt_, b_, c_, clutter_direct_, clutter_lightmap_);
      if (!probes_.empty()) {  // Udyn adds to every block's probes: all of them from this frame's b and r
        for (std::size_t i = 0; i < blocks; ++i)
          level_compute_block_probes(level_, dict_, deps, b_, r_, i, probes_);
        drt_apply_probes(*drt_, b_, c_, probes_);
      }
    }
    level_fill_atlas(level_, lightmap_, atlas_);
    ++stats_.evaluations;
    stats_.blocks_computed += dirty_.dirty_blocks(), stats_.blocks_kept += blocks - dirty_.dirty_blocks();
    stats_.slots_computed += dirty_.dirty_slots(), stats_.slots_kept += slots - dirty_.dirty_slots();
    stats_.tiles_written += dirty_.dirty_tiles(), stats_.tiles_kept += blocks - dirty_.dirty_tiles();
    updated_ = true;
    return Status::success();
  }

  Status copy(const char* what, const std::vector<float>& from, std::span<float> to) const {
    if (to.size() != from.size())
      return refused(std::string(what) + ": has " + std::to_string(to.size()) + " floats, expected " +
                     std::to_string(from.size()));
    if (!updated_) return refused("read before the first update");
    std::copy(from.begin(), from.end(), to.begin());
    return Status::success();
  }
  Status check_probe_grid(const DrtOperators& drt) const {
    bool any = false;
    for (const DrtObjectOperators& o : drt.objects) any |= !o.Udyn.empty() || !o.Udyn_c.empty();
    if (!any || probes_.empty() ||
        std::size_t(27) * drt.probes_per_block * level_.blocks.size() == probes_.size())
      return Status::success();
    return refused("the U_dyn operators are for " + std::to_string(drt.probes_per_block) +
                   " probes per block, the dictionary's grid has " +
                   std::to_string(probes_.size() / 27 / std::max<std::size_t>(level_.blocks.size(), 1)));
  }

  const Level& level_;
  const Dictionary& dict_;
  ReferenceBackendOptions options_;
  LevelBufferSizes sizes_;
  LevelDirtyTracker dirty_;
  // base_: the MRT lightmap (Ub b + Ur r), lightmap_ with the DRT delta when there is clutter.
  std::vector<float> b_, r_, base_, lightmap_, atlas_, probes_, ld_feedback_;
  FeedbackClamp feedback_;  // the clamped albedo and the bound of the step
  float rho_max_ = 0.0f;
  bool has_albedo_ = false, updated_ = false;
  const DrtOperators* drt_ = nullptr;
  DrtBufferSizes drt_sizes_;
  std::vector<float> c_, c_direct_, clutter_ld_, clutter_direct_, clutter_lightmap_;
  std::vector<float> rho_c_, clutter_indirect_, clutter_fed_;
  float clutter_ld_max_ = 0.0f, rho_c_max_ = 0.0f;
  BackendEvaluationStats stats_;
};

}  // namespace

Result<std::unique_ptr<Backend>> create_reference_backend(const Level& level, const Dictionary& dict,
                                                          const ReferenceBackendOptions& options) {
  if (Status s = check_level_operators(level, dict); !s.ok()) return s;
  return std::unique_ptr<Backend>(new ReferenceBackend(level, dict, options));
}

}  // namespace modrt
