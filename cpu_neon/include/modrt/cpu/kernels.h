// SPDX-License-Identifier: MIT
// modrt::cpu — the numeric kernels of the SIMD CPU backend (architecture.md §5 steps 2–6, 8).
//
// All kernels write into caller-provided buffers and never allocate. Each takes the ISA
// explicitly; an ISA that is not supported (isa_supported() is false) runs the scalar twin.
//
// RGB layouts:
//   interleaved: v[3 k + c] (c = 0, 1, 2 for R, G, B) — the level signals ld, b, r, lightmap.
//   planar:      v[c * stride + k] — three channel arrays of `stride` floats each (stride >= the
//                vector length). The GEMV kernels read their input planar so that one
//                contiguous vector load per channel feeds every row (deinterleave_rgb).
//
// GEMV strategy (documented because the accuracy contract depends on it): rows are taken
// four at a time; for each block of 8 (AVX2) or 4 (SSE4.1, NEON) columns the kernel loads
// the three planar channel vectors once and issues 12 FMAs (4 rows x 3 channels) into 12
// vector accumulators, so every matrix element is loaded once and used for all three
// channels. Column tails (cols not a multiple of the vector width) and row tails (rows not
// a multiple of 4) are handled without reading past the end of any array. The lanes are
// reduced pairwise (hadd), then the column tail is added. SIMD variants accumulate in
// float; the scalar twin accumulates in double, like core's reference_gemv_rgb.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>

#include "modrt/cpu/isa.h"
#include "modrt/level.h"

