// SPDX-License-Identifier: MIT
// SIMD CPU kernels (cpu_neon/) against core's scalar reference, for every ISA this CPU
// supports (Embree verify style: for (isa : isas)), on random sizes including zero, odd and
// non-multiples of every vector width. Needs no precompute, so it also runs cross-built on
// aarch64 under qemu (scripts/test-aarch64.sh), where the ISAs are scalar and NEON.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "cpu_test_support.h"
#include "modrt/cpu/kernels.h"
#include "modrt/reduced_feedback.h"
#include "modrt/reference_runtime.h"

namespace modrt::cpu {
namespace {

using namespace cpu_test;

const std::vector<std::uint32_t> kRowSizes = {0, 1, 2, 3, 4, 5, 7, 8, 9, 12, 13, 16, 17, 31, 33, 64};
const std::vector<std::uint32_t> kColSizes = {0, 1, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 32, 33, 100, 1537};

TEST(CpuKernels, SupportedIsasStartWithScalarAndCanBeForced) {
  const std::vector<Isa> isas = supported_isas();
  ASSERT_FALSE(isas.empty());
  EXPECT_EQ(isas.front(), Isa::scalar);
  EXPECT_EQ(best_isa(), isas.back());
  std::printf("  supported ISAs:");
  for (Isa isa : isas) std::printf(" %s", isa_name(isa));
  std::printf("\n");
  const Isa before = active_isa();
  for (Isa isa : isas) {
    EXPECT_TRUE(set_isa(isa));
    EXPECT_EQ(active_isa(), isa);
  }
  for (Isa isa : {Isa::scalar, Isa::sse41, Isa::avx2, Isa::neon}) {
    if (!isa_supported(isa)) {
      EXPECT_FALSE(set_isa(isa)) << isa_name(isa);
    }
  }
  EXPECT_TRUE(set_isa(before));
#if defined(MODRT_NO_SIMD)
  EXPECT_EQ(isas.size(), 1u);
#endif
}

TEST(CpuKernels, GemvMatchesReferenceForEveryIsaAndSize) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(1234);
    Worst worst;
    for (std::uint32_t rows : kRowSizes)
      for (std::uint32_t cols : kColSizes)
        for (bool accumulate : {false, true}) {
          const Matrix A = random_matrix(rng, rows, cols);
          const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
          std::vector<float> ref = random_vector(rng, 3 * std::size_t(rows), 0.0f, 1.0f);
          std::vector<float> got = ref;
          reference_gemv_rgb(A, in.data(), ref.data(), accumulate);
          std::vector<float> scratch(gemv_scratch_bound(cols));
          gemv_rgb_interleaved(isa, A, in.data(), got.data(), accumulate, scratch);
          expect_close(got, ref,
                       std::string(isa_name(isa)) + " " + std::to_string(rows) + "x" + std::to_string(cols) +
                           (accumulate ? " accumulate" : ""),
                       &worst);
        }
    worst.print("gemv_rgb", isa);
  }
}

// The per-channel matrices of the reduced feedback (core's ChannelMatrix) against core's
// reference_gemv_channels, every ISA, sizes across every step width (24 and 12 floats) and tail.
TEST(CpuKernels, GemvChannelsMatchesReferenceForEveryIsaAndSize) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(4321);
    Worst worst;
    for (std::uint32_t rows : kRowSizes)
      for (std::uint32_t cols : kColSizes)
        for (bool accumulate : {false, true}) {
          ChannelMatrix M{rows, cols, random_vector(rng, 3 * std::size_t(rows) * cols, -1.0f, 1.0f)};
          const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
          std::vector<float> ref = random_vector(rng, 3 * std::size_t(rows), 0.0f, 1.0f);
          std::vector<float> got = ref;
          reference_gemv_channels(M, in.data(), ref.data(), accumulate);
          gemv_channels(isa, M.data.data(), rows, cols, in.data(), got.data(), accumulate);
          expect_close(got, ref,
                       std::string(isa_name(isa)) + " " + std::to_string(rows) + "x" + std::to_string(cols) +
                           (accumulate ? " accumulate" : ""),
                       &worst);
        }
    worst.print("gemv_channels", isa);
  }
}

