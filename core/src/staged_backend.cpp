// SPDX-License-Identifier: MIT
#include "modrt/staged_backend.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include "modrt/feedback_policy.h"
#include "modrt/operator_limits.h"
#include "modrt/reference_runtime.h"

namespace modrt {

Status check_drt_probe_grid(const DrtOperators& drt, std::size_t probes_per_block, const char* who) {
  bool any = false;
  for (const DrtObjectOperators& o : drt.objects) any |= !o.Udyn.empty() || !o.Udyn_c.empty();
  if (!any || probes_per_block == 0 || drt.probes_per_block == probes_per_block) return Status::success();
  return Status::error(ErrorCode::invalid_argument, std::string(who) + ": the U_dyn operators are for " +
                                                        std::to_string(drt.probes_per_block) +
                                                        " probes per block, the dictionary's grid has " +
                                                        std::to_string(probes_per_block));
}

void ClutterBuffers::allocate(const DrtBufferSizes& sizes) {
  c.assign(sizes.c, 0.0f);
  c_direct = c;
  clutter_ld.assign(sizes.clutter_ld, 0.0f);
  clutter_direct.clear();
  clutter_direct.reserve(sizes.clutter_ld);
  clutter_lightmap.assign(sizes.clutter_lightmap, 0.0f);
  indirect.assign(sizes.clutter_lightmap, 0.0f);
  fed.assign(sizes.clutter_ld, 0.0f);
  fed_back = false;
}

void ClutterBuffers::set_light(std::span<const float> ld, std::span<const float> direct) {
  std::copy(ld.begin(), ld.end(), clutter_ld.begin());
  clutter_direct.assign(direct.begin(), direct.end());  // within the capacity allocate() reserved
}

StagedBackend::StagedBackend(const Level& level, const Dictionary& dict, const StagedBackendOptions& options,
                             const char* name)
    : level_(level),
      dict_(dict),
      options_(options),
      name_(name),
      sizes_(level_buffer_sizes(level, dict)),
      has_probes_(options.probes && sizes_.probes > 0),
      dirty_(LevelDirtyTracker::create(level)),
      b0_changes_(LevelBlockChanges::create(level)),
      all_blocks_(level.blocks.size(), 1),
      all_slots_(level.slots.size(), 1),
      no_slots_(level.slots.size(), 0),
      rho_(sizes_.ld, 0.0f),
      padding_(atlas_block_padding(level)),
      visible_(level.blocks.size(), 1),
      ext_(level.blocks.size(), 1),
      stale_(level.blocks.size(), 0),
      atlas_stale_(level.blocks.size(), 0),
      tiles_work_(level.blocks.size(), 0),
      out_work_(level.blocks.size(), 0),
      atlas_work_(level.blocks.size(), 0),
      no_blocks_(level.blocks.size(), 0),
      edge_stale_(level.blocks.size(), 0),
      probe_stale_(level.blocks.size(), 0),
      probe_work_(level.blocks.size(), 0),
      probe_wanted_(level.blocks.size(), 0) {}

Status StagedBackend::refused(const std::string& what) const {
  return Status::error(ErrorCode::invalid_argument, name_ + ": " + what);
}

void StagedBackend::timer_begin(TimedStage stage) { stage_start_[std::size_t(stage)] = Clock::now(); }

void StagedBackend::timer_end(TimedStage stage) {
  const auto ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - stage_start_[std::size_t(stage)]);
  stage_ns_[std::size_t(stage)] += std::uint64_t(ns.count());
}

void StagedBackend::timer_collect(BackendStageTimes& t) {
  const auto take = [this](TimedStage s) {
    const std::uint64_t v = stage_ns_[std::size_t(s)];
    stage_ns_[std::size_t(s)] = 0;
    return v;
  };
  t.upload = take(TimedStage::upload), t.feedback = take(TimedStage::feedback);
  t.b = take(TimedStage::b), t.r = take(TimedStage::r), t.lightmap = take(TimedStage::lightmap);
  t.drt = take(TimedStage::clutter_c) + take(TimedStage::drt), t.atlas = take(TimedStage::atlas),
  t.vector = take(TimedStage::vector);
  t.probes = take(TimedStage::probes), t.clutter = take(TimedStage::clutter);
}

template <class F>
Status StagedBackend::timed(TimedStage stage, F&& f) {
  if (!timing_) return f();
  timer_begin(stage);
  Status s = f();
  timer_end(stage);
  return s;
}

