// SPDX-License-Identifier: MIT
// gemv_channels (kernels.h): a matrix with one coefficient per channel (core's ChannelMatrix,
// the reduced feedback's A and B) times an interleaved RGB vector. Row r's 3 cols coefficients
// and the input are both interleaved, so a row is an elementwise product of two contiguous
// arrays summed by lane modulo 3: the SIMD variants take 24 (AVX2) or 12 (SSE4.1, NEON) floats
// per step into three accumulators whose lanes keep a fixed channel, and sum the lanes of each
// channel at the end of the row. They accumulate in float; the scalar twin in double.
#include <cstddef>

#include "modrt/cpu/kernels.h"
#include "simd_config.h"

#if MODRT_CPU_X86
#include <immintrin.h>
#endif
#if MODRT_CPU_NEON
#include <arm_neon.h>
#endif

namespace modrt::cpu {
namespace {

void gemv_channels_scalar(const float* M, std::size_t rows, std::size_t cols, const float* in, float* out,
                          bool accumulate) {
  for (std::size_t r = 0; r < rows; ++r) {
    const float* row = M + 3 * r * cols;
    double acc[3] = {0.0, 0.0, 0.0};
    for (std::size_t k = 0; k < cols; ++k)
      for (int c = 0; c < 3; ++c) acc[c] += double(row[3 * k + c]) * in[3 * k + c];
    for (int c = 0; c < 3; ++c) out[3 * r + c] = float((accumulate ? double(out[3 * r + c]) : 0.0) + acc[c]);
  }
}

#if MODRT_CPU_X86 || MODRT_CPU_NEON
// The lanes of `lanes` (step floats, lane i is channel i % 3) and the scalar tail summed per channel.
inline void finish_row(const float* lanes, std::size_t step, const float* row, const float* in,
                       std::size_t done, std::size_t length, float* out, bool accumulate) {
  float sum[3] = {0.0f, 0.0f, 0.0f};
  for (std::size_t i = 0; i < step; ++i) sum[i % 3] += lanes[i];
  for (std::size_t i = done; i < length; ++i) sum[i % 3] += row[i] * in[i];
  for (int c = 0; c < 3; ++c) out[c] = (accumulate ? out[c] : 0.0f) + sum[c];
}
#endif

#if MODRT_CPU_X86
MODRT_TARGET_AVX2 void gemv_channels_avx2(const float* M, std::size_t rows, std::size_t cols, const float* in,
                                          float* out, bool accumulate) {
  const std::size_t length = 3 * cols, steps = length / 24;
  alignas(32) float lanes[24];
  for (std::size_t r = 0; r < rows; ++r) {
    const float* row = M + r * length;
    __m256 a0 = _mm256_setzero_ps(), a1 = _mm256_setzero_ps(), a2 = _mm256_setzero_ps();
    for (std::size_t s = 0; s < steps; ++s) {
      const float* m = row + 24 * s;
      const float* x = in + 24 * s;
      a0 = _mm256_fmadd_ps(_mm256_loadu_ps(m), _mm256_loadu_ps(x), a0);
      a1 = _mm256_fmadd_ps(_mm256_loadu_ps(m + 8), _mm256_loadu_ps(x + 8), a1);
      a2 = _mm256_fmadd_ps(_mm256_loadu_ps(m + 16), _mm256_loadu_ps(x + 16), a2);
    }
    _mm256_store_ps(lanes, a0), _mm256_store_ps(lanes + 8, a1), _mm256_store_ps(lanes + 16, a2);
    finish_row(lanes, 24, row, in, 24 * steps, length, out + 3 * r, accumulate);
  }
}

MODRT_TARGET_SSE41 void gemv_channels_sse41(const float* M, std::size_t rows, std::size_t cols,
                                            const float* in, float* out, bool accumulate) {
  const std::size_t length = 3 * cols, steps = length / 12;
  alignas(16) float lanes[12];
  for (std::size_t r = 0; r < rows; ++r) {
    const float* row = M + r * length;
    __m128 a0 = _mm_setzero_ps(), a1 = _mm_setzero_ps(), a2 = _mm_setzero_ps();
    for (std::size_t s = 0; s < steps; ++s) {
      const float* m = row + 12 * s;
      const float* x = in + 12 * s;
      a0 = _mm_add_ps(a0, _mm_mul_ps(_mm_loadu_ps(m), _mm_loadu_ps(x)));
      a1 = _mm_add_ps(a1, _mm_mul_ps(_mm_loadu_ps(m + 4), _mm_loadu_ps(x + 4)));
      a2 = _mm_add_ps(a2, _mm_mul_ps(_mm_loadu_ps(m + 8), _mm_loadu_ps(x + 8)));
    }
    _mm_store_ps(lanes, a0), _mm_store_ps(lanes + 4, a1), _mm_store_ps(lanes + 8, a2);
    finish_row(lanes, 12, row, in, 12 * steps, length, out + 3 * r, accumulate);
  }
}
#endif

#if MODRT_CPU_NEON
void gemv_channels_neon(const float* M, std::size_t rows, std::size_t cols, const float* in, float* out,
                        bool accumulate) {
  const std::size_t length = 3 * cols, steps = length / 12;
  float lanes[12];
  for (std::size_t r = 0; r < rows; ++r) {
    const float* row = M + r * length;
    float32x4_t a0 = vdupq_n_f32(0.0f), a1 = vdupq_n_f32(0.0f), a2 = vdupq_n_f32(0.0f);
    for (std::size_t s = 0; s < steps; ++s) {
      const float* m = row + 12 * s;
      const float* x = in + 12 * s;
      a0 = vfmaq_f32(a0, vld1q_f32(m), vld1q_f32(x));
      a1 = vfmaq_f32(a1, vld1q_f32(m + 4), vld1q_f32(x + 4));
      a2 = vfmaq_f32(a2, vld1q_f32(m + 8), vld1q_f32(x + 8));
    }
    vst1q_f32(lanes, a0), vst1q_f32(lanes + 4, a1), vst1q_f32(lanes + 8, a2);
    finish_row(lanes, 12, row, in, 12 * steps, length, out + 3 * r, accumulate);
  }
}
#endif

}  // namespace

void gemv_channels(Isa isa, const float* M, std::size_t rows, std::size_t cols, const float* in, float* out,
                   bool accumulate) {
  switch (isa_supported(isa) ? isa : Isa::scalar) {
#if MODRT_CPU_X86
    case Isa::avx2: return gemv_channels_avx2(M, rows, cols, in, out, accumulate);
    case Isa::sse41: return gemv_channels_sse41(M, rows, cols, in, out, accumulate);
#endif
#if MODRT_CPU_NEON
    case Isa::neon: return gemv_channels_neon(M, rows, cols, in, out, accumulate);
#endif
    default: return gemv_channels_scalar(M, rows, cols, in, out, accumulate);
  }
}

}  // namespace modrt::cpu

#include "simd_config_end.h"