// Leading dimension > cols and a planar stride > cols (the padded layouts a caller may keep).
TEST(CpuKernels, GemvHonoursLeadingDimensionAndStride) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(99);
    for (std::uint32_t rows : {1u, 5u, 13u})
      for (std::uint32_t cols : {1u, 7u, 9u, 33u}) {
        const Matrix A = random_matrix(rng, rows, cols);
        const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
        const std::size_t lda = cols + 5, stride = cols + 3;
        std::vector<float> padded(rows * lda, std::numeric_limits<float>::quiet_NaN());
        for (std::uint32_t r = 0; r < rows; ++r)
          std::copy_n(&A.data[r * std::size_t(cols)], cols, &padded[r * lda]);
        std::vector<float> planar(3 * stride, std::numeric_limits<float>::quiet_NaN());
        deinterleave_rgb(in.data(), cols, planar.data(), stride);
        std::vector<float> ref(3 * std::size_t(rows)), got(ref.size());
        reference_gemv_rgb(A, in.data(), ref.data(), false);
        gemv_rgb(isa, padded.data(), rows, cols, lda, planar.data(), stride, got.data(), false);
        expect_close(got, ref, std::string(isa_name(isa)) + " padded", nullptr);
      }
  }
}

TEST(CpuKernels, ScatterMatchesReferenceForEveryIsaAndSize) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(77);
    Worst worst;
    for (std::uint32_t rows : kRowSizes)
      for (std::uint32_t cols : kColSizes) {
        if (cols > 100) continue;
        const Matrix A = random_matrix(rng, rows, cols);
        const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
        // Rows land on a shuffled subset of 2 x rows destination samples; about a third are -1.
        const std::size_t samples = 2 * std::size_t(rows) + 1;
        std::vector<std::int32_t> perm(samples);
        for (std::size_t i = 0; i < samples; ++i) perm[i] = std::int32_t(i);
        std::shuffle(perm.begin(), perm.end(), rng);
        std::vector<std::int32_t> map(rows);
        for (std::uint32_t r = 0; r < rows; ++r) map[r] = rng() % 3 == 0 ? -1 : perm[r];
        if (rows >= 8) std::fill(map.begin(), map.begin() + 4, -1);  // a whole skipped 4-row group
        std::vector<float> ref = random_vector(rng, 3 * samples, 0.0f, 1.0f);
        std::vector<float> got = ref;
        for (std::uint32_t r = 0; r < rows; ++r) {
          if (map[r] < 0) continue;
          for (int c = 0; c < 3; ++c) {
            double acc = 0.0;
            for (std::uint32_t k = 0; k < cols; ++k) acc += double(A(r, k)) * in[3 * k + std::size_t(c)];
            ref[3 * std::size_t(map[r]) + std::size_t(c)] += float(acc);
          }
        }
        std::vector<float> planar(3 * std::size_t(cols));
        deinterleave_rgb(in.data(), cols, planar.data(), cols);
        gemv_rgb_scatter(isa, A.data.data(), rows, cols, cols, map.data(), planar.data(), cols, got.data());
        expect_close(
            got, ref,
            std::string(isa_name(isa)) + " scatter " + std::to_string(rows) + "x" + std::to_string(cols),
            &worst);
      }
    worst.print("gemv_rgb_scatter", isa);
  }
}

// gemv_rgb_masked + add_scattered write the same bits as gemv_rgb_scatter; the masked kernel
// leaves unmapped rows alone.
TEST(CpuKernels, MaskedThenAddedEqualsScatter) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(19);
    for (std::uint32_t rows : kRowSizes)
      for (std::uint32_t cols : {0u, 3u, 8u, 12u, 13u, 32u, 37u}) {
        const Matrix A = random_matrix(rng, rows, cols);
        const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
        std::vector<float> planar(3 * std::size_t(cols));
        deinterleave_rgb(in.data(), cols, planar.data(), cols);
        const std::size_t samples = std::size_t(rows) + 2;
        std::vector<std::int32_t> map(rows);
        for (std::uint32_t r = 0; r < rows; ++r)
          map[r] = rng() % 3 == 0 ? -1 : std::int32_t((r + 1) % samples);
        if (rows >= 8) std::fill(map.begin(), map.begin() + 4, -1);
        const std::vector<float> base = random_vector(rng, 3 * samples, 0.0f, 1.0f);
        std::vector<float> scattered = base, added = base;
        gemv_rgb_scatter(isa, A.data.data(), rows, cols, cols, map.data(), planar.data(), cols,
                         scattered.data());
        const float sentinel = -7.0f;
        std::vector<float> values(3 * std::size_t(rows), sentinel);
        gemv_rgb_masked(isa, A.data.data(), rows, cols, cols, map.data(), planar.data(), cols, values.data());
        for (std::uint32_t r = 0; r < rows; ++r)
          if (map[r] < 0) {
            EXPECT_EQ(values[3 * r], sentinel);
            EXPECT_EQ(values[3 * r + 2], sentinel);
          }
        add_scattered(rows, map.data(), values.data(), added.data());
        EXPECT_EQ(added, scattered) << isa_name(isa) << " " << rows << "x" << cols;
      }
  }
}