void StagedBackend::count(const StageWork& w) {
  const std::uint64_t blocks = level_.blocks.size(), slots = level_.slots.size();
  ++stats_.evaluations;
  stats_.blocks_computed += w.block_count, stats_.blocks_kept += blocks - w.block_count;
  stats_.slots_computed += w.slot_count, stats_.slots_kept += slots - w.slot_count;
  stats_.tiles_written += w.tile_count - hidden_, stats_.tiles_kept += blocks - w.tile_count;
  stats_.tiles_hidden += hidden_, stats_.tiles_caught_up += caught_up_;
}

void StagedBackend::count_frame_kept() {
  const std::uint64_t blocks = level_.blocks.size(), slots = level_.slots.size();
  ++stats_.evaluations, ++stats_.evaluations_skipped;
  stats_.blocks_kept += blocks, stats_.slots_kept += slots, stats_.tiles_kept += blocks;
  times_ = BackendStageTimes{};
}

// Whether a padding neighbour of block i (a block whose interior i's padding copies) is flagged.
static bool padding_source_flagged(const AtlasBlockPadding& padding, std::size_t i,
                                   const std::vector<std::uint8_t>& flags) {
  for (std::uint32_t j : padding.sources_of(i))
    if (flags[j]) return true;
  return false;
}

void StagedBackend::plan_camera(const StageWork& mrt, const StageWork& out, StageWork& tiles,
                                StageWork& output) {
  const std::size_t n = level_.blocks.size();
  std::size_t tile_count = 0, out_count = 0, atlas_count = 0;
  hidden_ = caught_up_ = 0;
  const bool sources = stage_padding_sources_available();
  for (std::size_t i = 0; i < n; ++i) {
    // A tile is written when it changed now or earlier while hidden, and its block is visible or
    // a visible block's padding reads it; only its padding sources where the backend can (a
    // padding neighbour that is not visible), and then only when they changed.
    const bool edges_only = sources && ext_[i] && !visible_[i];
    const bool t = (mrt.tiles[i] || stale_[i]) && ext_[i] && !edges_only;
    const bool e = edges_only && (mrt.tiles[i] || edge_stale_[i]);
    tiles_work_[i] = t ? 1 : e ? kPaddingSourcesTile : 0;
    tile_count += t || e;
    hidden_ += mrt.tiles[i] && !t;
    caught_up_ += t && !mrt.tiles[i];
    out_work_[i] = out.tiles[i] || stale_[i];  // changed: now, or earlier while hidden
    edge_stale_[i] = (mrt.tiles[i] || edge_stale_[i]) && !t && !e;
  }
  // Unwritten from here: the tiles that changed outside ext_, and the rectangles of every block
  // outside visible_ whose tile or padding neighbours changed.
  atlas_stale_count_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool changed = out_work_[i] || padding_source_flagged(padding_, i, out_work_);
    atlas_work_[i] = visible_[i] && (changed || atlas_stale_[i]);
    atlas_count += atlas_work_[i];
    atlas_stale_[i] = !visible_[i] && (changed || atlas_stale_[i]);
    atlas_stale_count_ += atlas_stale_[i];
  }
  stale_count_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    stale_[i] = out_work_[i] && (!ext_[i] || (sources && !visible_[i]));  // edges only: stays stale
    stale_count_ += stale_[i];
    out_work_[i] = out_work_[i] && ext_[i];
    out_count += out_work_[i];
  }
  tiles = StageWork{
      mrt.blocks, mrt.slots, tiles_work_, mrt.block_count, mrt.slot_count, tile_count, tile_count == n,
      {},         0};
  output = StageWork{out.blocks, out.slots,      out_work_,   out.block_count, out.slot_count,
                     out_count,  out_count == n, atlas_work_, atlas_count};
}

