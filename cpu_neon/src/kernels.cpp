// SPDX-License-Identifier: MIT
// SIMD kernels: scalar twins always compiled; SSE4.1 and AVX2+FMA through per-function target
// attributes on x86-64; NEON on aarch64. See kernels.h for the layouts.
#include "modrt/cpu/kernels.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <type_traits>

#include "modrt/reference_runtime.h"
#include "simd_config.h"

#if MODRT_CPU_X86
#include <immintrin.h>
#endif
#if MODRT_CPU_NEON
#include <arm_neon.h>
#endif

namespace modrt::cpu {

// Exact whatever the rounding mode and flush-to-zero setting: bit manipulation, and for a
// subnormal half an exact product whose result is a normal float.
float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = std::uint32_t(h & 0x8000u) << 16, exp = (h >> 10) & 0x1fu, mant = h & 0x3ffu;
  if (exp == 0x1f) return std::bit_cast<float>(sign | 0x7f800000u | (mant << 13));  // Inf, NaN
  if (exp != 0) return std::bit_cast<float>(sign | ((exp + 112) << 23) | (mant << 13));
  const float v = float(mant) * 0x1p-24f;  // subnormal (or zero): mant x 2^-24, exact
  return sign ? -v : v;
}

bool float_to_half(float v, std::uint16_t* out) {
  const std::uint32_t x = std::bit_cast<std::uint32_t>(v);
  const std::uint32_t sign = (x >> 16) & 0x8000u, ax = x & 0x7fffffffu;
  if (ax > std::bit_cast<std::uint32_t>(kHalfMax)) return false;  // also Inf and NaN
  std::uint32_t h;
  if (ax >= 0x38800000u) {  // >= 2^-14: a normal half. Rebias, then round off 13 bits to even.
    h = (ax - (112u << 23) + 0xfffu + ((ax >> 13) & 1u)) >> 13;
  } else {  // a subnormal half: m = round(|v| 2^24), ties to even; m = 1024 is 2^-14, also right
    const std::uint32_t e = ax >> 23;
    if (e < 102) {  // |v| < 2^-25: rounds to zero
      h = 0;
    } else {
      const std::uint32_t mant = (ax & 0x7fffffu) | 0x800000u, shift = 126 - e;  // 14..24
      const std::uint32_t rem = mant & ((1u << shift) - 1u), halfway = 1u << (shift - 1);
      h = mant >> shift;
      h += rem > halfway || (rem == halfway && (h & 1u));
    }
  }
  *out = std::uint16_t(sign | h);
  return true;
}

std::size_t float_to_half(const float* in, std::size_t count, std::uint16_t* out) {
  for (std::size_t i = 0; i < count; ++i)
    if (!float_to_half(in[i], out + i)) return i;
  return count;
}

namespace {

// Writes one row's three sums, rounding as core's reference does: overwrite float(s);
// accumulate float(double(out) + s); scatter (row map) out += float(s).
inline void emit(float* out, const std::int32_t* map, bool accumulate, std::size_t row, double r, double g,
                 double b) {
  if (map) {
    if (map[row] < 0) return;
    if (!accumulate) {  // masked: the value the scatter would add, stored at the row's own place
      float* o = out + 3 * row;
      o[0] = float(r);
      o[1] = float(g);
      o[2] = float(b);
      return;
    }
    float* o = out + 3 * std::size_t(map[row]);
    o[0] += float(r);
    o[1] += float(g);
    o[2] += float(b);
    return;
  }
  float* o = out + 3 * row;
  if (accumulate) {
    o[0] = float(double(o[0]) + r);
    o[1] = float(double(o[1]) + g);
    o[2] = float(double(o[2]) + b);
  } else {
    o[0] = float(r);
    o[1] = float(g);
    o[2] = float(b);
  }
}

// SIMD variants accumulate in float within blocks of kBlock columns and add each block's
// sums into double: the float error then grows with the block length, not the row length
// (Td_b rows have 6 res^2 columns and cancel heavily).
[[maybe_unused]] constexpr std::size_t kBlock = 64;

inline bool all_skipped(const std::int32_t* map, std::size_t r, std::size_t count) {
  if (!map) return false;
  for (std::size_t i = 0; i < count; ++i)
    if (map[r + i] >= 0) return false;
  return true;
}

// A matrix element as float: float operators read in place, binary16 ones converted exactly.
inline float elem(const float* p) { return *p; }
inline float elem(const std::uint16_t* p) { return half_to_float(*p); }

// ---- scalar twin: double accumulation, like core's reference_gemv_rgb ----
template <class T>
void gemv_scalar(const T* A, std::size_t rows, std::size_t cols, std::size_t lda, const float* x,
                 std::size_t stride, float* out, const std::int32_t* map, bool accumulate) {
  const float* xr = x;
  const float* xg = x + stride;
  const float* xb = x + 2 * stride;
  for (std::size_t r = 0; r < rows; ++r) {
    if (all_skipped(map, r, 1)) continue;
    const T* a = A + r * lda;
    double s0 = 0.0, s1 = 0.0, s2 = 0.0;
    for (std::size_t k = 0; k < cols; ++k) {
      const double v = elem(a + k);
      s0 += v * xr[k];
      s1 += v * xg[k];
      s2 += v * xb[k];
    }
    emit(out, map, accumulate, r, s0, s1, s2);
  }
}

bool feedback_scalar(const float* ld_direct, const float* rho, const float* lightmap, float bound, float* ld,
                     std::size_t count) {
  bool clamped = false;
  for (std::size_t i = 0; i < count; ++i) {
    float l = std::max(lightmap[i], 0.0f);
    if (l > bound) {
      l = bound;
      clamped = true;
    }
    ld[i] = ld_direct[i] + rho[i] * l;
  }
  return clamped;
}

void clamp_nonnegative_scalar(float* v, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) v[i] = nonnegative_light(v[i]);
}