TEST(CpuKernels, FeedbackIsBitIdenticalToReference) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(5);
    for (std::size_t samples : {0u, 1u, 2u, 3u, 5u, 11u, 16u, 33u, 1000u}) {
      const std::size_t n = 3 * samples;
      FeedbackClamp clamp;
      clamp.rho = random_vector(rng, n, 0.0f, 0.95f);
      clamp.energy_bound = 2.0f;
      const std::vector<float> ld_direct = random_vector(rng, n, 0.0f, 1.0f);
      for (const float hi : {1.5f, 4.0f}) {  // without and with values above the bound
        const std::vector<float> lightmap = random_vector(rng, n, -0.5f, hi);
        std::vector<float> ref(n), got(n);
        const bool ref_clamped = apply_feedback(clamp, ld_direct, lightmap, ref);
        const bool got_clamped = feedback_rgb(isa, ld_direct.data(), clamp.rho.data(), lightmap.data(),
                                              clamp.energy_bound, got.data(), n);
        EXPECT_EQ(got_clamped, ref_clamped) << isa_name(isa) << " " << samples;
#if defined(__x86_64__)
        EXPECT_EQ(got, ref) << isa_name(isa) << " " << samples;
#else  // core's apply_feedback may be FMA-contracted by the compiler here: one rounding apart
        for (std::size_t i = 0; i < n; ++i) EXPECT_NEAR(got[i], ref[i], 2.5e-7f * std::abs(ref[i])) << i;
#endif
      }
    }
  }
}

// clamp_nonnegative is core's clamp_lightmap on every ISA (the lightmap policy), every
// length and alignment; -0 and denormals included.
TEST(CpuKernels, ClampNonnegativeIsCoresClampLightmap) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(17);
    for (std::size_t n : {0u, 1u, 3u, 4u, 5u, 7u, 8u, 9u, 31u, 33u, 1000u}) {
      std::vector<float> v = random_vector(rng, n + 1, -1e6f, 1e6f);
      if (n > 2) v[1] = -0.0f, v[2] = -1e-40f;
      std::vector<float> ref(v.begin() + 1, v.end()), got = v;
      clamp_lightmap(ref);
      clamp_nonnegative(isa, got.data() + 1, n);  // unaligned start
      EXPECT_EQ(got[0], v[0]) << "wrote before the span";
      for (std::size_t i = 0; i < n; ++i) {
        EXPECT_GE(got[i + 1], 0.0f) << isa_name(isa) << " " << n << " " << i;
        EXPECT_EQ(got[i + 1], ref[i]) << isa_name(isa) << " " << n << " " << i;
      }
    }
  }
}

// signal_change: the maxima equal the scalar twin's exactly; the sums are upper bounds on the
// exact sums (long double), within 2e-5 of them.
TEST(CpuKernels, SignalChangeBoundsTheExactSums) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(11);
    for (std::size_t n : {0u, 1u, 3u, 4u, 7u, 8u, 9u, 63u, 64u, 65u, 100u, 1537u, 4099u}) {
      const std::vector<float> ld = random_vector(rng, n, 0.0f, 2.0f);
      std::vector<float> ref = random_vector(rng, n, 0.0f, 2.0f);
      for (std::size_t i = 0; i < n; i += 3) ref[i] = ld[i];  // some unchanged values
      long double sum_sq = 0, sum_sq_diff = 0;
      float max = 0.0f, max_diff = 0.0f;
      for (std::size_t i = 0; i < n; ++i) {
        sum_sq += (long double)ld[i] * ld[i];
        sum_sq_diff += ((long double)ld[i] - ref[i]) * ((long double)ld[i] - ref[i]);
        max = std::max(max, ld[i]);
        max_diff = std::max(max_diff, std::abs(ld[i] - ref[i]));
      }
      const SignalChange c = signal_change(isa, ld.data(), ref.data(), n);
      const std::string what = std::string(isa_name(isa)) + " n " + std::to_string(n);
      EXPECT_EQ(c.max, max) << what;
      EXPECT_EQ(c.max_diff, max_diff) << what;
      EXPECT_GE((long double)c.sum_sq, sum_sq) << what;
      EXPECT_LE((long double)c.sum_sq, sum_sq * (1 + 2e-5L)) << what;
      EXPECT_GE((long double)c.sum_sq_diff, sum_sq_diff) << what;
      EXPECT_LE((long double)c.sum_sq_diff, sum_sq_diff * (1 + 2e-5L)) << what;
    }
    // Unchanged signal: no difference at all.
    const std::vector<float> same = random_vector(rng, 77, 0.0f, 1.0f);
    const SignalChange c = signal_change(isa, same.data(), same.data(), same.size());
    EXPECT_EQ(c.max_diff, 0.0f) << isa_name(isa);
    EXPECT_EQ(c.sum_sq_diff, 0.0) << isa_name(isa);
  }
}