Status StagedBackend::catch_up(bool all) {
  if (!updated_ || !camera_active() || !stage_camera_skip_available()) return Status::success();
  const std::size_t n = level_.blocks.size();
  const std::vector<std::uint8_t>& visible = all ? all_blocks_ : visible_;
  const std::vector<std::uint8_t>& ext = all ? all_blocks_ : ext_;
  // The stale tiles of the visible blocks (with `all`, every block's); a padding neighbour that
  // is not visible gets its padding sources where the backend can (plan_camera).
  const bool sources = stage_padding_sources_available() && !all;
  std::size_t tile_count = 0, atlas_count = 0, whole = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool edges_only = sources && ext[i] && !visible[i];
    const bool t = stale_[i] && ext[i] && !edges_only, e = edges_only && edge_stale_[i];
    tiles_work_[i] = t ? 1 : e ? kPaddingSourcesTile : 0;
    tile_count += t || e, whole += t;
  }
  for (std::size_t i = 0; i < n; ++i) {
    atlas_work_[i] =
        visible[i] && (atlas_stale_[i] || tiles_work_[i] || padding_source_flagged(padding_, i, tiles_work_));
    atlas_count += atlas_work_[i];
  }
  if (tile_count == 0 && atlas_count == 0) return Status::success();
  // The tiles from the b and r on hand (no block or slot is computed), then what the evaluation
  // that left them unwritten would have done after them.
  const StageWork tiles{no_blocks_, no_slots_, tiles_work_, 0, 0, tile_count, whole == n, {}, 0};
  const StageWork output{no_blocks_, no_slots_,  tiles_work_, 0,          0,
                         tile_count, whole == n, atlas_work_, atlas_count};
  catching_up_ = true;
  Status s = stage_begin();
  if (s.ok() && tile_count) s = stage_tiles(tiles);
  if (s.ok() && drt_ && tile_count) s = stage_catch_up_deltas(output);
  if (s.ok()) s = stage_atlas(output);
  if (s.ok()) s = stage_vector(output);
  stage_end(s.ok());
  catching_up_ = false;
  if (!s.ok()) return s;  // the flags stand: the next evaluation or catch-up writes them
  stale_count_ = atlas_stale_count_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    stale_[i] = stale_[i] && tiles_work_[i] != 1;
    edge_stale_[i] = edge_stale_[i] && tiles_work_[i] == 0;
    atlas_stale_[i] = atlas_stale_[i] && !visible[i];
    stale_count_ += stale_[i], atlas_stale_count_ += atlas_stale_[i];
  }
  stats_.tiles_caught_up += whole;
  return Status::success();
}

std::size_t StagedBackend::plan_probes(const StageWork& out) {
  // With clutter stage_probes adds the DRT probe deltas over every block: all of them, always.
  const bool skip = stage_probe_skip_available() && !drt_;
  std::size_t count = 0;
  probe_stale_count_ = 0;
  for (std::size_t i = 0; i < level_.blocks.size(); ++i) {
    const bool changed = out.tiles[i] || probe_stale_[i];
    probe_work_[i] = changed && (!skip || visible_[i]);
    probe_stale_[i] = changed && !probe_work_[i];
    count += probe_work_[i], probe_stale_count_ += probe_stale_[i];
  }
  return count;
}

Status StagedBackend::catch_up_probes(const std::vector<std::uint8_t>& wanted) {
  if (!updated_ || probe_stale_count_ == 0 || !has_probes_) return Status::success();
  const std::size_t n = level_.blocks.size();
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    probe_work_[i] = probe_stale_[i] && wanted[i];
    count += probe_work_[i];
  }
  if (count == 0) return Status::success();
  const StageWork work{no_blocks_, no_slots_, probe_work_, 0, 0, count, count == n, {}, 0};
  Status s = stage_begin();
  if (s.ok()) s = stage_probes(work);
  stage_end(s.ok());
  if (!s.ok()) return s;  // the flags stand
  for (std::size_t i = 0; i < n; ++i) probe_stale_[i] = probe_stale_[i] && !probe_work_[i];
  probe_stale_count_ -= count;
  stats_.probe_blocks_caught_up += count;
  return Status::success();
}

void StagedBackend::mark_all_stale() {
  // After a failed evaluation no tile is known to be current (the next one computes every
  // block's b, r and the visible tiles). A backend without the camera skip recomputes all.
  if (stage_probe_skip_available()) {
    std::fill(probe_stale_.begin(), probe_stale_.end(), std::uint8_t(1));
    probe_stale_count_ = probe_stale_.size();
  }
  if (!stage_camera_skip_available()) return;
  std::fill(stale_.begin(), stale_.end(), std::uint8_t(1));
  std::fill(edge_stale_.begin(), edge_stale_.end(), std::uint8_t(1));
  std::fill(atlas_stale_.begin(), atlas_stale_.end(), std::uint8_t(1));
  stale_count_ = atlas_stale_count_ = stale_.size();
}

