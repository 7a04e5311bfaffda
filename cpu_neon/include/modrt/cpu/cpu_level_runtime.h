// SPDX-License-Identifier: MIT
// modrt::cpu — the SIMD CPU runtime for a whole level (architecture.md §5 steps 2–6, 8 and 9).
//
// Computes exactly what core's level_evaluate / level_fill_atlas / level_compute_probes /
// level_multi_bounce compute (level_runtime.h), with the kernels of kernels.h, and agrees
// with them within 1e-5 relative L2 (tests/test_cpu_backend.cpp). Everything is allocated
// by create(); evaluate(), multi_bounce_step(), fill_atlas() and compute_probes() do not
// allocate (except to build an error message when they fail).
//
// Buffers kept between calls (layouts of level_runtime.h unless stated):
//   b: 3 kb per block, interleaved, and its planar copy (3 x kb per block, stride kb);
//   r: 3 kr per slot, interleaved, and its planar copy (3 x kr per slot, stride kr);
//   ld scratch: planar, 3 x (largest block sample count) per thread, reused block by block;
//   feedback: rho (albedo clamped), 3 x samples, and the ld of the current bounce;
//   schedule: the records of each slot (in level order) and the slots of each block.
//
// Work order. evaluate() runs two phases, each a loop over blocks:
//   1. per block i: b_i = Td_b ld_i (and its planar copy);
//   2. per block i: r_s = sum of T b(source) over the records of each slot s entering i, in
//      level order; then tile i of the lightmap = Ub b_i, += Ur r_s for those slots in order.
// Every output has one writer and one summation order, the same for any thread count, so
// results are bit-identical for every `threads` (and equal to the order of core's reference).
// compute_probes() is one such loop (Ubvol b_i, then the probe response of each slot of i).
//
// Threads. threads > 1 starts a fixed pool of threads - 1 workers in create() (the caller of
// evaluate() is the other one); blocks are handed out one at a time from an atomic counter.
// The pool allocates nothing per call. A runtime must not be used from two threads at once.
// Operators are not copied (float32, the default): they are read in place, row-major, from the
// Level and the Dictionary, which the runtime borrows and which must outlive it and stay
// unchanged.
//
// Float16 operators (CpuRuntimeOptions::operators = float16). create() rounds every operator
// a frame reads (Td_b, Ub, Ubvol and Ub_vec of the shapes the level's blocks use, Ur, every
// record's T, the probe and vector responses) to IEEE binary16, to nearest even, once, into
// one runtime-owned array (same row-major layouts); every GEMV then runs the _f16 kernels of
// kernels.h, which convert on load and accumulate in float exactly as the float kernels do.
// So the results are what this runtime computes in float32 for the half-rounded operators
// (the same bits, and within 1e-5 of core's reference on those operators), threads stay
// bit-identical, and no frame allocates. Half the operator bytes are streamed; rounding
// costs 1.5e-4 to 5.3e-4 relative L2 against float32 operators (lightmap <= 1.8e-4, b <=
// 5.3e-4 on the test levels; tests/test_cpu_backend.cpp, docs/cpu.md). A value with
// |v| > 65504 (the largest finite half) makes create() fail, naming the operator, element
// and value: never a silent Inf. Values below 6.1e-5 keep less relative precision
// (subnormal halves) and below 3e-8 become 0; the errors above include that.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "modrt/cpu/isa.h"
#include "modrt/feedback_policy.h"
#include "modrt/level.h"
#include "modrt/level_dirty.h"
#include "modrt/level_runtime.h"
#include "modrt/reduced_feedback.h"
#include "modrt/status.h"