// finite_nonnegative: one bad value anywhere (vector body or tail) is found; -0 is fine.
TEST(CpuKernels, FiniteNonnegativeFindsEveryBadValue) {
  const float bad[] = {-1.0f, -1e-30f, std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()};
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(3);
    for (std::size_t n : {0u, 1u, 5u, 8u, 13u, 64u, 67u}) {
      std::vector<float> v = random_vector(rng, n, 0.0f, 1.0f);
      EXPECT_TRUE(finite_nonnegative(isa, v.data(), n)) << isa_name(isa) << " " << n;
      if (n == 0) continue;
      v[n / 2] = -0.0f;
      v[0] = std::numeric_limits<float>::max();
      EXPECT_TRUE(finite_nonnegative(isa, v.data(), n)) << isa_name(isa) << " " << n;
      for (std::size_t at : {std::size_t(0), n / 2, n - 1})
        for (float b : bad) {
          std::vector<float> w = v;
          w[at] = b;
          EXPECT_FALSE(finite_nonnegative(isa, w.data(), n))
              << isa_name(isa) << " n " << n << " at " << at << " " << b;
        }
      // With a ceiling (kMaxLightValue for ld): the ceiling itself passes, one value above fails.
      v[0] = 0.5f;
      EXPECT_TRUE(finite_nonnegative(isa, v.data(), n, 2.0f)) << isa_name(isa) << " " << n;
      for (std::size_t at : {std::size_t(0), n / 2, n - 1}) {
        std::vector<float> w = v;
        w[at] = 2.0f;
        EXPECT_TRUE(finite_nonnegative(isa, w.data(), n, 2.0f))
            << isa_name(isa) << " n " << n << " at " << at;
        w[at] = 2.0000002f;
        EXPECT_FALSE(finite_nonnegative(isa, w.data(), n, 2.0f))
            << isa_name(isa) << " n " << n << " at " << at;
      }
    }
  }
}