namespace modrt::cpu {

// planar[c * stride + k] = rgb[3 k + c] for k < n. stride >= n.
void deinterleave_rgb(const float* rgb, std::size_t n, float* planar, std::size_t stride);

// Floats of scratch gemv_rgb_interleaved needs for a matrix with `cols` columns.
constexpr std::size_t gemv_scratch_bound(std::size_t cols) { return 3 * cols; }

// out[3 r + c] (+)= sum_k A[r * lda + k] * planar[c * stride + k], r < rows, k < cols.
// A is row-major with leading dimension lda >= cols. accumulate: add to out, else overwrite.
void gemv_rgb(Isa isa, const float* A, std::size_t rows, std::size_t cols, std::size_t lda,
              const float* planar, std::size_t stride, float* out, bool accumulate);

// The same with an interleaved input in[3 k + c]; `scratch` holds gemv_scratch_bound(A.cols)
// floats (the planar copy of `in`).
void gemv_rgb_interleaved(Isa isa, const Matrix& A, const float* in, float* out, bool accumulate,
                          std::span<float> scratch);

// The Ur r scatter of one response slot (architecture.md §5 step 5): for every row r of A with
// row_to_sample[r] >= 0, out[3 row_to_sample[r] + c] += sum_k A[r * lda + k] planar[c * stride + k].
// Rows mapped to -1 (faces the destination block lacks) are skipped.
void gemv_rgb_scatter(Isa isa, const float* A, std::size_t rows, std::size_t cols, std::size_t lda,
                      const std::int32_t* row_to_sample, const float* planar, std::size_t stride, float* out);

// gemv_rgb_scatter split in two, for a caller that keeps each slot's contribution:
// gemv_rgb_masked stores, for every row r with row_to_sample[r] >= 0, the values the scatter
// would add at out[3 r + c] (other rows untouched); add_scattered then adds them:
// out[3 row_to_sample[r] + c] += values[3 r + c], rows in order. The two in sequence write the
// same bits as gemv_rgb_scatter.
void gemv_rgb_masked(Isa isa, const float* A, std::size_t rows, std::size_t cols, std::size_t lda,
                     const std::int32_t* row_to_sample, const float* planar, std::size_t stride, float* out);
void add_scattered(std::size_t rows, const std::int32_t* row_to_sample, const float* values, float* out);

// A matrix with one coefficient per channel (core's ChannelMatrix: M[3 (r cols + k) + c]) times
// an interleaved input: out[3 r + c] (+)= sum_k M[3 (r cols + k) + c] in[3 k + c]. The reduced
// feedback's A and B (reduced_feedback.h). SIMD variants accumulate each row in float (lanes
// keep one channel each); the scalar twin in double, as core's reference_gemv_channels.
void gemv_channels(Isa isa, const float* M, std::size_t rows, std::size_t cols, const float* in, float* out,
                   bool accumulate);

// ---- float16 operator storage (CpuRuntimeOptions::operators) ----
// A matrix may be stored as IEEE binary16 bits (std::uint16_t, same row-major layout, lda in
// elements). The _f16 kernels convert each element to float on load (exactly) and are
// otherwise the float kernels: same row/column blocking and tails, same float accumulation in
// 64-column blocks summed in double, same rounding of the outputs. So an _f16 kernel on A
// writes the bits its float twin of the same ISA writes for the float matrix half_to_float(A)
// (tests/test_cpu_kernels.cpp), and the scalar twin equals core's reference on those values.
// Conversion per ISA: AVX2 with F16C (_mm256_cvtph_ps), SSE4.1 in software (half_to_float),
// NEON vcvt_f32_f16, scalar half_to_float. Where F16C is missing (or set_f16c(false)), Isa::avx2
// runs the SSE4.1 variant, whose bits it then writes.
void gemv_rgb_f16(Isa isa, const std::uint16_t* A, std::size_t rows, std::size_t cols, std::size_t lda,
                  const float* planar, std::size_t stride, float* out, bool accumulate);
void gemv_rgb_scatter_f16(Isa isa, const std::uint16_t* A, std::size_t rows, std::size_t cols,
                          std::size_t lda, const std::int32_t* row_to_sample, const float* planar,
                          std::size_t stride, float* out);
void gemv_rgb_masked_f16(Isa isa, const std::uint16_t* A, std::size_t rows, std::size_t cols, std::size_t lda,
                         const std::int32_t* row_to_sample, const float* planar, std::size_t stride,
                         float* out);

// The largest finite binary16 value.
inline constexpr float kHalfMax = 65504.0f;

// The float value of binary16 bits `h` (every half is a float: exact; Inf and NaN kept).
float half_to_float(std::uint16_t h);

// Rounds v to the nearest binary16, ties to even (subnormal halves included) and stores the
// bits. Returns false, storing nothing, when |v| > kHalfMax or v is NaN: operators must fit
// the finite range (values in (65504, 65520) that round down to 65504 are refused as well).
bool float_to_half(float v, std::uint16_t* out);

// The same over `count` values. Returns the index of the first value refused (out[0..index)
// written), or count when all fit.
std::size_t float_to_half(const float* in, std::size_t count, std::uint16_t* out);

// Multi-bounce feedback over `count` floats (3 x samples, interleaved):
// ld[i] = ld_direct[i] + rho[i] * min(max(lightmap[i], 0), bound). Returns true when the bound
// clamped some value. Bit-identical to core's apply_feedback on every ISA (no FMA contraction).
bool feedback_rgb(Isa isa, const float* ld_direct, const float* rho, const float* lightmap, float bound,
                  float* ld, std::size_t count);

// v[i] = max(v[i], 0) for `count` floats: core's clamp_lightmap (the lightmap policy,
// reference_runtime.h), bit-identical on every ISA for finite input.
void clamp_nonnegative(Isa isa, float* v, std::size_t count);

// How far a signal moved from a reference (the skip tests of CpuLevelRuntime), over `count`
// floats with ld >= 0: max ld, max |ld - ref|, and upper bounds on sum ld^2 and on
// sum (ld - ref)^2 (the SIMD variants sum in float within 64-element blocks and into double
// across them; every variant scales the sums by 1 + 1e-5, far above that rounding, so they
// never fall below the exact sums).
struct SignalChange {
  float max = 0.0f, max_diff = 0.0f;
  double sum_sq = 0.0, sum_sq_diff = 0.0;
};
SignalChange signal_change(Isa isa, const float* ld, const float* ref, std::size_t count);

// True when all `count` floats are in [0, max_value] (-0 included; NaN and Inf fail): the
// fast path of light signal validation (max_value = kMaxLightValue); a false answer is then
// explained by core's validate_light_signal.
bool finite_nonnegative(Isa isa, const float* v, std::size_t count,
                        float max_value = std::numeric_limits<float>::max());

// Atlas padding (architecture.md §5 step 6): atlas[3 dst + c] = atlas[3 src + c], records applied in
// order (corner records read texels written by earlier edge records). Scalar on every ISA:
// the copies are dependent gathers, not vector work.
void copy_padding(std::span<const PaddingRecord> records, float* atlas);

// atlas[3 texel[s] + c] = lightmap[3 s + c] for every sample s (the unpadded tile interiors).
void scatter_texels(std::span<const std::uint32_t> sample_texel, const float* lightmap, float* atlas);

}  // namespace modrt::cpu