namespace modrt::cpu {

class ThreadPool;  // src/thread_pool.h

// Skipping work a frame does not need (architecture.md §5). Off by default: every evaluate() then
// computes everything. ||x||_F is the L2 norm over all three channels of a signal (ld_i:
// 3 x samples of block i, b_i: 3 kb, r_s: 3 kr, a tile: 3 x samples); ||X||_2 the spectral norm
// of an operator. create() computes, in double, upper bounds on (rho(G) <= ||G^32||_inf^(1/32)
// for the Gram matrices, tight within kb^(1/64)):
//   per shape  ||Ub Td_b||_2  (the one-bounce operator of the block: ~1, where ||Td_b|| is not)
//              ||D Td_b||_2   with D = diag(column norms of Ub) ~ the singular values, so that
//                             b's large, cancelling high modes are weighted by their small sigma;
//   per record ||T||_F and ||T D^-1||_F (D of the source block's shape);   ||Ur||_2.
// Each skip, and what it changes against the full path for the same ld (exact arithmetic):
//  (a) Unchanged light. Block i keeps its b when, for every sample and channel,
//        |ld_i - ld_i^ref| <= ld_epsilon x max(ld_i^ref),
//      ld_i^ref being the ld that produced the kept b (a fixed reference: no drift). With
//      e_i = ||ld_i - ld_i^ref||_F <= ld_epsilon sqrt(3 n_i) max(ld_i^ref):
//        ||Ub (b_i - b_i^full)||_F <= ||Ub Td_b||_2 e_i,   ||D (b_i - b_i^full)||_F <= ||D Td_b||_2 e_i.
//      ld_epsilon = 0 keeps b only for an unchanged ld_i: exact.
//  (b) Dark blocks. When every value of ld_i is <= dark_ld, b_i = 0 with no GEMV: the same
//      bounds with e_i = ||ld_i||_F <= sqrt(3 n_i) dark_ld. dark_ld = 0 zeroes only all-zero
//      blocks, whose b is 0 anyway: exact.
//  (c) Small records. Record q (source block j) adds at most
//        w_q = min(||T_q||_F ||b_j||_F, ||T_q D^-1||_F ||D b_j||_F) >= ||T_q b_j||_F
//      to its slot. The records of slot s are taken in level order and q is left out when w_q,
//      plus the w of those already left out of s, stays <= record_epsilon x W_s, W_s = sum of
//      w_q over the slot (>= ||r_s||_F). So ||r_s - r_s(b used)||_F <= rho_s <= record_epsilon W_s,
//      rho_s the sum of the left-out w. Records with w = 0 (a dark source) are always left
//      out: exact.
//  (d) Unchanged tiles (keep_tiles). r_s is not recomputed when no source block's b changed,
//      and the lightmap tile of block i is not rewritten when b_i and every r_s entering i are
//      bitwise those that wrote it. Exact, but it relies on the caller passing back the
//      lightmap that the previous evaluate() wrote, unchanged (another buffer address
//      rewrites every tile; so does set_skip_options()). A tile that is rewritten starts from
//      a kept copy of Ub b_i and adds a kept copy of each slot's Ur r_s, recomputing only
//      those whose input changed: the same bits as the GEMVs.
//  (e) Nearly unchanged r (r_epsilon). When r_s is recomputed and ||r_new - r_s||_F <=
//      r_epsilon ||r_s||_F, r_s (the one that wrote the tile) is kept and counts as unchanged
//      for (d); the measured distance delta_s = ||r_new - r_s||_F joins the bound. Against
//      the kept r_s, not the last computed one: no drift. r_epsilon = 0: off.
// All together, per frame (skip_stats().lightmap_error_bound):
//   ||r_s - r_s^full||_F       <= sum over records q of s of ||T_q D^-1||_F ||D Td_b||_2 e_j + rho_s +
//   delta_s
//   ||tile_i - tile_i^full||_F <= ||Ub Td_b||_2 e_i + ||Ur||_2 sum over slots s entering i of the above
//   ||lightmap - lightmap^full||_2 <= sqrt(sum over blocks of the tile bounds^2).
// With float16 operators every norm above is computed from the half-rounded operators the
// kernels read (decoded exactly), not from the float originals: the bounds then hold for what
// the runtime computes, and need no rounding term, because both paths they compare use the
// same rounded operators. (The float16 rounding itself, float16 against float32 operators, is
// not a skip and is not in the bound.)
// Float rounding is not part of the bound: where b was kept, the two paths round different
// sums (relative ~1e-7, kernels.h). tests/test_cpu_backend.cpp checks the bound on a
// 300-frame moving-light sequence (observed error <= 0.25 x bound; docs/cpu.md).
struct CpuSkipOptions {
  bool enabled = false;
  float ld_epsilon = 0.0f;      // (a), relative, >= 0
  float dark_ld = 0.0f;         // (b), in units of ld, >= 0
  float record_epsilon = 0.0f;  // (c), relative, in [0, 1]
  bool keep_tiles = true;       // (d)
  float r_epsilon = 0.0f;       // (e), relative, >= 0
};

// What the last evaluate() (or multi_bounce_step()) skipped. All zero with skipping off.
struct CpuSkipStats {
  std::size_t blocks_computed = 0;   // b_i = Td_b ld_i evaluated
  std::size_t blocks_kept = 0;       // (a) b_i kept
  std::size_t blocks_dark = 0;       // (b) b_i = 0, no GEMV
  std::size_t records_computed = 0;  // T b GEMVs evaluated
  std::size_t records_skipped = 0;   // (c) left out (bound or dark source)
  std::size_t slots_kept = 0;        // (d) r_s reused: no source changed (its records not evaluated)
  std::size_t slots_close = 0;       // (e) r_s recomputed, but kept: within r_epsilon
  std::size_t tiles_written = 0;
  std::size_t tiles_skipped = 0;    // (d)
  double lightmap_error_bound = 0;  // bound on ||lightmap - full path||_2 (all channels), see above
};

// How the runtime holds the operators (see the header comment).
enum class OperatorStorage {
  float32,  // read in place from the Level and the Dictionary
  float16,  // rounded once by create() into runtime-owned IEEE binary16 arrays
};

struct CpuRuntimeOptions {
  std::optional<Isa> isa;  // none: active_isa(); an unsupported ISA makes create() fail
  int threads = 1;         // threads working on a frame, the caller included (1 to 256)
  CpuSkipOptions skip;     // off by default
  OperatorStorage operators = OperatorStorage::float32;
  // Flush subnormal floats to zero while the runtime computes (x86-64 MXCSR FTZ + DAZ, aarch64
  // FPCR.FZ; the caller's setting is restored before each call returns, and the pool's workers
  // set it around each task): ld, b, r or lightmap values below FLT_MIN (1.2e-38) read and write
  // as 0, and never cost a slow subnormal operation. False keeps IEEE gradual underflow.
  bool flush_denormals = true;
};

class CpuLevelRuntime {
 public:
  // Checks that the level was built against `dict` (check_level_matches, then every operator
  // size the runtime relies on) and allocates every buffer. Fails with invalid_argument on a
  // mismatch or bad options. `level` and `dict` are borrowed: they must outlive the runtime.
  static Result<CpuLevelRuntime> create(const Level& level, const Dictionary& dict,
                                        const CpuRuntimeOptions& options = {});

