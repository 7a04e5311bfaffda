// SPDX-License-Identifier: MIT
// modrt — the frame sequence every backend shares (architecture.md §5, "One frame"), stated
// once: StagedBackend implements the whole Backend interface on top of a narrow stage
// interface that the scalar reference, modrt::cpu and modrt::gles implement.
//
// What StagedBackend owns, for every backend alike:
//   - input validation (ld, albedo, clutter light and albedo: NaN, Inf, negative, sizes; the
//     message names the argument, sample and channel) before any stage runs, so a refused call
//     changes nothing;
//   - the albedo clamp and the multi-bounce bound (feedback_policy.h: clamp_albedo,
//     feedback_energy_bound, the feedback_ld_peak refusal; drt.h: drt_feedback_bound);
//   - exact dirty tracking (level_dirty.h: ld -> blocks -> slots -> tiles) and the skip of a
//     repeated ld; a feedback step or ld from a texture recomputes everything;
//   - the DRT sequence: when c is the clutter's direct light again and when its indirect light
//     is fed back, and that the deltas reach every tile (a changed b shades other blocks);
//   - the order of the stages, their timing and the evaluation statistics;
//   - the checks of every read (size, an update has run, the output exists).
//
// One evaluation runs, in this order (skipped stages do not run):
//   feedback (multi-bounce: ld = ld_direct + rho min(max(lightmap, 0), bound)) or ld (upload of
//   the dirty blocks' ld) | clutter c | b (Td_b ld) | r (Tb->r b) | tiles (Ub b + Ur r) |
//   deltas (DRT: dUb b + dUc c) | atlas (padding) | vector | probes | clutter lightmap.
// The MRT stages (b, r, tiles) get the dirty sets; the output stages (deltas, atlas, vector,
// probes) get them too without clutter, and every tile with clutter. A backend may fuse
// stages (GLES draws the tiles in its atlas pass), but it runs exactly the work it is given.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "modrt/backend.h"
#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/level_dirty.h"
#include "modrt/reduced_feedback.h"