// Margin that turns the rounded sums of squares into upper bounds (kernels.h).
constexpr double kSumMargin = 1.0 + 1e-5;

SignalChange signal_change_scalar(const float* ld, const float* ref, std::size_t count, SignalChange acc) {
  for (std::size_t i = 0; i < count; ++i) {
    const float v = ld[i];
    const double e = double(v) - ref[i];
    acc.max = std::max(acc.max, v);
    acc.max_diff = std::max(acc.max_diff, std::abs(v - ref[i]));
    acc.sum_sq += double(v) * v;
    acc.sum_sq_diff += e * e;
  }
  return acc;
}

bool finite_nonnegative_scalar(const float* v, std::size_t count, float max_value) {
  bool ok = true;
  for (std::size_t i = 0; i < count; ++i) ok &= v[i] >= 0.0f && v[i] <= max_value;
  return ok;
}

#if MODRT_CPU_X86

// ---- AVX2 + FMA: 8 columns per step, 4 rows x 3 channels = 12 accumulators ----
// (gemv_avx2, gemv_sse41 and gemv_neon are one algorithm with different vector operations.)
MODRT_TARGET_AVX2 inline __m128 hsum4_avx(__m256 a, __m256 b, __m256 c, __m256 d) {
  const __m256 t = _mm256_hadd_ps(_mm256_hadd_ps(a, b), _mm256_hadd_ps(c, d));
  return _mm_add_ps(_mm256_castps256_ps128(t), _mm256_extractf128_ps(t, 1));
}

// Matrix loads: floats in place; binary16 through F16C (the T = uint16_t instantiation is
// dispatched only when f16c_active()).
MODRT_TARGET_AVX2 inline __m256 load8_avx(const float* p) { return _mm256_loadu_ps(p); }
MODRT_TARGET_AVX2_F16C inline __m256 load8_avx(const std::uint16_t* p) {
  return _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}
MODRT_TARGET_AVX2 inline __m128 load4_avx(const float* p) { return _mm_loadu_ps(p); }
MODRT_TARGET_AVX2_F16C inline __m128 load4_avx(const std::uint16_t* p) {
  return _mm_cvtph_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)));
}