Status StagedBackend::set_visible_blocks(std::span<const std::uint8_t> visible) {
  if (!stage_camera_skip_available()) return refused("set_visible_blocks: no camera skip in this backend");
  const std::size_t n = level_.blocks.size();
  if (!visible.empty() && visible.size() != n)
    return refused("set_visible_blocks: visible has " + std::to_string(visible.size()) + " flags, expected " +
                   std::to_string(n) + " (one per block; none: every block)");
  for (std::size_t i = 0; i < n; ++i) visible_[i] = ext_[i] = visible.empty() || visible[i] != 0;
  for (std::size_t i = 0; i < n; ++i)
    if (visible_[i])
      for (std::uint32_t j : padding_.sources_of(i)) ext_[j] = 1;
  camera_skip_ = !visible.empty();
  // A block that became visible shows this frame's light now (its tiles were left unwritten).
  if (Status s = catch_up(false); !s.ok()) return s;
  return catch_up_probes(visible_);
}

// architecture.md §5 steps 2–9 after the input stage; see the header for the order.
Status StagedBackend::evaluate(const StageWork& mrt, bool clutter_feedback, const ClutterFeedback& feedback,
                               const ReducedSolveSettings* solve) {
  // With clutter the deltas read every block's b (shadows across openings): every tile's output.
  StageWork out = mrt;
  if (drt_)
    out = StageWork{
        all_blocks_, all_slots_, all_blocks_, mrt.block_count, mrt.slot_count, all_blocks_.size(), true,
        {},          0};
  // The camera skip: the tiles and rectangles of the visible blocks (and the stale ones); the
  // probes of the visible blocks (the others' when read: plan_probes).
  StageWork tiles = mrt, output = out;
  hidden_ = caught_up_ = 0;
  if (camera_active()) plan_camera(mrt, out, tiles, output);
  if (drt_ && (clutter_feedback || !rho_c_.empty())) {
    const ClutterCSource source = clutter_feedback ? ClutterCSource::feedback : ClutterCSource::direct;
    if (Status s = timed(TimedStage::drt, [&] { return stage_clutter_c(source, feedback); }); !s.ok())
      return s;
  }
  if (Status s = timed(TimedStage::b, [&] { return stage_b(mrt); }); !s.ok()) return s;
  if (solve) {
    ReducedSolveReport report;
    const Status s = timed(TimedStage::feedback,
                           [&] { return stage_solve(*reduced_, solver_, x_, warm_, *solve, report); });
    warm_ = s.ok();
    if (!s.ok()) return s;
    converged_.last = report;
    ++converged_.solves, converged_.iterations += std::uint64_t(report.iterations);
    converged_.blocks_applied += report.blocks_applied;
  }
  if (Status s = timed(TimedStage::r, [&] { return stage_r(mrt); }); !s.ok()) return s;
  if (Status s = timed(TimedStage::lightmap, [&] { return stage_tiles(tiles); }); !s.ok()) return s;
  if (drt_)
    if (Status s = timed(TimedStage::drt, [&] { return stage_deltas(output); }); !s.ok()) return s;
  if (Status s = timed(TimedStage::atlas, [&] { return stage_atlas(output); }); !s.ok()) return s;
  if (Status s = timed(TimedStage::vector, [&] { return stage_vector(output); }); !s.ok()) return s;
  if (has_probes_) {
    const std::size_t count = plan_probes(out);
    const StageWork probes{out.blocks,
                           out.slots,
                           probe_work_,
                           out.block_count,
                           out.slot_count,
                           count,
                           count == level_.blocks.size(),
                           {},
                           0};
    if (Status s = timed(TimedStage::probes, [&] { return stage_probes(probes); }); !s.ok()) return s;
    stats_.probe_blocks_computed += count;
  }
  if (drt_)
    if (Status s = timed(TimedStage::clutter, [&] { return stage_clutter_lightmap(); }); !s.ok()) return s;
  return Status::success();
}