namespace modrt {

// The items one stage computes: flags per block (blocks, tiles) and per slot, 1 = compute.
struct StageWork {
  std::span<const std::uint8_t> blocks, slots, tiles;
  std::size_t block_count = 0, slot_count = 0, tile_count = 0;  // how many flags are 1
  bool everything = false;                                      // every flag is 1
  // The output stages (atlas, vector) only, while the camera skip is on (else empty): the
  // blocks whose atlas rectangles (padding included) to write, from the interiors of the
  // `tiles` blocks, which include the visible blocks' padding neighbours (their interiors are
  // read by that padding) whose own rectangles are not written (Backend::set_visible_blocks).
  std::span<const std::uint8_t> atlas;
  std::size_t atlas_count = 0;
};

// Where this evaluation's clutter c (3 per clutter face) comes from.
enum class ClutterCSource {
  direct,    // c = Td_c clutter_ld, the clutter's direct light (set_clutter_light)
  feedback,  // c = Td_c drt_clutter_feedback(clutter_ld, rho_c, indirect of the last evaluation, bound)
};

// The terms of drt_feedback_bound for a clutter feedback step. ld_max_on_gpu: ld came from a
// texture and the backend found ld_max there (ld_max is then unused).
struct ClutterFeedback {
  float ld_max = 0.0f, rho_max = 0.0f, clutter_ld_max = 0.0f, rho_c_max = 0.0f;
  bool ld_max_on_gpu = false;
  float bound() const { return drt_feedback_bound(ld_max, rho_max, clutter_ld_max, rho_c_max); }
};

// The timed stages: each adds to its BackendStageTimes field (upload: the ld stage; lightmap:
// the tiles stage; drt: clutter c and the deltas; clutter: the clutter lightmap).
enum class TimedStage {
  upload,
  feedback,
  clutter_c,
  b,
  r,
  lightmap,
  drt,
  atlas,
  vector,
  probes,
  clutter,
  count
};

// What a read_* call copies out (StagedBackend checked its size and that an update has run).
enum class StageOutput {
  lightmap,
  atlas,
  probes,
  vector_lightmap,
  clutter_lightmap,
  clutter_vector_lightmap
};

// The clutter's light on the CPU, for a backend whose DRT stages run there (the reference,
// modrt::cpu): c of this evaluation and of the direct light alone, the clutter's light, its
// lightmap, and the last evaluation's indirect light (Cb b + Cc c) with the light fed back.
// allocate() sizes everything (capacity for clutter_direct too) so that no frame allocates.
// `indirect` is the last clutter lightmap's unclamped indirect light (drt_clutter_indirect),
// which the next feedback step reads; `fed_back` says whether this evaluation's clutter light
// is `fed` (a feedback step) or clutter_ld, the x_t of the real-radiance gather (radiance()).
struct ClutterBuffers {
  std::vector<float> c, c_direct, clutter_ld, clutter_direct, clutter_lightmap, indirect, fed;
  bool fed_back = false;
  void allocate(const DrtBufferSizes& sizes);
  // clutter_ld and clutter_direct (may be empty) copied in; c_direct is then the caller's.
  void set_light(std::span<const float> clutter_ld, std::span<const float> clutter_direct);
  std::span<const float> radiance() const { return fed_back ? fed : clutter_ld; }
  // c of the direct light again (and x_t its light): a new light, albedo or plain update.
  void use_direct_light() {
    c = c_direct;
    fed_back = false;
  }
};

struct StagedBackendOptions {
  bool probes = true;          // evaluate the volume probes (when the dictionary has them)
  bool skip_unchanged = true;  // recompute only what a changed ld reaches (exact)
};

class StagedBackend : public Backend {
 public:
  const LevelBufferSizes& sizes() const final { return sizes_; }
  Status update(std::span<const float> ld) final;
  Status update_from_texture(std::uint32_t ld_texture) final;
  Status set_albedo(std::span<const float> albedo, float max_albedo = kDefaultMaxAlbedo) final;
  Status multi_bounce_step(std::span<const float> ld_direct) final;
  Status multi_bounce_step_from_texture(std::uint32_t ld_texture) final;
  Status update_converged(std::span<const float> ld_direct, const ReducedSolveSettings& settings = {}) final;
  Status update_converged_from_texture(std::uint32_t ld_texture,
                                       const ReducedSolveSettings& settings = {}) final;
  ConvergedStats converged_stats() const final { return converged_; }
  bool converged_available() const final { return stage_solve_available(); }
  Status read_lightmap(std::span<float> lightmap) final;
  Status read_atlas(std::span<float> atlas) final;
  Status read_probes(std::span<float> probes) final;
  Status read_block_probes(std::size_t block, std::span<float> probes) final;
  Status read_vector_lightmap(std::span<float> vector_lightmap) final;
  const BackendStageTimes& stage_times() const final { return times_; }
  void set_timing(bool on) final { timing_ = on; }
  BackendEvaluationStats evaluation_stats() const final { return stats_; }
  void count_frame_kept() final;
  Status set_clutter(const DrtOperators* drt) final;
  Status set_clutter_light(std::span<const float> clutter_ld, std::span<const float> clutter_direct) final;
  Status set_clutter_albedo(std::span<const float> clutter_albedo,
                            float max_albedo = kDefaultMaxAlbedo) final;
  const DrtBufferSizes& clutter_sizes() const final { return drt_sizes_; }
  Status read_clutter_vector_lightmap(std::span<float> clutter_vector_lightmap) final;
  Status read_clutter_lightmap(std::span<float> clutter_lightmap) final;
  Status set_visible_blocks(std::span<const std::uint8_t> visible) final;

 protected:
  // `name` prefixes every message ("cpu", "gles", "reference"). `probes`: whether the backend
  // computes probes (the options' and the dictionary's); level and dict are borrowed.
  StagedBackend(const Level& level, const Dictionary& dict, const StagedBackendOptions& options,
                const char* name);

  const Level& level() const { return level_; }
  const Dictionary& dict() const { return dict_; }
  bool has_probes() const { return has_probes_; }
  const DrtOperators* clutter() const { return drt_; }
  bool timing() const { return timing_; }
  bool updated() const { return updated_; }
  // The clamped clutter albedo of set_clutter_albedo (3 per clutter texel; empty: none).
  std::span<const float> clutter_albedo() const {
    return rho_c_;
  }  // an evaluation has succeeded since the last set_clutter
  // invalid_argument, "<name>: <what>".
  Status refused(const std::string& what) const;
  // The converged solve's clutter scratch (sized when the reduced operators are built with clutter).
  ReducedClutterScratch& reduced_clutter_scratch() { return clutter_scratch_; }
  // The padding records and padding neighbours of each block (the camera skip's atlas work).
  const AtlasBlockPadding& atlas_padding() const { return padding_; }
  // Between stage_begin and stage_end: the camera skip's catch-up, not an evaluation (a
  // backend's own per-evaluation statistics leave it out).
  bool catching_up() const { return catching_up_; }