// One template for both element types, so it carries F16C in its target: the float
// instantiation contains no F16C instruction (none is emitted without a half conversion;
// checked with objdump) and runs on AVX2+FMA CPUs without F16C.
template <class T>
MODRT_TARGET_AVX2_F16C void gemv_avx2(const T* A, std::size_t rows, std::size_t cols, std::size_t lda,
                                      const float* x, std::size_t stride, float* out, const std::int32_t* map,
                                      bool accumulate) {
  const float* xr = x;
  const float* xg = x + stride;
  const float* xb = x + 2 * stride;
  const std::size_t kv = cols & ~std::size_t(8 - 1);
  std::size_t r = 0;
  for (; r + 4 <= rows; r += 4) {
    if (all_skipped(map, r, 4)) continue;
    const T* a[4] = {A + r * lda, A + (r + 1) * lda, A + (r + 2) * lda, A + (r + 3) * lda};
    double sr[4] = {0, 0, 0, 0}, sg[4] = {0, 0, 0, 0}, sb[4] = {0, 0, 0, 0};
    for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
      const std::size_t k1 = std::min(k0 + kBlock, kv);
      __m256 c0r = _mm256_setzero_ps(), c0g = c0r, c0b = c0r, c1r = c0r, c1g = c0r, c1b = c0r;
      __m256 c2r = c0r, c2g = c0r, c2b = c0r, c3r = c0r, c3g = c0r, c3b = c0r;
      for (std::size_t k = k0; k < k1; k += 8) {
        const __m256 vr = _mm256_loadu_ps(xr + k), vg = _mm256_loadu_ps(xg + k), vb = _mm256_loadu_ps(xb + k);
        __m256 v = load8_avx(a[0] + k);
        c0r = _mm256_fmadd_ps(v, vr, c0r), c0g = _mm256_fmadd_ps(v, vg, c0g),
        c0b = _mm256_fmadd_ps(v, vb, c0b);
        v = load8_avx(a[1] + k);
        c1r = _mm256_fmadd_ps(v, vr, c1r), c1g = _mm256_fmadd_ps(v, vg, c1g),
        c1b = _mm256_fmadd_ps(v, vb, c1b);
        v = load8_avx(a[2] + k);
        c2r = _mm256_fmadd_ps(v, vr, c2r), c2g = _mm256_fmadd_ps(v, vg, c2g),
        c2b = _mm256_fmadd_ps(v, vb, c2b);
        v = load8_avx(a[3] + k);
        c3r = _mm256_fmadd_ps(v, vr, c3r), c3g = _mm256_fmadd_ps(v, vg, c3g),
        c3b = _mm256_fmadd_ps(v, vb, c3b);
      }
      alignas(16) float fr[4], fg[4], fb[4];
      _mm_store_ps(fr, hsum4_avx(c0r, c1r, c2r, c3r));
      _mm_store_ps(fg, hsum4_avx(c0g, c1g, c2g, c3g));
      _mm_store_ps(fb, hsum4_avx(c0b, c1b, c2b, c3b));
      for (int i = 0; i < 4; ++i) sr[i] += fr[i], sg[i] += fg[i], sb[i] += fb[i];
    }
    // A column tail of 4..7: one 4-wide step (short rows such as kb = 12 would otherwise
    // spend a third of their columns in the scalar tail).
    std::size_t kt = kv;
    if (cols - kv >= 4) {
      const __m128 vr = _mm_loadu_ps(xr + kv), vg = _mm_loadu_ps(xg + kv), vb = _mm_loadu_ps(xb + kv);
      __m128 pr[4], pg[4], pb[4];
      for (int i = 0; i < 4; ++i) {
        const __m128 v = load4_avx(a[i] + kv);
        pr[i] = _mm_mul_ps(v, vr), pg[i] = _mm_mul_ps(v, vg), pb[i] = _mm_mul_ps(v, vb);
      }
      alignas(16) float fr[4], fg[4], fb[4];
      _mm_store_ps(fr, _mm_hadd_ps(_mm_hadd_ps(pr[0], pr[1]), _mm_hadd_ps(pr[2], pr[3])));
      _mm_store_ps(fg, _mm_hadd_ps(_mm_hadd_ps(pg[0], pg[1]), _mm_hadd_ps(pg[2], pg[3])));
      _mm_store_ps(fb, _mm_hadd_ps(_mm_hadd_ps(pb[0], pb[1]), _mm_hadd_ps(pb[2], pb[3])));
      for (int i = 0; i < 4; ++i) sr[i] += fr[i], sg[i] += fg[i], sb[i] += fb[i];
      kt = kv + 4;
    }
    for (int i = 0; i < 4; ++i) {
      for (std::size_t k = kt; k < cols; ++k) {
        const double v = elem(a[i] + k);
        sr[i] += v * xr[k], sg[i] += v * xg[k], sb[i] += v * xb[k];
      }
      emit(out, map, accumulate, r + std::size_t(i), sr[i], sg[i], sb[i]);
    }
  }
  for (; r < rows; ++r) {
    if (all_skipped(map, r, 1)) continue;
    const T* a0 = A + r * lda;
    double s[3] = {0, 0, 0};
    for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
      const std::size_t k1 = std::min(k0 + kBlock, kv);
      __m256 cr = _mm256_setzero_ps(), cg = cr, cb = cr;
      for (std::size_t k = k0; k < k1; k += 8) {
        const __m256 v = load8_avx(a0 + k);
        cr = _mm256_fmadd_ps(v, _mm256_loadu_ps(xr + k), cr);
        cg = _mm256_fmadd_ps(v, _mm256_loadu_ps(xg + k), cg);
        cb = _mm256_fmadd_ps(v, _mm256_loadu_ps(xb + k), cb);
      }
      alignas(16) float f[4];
      _mm_store_ps(f, hsum4_avx(cr, cg, cb, _mm256_setzero_ps()));
      s[0] += f[0], s[1] += f[1], s[2] += f[2];
    }
    for (std::size_t k = kv; k < cols; ++k) {
      const double v = elem(a0 + k);
      s[0] += v * xr[k], s[1] += v * xg[k], s[2] += v * xb[k];
    }
    emit(out, map, accumulate, r, s[0], s[1], s[2]);
  }
}

MODRT_TARGET_AVX2 bool feedback_avx2(const float* ld_direct, const float* rho, const float* lightmap,
                                     float bound, float* ld, std::size_t count) {
  const __m256 zero = _mm256_setzero_ps(), vbound = _mm256_set1_ps(bound);
  __m256 hit = zero;
  std::size_t i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m256 l = _mm256_max_ps(_mm256_loadu_ps(lightmap + i), zero);
    hit = _mm256_or_ps(hit, _mm256_cmp_ps(l, vbound, _CMP_GT_OQ));
    // mul then add (no FMA) so the result is bit-identical to the reference.
    const __m256 v = _mm256_add_ps(_mm256_loadu_ps(ld_direct + i),
                                   _mm256_mul_ps(_mm256_loadu_ps(rho + i), _mm256_min_ps(l, vbound)));
    _mm256_storeu_ps(ld + i, v);
  }
  const bool clamped = _mm256_movemask_ps(hit) != 0;
  return feedback_scalar(ld_direct + i, rho + i, lightmap + i, bound, ld + i, count - i) || clamped;
}

MODRT_TARGET_AVX2 void clamp_nonnegative_avx2(float* v, std::size_t count) {
  const __m256 zero = _mm256_setzero_ps();
  std::size_t i = 0;
  for (; i + 8 <= count; i += 8) _mm256_storeu_ps(v + i, _mm256_max_ps(_mm256_loadu_ps(v + i), zero));
  clamp_nonnegative_scalar(v + i, count - i);
}

// ---- SSE4.1: 4 columns per step, same row blocking, separate mul + add ----
MODRT_TARGET_SSE41 inline __m128 hsum4_sse(__m128 a, __m128 b, __m128 c, __m128 d) {
  return _mm_hadd_ps(_mm_hadd_ps(a, b), _mm_hadd_ps(c, d));
}

MODRT_TARGET_SSE41 inline __m128 madd_sse(__m128 a, __m128 b, __m128 c) {
  return _mm_add_ps(_mm_mul_ps(a, b), c);
}