  CpuLevelRuntime(CpuLevelRuntime&&) noexcept;
  CpuLevelRuntime& operator=(CpuLevelRuntime&&) noexcept;
  ~CpuLevelRuntime();  // stops the pool's workers
  CpuLevelRuntime(const CpuLevelRuntime&) = delete;
  CpuLevelRuntime& operator=(const CpuLevelRuntime&) = delete;

  Isa isa() const { return isa_; }
  bool flush_denormals() const { return flush_denormals_; }
  int threads() const { return threads_; }
  OperatorStorage operators() const { return operators_; }
  // Bytes of the operators this runtime's GEMVs read (the list in the header comment): float32,
  // those it borrows from the Level and the Dictionary; float16, its own half arrays (half as
  // many). The skip and schedule state is not counted.
  std::size_t operator_bytes() const { return operator_bytes_; }
  // Sizes of ld, lightmap, atlas and probes (and of the b, r this runtime holds).
  const LevelBufferSizes& sizes() const { return sizes_; }

  // Steps 2–5: b = Td_b ld, r = Tb->r b, lightmap = Ub b + Ur r. ld and lightmap hold
  // sizes().ld / sizes().lightmap floats. Fails (non_finite / invalid_argument, naming the
  // sample and channel) on NaN, Inf or negative ld, and on wrong sizes; then nothing is written.
  Status evaluate(std::span<const float> ld, std::span<float> lightmap);

