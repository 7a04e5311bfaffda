// SPDX-License-Identifier: MIT
// modrt — one frame over a Backend (architecture.md §5, "One frame"): the order of the steps,
// the multi-bounce feedback and its bound, the exact skip of a repeated frame, the summed stage
// times and the statistics, stated once for every caller (the C API, modrt-demo, the benches).
//
// A frame is the backend's update(ld) (its stages: b, r, lightmap, atlas with padding, probes,
// vector irradiance and, with clutter, c, the DRT deltas and the clutter lightmap), then
// `bounces` feedback steps multi_bounce_step(ld) (architecture.md §2: each one more bounce,
// with the albedo clamp and the bound of feedback_policy.h); with bounces = kConvergedBounces
// it is the backend's update_converged(ld) instead (the converged multi-bounce, issue 20).
//   - Refused before anything runs: with bounces, an ld whose fed-back light could pass
//     kMaxLightValue (feedback_ld_peak), so a frame never fails half way. With ld from a GL
//     texture the values stay on the GPU: the backend finds the bound there and clamps the
//     fed-back light at kMaxLightValue instead (Backend::multi_bounce_step_from_texture).
//   - Skipping: inside update() the backend recomputes only what a changed ld reaches (exact);
//     a feedback step changes every block's ld, so with bounces and skip_unchanged the pipeline
//     skips a whole frame whose ld is bit-identical to the last successful frame's while the
//     albedo and the clutter are unchanged: the results on hand are that frame's, bit for bit.
//   - After a failed frame (past the checks above only a GL error can fail a step) the next
//     frame runs whole.
// create() allocates (the copy of the last ld); nothing else allocates.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "modrt/backend.h"
#include "modrt/status.h"

namespace modrt {

// The most feedback steps a frame takes: 64 steps at the largest default albedo 0.95 leave
// 0.95^64 = 4 % of the bounce series, as close to converged as steps get.
inline constexpr std::uint32_t kMaxFrameBounces = 64;

// The `bounces` value of the converged solve (Backend::update_converged, reduced_feedback.h):
// every frame shows the converged multi-bounce, warm-started from the last frame's.
inline constexpr std::uint32_t kConvergedBounces = 0xffffffffu;
// What a kConvergedBounces frame runs where the backend has no converged solve
// (Backend::converged_available false; every backend today has one): one update and this many feedback
// steps, on every frame alike, so that no frame shows fewer bounces than another (issue 20).
// FrameStats::frames_fallback counts those frames.
inline constexpr std::uint32_t kConvergedFallbackSteps = 4;

struct FrameOptions {
  // Feedback steps after each update (0..kMaxFrameBounces), or kConvergedBounces.
  std::uint32_t bounces = 0;
  ReducedSolveSettings solve;  // the converged solve's tolerance and iteration limit
  bool skip_unchanged = true;  // with bounces: skip a frame that repeats the last one exactly
};

struct FrameStats {
  std::uint64_t frames = 0;            // frames that succeeded
  std::uint64_t frames_skipped = 0;    // of them, frames that ran nothing (identical input)
  std::uint64_t frames_fallback = 0;   // of them, kConvergedBounces frames run as one update and
                                       // kConvergedFallbackSteps feedback steps (no converged solve)
  BackendEvaluationStats evaluations;  // the backend's, since the pipeline's creation
};

class FramePipeline {
 public:
  // Borrows `backend` (it must outlive the pipeline). Fails on bounces > kMaxFrameBounces.
  static Result<FramePipeline> create(Backend& backend, const FrameOptions& options = {});

  Backend& backend() const { return *backend_; }
  const FrameOptions& options() const { return options_; }

  // The feedback's albedo (3 x samples, clamped to max_albedo < 1 by the backend). A failure
  // changes nothing.
  Status set_albedo(std::span<const float> albedo, float max_albedo = kDefaultMaxAlbedo);
  // Clutter (Backend::set_clutter and the calls after it): forwarded, and the next frame runs.
  Status set_clutter(const DrtOperators* drt);
  Status set_clutter_light(std::span<const float> clutter_ld, std::span<const float> clutter_direct);
  Status set_clutter_albedo(std::span<const float> clutter_albedo, float max_albedo = kDefaultMaxAlbedo);
  // The next frame runs whatever its input (the caller changed the backend behind the pipeline).
  void invalidate() { last_valid_ = false; }

  // One frame from CPU ld (3 x samples), with options().bounces steps, or with `bounces`.
  Status run(std::span<const float> ld);
  Status run(std::span<const float> ld, std::uint32_t bounces);
  // One frame with ld from a GL texture (Backend::update_from_texture, then
  // multi_bounce_step_from_texture per bounce; kConvergedBounces:
  // Backend::update_converged_from_texture): nothing is read back.
  Status run_from_texture(std::uint32_t ld_texture);
  Status run_from_texture(std::uint32_t ld_texture, std::uint32_t bounces);

  // The backend's stage times summed over the last frame's evaluations (0 for a skipped frame).
  const BackendStageTimes& times() const { return times_; }
  FrameStats stats() const;
  bool last_frame_skipped() const { return last_skipped_; }

 private:
  FramePipeline(Backend& backend, const FrameOptions& options);
  Status evaluate(std::span<const float> ld, std::uint32_t bounces);
  // The frame's backend calls, shared by evaluate and run_from_texture: the converged solve,
  // or the first bounce then `bounces` feedback steps (kConvergedFallbackSteps for
  // kConvergedBounces where the backend has no converged solve), each call's stage times added.
  template <class Converged, class First, class Step>
  Status run_bounces(std::uint32_t bounces, Converged converged, First first, Step step);
  void add_times();

  Backend* backend_ = nullptr;
  FrameOptions options_;
  std::vector<float> ld_last_;  // the last successful frame's ld (with bounces)
  bool last_valid_ = false;
  bool last_skipped_ = false;
  std::uint32_t last_bounces_ = 0;
  float rho_max_ = 0.0f;
  BackendStageTimes times_;
  BackendEvaluationStats start_;  // the backend's at creation
  std::uint64_t frames_ = 0, frames_skipped_ = 0, frames_fallback_ = 0;
};

}  // namespace modrt