TEST(CpuKernels, PaddingCopiesInRecordOrder) {
  // 4 texels; record 2 reads texel 1, written by record 1: order matters.
  std::vector<float> atlas = {1, 2, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  const std::vector<PaddingRecord> records = {{1, 0}, {2, 1}, {3, 2}};
  copy_padding(records, atlas.data());
  for (int t = 0; t < 4; ++t)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(atlas[std::size_t(3 * t + c)], float(c + 1));
  std::vector<float> a2(12, 0.0f);
  const std::vector<std::uint32_t> texel = {3, 1};
  const std::vector<float> lm = {1, 2, 3, 4, 5, 6};
  scatter_texels(texel, lm.data(), a2.data());
  EXPECT_EQ(a2, (std::vector<float>{0, 0, 0, 4, 5, 6, 0, 0, 0, 1, 2, 3}));
}

// ---- float16 operator storage ----

// The float value of binary16 bits, from the format's definition.
double half_value(std::uint16_t h) {
  const int exp = (h >> 10) & 0x1f, mant = h & 0x3ff;
  const double mag = exp == 0 ? std::ldexp(double(mant), -24) : std::ldexp(double(1024 + mant), exp - 25);
  return (h & 0x8000) ? -mag : mag;
}

// Every one of the 65536 bit patterns converts exactly and round-trips.
TEST(CpuKernels, HalfToFloatIsExactForEveryHalf) {
  for (std::uint32_t bits = 0; bits < 0x10000; ++bits) {
    const std::uint16_t h = std::uint16_t(bits);
    const float f = half_to_float(h);
    if (((h >> 10) & 0x1f) == 0x1f) {  // Inf (mantissa 0) or NaN
      EXPECT_EQ(std::isnan(f), (h & 0x3ff) != 0) << bits;
      if ((h & 0x3ff) == 0) {
        EXPECT_EQ(f, (h & 0x8000) ? -INFINITY : INFINITY) << bits;
      }
      std::uint16_t out = 0x1234;
      EXPECT_FALSE(float_to_half(f, &out)) << bits;
      EXPECT_EQ(out, 0x1234) << bits;
      continue;
    }
    ASSERT_EQ(double(f), half_value(h)) << bits;
    EXPECT_EQ(std::signbit(f), (h & 0x8000) != 0) << bits;  // -0 too
    std::uint16_t back = 0;
    ASSERT_TRUE(float_to_half(f, &back)) << bits;
    EXPECT_EQ(back, h) << bits;
  }
}

// Between two neighbouring halves: the midpoint goes to the one with the even bit pattern,
// anything off it to the nearer one; the same mirrored for negative values.
TEST(CpuKernels, FloatToHalfRoundsToNearestEven) {
  auto to_half = [](float v) {
    std::uint16_t h = 0;
    EXPECT_TRUE(float_to_half(v, &h)) << v;
    return h;
  };
  for (std::uint32_t bits = 0; bits < 0x7bff; ++bits) {
    const std::uint16_t lo = std::uint16_t(bits), hi = std::uint16_t(bits + 1);
    const float a = half_to_float(lo), b = half_to_float(hi);
    const float mid = a + (b - a) * 0.5f;  // exact: a float has 13 more mantissa bits
    ASSERT_EQ(double(mid), (half_value(lo) + half_value(hi)) / 2) << bits;
    const std::uint16_t even = (lo & 1) ? hi : lo;
    EXPECT_EQ(to_half(mid), even) << bits;
    EXPECT_EQ(to_half(-mid), even | 0x8000) << bits;
    EXPECT_EQ(to_half(std::nextafter(mid, 0.0f)), lo) << bits;
    EXPECT_EQ(to_half(std::nextafter(mid, 1e9f)), hi) << bits;
    EXPECT_EQ(to_half(-std::nextafter(mid, 1e9f)), hi | 0x8000) << bits;
  }
  // Below the smallest subnormal half (2^-24): 2^-25 is a tie that goes to 0; float subnormals
  // and tiny values vanish (keeping their sign).
  EXPECT_EQ(to_half(0x1p-25f), 0);
  EXPECT_EQ(to_half(std::nextafter(0x1p-25f, 1.0f)), 1);
  EXPECT_EQ(to_half(0x1.8p-24f), 2);  // 1.5 x 2^-24: tie between 1 and 2, even is 2
  EXPECT_EQ(to_half(1e-30f), 0);
  EXPECT_EQ(to_half(-1e-40f), 0x8000);
  EXPECT_EQ(to_half(std::numeric_limits<float>::denorm_min()), 0);
  EXPECT_EQ(to_half(1.0f + 0x1p-11f), 0x3c00);    // tie between 1 and 1 + 2^-10: to 1
  EXPECT_EQ(to_half(1.0f + 0x1.8p-10f), 0x3c02);  // tie between 1 + 2^-10 (odd) and 1 + 2^-9
}

TEST(CpuKernels, FloatToHalfRefusesValuesBeyondTheHalfRange) {
  std::uint16_t h = 0;
  EXPECT_TRUE(float_to_half(kHalfMax, &h));
  EXPECT_EQ(h, 0x7bff);
  EXPECT_TRUE(float_to_half(-kHalfMax, &h));
  EXPECT_EQ(h, 0xfbff);
  for (float v : {std::nextafter(kHalfMax, 1e9f), 65519.0f, 65520.0f, 1e6f, std::numeric_limits<float>::max(),
                  std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN()}) {
    h = 0x1234;
    EXPECT_FALSE(float_to_half(v, &h)) << v;
    EXPECT_FALSE(float_to_half(-v, &h)) << -v;
    EXPECT_EQ(h, 0x1234) << v;  // nothing stored
  }
  // The array form names the first value refused.
  const std::vector<float> in = {1.0f, -2.5f, 0.0f, 7e4f, 3.0f, 1e9f};
  std::vector<std::uint16_t> out(in.size(), 0);
  EXPECT_EQ(float_to_half(in.data(), in.size(), out.data()), 3u);
  EXPECT_EQ(out[0], 0x3c00);
  EXPECT_EQ(out[1], 0xc100);
  EXPECT_EQ(float_to_half(in.data(), 3, out.data()), 3u);
  EXPECT_EQ(float_to_half(in.data(), 0, out.data()), 0u);
}

// A random matrix rounded to halves, row-major with leading dimension lda (padding: NaN
// halves, so a read past a row shows), and the same values as floats.
struct HalfMatrix {
  std::vector<std::uint16_t> half;
  std::vector<float> value;
  std::size_t lda = 0;
};

HalfMatrix random_half_matrix(std::mt19937& rng, std::size_t rows, std::size_t cols, std::size_t lda) {
  HalfMatrix m{std::vector<std::uint16_t>(rows * lda, 0x7e00),
               std::vector<float>(rows * lda, std::numeric_limits<float>::quiet_NaN()), lda};
  std::uniform_real_distribution<float> d(-1.0f, 1.0f);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t k = 0; k < cols; ++k) {
      std::uint16_t h = 0;
      EXPECT_TRUE(float_to_half(d(rng), &h));
      m.half[r * lda + k] = h;
      m.value[r * lda + k] = half_to_float(h);
    }
  return m;
}

