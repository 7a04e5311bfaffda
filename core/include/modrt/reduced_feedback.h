// SPDX-License-Identifier: MIT
// modrt — converged multi-bounce in the reduced space (issue 20, docs/accuracy.md "Converged
// multi-bounce").
//
// The n-space feedback (reference_runtime.h, MRT §7.3) evaluates the whole lightmap per bounce:
// ld = ld_direct + rho L, b = Td_b ld, L = Ub b + Ur r. With the albedo fixed, one bounce is
// linear in b alone:
//   b <- b0 + M b,   M b = A_i b_i + sum over the slots s entering block i of B_s r_s,   r = Tb->r b
// per block i, where b0 = Td_b ld_direct and, per channel c,
//   A_i = Td_b diag(rho_c) Ub          (kb x kb, block i's own light fed back)
//   B_s = Td_b diag(rho_c) Ur(turned)  (kb x kr, the light that entered through slot s fed back)
// built once when the albedo is set (kb: the block's own modes, block_kb; the unknowns keep
// the level's kb per block, zero past them). A bounce then costs O(kb^2 + kb kr) per block
// instead of O(n kb), and the converged answer b* = (I - M)^-1 b0 is reached every frame by iterating
// from the last frame's b* (ReducedSolver).
//
// The solve (block Jacobi): most of a bounce's light stays in its block (A), so each block's
// own bounces are solved exactly, P_i = (I - s A_i)^-1 (kb x kb per channel, at build), and the
// iteration runs only over the light crossing interfaces:
//   b <- c + G b,   c = P b0,   G b = sum over the slots s entering block i of P_i s B_s r_s
// whose fixed point is that of b <- b0 + s M b. Its contraction (the spectral radius of G) is far
// below M's when blocks are weakly coupled (the 11-block test maze: 0.65 -> 0.41), so a frame takes a few
// applications of G, each one pass over the Tb->r records plus kb x kr per slot.
//
// Convergence is guaranteed by a stated rule, checked when the albedo is set: the spectral
// radius q of M is estimated (power iteration); the physical operator has q <= max albedo < 1,
// but the low-rank operators can exceed it, so above kReducedMaxSpectralRadius M is damped,
// s = kReducedMaxSpectralRadius / q. Then G's radius is estimated too; block Jacobi is used when
// it is below kReducedMaxSpectralRadius and below s q (it is for every level tested), else
// the plain iteration b <- b0 + s M b (G = s M, P = I) whose radius is s q by construction.
//
// Clamping: n-space feedback feeds back min(max(L, 0), bound); the reduced solve feeds back the
// unclamped Ub b + Ur r (it never forms L). The two agree wherever no texel of the fed-back
// lightmaps was negative or at the bound; the lightmap written from b* is clamped at 0 like every
// lightmap (reference_runtime.h's policy), so outputs are never negative.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/drt.h"
#include "modrt/feedback_policy.h"
#include "modrt/level.h"
#include "modrt/level_dirty.h"
#include "modrt/status.h"