// Binary16 matrix loads convert in software: SSE4.1 has no half conversion (F16C CPUs take
// the AVX2 path).
MODRT_TARGET_SSE41 inline __m128 load4_sse(const float* p) { return _mm_loadu_ps(p); }
MODRT_TARGET_SSE41 inline __m128 load4_sse(const std::uint16_t* p) {
  return _mm_setr_ps(half_to_float(p[0]), half_to_float(p[1]), half_to_float(p[2]), half_to_float(p[3]));
}

template <class T>
MODRT_TARGET_SSE41 void gemv_sse41(const T* A, std::size_t rows, std::size_t cols, std::size_t lda,
                                   const float* x, std::size_t stride, float* out, const std::int32_t* map,
                                   bool accumulate) {
  const float* xr = x;
  const float* xg = x + stride;
  const float* xb = x + 2 * stride;
  const std::size_t kv = cols & ~std::size_t(4 - 1);
  std::size_t r = 0;
  for (; r + 4 <= rows; r += 4) {
    if (all_skipped(map, r, 4)) continue;
    const T* a[4] = {A + r * lda, A + (r + 1) * lda, A + (r + 2) * lda, A + (r + 3) * lda};
    double sr[4] = {0, 0, 0, 0}, sg[4] = {0, 0, 0, 0}, sb[4] = {0, 0, 0, 0};
    for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
      const std::size_t k1 = std::min(k0 + kBlock, kv);
      __m128 c0r = _mm_setzero_ps(), c0g = c0r, c0b = c0r, c1r = c0r, c1g = c0r, c1b = c0r;
      __m128 c2r = c0r, c2g = c0r, c2b = c0r, c3r = c0r, c3g = c0r, c3b = c0r;
      for (std::size_t k = k0; k < k1; k += 4) {
        const __m128 vr = _mm_loadu_ps(xr + k), vg = _mm_loadu_ps(xg + k), vb = _mm_loadu_ps(xb + k);
        __m128 v = load4_sse(a[0] + k);
        c0r = madd_sse(v, vr, c0r), c0g = madd_sse(v, vg, c0g), c0b = madd_sse(v, vb, c0b);
        v = load4_sse(a[1] + k);
        c1r = madd_sse(v, vr, c1r), c1g = madd_sse(v, vg, c1g), c1b = madd_sse(v, vb, c1b);
        v = load4_sse(a[2] + k);
        c2r = madd_sse(v, vr, c2r), c2g = madd_sse(v, vg, c2g), c2b = madd_sse(v, vb, c2b);
        v = load4_sse(a[3] + k);
        c3r = madd_sse(v, vr, c3r), c3g = madd_sse(v, vg, c3g), c3b = madd_sse(v, vb, c3b);
      }
      alignas(16) float fr[4], fg[4], fb[4];
      _mm_store_ps(fr, hsum4_sse(c0r, c1r, c2r, c3r));
      _mm_store_ps(fg, hsum4_sse(c0g, c1g, c2g, c3g));
      _mm_store_ps(fb, hsum4_sse(c0b, c1b, c2b, c3b));
      for (int i = 0; i < 4; ++i) sr[i] += fr[i], sg[i] += fg[i], sb[i] += fb[i];
    }
    for (int i = 0; i < 4; ++i) {
      for (std::size_t k = kv; k < cols; ++k) {
        const double v = elem(a[i] + k);
        sr[i] += v * xr[k], sg[i] += v * xg[k], sb[i] += v * xb[k];
      }
      emit(out, map, accumulate, r + std::size_t(i), sr[i], sg[i], sb[i]);
    }
  }
  for (; r < rows; ++r) {
    if (all_skipped(map, r, 1)) continue;
    const T* a0 = A + r * lda;
    double s[3] = {0, 0, 0};
    for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
      const std::size_t k1 = std::min(k0 + kBlock, kv);
      __m128 cr = _mm_setzero_ps(), cg = cr, cb = cr;
      for (std::size_t k = k0; k < k1; k += 4) {
        const __m128 v = load4_sse(a0 + k);
        cr = madd_sse(v, _mm_loadu_ps(xr + k), cr);
        cg = madd_sse(v, _mm_loadu_ps(xg + k), cg);
        cb = madd_sse(v, _mm_loadu_ps(xb + k), cb);
      }
      alignas(16) float f[4];
      _mm_store_ps(f, hsum4_sse(cr, cg, cb, _mm_setzero_ps()));
      s[0] += f[0], s[1] += f[1], s[2] += f[2];
    }
    for (std::size_t k = kv; k < cols; ++k) {
      const double v = elem(a0 + k);
      s[0] += v * xr[k], s[1] += v * xg[k], s[2] += v * xb[k];
    }
    emit(out, map, accumulate, r, s[0], s[1], s[2]);
  }
}

MODRT_TARGET_SSE41 bool feedback_sse41(const float* ld_direct, const float* rho, const float* lightmap,
                                       float bound, float* ld, std::size_t count) {
  const __m128 zero = _mm_setzero_ps(), vbound = _mm_set1_ps(bound);
  __m128 hit = zero;
  std::size_t i = 0;
  for (; i + 4 <= count; i += 4) {
    const __m128 l = _mm_max_ps(_mm_loadu_ps(lightmap + i), zero);
    hit = _mm_or_ps(hit, _mm_cmpgt_ps(l, vbound));
    _mm_storeu_ps(ld + i, _mm_add_ps(_mm_loadu_ps(ld_direct + i),
                                     _mm_mul_ps(_mm_loadu_ps(rho + i), _mm_min_ps(l, vbound))));
  }
  const bool clamped = _mm_movemask_ps(hit) != 0;
  return feedback_scalar(ld_direct + i, rho + i, lightmap + i, bound, ld + i, count - i) || clamped;
}