// The input stage (ld, ld texture or feedback) and the evaluation, between stage_begin and
// stage_end; whatever fails, the next update runs whole.
Status StagedBackend::run_input_and_evaluate(bool texture, std::span<const float> ld,
                                             std::uint32_t ld_texture, bool feedback, float bound,
                                             const ClutterFeedback& clutter_feedback) {
  const StageWork all{
      all_blocks_, all_slots_, all_blocks_, all_blocks_.size(), all_slots_.size(), all_blocks_.size(), true,
      {},          0};
  const StageWork dirty{dirty_.blocks(),
                        dirty_.slots(),
                        dirty_.tiles(),
                        dirty_.dirty_blocks(),
                        dirty_.dirty_slots(),
                        dirty_.dirty_tiles(),
                        dirty_.dirty_blocks() == all_blocks_.size(),
                        {},
                        0};
  // Without skipping the dirty sets are not kept (update() marks nothing): every item runs.
  const StageWork& mrt = (texture || feedback || !options_.skip_unchanged) ? all : dirty;
  // A feedback step reads the whole lightmap: the hidden tiles first.
  if (feedback)
    if (Status s = catch_up(true); !s.ok()) return s;
  if (Status s = stage_begin(); !s.ok()) return s;
  Status s;
  if (feedback && texture)
    s = timed(TimedStage::feedback, [&] { return stage_feedback_texture(ld_texture, bound); });
  else if (feedback)
    s = timed(TimedStage::feedback, [&] { return stage_feedback(ld, bound); });
  else if (texture)
    s = timed(TimedStage::upload, [&] { return stage_ld_texture(ld_texture); });
  else
    s = timed(TimedStage::upload, [&] { return stage_ld(ld, mrt); });
  const bool clutter_fed = feedback && drt_ && !rho_c_.empty();
  if (s.ok()) s = evaluate(mrt, clutter_fed, clutter_feedback);
  stage_end(s.ok());
  if (timing_) {
    times_ = BackendStageTimes{};
    timer_collect(times_);
  }
  if (!s.ok()) {
    dirty_.invalidate();
    mark_all_stale();
    return s;
  }
  // After a feedback step or ld from a texture, the next update compares with no ld of its own.
  if (texture || feedback) dirty_.invalidate();
  count(mrt);
  updated_ = true;
  return Status::success();
}

Status StagedBackend::update(std::span<const float> ld) {
  if (Status s = validate_light_signal(ld, level_.sample_count, "ld"); !s.ok()) return s;
  const bool everything = !updated_;
  if (options_.skip_unchanged && dirty_.mark(ld, everything) == 0 && !everything) {  // this frame's results
    count_frame_kept();
    return Status::success();
  }
  return run_input_and_evaluate(false, ld, 0, false, 0.0f, {});
}

Status StagedBackend::update_from_texture(std::uint32_t ld_texture) {
  return run_input_and_evaluate(true, {}, ld_texture, false, 0.0f, {});
}

Status StagedBackend::stage_ld_texture(std::uint32_t ld_texture) {
  (void)ld_texture;
  return refused("ld comes from CPU memory: use update()");
}

Status StagedBackend::stage_feedback_texture(std::uint32_t ld_texture, float bound_per_ld) {
  (void)ld_texture, (void)bound_per_ld;
  return refused("ld comes from CPU memory: use multi_bounce_step()");
}

Status StagedBackend::set_albedo(std::span<const float> albedo, float max_albedo) {
  if (Status s = check_max_albedo(max_albedo, "set_albedo"); !s.ok()) return refused(s.message());
  if (Status s = validate_light_signal(albedo, level_.sample_count, "albedo"); !s.ok()) return s;
  const float rho_max = clamp_albedo(albedo, max_albedo, rho_).rho_max;
  if (Status s = stage_albedo(rho_); !s.ok()) return s;
  rho_max_ = rho_max;
  has_albedo_ = true;
  reduced_.reset();  // rebuilt for this albedo by the next converged update
  warm_ = false;
  return Status::success();
}

Status StagedBackend::stage_solve(const ReducedFeedback& op, ReducedSolver& solver, std::span<float> x,
                                  bool warm, const ReducedSolveSettings& settings,
                                  ReducedSolveReport& report) {
  (void)op, (void)solver, (void)x, (void)warm, (void)settings, (void)report;
  // update_converged refuses before any stage unless stage_solve_available(); kept for a backend
  // that claims the solve without implementing it.
  return refused("update_converged: no converged solve in this backend: use multi_bounce_step()");
}

void StagedBackend::stage_reduced_apply(const ReducedFeedback& op, std::span<const float> x,
                                        std::span<float> out) {
  r_scratch_.resize(sizes_.r);
  reference_apply_reduced_feedback(level_, dirty_.dependencies(), op, x, r_scratch_, out);
}

Status StagedBackend::update_converged(std::span<const float> ld_direct,
                                       const ReducedSolveSettings& settings) {
  return run_converged(false, ld_direct, 0, settings);
}