namespace modrt {

// Above this estimated spectral radius the reduced feedback is damped to it (header).
inline constexpr double kReducedMaxSpectralRadius = 0.98;

// A matrix with one coefficient per channel: data[3 (r cols + k) + c] is row r, column k,
// channel c (out[3 r + c] = sum_k data[3 (r cols + k) + c] in[3 k + c]).
struct ChannelMatrix {
  std::uint32_t rows = 0, cols = 0;
  std::vector<float> data;  // 3 rows cols
};

// out[3 r + c] (+)= sum_k M(r, k, c) in[3 k + c], accumulated in double (the scalar reference).
void reference_gemv_channels(const ChannelMatrix& M, const float* in, float* out, bool accumulate);

// The clutter's part of the converged solve (DRT, docs/drt.md "Multi-bounce"): the unknowns
// grow by c (3 per clutter face, after b's) and one bounce is
//   b <- b0 + M b + Td_b diag(rho) (dUb b + dUc c)   (the DRT deltas fed back with the lightmap)
//   c <- c0 + Td_c diag(rho_c) (Cb b + Cc c)          (the clutter's indirect light fed back)
// with c0 = Td_c clutter_ld (drt_multi_bounce's fixed point without its clamps). Applied
// matrix-free from the DRT operators, which reach few samples, with Td_b's column at each of
// them times its albedo (w); in the block Jacobi iteration the b part goes through P as well.
struct ReducedClutter {
  const DrtOperators* drt = nullptr;  // null: no clutter (every member empty)
  std::size_t c_unknowns = 0;         // 3 per clutter face
  std::vector<float> rho_c;           // clamped, 3 per clutter texel; empty: not fed back
  // The level samples dUb / dUc rows reach (ascending), their blocks, and per level sample its
  // index among them (-1: none); w: 3 kb per such sample, w[3 k + ch] = Td_b(k, local) rho(ch).
  std::vector<std::uint32_t> samples, sample_block;
  std::vector<std::int32_t> position;
  std::vector<float> w;
  float scale = 1.0f;  // the damping s (1 while M's radius is estimated)
};

// The clutter application's scratch: delta (a lightmap, 3 per level sample, of which the
// reached samples are used), indirect (3 per clutter texel), t (3 kb per block, 3 kb more).
// allocate() sizes it; the applications allocate nothing of their own.
struct ReducedClutterScratch {
  std::vector<float> delta, indirect, t;
  void allocate(const Level& level, std::uint32_t kb, const DrtOperators& drt);
};

struct ReducedFeedback {
  std::uint32_t kb = 0, kr = 0;
  bool block_jacobi = true;  // false: the plain iteration (header)
  // The iteration b <- c + G b with c = P b0 and
  //   G b = A_i b_i + sum over the slots s entering block i of B_s r_s,  r = Tb->r b:
  // block Jacobi: P per block = (I - s A_i)^-1, A empty, B_s = P_i s B_s (kb x kr);
  // plain: P empty (c = b0), A_i = s A_i (kb x kb), B_s = s B_s.
  std::vector<ChannelMatrix> P, A, B;
  double spectral_radius = 0.0;  // estimated for M (before damping), largest over the channels
  float damping = 1.0f;          // s
  double contraction = 0.0;      // estimated spectral radius of G (<= kReducedMaxSpectralRadius)
  ReducedClutter clutter;        // DRT (empty without clutter): unknowns() = b's + clutter.c_unknowns
  std::size_t unknowns(const Level& level) const {
    return 3 * std::size_t(kb) * level.blocks.size() + clutter.c_unknowns;
  }
};

// The clutter the reduced solve includes: `drt`, or none for operators that gather the real
// radiance (DrtObjectOperators::has_gather: their terms read ld and the clutter's light, which
// the unknowns b and c do not carry; the converged update then takes kGatherConvergedSteps
// feedback steps with the clutter after the solve, drt.h).
const DrtOperators* reduced_solve_clutter(const DrtOperators* drt);

// Builds the operators from the clamped albedo rho (3 x samples, validated: finite, in [0, 1))
// in double (per-face products where rho is constant per face), stores float, and estimates
// the radii (header) by 24 power iterations each through `apply`
// (out = G x of the operator given; empty: reference_apply_reduced_feedback), so that a backend
// estimates with its own kernels and threads. The level must be checked against dict
// (check_level_operators). Allocates. Fails (non_finite) when an estimate is not finite.
using ReducedApply =
    std::function<void(const ReducedFeedback& op, std::span<const float> x, std::span<float> out)>;
// With `drt` (checked against the level, check_drt_operators) the clutter's part too (rho_c:
// the clamped clutter albedo, 3 per clutter texel, or empty), in the radii as well.
Result<ReducedFeedback> build_reduced_feedback(const Level& level, const Dictionary& dict,
                                               const LevelDependencies& deps, std::span<const float> rho,
                                               const ReducedApply& apply = {},
                                               const DrtOperators* drt = nullptr,
                                               std::span<const float> rho_c = {});

// c = P b0 (c = b0 for the plain iteration), 3 kb per block.
void reference_reduced_rhs(const Level& level, const ReducedFeedback& op, std::span<const float> b0,
                           std::span<float> c);
// out = G x (3 kb per block), with r = Tb->r x written to r_scratch (3 kr per slot). Of the
// b part only: x and out may be longer (the clutter's c after b), the rest is not touched.
void reference_apply_reduced_feedback(const Level& level, const LevelDependencies& deps,
                                      const ReducedFeedback& op, std::span<const float> x,
                                      std::span<float> r_scratch, std::span<float> out);
// The incremental solve's application (ReducedSolver::solve_incremental): y += G d and
// r += Tb->r d with d read only in the flagged blocks (the others count as 0); r_delta receives
// Tb->r d (3 kr per slot). Of the b part only. Allocates.
void reference_apply_reduced_feedback_delta(const Level& level, const LevelDependencies& deps,
                                            const ReducedFeedback& op, std::span<const float> delta,
                                            std::span<const std::uint8_t> blocks, std::span<float> y,
                                            std::span<float> r, std::span<float> r_delta);
// The clutter's terms of G (op.clutter not empty), x and out of op.unknowns(level) floats, b
// then c: out's b part (holding the b part of G x) gains P s Td_b diag(rho) (dUb b + dUc c)
// (s Td_b ... for the plain iteration), its c part becomes s Td_c diag(rho_c) (Cb b + Cc c).
// The reference computes the DRT terms with drt.h's functions (which allocate per call);
void reference_apply_reduced_clutter(const Level& level, const ReducedFeedback& op, std::span<const float> x,
                                     std::span<float> out, ReducedClutterScratch& scratch);
// a backend with its own DRT kernels zeroes the reached samples of scratch.delta
// (reduced_clutter_clear), adds dUb b + dUc c into it and writes Cb b + Cc c into
// scratch.indirect, then calls reduced_clutter_feedback for the rest (allocates nothing).
void reduced_clutter_clear(const ReducedFeedback& op, ReducedClutterScratch& scratch);
// Before a solve with clutter (op.clutter not empty; else nothing): the c part of rhs (after the
// nb of b) is c0 = Td_c clutter_ld, and of x too when not warm.
void reduced_clutter_start(const ReducedFeedback& op, std::size_t nb, std::span<const float> c0,
                           std::span<float> x, std::span<float> rhs, bool warm);
void reduced_clutter_feedback(const Level& level, const ReducedFeedback& op, ReducedClutterScratch& scratch,
                              std::span<float> out);

struct ReducedSolveSettings {
  // Stop when the remaining error of b, estimated from the last step and the contraction q as
  // step q / (1 - q), is at most tolerance x max |b|.
  float tolerance = 1e-3f;
  int max_iterations = 256;
  // The warm start's memory (ReducedSolver): the last `history` solves' (rhs, solution) pairs;
  // 0: the last solution moved by the change of rhs only.
  int history = 4;
  // The incremental solve (ReducedSolver::solve_incremental) where the backend applies G to a
  // part of the blocks: each pass applies G only to the blocks whose change still exceeds the
  // stopping rule's threshold. Same stopping rule and error bound; false: every block each pass.
  bool incremental = true;
  // Every this many incremental solves, G x is recomputed whole (no float drift accumulates).
  int refresh_interval = 64;
};

struct ReducedSolveReport {
  int iterations = 0;      // applications of M
  bool converged = false;  // the tolerance was met (else max_iterations ran)
  float residual = 0.0f;   // max |b0 + s M b - b| / max |b| at the last b before its step
  // residual q / (1 - q): the estimated relative error of b (the incremental solve: residual /
  // (1 - q), the error of the iterate its r comes from, ReducedSolver)
  float error_bound = 0.0f;
  // false: a GPU solve that ran its a-priori iteration count (reduced_solve_iterations) without
  // reading the residual back; residual and error_bound then hold that count's bound q^k, and
  // converged says whether the count was within max_iterations.
  bool measured = true;
  // Blocks G was applied to over the solve's passes (iterations x blocks for the full
  // iteration; fewer for the incremental one, whose refresh counts every block once).
  std::uint64_t blocks_applied = 0;
};

// The iterations after which a solve started from b0 is within `tolerance` of b*, a priori:
// the error after k steps is about q^k |b* - b0| <= q^k |b*| (0 <= b0 <= b* where the operators
// are non-negative, as the physical ones are), so k = ceil(log tolerance / log q), at least 1. For a
// solve that cannot check its residual every step (the GLES passes read nothing back);
// max_iterations caps it (then the bound is not met).
int reduced_solve_iterations(double contraction, float tolerance, int max_iterations);

// The fixed-point iteration of the converged solve, stated once for every backend: a backend
// writes c = P b0 into rhs() and supplies `apply(x, out)` (out = G x, its kernels and threads);
// the solver does the rest (the update, the residual, the stopping rule). x holds the warm start
// on entry (the last frame's b*, or b0) and b* on return. create() allocates; solve() does not.
//
// The warm start: the system is linear and separate per channel, so a right-hand side in the
// span of earlier ones, rhs = sum_k a_k rhs_k, has the solution sum_k a_k x_k. Each warm solve
// starts from the least-squares combination of the last `history` pairs (per channel) plus the
// part of rhs they do not explain (the first term of (I - G)^-1 of it, at no cost): a light
// that dims or brightens is solved at once, one that moves along a path nearly so.
//
// The incremental solve (solve_incremental) keeps, across solves, the iterate x_a that G was last
// applied to and y = G x_a; a pass sets x = rhs + y and applies G only to the change d = x - x_a of
// the blocks where max |d| exceeds the threshold t = tolerance (1 - q) max |x|: y += G d, x_a = x
// there. Since x = rhs + G x_a and b* = rhs + G b*, x - b* = G (x_a - x) + G (x - b*), so
// |x - b*| <= q / (1 - q) max |x - x_a| (the full iteration's bound with its step) and
// |x_a - b*| <= max |x - x_a| / (1 - q). The solve stops when every block's change is at most t:
// b* (x) is then within q tolerance max |x| and the r the tiles read (Tb->r x_a) is Tb->r of a
// vector within tolerance max |x| of b*. A frame whose rhs changed in a few blocks applies G
// around them only; an unchanged rhs applies nothing.
class ReducedSolver {
 public:
  static constexpr int kMaxHistory = 8;
  // block_floats: the unknowns per block (3 kb) for the incremental solve and blocks_applied; the
  // unknowns after the last whole block (the clutter's c) are one block more. 0: one block.
  // r_floats: the incremental solve's r (3 kr per slot).
  static ReducedSolver create(std::size_t unknowns, int history = ReducedSolveSettings{}.history,
                              std::size_t block_floats = 0, std::size_t r_floats = 0) {
    ReducedSolver s;
    s.next_.assign(unknowns, 0.0f);
    s.rhs_.assign(unknowns, 0.0f);
    s.capacity_ = history < 1 ? 1 : (history > kMaxHistory ? kMaxHistory : history);
    s.history_rhs_.assign(unknowns * std::size_t(s.capacity_), 0.0f);
    s.history_x_.assign(unknowns * std::size_t(s.capacity_), 0.0f);
    s.block_floats_ = block_floats == 0 || block_floats > unknowns ? (unknowns ? unknowns : 1) : block_floats;
    const std::size_t blocks = (unknowns + s.block_floats_ - 1) / s.block_floats_;
    s.applied_.assign(unknowns, 0.0f);
    s.delta_.assign(unknowns, 0.0f);
    s.flags_.assign(blocks, 0);
    s.all_.assign(blocks, 1);
    s.r_.assign(r_floats, 0.0f);
    s.history_y_.assign(unknowns * std::size_t(s.capacity_), 0.0f);
    s.history_r_.assign(r_floats * std::size_t(s.capacity_), 0.0f);
    return s;
  }
  // The incremental solve's r = Tb->r x_a (the r the tiles read after it).
  std::span<const float> r() const { return r_; }
  std::size_t unknowns() const { return next_.size(); }
  std::size_t blocks() const { return flags_.size(); }
  std::span<float> rhs() { return rhs_; }