MODRT_TARGET_SSE41 void clamp_nonnegative_sse41(float* v, std::size_t count) {
  const __m128 zero = _mm_setzero_ps();
  std::size_t i = 0;
  for (; i + 4 <= count; i += 4) _mm_storeu_ps(v + i, _mm_max_ps(_mm_loadu_ps(v + i), zero));
  clamp_nonnegative_scalar(v + i, count - i);
}

MODRT_TARGET_AVX2 inline float hsum8_avx(__m256 a) {
  __m128 s = _mm_add_ps(_mm256_castps256_ps128(a), _mm256_extractf128_ps(a, 1));
  s = _mm_hadd_ps(s, s);
  return _mm_cvtss_f32(_mm_hadd_ps(s, s));
}

MODRT_TARGET_AVX2 inline float hmax8_avx(__m256 a) {
  __m128 m = _mm_max_ps(_mm256_castps256_ps128(a), _mm256_extractf128_ps(a, 1));
  m = _mm_max_ps(m, _mm_movehl_ps(m, m));
  return _mm_cvtss_f32(_mm_max_ss(m, _mm_shuffle_ps(m, m, 1)));
}

MODRT_TARGET_AVX2 SignalChange signal_change_avx2(const float* ld, const float* ref, std::size_t count) {
  const __m256 sign = _mm256_set1_ps(-0.0f);
  __m256 mx = _mm256_setzero_ps(), md = mx;
  SignalChange out;
  const std::size_t kv = count & ~std::size_t(8 - 1);
  for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
    const std::size_t k1 = std::min(k0 + kBlock, kv);
    __m256 sm = _mm256_setzero_ps(), sd = sm;
    for (std::size_t k = k0; k < k1; k += 8) {
      const __m256 v = _mm256_loadu_ps(ld + k), e = _mm256_sub_ps(v, _mm256_loadu_ps(ref + k));
      mx = _mm256_max_ps(mx, v);
      md = _mm256_max_ps(md, _mm256_andnot_ps(sign, e));
      sm = _mm256_fmadd_ps(v, v, sm);
      sd = _mm256_fmadd_ps(e, e, sd);
    }
    out.sum_sq += hsum8_avx(sm);
    out.sum_sq_diff += hsum8_avx(sd);
  }
  out.max = hmax8_avx(mx);
  out.max_diff = hmax8_avx(md);
  return signal_change_scalar(ld + kv, ref + kv, count - kv, out);
}

MODRT_TARGET_AVX2 bool finite_nonnegative_avx2(const float* v, std::size_t count, float max_value) {
  const __m256 zero = _mm256_setzero_ps(), big = _mm256_set1_ps(max_value);
  __m256 ok = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  std::size_t i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m256 x = _mm256_loadu_ps(v + i);  // ordered compares: NaN fails both
    ok = _mm256_and_ps(ok,
                       _mm256_and_ps(_mm256_cmp_ps(x, zero, _CMP_GE_OQ), _mm256_cmp_ps(x, big, _CMP_LE_OQ)));
  }
  return _mm256_movemask_ps(ok) == 0xff && finite_nonnegative_scalar(v + i, count - i, max_value);
}

MODRT_TARGET_SSE41 inline float hsum4_one_sse(__m128 a) {
  a = _mm_hadd_ps(a, a);
  return _mm_cvtss_f32(_mm_hadd_ps(a, a));
}

MODRT_TARGET_SSE41 inline float hmax4_sse(__m128 m) {
  m = _mm_max_ps(m, _mm_movehl_ps(m, m));
  return _mm_cvtss_f32(_mm_max_ss(m, _mm_shuffle_ps(m, m, 1)));
}

MODRT_TARGET_SSE41 SignalChange signal_change_sse41(const float* ld, const float* ref, std::size_t count) {
  const __m128 sign = _mm_set1_ps(-0.0f);
  __m128 mx = _mm_setzero_ps(), md = mx;
  SignalChange out;
  const std::size_t kv = count & ~std::size_t(4 - 1);
  for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
    const std::size_t k1 = std::min(k0 + kBlock, kv);
    __m128 sm = _mm_setzero_ps(), sd = sm;
    for (std::size_t k = k0; k < k1; k += 4) {
      const __m128 v = _mm_loadu_ps(ld + k), e = _mm_sub_ps(v, _mm_loadu_ps(ref + k));
      mx = _mm_max_ps(mx, v);
      md = _mm_max_ps(md, _mm_andnot_ps(sign, e));
      sm = madd_sse(v, v, sm);
      sd = madd_sse(e, e, sd);
    }
    out.sum_sq += hsum4_one_sse(sm);
    out.sum_sq_diff += hsum4_one_sse(sd);
  }
  out.max = hmax4_sse(mx);
  out.max_diff = hmax4_sse(md);
  return signal_change_scalar(ld + kv, ref + kv, count - kv, out);
}