// The float kernel an _f16 kernel equals bit for bit: the same ISA, except AVX2 without F16C
// (then the SSE4.1 variant runs).
Isa float_twin(Isa isa) { return isa == Isa::avx2 && !f16c_active() ? Isa::sse41 : isa; }

// Every ISA's f16 GEMV equals the scalar f16 twin within 1e-5 relative, and the float kernel
// on the same (half-rounded) values bit for bit; the scalar twin equals core's reference on
// those values bit for bit.
TEST(CpuKernels, GemvF16MatchesScalarTwinForEveryIsaAndSize) {
  std::printf("  F16C: %s\n", f16c_supported() ? "yes" : "no");
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(4321);
    Worst worst;
    for (std::uint32_t rows : kRowSizes)
      for (std::uint32_t cols : kColSizes)
        for (bool accumulate : {false, true}) {
          const std::size_t lda = cols + (rows % 2 ? 3 : 0), stride = cols + (cols % 3);
          const HalfMatrix A = random_half_matrix(rng, rows, cols, lda);
          const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
          std::vector<float> planar(3 * stride, std::numeric_limits<float>::quiet_NaN());
          deinterleave_rgb(in.data(), cols, planar.data(), stride);
          const std::vector<float> start = random_vector(rng, 3 * std::size_t(rows), 0.0f, 1.0f);
          std::vector<float> twin = start, got = start, as_float = start;
          gemv_rgb_f16(Isa::scalar, A.half.data(), rows, cols, lda, planar.data(), stride, twin.data(),
                       accumulate);
          gemv_rgb_f16(isa, A.half.data(), rows, cols, lda, planar.data(), stride, got.data(), accumulate);
          gemv_rgb(float_twin(isa), A.value.data(), rows, cols, lda, planar.data(), stride, as_float.data(),
                   accumulate);
          const std::string what = std::string(isa_name(isa)) + " f16 " + std::to_string(rows) + "x" +
                                   std::to_string(cols) + (accumulate ? " accumulate" : "");
          expect_close(got, twin, what, &worst);
          EXPECT_EQ(got, as_float) << what;
          if (isa == Isa::scalar) {
            Matrix dense(rows, cols);
            for (std::size_t r = 0; r < rows; ++r)
              std::copy_n(A.value.begin() + std::ptrdiff_t(r * lda), cols,
                          dense.data.begin() + std::ptrdiff_t(r * cols));
            std::vector<float> ref = start;
            reference_gemv_rgb(dense, in.data(), ref.data(), accumulate);
            EXPECT_EQ(twin, ref) << what;
          }
        }
    worst.print("gemv_rgb_f16", isa);
  }
}

