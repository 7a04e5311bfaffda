// modrt::cpu — the SIMD CPU runtime for a whole level (SPEC §5 steps 2–6, 8 and 9).
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
// Operators are not copied: they are read in place, row-major, from the Level and the
// Dictionary, which the runtime borrows and which must outlive it and stay unchanged.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "modrt/cpu/isa.h"
#include "modrt/level.h"
#include "modrt/level_runtime.h"
#include "modrt/status.h"

namespace modrt::cpu {

class ThreadPool;  // src/thread_pool.h

struct CpuRuntimeOptions {
  std::optional<Isa> isa;  // none: active_isa(); an unsupported ISA makes create() fail
  int threads = 1;         // threads working on a frame, the caller included (1 to 256)
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
  int threads() const { return threads_; }
  // Sizes of ld, lightmap, atlas and probes (and of the b, r this runtime holds).
  const LevelBufferSizes& sizes() const { return sizes_; }

  // Steps 2–5: b = Td_b ld, r = Tb->r b, lightmap = Ub b + Ur r. ld and lightmap hold
  // sizes().ld / sizes().lightmap floats. Fails (non_finite / invalid_argument, naming the
  // sample and channel) on NaN, Inf or negative ld, and on wrong sizes; then nothing is written.
  Status evaluate(std::span<const float> ld, std::span<float> lightmap);

  // Multi-bounce feedback. set_albedo() validates the albedo (3 x samples), clamps it to
  // max_albedo (as core's prepare_feedback) and stores it. multi_bounce_step() is one
  // feedback iteration reusing the previous frame's lightmap, as a game does once per frame:
  //   ld = ld_direct + rho * min(max(lightmap, 0), max(ld_direct) / (1 - max rho)),
  //   then evaluate(ld, lightmap). lightmap is read and overwritten.
  // Starting from evaluate(ld_direct, lightmap), k steps equal level_multi_bounce after k
  // iterations. `value_clamped` (optional) reports whether the energy bound clamped.
  Status set_albedo(std::span<const float> albedo, float max_albedo = 0.95f);
  Status multi_bounce_step(std::span<const float> ld_direct, std::span<float> lightmap,
                           bool* value_clamped = nullptr);

  // Step 6: lightmap into the padded atlas (sizes().atlas floats) with padding filled;
  // texels outside every tile are zero. Fails on wrong sizes.
  Status fill_atlas(std::span<const float> lightmap, std::span<float> atlas) const;

  // Step 9: volume probes (SH9 radiance, sizes().probes floats) from the b and r of the last
  // evaluate(): Ubvol b per block plus the probe response of every slot's r.
  Status compute_probes(std::span<float> probes) const;

  // b and r of the last evaluate() (interleaved, level_runtime.h layouts).
  std::span<const float> b() const { return b_; }
  std::span<const float> r() const { return r_; }

 private:
  CpuLevelRuntime() = default;
  // Runs f(index, thread) for index in [0, count) on the pool (or inline with one thread).
  template <class F>
  void parallel_for(std::size_t count, F& f) const;
  void compute_block_b(std::size_t i, std::span<const float> ld, int thread);
  void compute_block_lightmap(std::size_t i, std::span<float> lightmap);

  const Level* level_ = nullptr;
  const Dictionary* dict_ = nullptr;
  Isa isa_ = Isa::scalar;
  int threads_ = 1;
  std::unique_ptr<ThreadPool> pool_;  // null with one thread
  LevelBufferSizes sizes_;
  std::size_t max_block_samples_ = 0;
  std::vector<float> b_, b_planar_, r_, r_planar_, ld_planar_;
  std::vector<float> rho_, ld_feedback_;
  // CSR schedules: records of slot s are slot_records_[slot_record_begin_[s] ..
  // slot_record_begin_[s + 1]); slots entering block i likewise in block_slots_.
  std::vector<std::uint32_t> slot_record_begin_, slot_records_, block_slot_begin_, block_slots_;
  float rho_max_ = 0.0f;
  bool has_albedo_ = false;
};

}  // namespace modrt::cpu