MODRT_TARGET_SSE41 bool finite_nonnegative_sse41(const float* v, std::size_t count, float max_value) {
  const __m128 zero = _mm_setzero_ps(), big = _mm_set1_ps(max_value);
  __m128 ok = _mm_castsi128_ps(_mm_set1_epi32(-1));
  std::size_t i = 0;
  for (; i + 4 <= count; i += 4) {
    const __m128 x = _mm_loadu_ps(v + i);
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpge_ps(x, zero), _mm_cmple_ps(x, big)));
  }
  return _mm_movemask_ps(ok) == 0xf && finite_nonnegative_scalar(v + i, count - i, max_value);
}

#endif  // MODRT_CPU_X86

#if MODRT_CPU_NEON

// ---- NEON (aarch64): 4 columns per step, 4 rows x 3 channels = 12 accumulators, FMA ----
inline float32x4_t hsum4_neon(float32x4_t a, float32x4_t b, float32x4_t c, float32x4_t d) {
  return vpaddq_f32(vpaddq_f32(a, b), vpaddq_f32(c, d));
}

// vfmaq_f32(acc, a, b) = acc + a * b, argument order as the x86 helpers.
inline float32x4_t fma_neon(float32x4_t a, float32x4_t b, float32x4_t acc) { return vfmaq_f32(acc, a, b); }

inline float32x4_t load4_neon(const float* p) { return vld1q_f32(p); }
inline float32x4_t load4_neon(const std::uint16_t* p) {
  return vcvt_f32_f16(vreinterpret_f16_u16(vld1_u16(p)));
}

template <class T>
void gemv_neon(const T* A, std::size_t rows, std::size_t cols, std::size_t lda, const float* x,
               std::size_t stride, float* out, const std::int32_t* map, bool accumulate) {
  const float* xr = x;
  const float* xg = x + stride;
  const float* xb = x + 2 * stride;
  const std::size_t kv = cols & ~std::size_t(4 - 1);
  std::size_t r = 0;
  for (; r + 4 <= rows; r += 4) {
    if (all_skipped(map, r, 4)) continue;
    const T* a[4] = {A + r * lda, A + (r + 1) * lda, A + (r + 2) * lda, A + (r + 3) * lda};
    double sr[4] = {0, 0, 0, 0}, sg[4] = {0, 0, 0, 0}, sb[4] = {0, 0, 0, 0};
    for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
      const std::size_t k1 = std::min(k0 + kBlock, kv);
      float32x4_t c0r = vdupq_n_f32(0.0f), c0g = c0r, c0b = c0r, c1r = c0r, c1g = c0r, c1b = c0r;
      float32x4_t c2r = c0r, c2g = c0r, c2b = c0r, c3r = c0r, c3g = c0r, c3b = c0r;
      for (std::size_t k = k0; k < k1; k += 4) {
        const float32x4_t vr = vld1q_f32(xr + k), vg = vld1q_f32(xg + k), vb = vld1q_f32(xb + k);
        float32x4_t v = load4_neon(a[0] + k);
        c0r = fma_neon(v, vr, c0r), c0g = fma_neon(v, vg, c0g), c0b = fma_neon(v, vb, c0b);
        v = load4_neon(a[1] + k);
        c1r = fma_neon(v, vr, c1r), c1g = fma_neon(v, vg, c1g), c1b = fma_neon(v, vb, c1b);
        v = load4_neon(a[2] + k);
        c2r = fma_neon(v, vr, c2r), c2g = fma_neon(v, vg, c2g), c2b = fma_neon(v, vb, c2b);
        v = load4_neon(a[3] + k);
        c3r = fma_neon(v, vr, c3r), c3g = fma_neon(v, vg, c3g), c3b = fma_neon(v, vb, c3b);
      }
      float fr[4], fg[4], fb[4];
      vst1q_f32(fr, hsum4_neon(c0r, c1r, c2r, c3r));
      vst1q_f32(fg, hsum4_neon(c0g, c1g, c2g, c3g));
      vst1q_f32(fb, hsum4_neon(c0b, c1b, c2b, c3b));
      for (int i = 0; i < 4; ++i) sr[i] += fr[i], sg[i] += fg[i], sb[i] += fb[i];
    }
    for (int i = 0; i < 4; ++i) {
      for (std::size_t k = kv; k < cols; ++k) {
        const double v = elem(a[i] + k);
        sr[i] += v * xr[k], sg[i] += v * xg[k], sb[i] += v * xb[k];
      }
      emit(out, map, accumulate, r + std::size_t(i), sr[i], sg[i], sb[i]);
    }
  }
  for (; r < rows; ++r) {
    if (all_skipped(map, r, 1)) continue;
    const T* a0 = A + r * lda;
    double s[3] = {0, 0, 0};
    for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
      const std::size_t k1 = std::min(k0 + kBlock, kv);
      float32x4_t cr = vdupq_n_f32(0.0f), cg = cr, cb = cr;
      for (std::size_t k = k0; k < k1; k += 4) {
        const float32x4_t v = load4_neon(a0 + k);
        cr = fma_neon(v, vld1q_f32(xr + k), cr);
        cg = fma_neon(v, vld1q_f32(xg + k), cg);
        cb = fma_neon(v, vld1q_f32(xb + k), cb);
      }
      float f[4];
      vst1q_f32(f, hsum4_neon(cr, cg, cb, vdupq_n_f32(0.0f)));
      s[0] += f[0], s[1] += f[1], s[2] += f[2];
    }
    for (std::size_t k = kv; k < cols; ++k) {
      const double v = elem(a0 + k);
      s[0] += v * xr[k], s[1] += v * xg[k], s[2] += v * xb[k];
    }
    emit(out, map, accumulate, r, s[0], s[1], s[2]);
  }
}

