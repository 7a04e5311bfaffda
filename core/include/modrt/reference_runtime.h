// SPDX-License-Identifier: MIT
// modrt — the scalar reference runtime for one block (architecture.md §5, MRT §7.3 steps 1–3, 8–9).
//
// This is the oracle every backend is checked against: plain loops in float with double
// accumulation, no SIMD, no skipping. RGB signals are interleaved per sample:
// ld[3*s + c]; b[3*k + c]; lightmap[3*s + c]; vector irradiance [3*(4*s + i) + c];
// probes [3*(9*p + j) + c]. Operators are scalar and applied per channel.
#pragma once

#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/feedback_policy.h"

namespace modrt {

// The largest light value (ld, albedo) any runtime accepts. Transport multiplies ld by
// operators with entries up to ~1e3 and multi-bounce amplifies it by up to 1 / (1 - 0.95), so
// 1e30 keeps every intermediate far below float's 3.4e38: a lightmap never overflows to Inf
// (and Inf - Inf to NaN) from finite input. Brighter scenes are rescaled by the caller.
inline constexpr float kMaxLightValue = 1e30f;

// The lightmap policy (issue 18): a lightmap texel is E_ind / pi, never negative, but the
// low-rank operators ring below 0 around a spike in ld. Every lightmap a runtime outputs (core,
// the CPU runtime on every ISA, the GLES atlas pass; with DRT, again after its delta, see
// drt_apply) is
// clamped by max(lightmap, 0), the clamp multi-bounce feedback already applied before its
// energy bound (apply_feedback uses this function). The atlas copies the clamped lightmap.
// Probes (radiance SH9) and vector irradiance (OHLSH) are coefficients, legitimately
// negative, and are not clamped; what is evaluated from them (the C API's probe sampler) is.
inline float nonnegative_light(float v) { return std::max(v, 0.0f); }
// lightmap[i] = nonnegative_light(lightmap[i]) for every float.
void clamp_lightmap(std::span<float> lightmap);

// Fails with non_finite (NaN/Inf) or invalid_argument (negative, above kMaxLightValue, wrong
// size), naming the first offending sample and channel. `what` prefixes the message (e.g. "ld").
Status validate_light_signal(std::span<const float> rgb, std::size_t samples, const char* what);

// b = Td_b ld (MRT eq. 3). ld: 3n, b: 3kb. Validates ld.
Status compute_b(const ShapeOperators& op, std::span<const float> ld, std::span<float> b);
// lightmap = clamp_lightmap(Ub b) (E_ind / pi at the samples). b: 3kb, lightmap: 3n.
void apply_Ub(const ShapeOperators& op, std::span<const float> b, std::span<float> lightmap);
// OHLSH vector irradiance = U_vec_b b. out: 3 * 4n.
void apply_Ub_vec(const ShapeOperators& op, std::span<const float> b, std::span<float> out);
// Volume probe radiance SH9 = Ubvol b. out: 3 * 9 g^3.
void apply_Ubvol(const ShapeOperators& op, std::span<const float> b, std::span<float> out);

struct MultiBounceSettings {
  int max_iterations = 200;
  float tolerance = 1e-6f;               // stop when max |b_{k+1} - b_k| <= tolerance * max |b_k|
  float max_albedo = kDefaultMaxAlbedo;  // albedo is clamped to this in the feedback, so the bounce
                                         // series is geometric with ratio <= max_albedo
};

struct MultiBounceReport {
  int iterations = 0;
  bool converged = false;
  bool albedo_clamped = false;  // some albedo exceeded max_albedo and was clamped
  bool value_clamped = false;   // some lightmap texel hit the energy bound and was clamped
  float energy_bound = 0.0f;    // max(ld_direct) / (1 - max albedo used): no texel exceeds it
};

// Building blocks shared by the block and level reference runtimes.
// out[3r + c] (+)= sum_k A(r, k) in[3k + c], accumulated in double.
void reference_gemv_rgb(const Matrix& A, const float* in, float* out, bool accumulate);

// The clamps of multi-bounce feedback, prepared once per solve.
struct FeedbackClamp {
  std::vector<float> rho;     // albedo clamped to settings.max_albedo
  float energy_bound = 0.0f;  // max(ld_direct) / (1 - max rho)
  bool albedo_clamped = false;
};
// Validates ld_direct and albedo (3 * samples each) and the settings.
Result<FeedbackClamp> prepare_feedback(std::span<const float> ld_direct, std::span<const float> albedo,
                                       std::size_t samples, const MultiBounceSettings& settings);
// ld = ld_direct + rho * min(max(lightmap, 0), energy_bound); true when the bound clamped.
bool apply_feedback(const FeedbackClamp& clamp, std::span<const float> ld_direct,
                    std::span<const float> lightmap, std::span<float> ld);
// max |b - b_prev| <= tolerance * max |b|.
bool feedback_converged(std::span<const float> b, std::span<const float> b_prev, float tolerance);

// Multi-bounce feedback ld = ld_direct + albedo * lightmap, b = Td_b ld, lightmap = Ub b,
// iterated to convergence. The feedback uses max(lightmap, 0) clamped to energy_bound (the
// maximum principle of a transport operator with row sums <= 1), so even an operator
// whose low-rank error pushes its spectral radius above 1 cannot diverge.
// ld_direct, albedo: 3n; b: 3kb; lightmap: 3n.
Result<MultiBounceReport> multi_bounce(const ShapeOperators& op, std::span<const float> ld_direct,
                                       std::span<const float> albedo, const MultiBounceSettings& settings,
                                       std::span<float> b, std::span<float> lightmap);

}  // namespace modrt