// The scatter and masked f16 kernels: within 1e-5 of the scalar f16 twin, bit for bit the float
// kernels on the same values, and masked + add_scattered writes the scatter's bits.
TEST(CpuKernels, ScatterAndMaskedF16MatchScalarTwin) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(555);
    Worst worst;
    for (std::uint32_t rows : kRowSizes)
      for (std::uint32_t cols : kColSizes) {
        if (cols > 100) continue;
        const HalfMatrix A = random_half_matrix(rng, rows, cols, cols);
        const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
        std::vector<float> planar(3 * std::size_t(cols));
        deinterleave_rgb(in.data(), cols, planar.data(), cols);
        const std::size_t samples = 2 * std::size_t(rows) + 1;
        std::vector<std::int32_t> perm(samples);
        for (std::size_t i = 0; i < samples; ++i) perm[i] = std::int32_t(i);
        std::shuffle(perm.begin(), perm.end(), rng);
        std::vector<std::int32_t> map(rows);
        for (std::uint32_t r = 0; r < rows; ++r) map[r] = rng() % 3 == 0 ? -1 : perm[r];
        if (rows >= 8) std::fill(map.begin(), map.begin() + 4, -1);
        const std::vector<float> base = random_vector(rng, 3 * samples, 0.0f, 1.0f);
        std::vector<float> twin = base, got = base, as_float = base, added = base;
        gemv_rgb_scatter_f16(Isa::scalar, A.half.data(), rows, cols, cols, map.data(), planar.data(), cols,
                             twin.data());
        gemv_rgb_scatter_f16(isa, A.half.data(), rows, cols, cols, map.data(), planar.data(), cols,
                             got.data());
        gemv_rgb_scatter(float_twin(isa), A.value.data(), rows, cols, cols, map.data(), planar.data(), cols,
                         as_float.data());
        const std::string what =
            std::string(isa_name(isa)) + " f16 scatter " + std::to_string(rows) + "x" + std::to_string(cols);
        expect_close(got, twin, what, &worst);
        EXPECT_EQ(got, as_float) << what;
        const float sentinel = -7.0f;
        std::vector<float> values(3 * std::size_t(rows), sentinel), values_float = values;
        gemv_rgb_masked_f16(isa, A.half.data(), rows, cols, cols, map.data(), planar.data(), cols,
                            values.data());
        gemv_rgb_masked(float_twin(isa), A.value.data(), rows, cols, cols, map.data(), planar.data(), cols,
                        values_float.data());
        EXPECT_EQ(values, values_float) << what;
        for (std::uint32_t r = 0; r < rows; ++r)
          if (map[r] < 0) {
            EXPECT_EQ(values[3 * r], sentinel) << what;
          }
        add_scattered(rows, map.data(), values.data(), added.data());
        EXPECT_EQ(added, got) << what;
      }
    worst.print("gemv_rgb_scatter_f16", isa);
  }
}

// Without F16C (forced off here) the AVX2 f16 kernels run the SSE4.1 variant: its bits, not
// the F16C path's; the switch refuses to turn F16C on where the CPU lacks it.
TEST(CpuKernels, F16WithoutF16cRunsTheSse41Variant) {
  if (!isa_supported(Isa::avx2) || !isa_supported(Isa::sse41)) GTEST_SKIP() << "no AVX2 / SSE4.1 here";
  const bool before = f16c_active();
  EXPECT_EQ(set_f16c(true), f16c_supported());
  ASSERT_TRUE(set_f16c(false));
  EXPECT_FALSE(f16c_active());
  std::mt19937 rng(8);
  int differs_from_f16c = 0;
  for (std::uint32_t rows : {1u, 5u, 16u, 33u})
    for (std::uint32_t cols : {3u, 12u, 31u, 100u}) {
      const HalfMatrix A = random_half_matrix(rng, rows, cols, cols);
      const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
      std::vector<float> planar(3 * std::size_t(cols));
      deinterleave_rgb(in.data(), cols, planar.data(), cols);
      std::vector<float> got(3 * std::size_t(rows)), sse(got.size()), avx(got.size());
      gemv_rgb_f16(Isa::avx2, A.half.data(), rows, cols, cols, planar.data(), cols, got.data(), false);
      gemv_rgb(Isa::sse41, A.value.data(), rows, cols, cols, planar.data(), cols, sse.data(), false);
      gemv_rgb(Isa::avx2, A.value.data(), rows, cols, cols, planar.data(), cols, avx.data(), false);
      EXPECT_EQ(got, sse) << rows << "x" << cols;
      differs_from_f16c += got != avx;
    }
  EXPECT_GT(differs_from_f16c, 0);  // the two variants do round differently: the test can tell
  EXPECT_TRUE(set_f16c(before));
}

}  // namespace
}  // namespace modrt::cpu