  // Iterates x <- rhs() + G x. With `warm` (x is the last solve's solution for the last rhs),
  // x first becomes the prediction from the history (class comment); without, the history is
  // forgotten (the operator changed) and x is used as it is.
  template <class Apply>
  ReducedSolveReport solve(Apply&& apply, std::span<float> x, double contraction,
                           const ReducedSolveSettings& settings, bool warm = false) {
    ReducedSolveReport report;
    predict(x, warm, settings.history);
    const double q = contraction < 1e-12 ? 1e-12 : contraction;
    const double tail = q / (1.0 - q);  // remaining error per unit of step (geometric tail)
    for (int it = 1; it <= settings.max_iterations; ++it) {
      apply(std::span<const float>(x), std::span<float>(next_));
      const Step st = step(x);
      report.iterations = it;
      report.residual = float(st.largest > 0.0 ? st.change / st.largest : 0.0);
      report.error_bound = float(report.residual * tail);
      if (st.change * tail <= double(settings.tolerance) * st.largest) {
        report.converged = true;
        break;
      }
    }
    report.blocks_applied = std::uint64_t(report.iterations) * blocks();
    remember(x);
    incremental_solves_ = -1;  // next_ no longer holds G x_a, nor the history the incremental state
    return report;
  }

  // The incremental solve (class comment). apply_delta(d, blocks, y, r) adds G d to y and
  // Tb->r d to r (r(): 3 kr per slot) reading d only in the blocks flagged in `blocks`. warm
  // false (another operator, or after a full solve) starts from x_a = 0; a warm solve starts from
  // the history's prediction (the least-squares combination of the last settings.history
  // solves' rhs, per channel, applied to their x_a, G x_a and r alike, so y = G x_a and r =
  // Tb->r x_a still hold); every settings.refresh_interval solves y and r are recomputed from
  // x_a whole. x receives b* (its content on entry is not read). Allocates nothing.
  template <class ApplyDelta>
  ReducedSolveReport solve_incremental(ApplyDelta&& apply_delta, std::span<float> x, double contraction,
                                       const ReducedSolveSettings& settings, bool warm) {
    ReducedSolveReport report;
    const double q = contraction < 1e-12 ? 1e-12 : contraction;
    const double per_change = 1.0 / (1.0 - q);  // |x_a - b*| per unit of max |x - x_a|
    if (!warm || incremental_solves_ < 0) {
      std::fill(applied_.begin(), applied_.end(), 0.0f);
      std::fill(next_.begin(), next_.end(), 0.0f);
      std::fill(r_.begin(), r_.end(), 0.0f);
      count_ = 0, incremental_solves_ = 0;
    } else if (incremental_solves_ >= settings.refresh_interval) {
      std::fill(next_.begin(), next_.end(), 0.0f);
      std::fill(r_.begin(), r_.end(), 0.0f);
      apply_delta(std::span<const float>(applied_), std::span<const std::uint8_t>(all_),
                  std::span<float>(next_), std::span<float>(r_));
      report.blocks_applied += blocks();
      incremental_solves_ = 0;
    } else if (settings.history > 0) {
      predict_state(settings.history);
    }
    for (int pass = 0;; ++pass) {
      const Step st = incremental_step(x);
      report.residual = float(st.largest > 0.0 ? st.change / st.largest : 0.0);
      report.error_bound = float(report.residual * per_change);
      if (st.change * per_change <= double(settings.tolerance) * st.largest) {
        report.converged = true;
        break;
      }
      if (pass == settings.max_iterations) break;
      report.blocks_applied += flag_changed(double(settings.tolerance) * st.largest / per_change);
      apply_delta(std::span<const float>(delta_), std::span<const std::uint8_t>(flags_),
                  std::span<float>(next_), std::span<float>(r_));
      take_flagged(x);
      report.iterations = pass + 1;
    }
    remember_state();
    ++incremental_solves_;
    return report;
  }

