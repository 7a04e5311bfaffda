// SPDX-License-Identifier: MIT
#include "modrt/frame_pipeline.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include "modrt/feedback_policy.h"
#include "modrt/operator_limits.h"

namespace modrt {
namespace {

BackendEvaluationStats minus(const BackendEvaluationStats& a, const BackendEvaluationStats& b) {
  BackendEvaluationStats d;
  d.evaluations = a.evaluations - b.evaluations;
  d.evaluations_skipped = a.evaluations_skipped - b.evaluations_skipped;
  d.blocks_computed = a.blocks_computed - b.blocks_computed;
  d.blocks_kept = a.blocks_kept - b.blocks_kept;
  d.slots_computed = a.slots_computed - b.slots_computed;
  d.slots_kept = a.slots_kept - b.slots_kept;
  d.tiles_written = a.tiles_written - b.tiles_written;
  d.tiles_kept = a.tiles_kept - b.tiles_kept;
  d.tiles_hidden = a.tiles_hidden - b.tiles_hidden;
  d.tiles_caught_up = a.tiles_caught_up - b.tiles_caught_up;
  return d;
}

Status check_bounces(std::uint32_t bounces, const char* who) {
  if (bounces <= kMaxFrameBounces || bounces == kConvergedBounces) return Status::success();
  return Status::error(ErrorCode::invalid_argument,
                       std::string(who) + ": bounces " + std::to_string(bounces) + " is not in 0.." +
                           std::to_string(kMaxFrameBounces) + " nor kConvergedBounces");
}

}  // namespace

FramePipeline::FramePipeline(Backend& backend, const FrameOptions& options)
    : backend_(&backend), options_(options), start_(backend.evaluation_stats()) {}

Result<FramePipeline> FramePipeline::create(Backend& backend, const FrameOptions& options) {
  if (Status s = check_bounces(options.bounces, "frame pipeline"); !s.ok()) return s;
  FramePipeline p(backend, options);
  p.ld_last_.assign(backend.sizes().ld, 0.0f);
  return p;
}

Status FramePipeline::set_albedo(std::span<const float> albedo, float max_albedo) {
  if (Status s = backend_->set_albedo(albedo, max_albedo); !s.ok()) return s;
  rho_max_ = largest_clamped_albedo(albedo, max_albedo);
  last_valid_ = false;
  return Status::success();
}

Status FramePipeline::set_clutter(const DrtOperators* drt) {
  last_valid_ = false;
  return backend_->set_clutter(drt);
}
Status FramePipeline::set_clutter_light(std::span<const float> clutter_ld,
                                        std::span<const float> clutter_direct) {
  last_valid_ = false;
  return backend_->set_clutter_light(clutter_ld, clutter_direct);
}
Status FramePipeline::set_clutter_albedo(std::span<const float> clutter_albedo, float max_albedo) {
  last_valid_ = false;
  return backend_->set_clutter_albedo(clutter_albedo, max_albedo);
}

Status FramePipeline::run(std::span<const float> ld) { return run(ld, options_.bounces); }

Status FramePipeline::run(std::span<const float> ld, std::uint32_t bounces) {
  if (Status s = check_bounces(bounces, "frame pipeline: run"); !s.ok()) return s;
  if (ld.size() != ld_last_.size())
    return Status::error(ErrorCode::invalid_argument, "frame pipeline: ld has " + std::to_string(ld.size()) +
                                                          " floats, expected " +
                                                          std::to_string(ld_last_.size()));
  if (bounces > 0) {
    // The same ld, albedo, clutter and bounce count as the last frame: the same results, bit for bit.
    if (options_.skip_unchanged && last_valid_ && bounces == last_bounces_ &&
        std::equal(ld.begin(), ld.end(), ld_last_.begin())) {
      ++frames_, ++frames_skipped_;
      backend_->count_frame_kept();
      times_ = BackendStageTimes{};
      last_skipped_ = true;
      return Status::success();
    }
    // Refused before anything runs, not half way through the bounces (feedback_policy.h).
    if (const double peak = feedback_ld_peak(largest_light(ld), rho_max_); peak > kMaxLightValue) {
      char text[64];
      std::snprintf(text, sizeof text, "%g", peak);
      return Status::error(
          ErrorCode::invalid_argument,
          std::string("with bounces, the fed-back light can reach ") + text +
              ", above the largest light value 1e30 (kMaxLightValue): rescale the scene's light");
    }
  }
  last_valid_ = false;  // until this frame has succeeded
  if (Status s = evaluate(ld, bounces); !s.ok()) return s;
  if (bounces > 0) {
    std::copy(ld.begin(), ld.end(), ld_last_.begin());
    last_bounces_ = bounces;
    last_valid_ = true;
  }
  return Status::success();
}

Status FramePipeline::run_from_texture(std::uint32_t ld_texture) {
  return run_from_texture(ld_texture, options_.bounces);
}

template <class Converged, class First, class Step>
Status FramePipeline::run_bounces(std::uint32_t bounces, Converged converged, First first, Step step) {
  if (bounces == kConvergedBounces && backend_->converged_available()) {
    if (Status s = converged(); !s.ok()) return s;
    add_times();
    return Status::success();
  }
  const bool fallback = bounces == kConvergedBounces;
  const std::uint32_t steps = fallback ? kConvergedFallbackSteps : bounces;
  if (Status s = first(); !s.ok()) return s;
  add_times();
  for (std::uint32_t i = 0; i < steps; ++i) {
    if (Status s = step(); !s.ok()) return s;
    add_times();
  }
  frames_fallback_ += fallback;
  return Status::success();
}

Status FramePipeline::run_from_texture(std::uint32_t ld_texture, std::uint32_t bounces) {
  if (Status s = check_bounces(bounces, "frame pipeline: run_from_texture"); !s.ok()) return s;
  last_valid_ = false;  // the pipeline does not see the texture's values: never skipped
  times_ = BackendStageTimes{};
  if (Status s = run_bounces(
          bounces, [&] { return backend_->update_converged_from_texture(ld_texture, options_.solve); },
          [&] { return backend_->update_from_texture(ld_texture); },
          [&] { return backend_->multi_bounce_step_from_texture(ld_texture); });
      !s.ok())
    return s;
  ++frames_;
  last_skipped_ = false;
  return Status::success();
}

Status FramePipeline::evaluate(std::span<const float> ld, std::uint32_t bounces) {
  times_ = BackendStageTimes{};
  const std::uint64_t skipped_before = backend_->evaluation_stats().evaluations_skipped;
  if (Status s = run_bounces(
          bounces, [&] { return backend_->update_converged(ld, options_.solve); },
          [&] { return backend_->update(ld); }, [&] { return backend_->multi_bounce_step(ld); });
      !s.ok())
    return s;
  ++frames_;
  // Only a one-bounce frame can be skipped whole (a feedback step always reads the new ld).
  last_skipped_ = bounces == 0 && backend_->evaluation_stats().evaluations_skipped != skipped_before;
  frames_skipped_ += last_skipped_;
  return Status::success();
}

void FramePipeline::add_times() {
  const BackendStageTimes& t = backend_->stage_times();
  times_.upload += t.upload, times_.feedback += t.feedback, times_.b += t.b, times_.r += t.r;
  times_.atlas += t.atlas, times_.probes += t.probes, times_.vector += t.vector, times_.drt += t.drt;
  times_.clutter += t.clutter, times_.lightmap += t.lightmap;
}

FrameStats FramePipeline::stats() const {
  FrameStats s;
  s.frames = frames_;
  s.frames_skipped = frames_skipped_;
  s.frames_fallback = frames_fallback_;
  s.evaluations = minus(backend_->evaluation_stats(), start_);
  return s;
}

}  // namespace modrt