  // ---- The stages. Each may fail only for a reason of its own (a GL error); the inputs
  // are valid and the sizes right. ----
  // ld (3 x samples) for this evaluation: at least the blocks work.blocks marks.
  virtual Status stage_ld(std::span<const float> ld, const StageWork& work) = 0;
  // ld from the caller's GL texture (Backend::update_from_texture); default: refused.
  virtual Status stage_ld_texture(std::uint32_t ld_texture);
  virtual TextureSize stage_ld_texture_size() const { return {}; }
  // The multi-bounce ld: ld_direct + rho min(max(lightmap, 0), bound), rho of stage_albedo and
  // the lightmap of the last evaluation (with its DRT delta).
  virtual Status stage_feedback(std::span<const float> ld_direct, float bound) = 0;
  // The same with ld_direct from a GL texture and bound = bound_per_ld x (its largest value,
  // found on the GPU); default: refused.
  virtual Status stage_feedback_texture(std::uint32_t ld_texture, float bound_per_ld);
  // The clamped albedo (3 x samples) the feedback multiplies by.
  virtual Status stage_albedo(std::span<const float> rho) = 0;
  // The converged solve (update_converged), after the b stage wrote b0 = Td_b ld_direct: with
  // `warm` x holds the last solve's b* (else the backend starts from x = b0); the backend writes
  // c = P b0 into solver.rhs() and runs solver.solve with its application of op (out = G x); on
  // return its b and x hold b*, and its r is the r of the last application (r = Tb->r of the
  // iterate before b*, within the solve's tolerance of Tb->r b*): the r stage that follows has no
  // slot to compute and the tiles, probes and vector irradiance read that r. With clutter
  // (op.clutter.drt) the unknowns are b then c: x's c part starts at c0 = Td_c clutter_ld (the
  // direct light's c) when cold, the rhs's c part is c0, the application adds the clutter's
  // terms (reference_apply_reduced_clutter, or reduced_clutter_feedback after the backend's DRT
  // kernels; scratch: reduced_clutter_scratch()), and on return its c holds c* for the deltas
  // and the clutter lightmap that follow. Default: refused (a backend without a reduced solve).
  virtual Status stage_solve(const ReducedFeedback& op, ReducedSolver& solver, std::span<float> x, bool warm,
                             const ReducedSolveSettings& settings, ReducedSolveReport& report);
  virtual bool stage_solve_available() const { return false; }  // true where stage_solve is implemented
  // true where the backend keeps b0 per block between converged evaluations: the b stage of a
  // converged evaluation then computes b0 of the blocks whose ld changed since the last one that
  // succeeded (work.blocks; with skip_unchanged, from CPU ld), and stage_solve takes the other
  // blocks' b0 from the last such evaluation. false: every block's, every converged evaluation.
  virtual bool stage_solve_keeps_b0() const { return false; }
  // out = G x of `op` with the backend's kernels, for the radius estimates of the build
  // (build_reduced_feedback); default: core's reference_apply_reduced_feedback.
  virtual void stage_reduced_apply(const ReducedFeedback& op, std::span<const float> x, std::span<float> out);
  virtual Status stage_b(const StageWork& work) = 0;
  virtual Status stage_r(const StageWork& work) = 0;
  virtual Status stage_tiles(const StageWork& work) = 0;
  // The atlas rectangles of work.atlas from the lightmap; with the camera skip on, the
  // interiors of work.tiles first (a backend whose stage_atlas does not take it that way
  // keeps stage_camera_skip_available() false).
  virtual Status stage_atlas(const StageWork& work) = 0;
  virtual bool stage_camera_skip_available() const { return false; }
  // The camera skip's hidden padding neighbours: true where stage_tiles writes, for a tile flag
  // of kPaddingSourcesTile, only the samples atlas padding copies (bit-identical to the whole
  // tile's), so that a block that is not visible costs its edges, not its tile.
  virtual bool stage_padding_sources_available() const { return false; }
  static constexpr std::uint8_t kPaddingSourcesTile = 2;
  // The camera skip's catch-up (tiles written late from the b and r on hand): the DRT deltas
  // over them as the evaluation that left them unwritten would have added them. The default
  // reruns stage_deltas (CPU and reference: lightmap = base + deltas, idempotent); a backend
  // whose delta pass also advances the clutter's feedback (GLES) keeps the deltas it has.
  virtual Status stage_catch_up_deltas(const StageWork& work) { return stage_deltas(work); }
  // Vector irradiance for a backend that renders it every evaluation (GLES); a backend that
  // computes it on request (read_output) keeps the default.
  virtual Status stage_vector(const StageWork& work) {
    (void)work;
    return Status::success();
  }
  virtual Status stage_probes(const StageWork& work) = 0;
  // The camera skip's probes: true where stage_probes computes the work.tiles blocks' probes
  // only (and adds no DRT over the others), so that a hidden block's probes can wait until
  // they are read or the block comes into view; a backend whose renderer samples the probe
  // volume on the GPU (GLES) keeps the default and computes every block's.
  virtual bool stage_probe_skip_available() const { return false; }
  // Where the backend keeps the probes in CPU memory (sizes().probes floats), for
  // read_block_probes to copy one block's; empty: read_output copies them all.
  virtual std::span<const float> stage_probes_data() const { return {}; }
  // Around each evaluation (GL state); stage_end runs after a failed stage too (ok false).
  virtual Status stage_begin() { return Status::success(); }
  virtual void stage_end(bool ok) { (void)ok; }
  // Copies `output` of the last evaluation into out (its size checked; probes and clutter
  // outputs exist). Vector outputs may fail when the backend has no vector operators.
  virtual Status read_output(StageOutput output, std::span<float> out) = 0;
  // DRT. stage_clutter_set: allocate for `drt` (checked against the level), or release for
  // nullptr; on failure the previous clutter stays. stage_clutter_light: the validated light
  // (clutter_direct may be empty); c becomes Td_c clutter_ld. stage_clutter_albedo: the clamped
  // clutter albedo (empty: none); c becomes the direct light's again.
  virtual Status stage_clutter_set(const DrtOperators* drt) = 0;
  virtual Status stage_clutter_light(std::span<const float> clutter_ld,
                                     std::span<const float> clutter_direct) = 0;
  virtual Status stage_clutter_albedo(std::span<const float> rho_c) = 0;
  // c for this evaluation, before the b stage overwrites the last evaluation's b.
  virtual Status stage_clutter_c(ClutterCSource source, const ClutterFeedback& feedback) = 0;
  // The DRT deltas dUb b + dUc c (and their vector and probe twins) of this evaluation's b and c,
  // and the gather's Ht x_t - Hs x_s of its ld and clutter light (drt_apply_gather).
  virtual Status stage_deltas(const StageWork& work) = 0;
  // The clutter lightmap drt_clutter_indirect + clutter_direct, clamped at 0 (with the gather
  // reading this evaluation's ld and clutter light).
  virtual Status stage_clutter_lightmap() = 0;
  // Timing (when on): default, the steady clock around each stage; a backend with GPU timer
  // queries overrides the three together.
  virtual void timer_begin(TimedStage stage);
  virtual void timer_end(TimedStage stage);
  virtual void timer_collect(BackendStageTimes& times);