  // The stages of evaluate() over chosen items, for a caller that tracks what changed itself
  // (StagedBackend, core's staged_backend.h: flags per block or slot, 1 = compute). ld must
  // hold valid values (evaluate()'s checks are the caller's) and the lightmap must be the one
  // these calls wrote before, so that the tiles not computed stay right. compute_b: b_i of
  // the flagged blocks. compute_r_and_tiles: in one task per block i with a flagged tile or a
  // flagged slot entering it, r of the flagged slots entering i, then, for a flagged tile,
  // tile i = Ub b_i + Ur r (a flagged slot may enter a block whose tile is not flagged: the
  // camera skip leaves hidden tiles unwritten but every r current). A tile flag of
  // kPaddingSourcesOnly writes only the tile's samples that atlas padding copies (the camera
  // skip's hidden padding neighbours): the operator rows of the other samples are masked, the
  // rest computed as in the whole tile. The results are bit-identical to evaluate()'s; nothing
  // is allocated.
  static constexpr std::uint8_t kPaddingSourcesOnly = 2;
  void compute_b(std::span<const float> ld, std::span<const std::uint8_t> blocks);
  void compute_r_and_tiles(std::span<const std::uint8_t> slots, std::span<const std::uint8_t> tiles,
                           std::span<float> lightmap);
  // fill_atlas for chosen blocks (the camera skip, staged_backend.h): the sample texels of the
  // blocks `tiles` flags, then the padding records of the blocks `rects` flags (`padding`:
  // core's atlas_block_padding of this level). The other texels keep their values.
  void fill_atlas_blocks(std::span<const float> lightmap, std::span<float> atlas,
                         std::span<const std::uint8_t> tiles, std::span<const std::uint8_t> rects,
                         const AtlasBlockPadding& padding) const;
  // compute_probes for the flagged blocks only (the others keep their probes).
  void compute_probes(std::span<const std::uint8_t> blocks, std::span<float> probes);

  // Multi-bounce feedback. set_albedo() validates the albedo (3 x samples), clamps it to
  // max_albedo (as core's prepare_feedback) and stores it. multi_bounce_step() is one
  // feedback iteration reusing the previous frame's lightmap, as a game does once per frame:
  //   ld = ld_direct + rho * min(max(lightmap, 0), max(ld_direct) / (1 - max rho)),
  //   then evaluate(ld, lightmap). lightmap is read and overwritten.
  // Starting from evaluate(ld_direct, lightmap), k steps equal level_multi_bounce after k
  // iterations. `value_clamped` (optional) reports whether the energy bound clamped.
  Status set_albedo(std::span<const float> albedo, float max_albedo = kDefaultMaxAlbedo);
  Status multi_bounce_step(std::span<const float> ld_direct, std::span<float> lightmap,
                           bool* value_clamped = nullptr);

  // Step 6: lightmap into the padded atlas (sizes().atlas floats) with padding filled;
  // texels outside every tile are zero. Fails on wrong sizes.
  Status fill_atlas(std::span<const float> lightmap, std::span<float> atlas) const;

  // Step 9: volume probes (SH9 radiance, sizes().probes floats) from the b and r of the last
  // evaluate(): Ubvol b per block plus the probe response of every slot's r.
  Status compute_probes(std::span<float> probes) const;

  // Step 9, vector irradiance (MRT §6.4; level_compute_vector_irradiance's layout,
  // sizes().vector_lightmap floats) from the b and r of the last evaluate(): Ub_vec b per
  // block, then each slot's turned Ur_vec r scattered through its four-row map (row 4 t + i
  // of the response -> coefficient i of the sample that dead-end row t lands on). Fails when
  // has_vector_irradiance() is false.
  Status compute_vector_irradiance(std::span<float> vector_lightmap) const;
  bool has_vector_irradiance() const { return vector_ready_; }

  // Skipping (CpuSkipOptions). set_skip_options() fails on invalid values (negative, NaN,
  // record_epsilon > 1) and otherwise makes the next evaluate() compute everything.
  Status set_skip_options(const CpuSkipOptions& skip);
  const CpuSkipOptions& skip_options() const { return skip_; }
  const CpuSkipStats& skip_stats() const { return stats_; }