bool feedback_neon(const float* ld_direct, const float* rho, const float* lightmap, float bound, float* ld,
                   std::size_t count) {
  const float32x4_t zero = vdupq_n_f32(0.0f), vbound = vdupq_n_f32(bound);
  uint32x4_t hit = vdupq_n_u32(0);
  std::size_t i = 0;
  for (; i + 4 <= count; i += 4) {
    const float32x4_t l = vmaxq_f32(vld1q_f32(lightmap + i), zero);
    hit = vorrq_u32(hit, vcgtq_f32(l, vbound));
    // vmulq + vaddq, not vfmaq: bit-identical to the reference.
    vst1q_f32(ld + i,
              vaddq_f32(vld1q_f32(ld_direct + i), vmulq_f32(vld1q_f32(rho + i), vminq_f32(l, vbound))));
  }
  const bool clamped = vmaxvq_u32(hit) != 0;
  return feedback_scalar(ld_direct + i, rho + i, lightmap + i, bound, ld + i, count - i) || clamped;
}

void clamp_nonnegative_neon(float* v, std::size_t count) {
  const float32x4_t zero = vdupq_n_f32(0.0f);
  std::size_t i = 0;
  for (; i + 4 <= count; i += 4) vst1q_f32(v + i, vmaxq_f32(vld1q_f32(v + i), zero));
  clamp_nonnegative_scalar(v + i, count - i);
}

SignalChange signal_change_neon(const float* ld, const float* ref, std::size_t count) {
  float32x4_t mx = vdupq_n_f32(0.0f), md = mx;
  SignalChange out;
  const std::size_t kv = count & ~std::size_t(4 - 1);
  for (std::size_t k0 = 0; k0 < kv; k0 += kBlock) {
    const std::size_t k1 = std::min(k0 + kBlock, kv);
    float32x4_t sm = vdupq_n_f32(0.0f), sd = sm;
    for (std::size_t k = k0; k < k1; k += 4) {
      const float32x4_t v = vld1q_f32(ld + k), e = vsubq_f32(v, vld1q_f32(ref + k));
      mx = vmaxq_f32(mx, v);
      md = vmaxq_f32(md, vabsq_f32(e));
      sm = fma_neon(v, v, sm);
      sd = fma_neon(e, e, sd);
    }
    out.sum_sq += vaddvq_f32(sm);
    out.sum_sq_diff += vaddvq_f32(sd);
  }
  out.max = vmaxvq_f32(mx);
  out.max_diff = vmaxvq_f32(md);
  return signal_change_scalar(ld + kv, ref + kv, count - kv, out);
}

bool finite_nonnegative_neon(const float* v, std::size_t count, float max_value) {
  const float32x4_t zero = vdupq_n_f32(0.0f), big = vdupq_n_f32(max_value);
  uint32x4_t ok = vdupq_n_u32(0xffffffffu);
  std::size_t i = 0;
  for (; i + 4 <= count; i += 4) {
    const float32x4_t x = vld1q_f32(v + i);  // ordered compares: NaN fails both
    ok = vandq_u32(ok, vandq_u32(vcgeq_f32(x, zero), vcleq_f32(x, big)));
  }
  return vminvq_u32(ok) == 0xffffffffu && finite_nonnegative_scalar(v + i, count - i, max_value);
}

#endif  // MODRT_CPU_NEON

template <class T>
void gemv_dispatch(Isa isa, const T* A, std::size_t rows, std::size_t cols, std::size_t lda, const float* x,
                   std::size_t stride, float* out, const std::int32_t* map, bool accumulate) {
  if (rows == 0) return;
  Isa use = isa_supported(isa) ? isa : Isa::scalar;
  if (std::is_same_v<T, std::uint16_t> && use == Isa::avx2 && !f16c_active())
    use = isa_supported(Isa::sse41) ? Isa::sse41 : Isa::scalar;
  switch (use) {
#if MODRT_CPU_X86
    case Isa::avx2: return gemv_avx2(A, rows, cols, lda, x, stride, out, map, accumulate);
    case Isa::sse41: return gemv_sse41(A, rows, cols, lda, x, stride, out, map, accumulate);
#endif
#if MODRT_CPU_NEON
    case Isa::neon: return gemv_neon(A, rows, cols, lda, x, stride, out, map, accumulate);
#endif
    default: return gemv_scalar(A, rows, cols, lda, x, stride, out, map, accumulate);
  }
}

}  // namespace

void deinterleave_rgb(const float* rgb, std::size_t n, float* planar, std::size_t stride) {
  for (std::size_t k = 0; k < n; ++k) {
    planar[k] = rgb[3 * k];
    planar[stride + k] = rgb[3 * k + 1];
    planar[2 * stride + k] = rgb[3 * k + 2];
  }
}

void gemv_rgb(Isa isa, const float* A, std::size_t rows, std::size_t cols, std::size_t lda,
              const float* planar, std::size_t stride, float* out, bool accumulate) {
  gemv_dispatch(isa, A, rows, cols, lda, planar, stride, out, nullptr, accumulate);
}

void gemv_rgb_interleaved(Isa isa, const Matrix& A, const float* in, float* out, bool accumulate,
                          std::span<float> scratch) {
  deinterleave_rgb(in, A.cols, scratch.data(), A.cols);
  gemv_dispatch(isa, A.data.data(), A.rows, A.cols, A.cols, scratch.data(), A.cols, out, nullptr, accumulate);
}