 private:
  using Clock = std::chrono::steady_clock;
  // One evaluation after its input stage: everything from clutter c to the clutter lightmap.
  // solve: the converged solve's settings (update_converged), run after the b stage.
  Status evaluate(const StageWork& mrt, bool clutter_feedback, const ClutterFeedback& feedback,
                  const ReducedSolveSettings* solve = nullptr);
  // update_converged and its texture twin.
  Status run_converged(bool texture, std::span<const float> ld_direct, std::uint32_t ld_texture,
                       const ReducedSolveSettings& settings);
  Status run_input_and_evaluate(bool texture, std::span<const float> ld, std::uint32_t ld_texture,
                                bool feedback, float bound, const ClutterFeedback& clutter_feedback);
  void count(const StageWork& work);
  // The camera skip: the tiles and atlas work of an evaluation whose MRT work is `mrt` and
  // whose outputs change on out.tiles, within visible_ / ext_ (the stale blocks' too); then
  // the stale flags of what stays unwritten. catch_up produces the stale tiles inside
  // (visible, ext) with the b and r on hand; with all, every one (before a feedback step).
  void plan_camera(const StageWork& mrt, const StageWork& out, StageWork& tiles, StageWork& atlas);
  Status catch_up(bool all);
  // The probes of the stale blocks flagged in `wanted`, from the b and r on hand.
  Status catch_up_probes(const std::vector<std::uint8_t>& wanted);
  // This evaluation's probe work (probe_work_): the blocks whose probes changed (out.tiles) or
  // waited, within visible_ where the backend has the probe skip; the rest stay stale.
  std::size_t plan_probes(const StageWork& out);
  void mark_all_stale();
  bool camera_active() const { return camera_skip_ || stale_count_ > 0 || atlas_stale_count_ > 0; }
  Status check_read(const char* what, std::size_t expected, std::size_t got) const;
  template <class F>
  Status timed(TimedStage stage, F&& f);