Status StagedBackend::update_converged_from_texture(std::uint32_t ld_texture,
                                                    const ReducedSolveSettings& settings) {
  return run_converged(true, {}, ld_texture, settings);
}

Status StagedBackend::run_converged(bool texture, std::span<const float> ld_direct, std::uint32_t ld_texture,
                                    const ReducedSolveSettings& settings) {
  const char* fn = texture ? "update_converged_from_texture" : "update_converged";
  // Refused before any stage runs (a refused call changes nothing).
  if (!stage_solve_available())
    return refused(std::string(fn) + ": no converged solve" + (drt_ ? " with clutter" : "") +
                   " in this backend: use multi_bounce_step()");
  if (!has_albedo_) return refused(std::string(fn) + ": call set_albedo first");
  if (!(settings.tolerance > 0.0f && settings.tolerance < 1.0f) || settings.max_iterations < 1)
    return refused(std::string(fn) + ": tolerance must be in (0, 1) and max_iterations at least 1");
  if (!texture)
    if (Status s = validate_light_signal(ld_direct, level_.sample_count, "ld_direct"); !s.ok()) return s;
  if (!reduced_) {
    const Clock::time_point start = Clock::now();
    Result<ReducedFeedback> op = build_reduced_feedback(
        level_, dict_, dirty_.dependencies(), rho_,
        [this](const ReducedFeedback& o, std::span<const float> x, std::span<float> y) {
          stage_reduced_apply(o, x, y);
        },
        reduced_solve_clutter(drt_), rho_c_);
    if (!op.ok()) return op.status();
    reduced_.emplace(std::move(op).value());
    const std::size_t unknowns = reduced_->unknowns(level_);
    if (solver_.unknowns() != unknowns)
      solver_ =
          ReducedSolver::create(unknowns, ReducedSolver::kMaxHistory, 3 * std::size_t(level_.kb), sizes_.r);
    x_.assign(unknowns, 0.0f);
    if (reduced_->clutter.drt) clutter_scratch_.allocate(level_, level_.kb, *drt_);
    warm_ = false;
    converged_.spectral_radius = reduced_->spectral_radius;
    converged_.damping = reduced_->damping;
    converged_.contraction = reduced_->contraction;
    converged_.block_jacobi = reduced_->block_jacobi;
    converged_.build_ns =
        std::uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start).count());
  }
  // Every block's tile, and b0 of every block or (stage_solve_keeps_b0) of the blocks whose ld
  // changed; r comes from the solve (stage_solve), no slot is computed after it.
  const bool changed_b0_only = !texture && options_.skip_unchanged && stage_solve_keeps_b0();
  if (changed_b0_only)
    b0_changes_.mark(ld_direct);
  else
    b0_changes_.invalidate();
  const StageWork work{changed_b0_only ? b0_changes_.blocks() : std::span<const std::uint8_t>(all_blocks_),
                       no_slots_,
                       all_blocks_,
                       changed_b0_only ? b0_changes_.count() : all_blocks_.size(),
                       0,
                       all_blocks_.size(),
                       false,
                       {},
                       0};
  if (Status s = stage_begin(); !s.ok()) {
    b0_changes_.invalidate();
    return s;
  }
  Status s = timed(TimedStage::upload,
                   [&] { return texture ? stage_ld_texture(ld_texture) : stage_ld(ld_direct, work); });
  if (s.ok()) s = evaluate(work, false, {}, &settings);
  stage_end(s.ok());
  if (timing_) {
    times_ = BackendStageTimes{};
    timer_collect(times_);
  }
  dirty_.invalidate();  // the results on hand are not update(ld_direct)'s
  if (!s.ok()) {
    b0_changes_.invalidate();  // the backend's b0 may be half written
    warm_ = false;
    mark_all_stale();
    return s;
  }
  count(work);
  updated_ = true;
  // Gather operators: the solve left the clutter out (reduced_solve_clutter); its light and
  // shadows bounce on in kGatherConvergedSteps feedback steps (drt.h, drt_converged_bounce).
  if (gather_)
    for (int step = 0; step < kGatherConvergedSteps; ++step)
      if (Status fed = texture ? multi_bounce_step_from_texture(ld_texture) : multi_bounce_step(ld_direct);
          !fed.ok())
        return fed;
  return Status::success();
}