void gemv_rgb_scatter(Isa isa, const float* A, std::size_t rows, std::size_t cols, std::size_t lda,
                      const std::int32_t* row_to_sample, const float* planar, std::size_t stride,
                      float* out) {
  gemv_dispatch(isa, A, rows, cols, lda, planar, stride, out, row_to_sample, true);
}

void gemv_rgb_masked(Isa isa, const float* A, std::size_t rows, std::size_t cols, std::size_t lda,
                     const std::int32_t* row_to_sample, const float* planar, std::size_t stride, float* out) {
  gemv_dispatch(isa, A, rows, cols, lda, planar, stride, out, row_to_sample, false);
}

void gemv_rgb_f16(Isa isa, const std::uint16_t* A, std::size_t rows, std::size_t cols, std::size_t lda,
                  const float* planar, std::size_t stride, float* out, bool accumulate) {
  gemv_dispatch(isa, A, rows, cols, lda, planar, stride, out, nullptr, accumulate);
}

void gemv_rgb_scatter_f16(Isa isa, const std::uint16_t* A, std::size_t rows, std::size_t cols,
                          std::size_t lda, const std::int32_t* row_to_sample, const float* planar,
                          std::size_t stride, float* out) {
  gemv_dispatch(isa, A, rows, cols, lda, planar, stride, out, row_to_sample, true);
}

void gemv_rgb_masked_f16(Isa isa, const std::uint16_t* A, std::size_t rows, std::size_t cols, std::size_t lda,
                         const std::int32_t* row_to_sample, const float* planar, std::size_t stride,
                         float* out) {
  gemv_dispatch(isa, A, rows, cols, lda, planar, stride, out, row_to_sample, false);
}

void add_scattered(std::size_t rows, const std::int32_t* row_to_sample, const float* values, float* out) {
  for (std::size_t r = 0; r < rows; ++r) {
    if (row_to_sample[r] < 0) continue;
    float* o = out + 3 * std::size_t(row_to_sample[r]);
    const float* v = values + 3 * r;
    o[0] += v[0], o[1] += v[1], o[2] += v[2];
  }
}

bool feedback_rgb(Isa isa, const float* ld_direct, const float* rho, const float* lightmap, float bound,
                  float* ld, std::size_t count) {
  switch (isa_supported(isa) ? isa : Isa::scalar) {
#if MODRT_CPU_X86
    case Isa::avx2: return feedback_avx2(ld_direct, rho, lightmap, bound, ld, count);
    case Isa::sse41: return feedback_sse41(ld_direct, rho, lightmap, bound, ld, count);
#endif
#if MODRT_CPU_NEON
    case Isa::neon: return feedback_neon(ld_direct, rho, lightmap, bound, ld, count);
#endif
    default: return feedback_scalar(ld_direct, rho, lightmap, bound, ld, count);
  }
}

void clamp_nonnegative(Isa isa, float* v, std::size_t count) {
  switch (isa_supported(isa) ? isa : Isa::scalar) {
#if MODRT_CPU_X86
    case Isa::avx2: return clamp_nonnegative_avx2(v, count);
    case Isa::sse41: return clamp_nonnegative_sse41(v, count);
#endif
#if MODRT_CPU_NEON
    case Isa::neon: return clamp_nonnegative_neon(v, count);
#endif
    default: return clamp_nonnegative_scalar(v, count);
  }
}

SignalChange signal_change(Isa isa, const float* ld, const float* ref, std::size_t count) {
  SignalChange c;
  switch (isa_supported(isa) ? isa : Isa::scalar) {
#if MODRT_CPU_X86
    case Isa::avx2: c = signal_change_avx2(ld, ref, count); break;
    case Isa::sse41: c = signal_change_sse41(ld, ref, count); break;
#endif
#if MODRT_CPU_NEON
    case Isa::neon: c = signal_change_neon(ld, ref, count); break;
#endif
    default: c = signal_change_scalar(ld, ref, count, SignalChange{}); break;
  }
  c.sum_sq *= kSumMargin;
  c.sum_sq_diff *= kSumMargin;
  return c;
}

bool finite_nonnegative(Isa isa, const float* v, std::size_t count, float max_value) {
  switch (isa_supported(isa) ? isa : Isa::scalar) {
#if MODRT_CPU_X86
    case Isa::avx2: return finite_nonnegative_avx2(v, count, max_value);
    case Isa::sse41: return finite_nonnegative_sse41(v, count, max_value);
#endif
#if MODRT_CPU_NEON
    case Isa::neon: return finite_nonnegative_neon(v, count, max_value);
#endif
    default: return finite_nonnegative_scalar(v, count, max_value);
  }
}

void copy_padding(std::span<const PaddingRecord> records, float* atlas) {
  for (const PaddingRecord& p : records) {
    const float* s = atlas + 3 * std::size_t(p.src);
    float* d = atlas + 3 * std::size_t(p.dst);
    d[0] = s[0], d[1] = s[1], d[2] = s[2];
  }
}

void scatter_texels(std::span<const std::uint32_t> sample_texel, const float* lightmap, float* atlas) {
  for (std::size_t s = 0; s < sample_texel.size(); ++s) {
    float* d = atlas + 3 * std::size_t(sample_texel[s]);
    d[0] = lightmap[3 * s], d[1] = lightmap[3 * s + 1], d[2] = lightmap[3 * s + 2];
  }
}

}  // namespace modrt::cpu

#include "simd_config_end.h"