  // The converged solve (core's reduced_feedback.h), twins of reference_reduced_rhs (c = P b0,
  // b0 = Td_b ld_direct as compute_b writes it, threaded over blocks) and
  // reference_apply_reduced_feedback (out = A_i x_i + sum of B_s r_s over the slots entering
  // block i, r = Tb->r x through this runtime's record operators, float or float16; threaded
  // over slots, then blocks). b0, c, x and out: sizes().b floats; r is this runtime's r.
  // Nothing is allocated.
  void reduced_rhs(const ReducedFeedback& op, std::span<const float> b0, std::span<float> c);
  void apply_reduced_feedback(const ReducedFeedback& op, std::span<const float> x, std::span<float> out);
  // The incremental solve's application (twin of reference_apply_reduced_feedback_delta): y +=
  // G d and r += Tb->r d (3 kr per slot), d read only in the flagged blocks; a record is read
  // only when its source block is flagged, a slot's B only when such a record enters it.
  // Threaded over slots, then blocks. Nothing is allocated.
  void apply_reduced_feedback_delta(const ReducedFeedback& op, std::span<const float> d,
                                    std::span<const std::uint8_t> blocks, std::span<float> y,
                                    std::span<float> r);
  // After the solve: b = b_new (sizes().b floats, the solve's b*) and r the last application's,
  // or `r` where given (the incremental solve's, ReducedSolver::r()): the b and r that
  // compute_r_and_tiles (with no slot flagged), compute_probes and compute_vector_irradiance read.
  void finish_reduced_solve(std::span<const float> b_new, std::span<const float> r = {});

  // b and r of the last evaluate() (interleaved, level_runtime.h layouts).
  std::span<const float> b() const { return b_; }
  std::span<const float> r() const { return r_; }

 private:
  CpuLevelRuntime() = default;
  // Runs f(index, thread) for index in [0, count) on the pool (or inline with one thread).
  template <class F>
  void parallel_for(std::size_t count, F& f) const;
  void compute_block_b(std::size_t i, std::span<const float> ld, int thread);
  // slots: flags (null: all); tile: 0 the slots' r only, 1 the whole tile, kPaddingSourcesOnly
  // the samples atlas padding reads.
  void compute_block_lightmap(std::size_t i, std::span<float> lightmap, const std::uint8_t* slots = nullptr,
                              std::uint8_t tile = 1);
  void build_padding_rows();  // padding_ub_rows_, padding_ur_rows_
  void compute_block_probes(std::size_t i, std::span<float> probes) const;
  std::span<const std::uint32_t> flagged(std::span<const std::uint8_t> flags);
  void skip_block_b(std::size_t i, std::span<const float> ld, int thread);
  void skip_block_lightmap(std::size_t i, std::span<float> lightmap, int thread);
  void finish_skip_stats();
  double record_weight(std::size_t rec, std::size_t src) const;

  // One operator as the kernels read it: f32 (borrowed) or f16 (in half_), the other null.
  struct OperatorRef {
    const float* f32 = nullptr;
    const std::uint16_t* f16 = nullptr;
  };
  struct ShapeRefs {
    OperatorRef td_b, ub, ubvol, ub_vec;
  };
  // The GEMV kernels of kernels.h on A (rows x cols, lda = cols), float or f16 by A's storage.
  void gemv(const OperatorRef& A, std::size_t rows, std::size_t cols, const float* planar, float* out,
            bool accumulate) const;
  void gemv_scatter(const OperatorRef& A, std::size_t rows, std::size_t cols, const std::int32_t* map,
                    const float* planar, float* out) const;
  void gemv_masked(const OperatorRef& A, std::size_t rows, std::size_t cols, const std::int32_t* map,
                   const float* planar, float* out) const;
  Status prepare_operators(OperatorStorage storage);