Status StagedBackend::multi_bounce_step(std::span<const float> ld_direct) {
  if (!has_albedo_) return refused("multi_bounce_step: call set_albedo first");
  if (!updated_) return refused("multi_bounce_step: call update first");
  if (Status s = validate_light_signal(ld_direct, level_.sample_count, "ld_direct"); !s.ok()) return s;
  const float ld_max = largest_light(ld_direct);
  // The fed-back ld is at most ld_max + rho_max x bound; refused when that can pass the largest
  // light value, so that every stage stays within the float range operator_limits.h assumes.
  if (const double fed = feedback_ld_peak(ld_max, rho_max_); fed > kMaxLightValue) {
    char text[64];
    std::snprintf(text, sizeof text, "%g", fed);
    return refused(std::string("multi_bounce_step: the fed-back light can reach ") + text +
                   ", above the largest light value 1e30 (kMaxLightValue): rescale the scene's light");
  }
  const ClutterFeedback clutter{ld_max, rho_max_, clutter_ld_max_, rho_c_max_, false};
  return run_input_and_evaluate(false, ld_direct, 0, true, feedback_energy_bound(ld_max, rho_max_), clutter);
}

Status StagedBackend::multi_bounce_step_from_texture(std::uint32_t ld_texture) {
  if (!has_albedo_) return refused("multi_bounce_step_from_texture: call set_albedo first");
  if (!updated_) return refused("multi_bounce_step_from_texture: call update first");
  // ld_max is found on the GPU: the bound is ld_max x feedback_energy_bound(1, rho_max).
  const ClutterFeedback clutter{0.0f, rho_max_, clutter_ld_max_, rho_c_max_, true};
  return run_input_and_evaluate(true, {}, ld_texture, true, feedback_energy_bound(1.0f, rho_max_), clutter);
}

Status StagedBackend::check_read(const char* what, std::size_t expected, std::size_t got) const {
  if (got != expected)
    return refused(std::string(what) + ": has " + std::to_string(got) + " floats, expected " +
                   std::to_string(expected));
  if (!updated_) return refused("read before the first update");
  return Status::success();
}

Status StagedBackend::read_lightmap(std::span<float> out) {
  if (Status s = check_read("lightmap", sizes_.lightmap, out.size()); !s.ok()) return s;
  return read_output(StageOutput::lightmap, out);
}

Status StagedBackend::read_atlas(std::span<float> out) {
  if (Status s = check_read("atlas", sizes_.atlas, out.size()); !s.ok()) return s;
  return read_output(StageOutput::atlas, out);
}

Status StagedBackend::read_probes(std::span<float> out) {
  if (!has_probes_)
    return refused("no probes: the dictionary has none, or the backend's probes option is off");
  if (Status s = check_read("probes", sizes_.probes, out.size()); !s.ok()) return s;
  if (Status s = catch_up_probes(all_blocks_); !s.ok()) return s;
  return read_output(StageOutput::probes, out);
}

Status StagedBackend::read_block_probes(std::size_t block, std::span<float> out) {
  if (!has_probes_)
    return refused("no probes: the dictionary has none, or the backend's probes option is off");
  const std::size_t n = level_.blocks.size();
  if (block >= n)
    return refused("read_block_probes: block " + std::to_string(block) + " of a level with " +
                   std::to_string(n) + " blocks");
  const std::size_t per_block = sizes_.probes / n;
  if (Status s = check_read("block probes", per_block, out.size()); !s.ok()) return s;
  if (probe_stale_[block]) {
    std::fill(probe_wanted_.begin(), probe_wanted_.end(), std::uint8_t(0));
    probe_wanted_[block] = 1;
    if (Status s = catch_up_probes(probe_wanted_); !s.ok()) return s;
  }
  std::span<const float> all = stage_probes_data();
  if (all.empty()) {
    probe_scratch_.resize(sizes_.probes);
    if (Status s = read_output(StageOutput::probes, probe_scratch_); !s.ok()) return s;
    all = probe_scratch_;
  }
  std::copy_n(all.begin() + std::ptrdiff_t(per_block * block), per_block, out.begin());
  return Status::success();
}

Status StagedBackend::read_vector_lightmap(std::span<float> out) {
  if (Status s = check_read("vector lightmap", sizes_.vector_lightmap, out.size()); !s.ok()) return s;
  return read_output(StageOutput::vector_lightmap, out);
}