 private:
  struct Step {
    double change = 0.0, largest = 0.0;  // max |x_new - x|, max |x_new|
  };
  // x <- rhs + next (next = G x), the largest change and value.
  Step step(std::span<float> x);
  // The warm start (class comment); history 0: x += rhs - rhs_last.
  void predict(std::span<float> x, bool warm, int history);
  // Keeps (rhs, x) as the newest pair.
  void remember(std::span<const float> x);
  // The least-squares coefficients of rhs ~ sum_k a_k rhs_k over the newest k_max pairs of
  // channel c (normal equations, a small ridge); false where the channel has no light or the
  // system is singular.
  bool history_coefficients(std::size_t c, int k_max, double* a) const;
  std::size_t history_slot(int age, std::size_t n) const {  // age 0: the newest pair
    return std::size_t((head_ - 1 - age + 2 * capacity_) % capacity_) * n;
  }
  // The incremental solve's warm start: applied_, next_ and r_ = the history's combination.
  void predict_state(int history);
  // Keeps (rhs, applied, next, r) as the newest entry.
  void remember_state();
  // The incremental solve's pass: x = rhs + next, delta = x - applied, the largest change, value.
  Step incremental_step(std::span<float> x);
  // flags = the blocks whose largest |delta| exceeds threshold; returns their count.
  std::size_t flag_changed(double threshold);
  // applied = x in the flagged blocks.
  void take_flagged(std::span<const float> x);
  std::vector<float> next_, rhs_;
  // The incremental solve: x_a (applied_), next_ = G x_a while incremental_solves_ >= 0 (the
  // solves since the last refresh), the change and the block flags of a pass, every block flagged.
  std::vector<float> applied_, delta_, r_;
  std::vector<float> history_y_, history_r_;  // with history_x_ (x_a) and history_rhs_: the ring
  std::vector<std::uint8_t> flags_, all_;
  std::size_t block_floats_ = 1;
  int incremental_solves_ = -1;
  std::vector<float> history_rhs_, history_x_;  // capacity_ pairs, a ring; newest at head_ - 1
  int capacity_ = 1, count_ = 0, head_ = 0;
};

struct ConvergedBounceSettings {
  float max_albedo = kDefaultMaxAlbedo;  // the feedback's albedo clamp (feedback_policy.h)
  ReducedSolveSettings solve;
};

struct ConvergedBounceReport {
  ReducedSolveReport solve;
  double spectral_radius = 0.0;  // ReducedFeedback's estimates
  float damping = 1.0f;
  double contraction = 0.0;
  bool block_jacobi = true;
  bool albedo_clamped = false;
};

// The converged multi-bounce of a level from a cold start (x = b0), the scalar oracle of the
// backends' converged solve: validates ld_direct and albedo, clamps the albedo, builds the
// reduced feedback, solves, and writes b*, r (the last application's: Tb->r of the iterate
// before b*, within the tolerance of Tb->r b*; staged_backend.h's stage_solve) and the lightmap
// (clamped at 0) from them. Allocates per call.
Result<ConvergedBounceReport> level_converged_bounce(const Level& level, const Dictionary& dict,
                                                     std::span<const float> ld_direct,
                                                     std::span<const float> albedo,
                                                     const ConvergedBounceSettings& settings,
                                                     std::span<float> b, std::span<float> r,
                                                     std::span<float> lightmap);

// The converged multi-bounce with clutter from a cold start, the oracle of the backends'
// update_converged with clutter: drt_multi_bounce's fixed point (without its clamps) in the
// reduced space, b* and c* (3 per clutter face), r of the last application, and the lightmap
// Ub b* + Ur r + dUb b* + dUc c* clamped at 0. clutter_albedo may be empty (c* = Td_c clutter_ld).
// With gather operators (reduced_solve_clutter): the level's solve without the clutter, its
// evaluation with the clutter's deltas (x_s = ld_direct, x_t = clutter_ld), then
// kGatherConvergedSteps steps of drt_multi_bounce from it; last_ld and last_clutter_radiance
// (when not empty) receive the last evaluation's x_s and x_t (ld_direct and clutter_ld without
// the gather), the inputs of drt_evaluate_clutter_lightmap. Allocates per call.
Result<ConvergedBounceReport> drt_converged_bounce(
    const Level& level, const Dictionary& dict, const DrtOperators& drt, std::span<const float> ld_direct,
    std::span<const float> albedo, std::span<const float> clutter_ld, std::span<const float> clutter_albedo,
    const ConvergedBounceSettings& settings, std::span<float> b, std::span<float> r,
    std::span<float> lightmap, std::span<float> c, std::span<float> last_ld = {},
    std::span<float> last_clutter_radiance = {});

}  // namespace modrt