  const Level& level_;
  const Dictionary& dict_;
  StagedBackendOptions options_;
  std::string name_;
  LevelBufferSizes sizes_;
  bool has_probes_ = false;
  LevelDirtyTracker dirty_;
  // The blocks whose b0 a converged evaluation computes (stage_solve_keeps_b0).
  LevelBlockChanges b0_changes_;
  std::vector<std::uint8_t> all_blocks_, all_slots_, no_slots_;  // every flag 1; every slot flag 0
  std::vector<float> rho_;                                       // the clamped albedo, for stage_albedo
  float rho_max_ = 0.0f;
  bool has_albedo_ = false, updated_ = false, timing_ = false;
  const DrtOperators* drt_ = nullptr;
  bool gather_ = false;  // drt_->has_gather()
  DrtBufferSizes drt_sizes_;
  std::vector<float> rho_c_, rho_c_next_;  // the clamped clutter albedo (empty: none); the next one
  // The converged solve: the reduced operators of the current albedo (built on first use), the
  // solver, the last solve's b* (the warm start while warm_) and the statistics.
  std::optional<ReducedFeedback> reduced_;
  ReducedSolver solver_;
  std::vector<float> x_, r_scratch_;
  ReducedClutterScratch clutter_scratch_;  // r_scratch_: the default stage_reduced_apply's r
  bool warm_ = false;
  ConvergedStats converged_;
  float clutter_ld_max_ = 0.0f, rho_c_max_ = 0.0f;
  // The camera skip (set_visible_blocks): the visible blocks and those with their padding
  // neighbours (ext_), every flag 1 while it is off; per block whether its lightmap tile (and
  // atlas interior) or its atlas rectangles are not current; the work flags of one evaluation.
  AtlasBlockPadding padding_;
  bool camera_skip_ = false;
  std::vector<std::uint8_t> visible_, ext_, stale_, atlas_stale_, tiles_work_, out_work_, atlas_work_,
      no_blocks_;
  std::size_t stale_count_ = 0, atlas_stale_count_ = 0;
  // Per block whether its padding sources (the samples other blocks' padding copies) are not
  // current: implies stale_ (stage_padding_sources_available).
  std::vector<std::uint8_t> edge_stale_;
  // Per block whether its probes are not current (hidden while they changed), the probe work
  // of one evaluation or catch-up, and a one-block request (read_block_probes).
  std::vector<std::uint8_t> probe_stale_, probe_work_, probe_wanted_;
  std::size_t probe_stale_count_ = 0;
  std::vector<float> probe_scratch_;  // read_block_probes without stage_probes_data
  bool catching_up_ = false;
  std::uint64_t hidden_ = 0, caught_up_ = 0;  // of the evaluation being counted
  BackendStageTimes times_;
  BackendEvaluationStats stats_;
  Clock::time_point stage_start_[std::size_t(TimedStage::count)];
  std::uint64_t stage_ns_[std::size_t(TimedStage::count)] = {};
};

// U_dyn operators (DrtBuildSettings::probes) are for `drt.probes_per_block` probes per block;
// a backend rendering probes_per_block probes per block (0: none) refuses others.
Status check_drt_probe_grid(const DrtOperators& drt, std::size_t probes_per_block, const char* who);

}  // namespace modrt