Status StagedBackend::set_clutter(const DrtOperators* drt) {
  if (drt && !drt->empty()) {
    if (Status s = check_drt_operators(level_, *drt); !s.ok()) return s;
    const std::size_t per_block =
        has_probes_ && !level_.blocks.empty() ? sizes_.probes / 27 / level_.blocks.size() : 0;
    if (Status s = check_drt_probe_grid(*drt, per_block, name_.c_str()); !s.ok()) return s;
  } else {
    drt = nullptr;
  }
  if (Status s = stage_clutter_set(drt); !s.ok()) return s;
  drt_ = drt;
  gather_ = drt && drt->has_gather();
  drt_sizes_ = drt ? drt_buffer_sizes(*drt) : DrtBufferSizes{};
  rho_c_.clear();
  rho_c_.reserve(drt_sizes_.clutter_ld);  // set_clutter_albedo allocates nothing
  rho_c_next_.reserve(drt_sizes_.clutter_ld);
  clutter_ld_max_ = rho_c_max_ = 0.0f;
  reduced_.reset();  // the converged solve's operators include the clutter's (rebuilt)
  warm_ = false;
  dirty_.invalidate();
  updated_ = false;  // the results on hand are not of this clutter
  return Status::success();
}

Status StagedBackend::set_clutter_light(std::span<const float> clutter_ld,
                                        std::span<const float> clutter_direct) {
  if (!drt_) return refused("set_clutter_light: no clutter set");
  const std::size_t n = drt_sizes_.clutter_ld;
  if (clutter_ld.size() != n || (!clutter_direct.empty() && clutter_direct.size() != n))
    return refused("set_clutter_light: clutter_ld has " + std::to_string(clutter_ld.size()) +
                   " floats and clutter_direct " + std::to_string(clutter_direct.size()) + ", expected " +
                   std::to_string(n) + " (clutter_direct may be empty)");
  if (Status s = validate_light_signal(clutter_ld, n / 3, "clutter_ld"); !s.ok()) return s;
  if (!clutter_direct.empty())
    if (Status s = validate_light_signal(clutter_direct, n / 3, "clutter_direct"); !s.ok()) return s;
  if (Status s = stage_clutter_light(clutter_ld, clutter_direct); !s.ok()) return s;
  clutter_ld_max_ = largest_light(clutter_ld);
  dirty_.invalidate();  // c changed whatever ld does
  return Status::success();
}

Status StagedBackend::set_clutter_albedo(std::span<const float> clutter_albedo, float max_albedo) {
  if (!drt_) return refused("set_clutter_albedo: no clutter set");
  // (The message is built only on failure: this call allocates nothing.)
  if (Status s = check_max_albedo(max_albedo, "set_clutter_albedo"); !s.ok()) return refused(s.message());
  if (!clutter_albedo.empty()) {
    if (clutter_albedo.size() != drt_sizes_.clutter_ld)
      return refused("set_clutter_albedo: clutter_albedo has " + std::to_string(clutter_albedo.size()) +
                     " floats, expected " + std::to_string(drt_sizes_.clutter_ld) + " (or none)");
    if (Status s = validate_light_signal(clutter_albedo, drt_sizes_.clutter_texels, "clutter_albedo");
        !s.ok())
      return s;
  }
  rho_c_next_.resize(clutter_albedo.size());  // within the capacity set_clutter reserved
  const float rho_c_max = clamp_albedo(clutter_albedo, max_albedo, rho_c_next_).rho_max;
  // rho_c is in the converged solve's operators: the next one rebuilds them when it changed.
  if (rho_c_next_ != rho_c_) reduced_.reset(), warm_ = false;
  rho_c_.swap(rho_c_next_);
  if (Status s = stage_clutter_albedo(rho_c_); !s.ok()) {
    rho_c_.clear();
    reduced_.reset(), warm_ = false;
    return s;
  }
  rho_c_max_ = rho_c_max;
  return Status::success();
}

Status StagedBackend::read_clutter_vector_lightmap(std::span<float> out) {
  if (!drt_) return refused("read_clutter_vector_lightmap: no clutter set");
  if (Status s = check_read("clutter vector lightmap", drt_sizes_.clutter_vector_lightmap, out.size());
      !s.ok())
    return s;
  return read_output(StageOutput::clutter_vector_lightmap, out);
}

Status StagedBackend::read_clutter_lightmap(std::span<float> out) {
  if (!drt_) return refused("read_clutter_lightmap: no clutter set");
  if (Status s = check_read("clutter lightmap", drt_sizes_.clutter_lightmap, out.size()); !s.ok()) return s;
  return read_output(StageOutput::clutter_lightmap, out);
}

}  // namespace modrt