  const Level* level_ = nullptr;
  const Dictionary* dict_ = nullptr;
  OperatorStorage operators_ = OperatorStorage::float32;
  std::size_t operator_bytes_ = 0;
  std::vector<std::uint16_t> half_;      // float16: every operator, one after another
  std::vector<ShapeRefs> shape_ops_;     // per dictionary shape (null where no block uses it)
  std::vector<OperatorRef> record_ops_;  // per record: T
  std::vector<OperatorRef> probe_ops_;   // per face: probe_response (null where empty)
  std::vector<OperatorRef> vector_ops_;  // per face: vector_response (null where empty)
  OperatorRef ur_op_;
  Isa isa_ = Isa::scalar;
  int threads_ = 1;
  bool flush_denormals_ = true;
  std::unique_ptr<ThreadPool> pool_;  // null with one thread
  LevelBufferSizes sizes_;
  std::size_t max_block_samples_ = 0;
  std::vector<float> b_, b_planar_, r_, r_planar_, ld_planar_;
  // Per block, its modes (block_kb): b_ keeps level.kb floats a channel a block, a block's
  // planar copy (b_planar_, x_planar_) has channel stride block_kb_[i] inside that space.
  std::vector<std::uint32_t> block_kb_;
  std::vector<float> x_planar_;  // apply_reduced_feedback's planar x
  // apply_reduced_feedback_delta: Tb->r d, and per slot whether a flagged record entered it.
  std::vector<float> r_delta_;
  std::vector<std::uint8_t> slot_touched_;
  std::vector<float> rho_, ld_feedback_;
  // CSR schedules: records of slot s are slot_records_[slot_record_begin_[s] ..
  // slot_record_begin_[s + 1]); slots entering block i likewise in block_slots_.
  std::vector<std::uint32_t> slot_record_begin_, slot_records_, block_slot_begin_, block_slots_;
  std::vector<std::uint32_t> work_items_;  // the flagged indices of a stage call (blocks capacity)
  // Row masks of the samples atlas padding copies (a padding record's source): per level sample
  // its block-local index or -1 (Ub's rows, by block sample_offset), and per slot and Ur row its
  // ur_row_to_sample entry or -1.
  std::vector<std::int32_t> padding_ub_rows_, padding_ur_rows_;

  // Skipping state (all sized by create()). Per block: what phase 1 did (BlockAction), whether
  // b changed, beta_i, ||b_i||_F, the tile's bound and whether it was written, the ld that
  // produced b (ld_ref_, 3 x samples) and its max. Per slot: whether r changed, rho_s, records
  // computed and skipped, whether r was reused. Per thread: b and r scratch.
  CpuSkipOptions skip_;
  CpuSkipStats stats_;
  bool skip_state_valid_ = false;  // false: the next evaluate() computes everything
  const float* last_lightmap_ = nullptr;
  // Norms for the bounds (CpuSkipOptions): per shape ||Ub Td_b||_2, ||D Td_b||_2 and D (kb);
  // per record ||T||_F and ||T D^-1||_F (D of the source's shape); ||Ur||_2.
  std::vector<double> shape_ub_td_norm_, shape_d_td_norm_, shape_d_, record_norm_, record_d_norm_;
  double ur_norm_ = 0.0;
  std::vector<std::uint8_t> block_action_, b_changed_, tile_written_, r_changed_, slot_kept_;
  std::vector<double> ld_delta_, b_norm_, b_d_norm_, tile_bound_, slot_rho_;
  std::vector<std::uint32_t> slot_records_computed_, slot_records_skipped_;
  std::vector<float> ld_ref_, ld_ref_max_, b_scratch_, r_scratch_;
  std::vector<float> self_lightmap_;      // Ub b per block (lightmap layout), sized when skipping is on
  std::vector<float> slot_contribution_;  // Ur r per slot (3 x Ur rows, unmapped rows unused), likewise
  std::vector<double> slot_drift_;        // (e) ||r_s kept - r_s computed||_F
  std::vector<std::uint8_t> slot_close_;
  float rho_max_ = 0.0f;
  bool has_albedo_ = false;
  // Vector irradiance: per slot, 4 x (Ur rows) entries mapping response row 4 t + i to
  // vector-lightmap row 4 sample + i of the slot's block (-1: face missing); stride vector_rows_.
  std::vector<std::int32_t> vector_row_map_;
  std::size_t vector_rows_ = 0;
  bool vector_ready_ = false;  // check_level_vector_operators passed (also with no slots)
};

}  // namespace modrt::cpu
