// SPDX-License-Identifier: MIT
// Numerical stress (issue 9): the runtime driven far outside comfortable inputs, through the
// real dictionary, level build and SIMD CPU runtime (no mocks). Each test prints what it
// measured; docs/robustness.md has the table.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "level_fixtures.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/cpu/direct_light.h"
#include "modrt/cpu/isa.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/bake.h"
#include "stress/stress_report.h"

#if defined(__x86_64__) || defined(_M_X64)
#include <xmmintrin.h>
#endif

namespace modrt::cpu {
namespace {

using test::test_level;
using test::TestLevel;

const Dictionary& dict() { return test::small_test_dictionary(); }

double rel_l2(std::span<const float> a, std::span<const float> b, double scale_b = 1.0) {
  double num = 0, den = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double d = double(a[i]) - scale_b * double(b[i]);
    num += d * d;
    den += scale_b * scale_b * double(b[i]) * b[i];
  }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

bool all_finite(std::span<const float> v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

// The calling thread's float control register (MXCSR, FPCR), to check that the runtime
// restores it.
unsigned fp_control() {
#if defined(__x86_64__) || defined(_M_X64)
  return _mm_getcsr();
#elif defined(__aarch64__)
  std::uint64_t fpcr;
  __asm__ volatile("mrs %0, fpcr" : "=r"(fpcr));
  return unsigned(fpcr);
#else
  return 0;
#endif
}

// Multi-bounce feedback over 10 000 steps with uniform albedo 0, 0.99, 1.0 and 1.5: the
// albedo is clamped to max_albedo = 0.95 and the fed-back lightmap to max(ld) / (1 - 0.95)
// (architecture.md §2, core's apply_feedback), so the iteration stays finite and bounded whatever the
// spectral radius of the low-rank operator. That radius, rho(0.95 F) estimated by power
// iteration on the linear part, is printed: below 1 the steps converge (checked), above 1
// the clamp alone bounds them.
TEST(Stress, MultiBounceStaysBoundedForAnyAlbedo) {
  const TestLevel& t = test_level("maze11");
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict());
  ASSERT_TRUE(rt.ok());
  const std::size_t n = rt->sizes().lightmap;
  // Spectral radius of L -> F(0.95 L), the feedback's linear part, by power iteration.
  std::vector<float> x(n, 1.0f), y(n);
  double radius = 0.0;
  for (int it = 0; it < 60; ++it) {
    for (float& v : x) v *= 0.95f;
    ASSERT_TRUE(rt->evaluate(std::vector<float>(x.begin(), x.end()), y).ok());
    double norm = 0, prev = 0;
    for (std::size_t i = 0; i < n; ++i)
      norm += double(std::max(y[i], 0.0f)) * std::max(y[i], 0.0f), prev += double(x[i]) * x[i];
    radius = std::sqrt(norm / prev);
    const double scale = 1.0 / std::sqrt(norm / double(n));
    for (std::size_t i = 0; i < n; ++i) x[i] = float(std::max(y[i], 0.0f) * scale);
  }
  // A physical one-bounce operator has radius <= 1 (a closed white box returns all light); the
  // low-rank MRT operator can exceed it slightly, which is why the feedback is clamped.
  std::printf(
      "  spectral radius: one-bounce operator F %.4f, feedback 0.95 F %.6f (maze11, test dictionary)\n",
      radius / 0.95, radius);
  stress::report("multi-bounce feedback (maze11)", "spectral radius (power iteration)",
                 stress::fmt("F %.4f, 0.95 F %.6f", radius / 0.95, radius));
  for (float albedo : {0.0f, 0.99f, 1.0f, 1.5f}) {
    Result<CpuLevelRuntime> r = CpuLevelRuntime::create(t.level, dict());
    ASSERT_TRUE(r.ok());
    ASSERT_TRUE(r->set_albedo(std::vector<float>(n, albedo)).ok());
    std::vector<float> lightmap(n), previous(n), one_bounce(n);
    ASSERT_TRUE(r->evaluate(t.ld, one_bounce).ok());
    lightmap = one_bounce;
    const float ld_max = *std::max_element(t.ld.begin(), t.ld.end());
    const float bound = ld_max / (1.0f - std::min(albedo, 0.95f));
    bool clamped_ever = false;
    double last_change = 0.0;
    for (int step = 0; step < 10000; ++step) {
      previous = lightmap;
      bool clamped = false;
      ASSERT_TRUE(r->multi_bounce_step(t.ld, lightmap, &clamped).ok()) << "step " << step;
      clamped_ever |= clamped;
      if (step % 1000 == 999) {
        ASSERT_TRUE(all_finite(lightmap)) << "albedo " << albedo << " step " << step;
      }
      if (step == 9999) last_change = rel_l2(lightmap, previous);
    }
    const float lm_max = *std::max_element(lightmap.begin(), lightmap.end());
    // The one-bounce operator applied to an ld bounded by `bound` per value.
    const float one_max = *std::max_element(one_bounce.begin(), one_bounce.end());
    EXPECT_TRUE(all_finite(lightmap));
    EXPECT_LE(lm_max, one_max / ld_max * bound * 1.5f) << "albedo " << albedo;
    if (albedo == 0.0f) {
      EXPECT_EQ(lightmap, one_bounce);
    }
    if (radius < 0.99) {  // a contraction with margin converges well within 10 000 steps
      EXPECT_LT(last_change, 1e-6) << "albedo " << albedo;
    }
    stress::row(stress::fmt("multi-bounce albedo %.2f, 10 000 steps (maze11)", albedo), "lightmap max",
                stress::fmt("%.4g, last step change %.1e", lm_max, last_change),
                stress::fmt("finite, <= 1.5 x %.4g (clamp)", one_max / ld_max * bound),
                all_finite(lightmap) && lm_max <= one_max / ld_max * bound * 1.5f);
    std::printf(
        "  albedo %.2f: 10 000 steps, max %.4g (bound %.4g x one-bounce gain %.3f), last step change %.2e, "
        "energy clamp %s\n",
        albedo, lm_max, bound, one_max / ld_max, last_change, clamped_ever ? "hit" : "never hit");
  }
}

// Light from 1e-8 to 1e8 times the fixture's: the lightmap scales with it (linear transport),
// within float rounding, and stays finite. Beyond float's range the runtime's policy applies:
// ld must be finite (rejected otherwise, naming the sample); finite ld as large as 1e30 gives
// a finite lightmap.
TEST(Stress, LightIntensityOverSixteenDecadesIsLinear) {
  const TestLevel& t = test_level("maze41");
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict());
  ASSERT_TRUE(rt.ok());
  std::vector<float> reference(rt->sizes().lightmap), lightmap(reference.size());
  ASSERT_TRUE(rt->evaluate(t.ld, reference).ok());
  for (double scale : {1e-8, 1e-4, 1e4, 1e8, 1e20, 1e30}) {
    std::vector<float> ld(t.ld);
    for (float& v : ld) v = float(double(v) * scale);
    ASSERT_TRUE(rt->evaluate(ld, lightmap).ok());
    EXPECT_TRUE(all_finite(lightmap)) << scale;
    const double e = rel_l2(lightmap, reference, scale);
    EXPECT_LT(e, 1e-6) << scale;
    std::printf("  ld x %.0e: lightmap vs scaled reference rel L2 %.2e\n", scale, e);
    stress::row(stress::fmt("ld x %.0e (maze41)", scale), "lightmap vs scale x reference",
                stress::fmt("%.2e", e), "<= 1e-6, finite", e < 1e-6 && all_finite(lightmap));
  }
  std::vector<float> ld(t.ld);
  ld[5] = std::numeric_limits<float>::infinity();
  const Status inf_status = rt->evaluate(ld, lightmap);
  EXPECT_EQ(inf_status.code(), ErrorCode::non_finite);
  ld[5] = std::numeric_limits<float>::quiet_NaN();
  const Status nan_status = rt->evaluate(ld, lightmap);
  EXPECT_EQ(nan_status.code(), ErrorCode::non_finite);
  stress::row("ld with Inf / NaN", "validate_light_signal", "non_finite, names sample and channel", "refused",
              inf_status.code() == ErrorCode::non_finite && nan_status.code() == ErrorCode::non_finite);
  ld = t.ld;
  ld[7] = -1.0f;
  const Status negative = rt->evaluate(ld, lightmap);
  EXPECT_EQ(negative.code(), ErrorCode::invalid_argument);
  stress::row("ld with a negative value", "validate_light_signal", "invalid_argument", "refused",
              negative.code() == ErrorCode::invalid_argument);
  // Finite but beyond kMaxLightValue, where transport could overflow: refused, naming it.
  ld = t.ld;
  for (float& v : ld) v *= 1e31f;
  const Status s = rt->evaluate(ld, lightmap);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("largest light value"), std::string::npos) << s.message();
  stress::row("ld x 1e31 (above kMaxLightValue 1e30)", "validate_light_signal", "invalid_argument", "refused",
              s.code() == ErrorCode::invalid_argument);
}

// Denormal ld (1e-40, below FLT_MIN = 1.2e-38). By default the runtime flushes subnormals to
// zero while it computes (CpuRuntimeOptions::flush_denormals, fp_env.h): the lightmap is then
// exactly 0, and the caller's FPU control word is left as it was. With the flush off, IEEE
// gradual underflow keeps the normal-range lightmap's shape roughly (subnormals carry fewer
// significant bits). Either way finite. The cost: modrt-bench-stress BM_CpuDenormalLd.
TEST(Stress, DenormalLightIsFlushedToZero) {
  const TestLevel& t = test_level("maze11");
  std::vector<float> reference(level_buffer_sizes(t.level, dict()).lightmap), lightmap(reference.size());
  const float ld_max = *std::max_element(t.ld.begin(), t.ld.end());
  std::vector<float> ld(t.ld);
  for (float& v : ld) v = v / ld_max * 1e-40f;
  for (Isa isa : supported_isas()) {
    CpuRuntimeOptions options;
    options.isa = isa;
    Result<CpuLevelRuntime> flushing = CpuLevelRuntime::create(t.level, dict(), options);
    options.flush_denormals = false;
    Result<CpuLevelRuntime> gradual = CpuLevelRuntime::create(t.level, dict(), options);
    ASSERT_TRUE(flushing.ok() && gradual.ok());
    ASSERT_TRUE(gradual->evaluate(t.ld, reference).ok());
    const unsigned before = fp_control();
    ASSERT_TRUE(flushing->evaluate(ld, lightmap).ok());
    const bool restored = fp_control() == before;
    const float flushed_max = *std::max_element(lightmap.begin(), lightmap.end());
    const float flushed_min = *std::min_element(lightmap.begin(), lightmap.end());
    EXPECT_TRUE(stress::row(std::string("ld at 1e-40, flush on (default), ") + isa_name(isa), "lightmap",
                            stress::fmt("max %.3g, min %.3g, FPU control word %s", double(flushed_max),
                                        double(flushed_min), restored ? "restored" : "CHANGED"),
                            "exactly 0, control word restored",
                            flushed_max == 0.0f && flushed_min == 0.0f && restored));
    ASSERT_TRUE(gradual->evaluate(ld, lightmap).ok());
    const float out_max = *std::max_element(lightmap.begin(), lightmap.end());
    const float ref_max = *std::max_element(reference.begin(), reference.end());
    const double shape = rel_l2(lightmap, reference, double(out_max) / ref_max);
    EXPECT_TRUE(
        stress::row(std::string("ld at 1e-40, flush off, ") + isa_name(isa), "lightmap",
                    stress::fmt("max %.3g, shape vs normal range rel L2 %.3f", double(out_max), shape),
                    "finite, shape within 0.05", all_finite(lightmap) && out_max > 0.0f && shape < 0.05));
  }
}

// A long animated run: a point light circling through maze41 (CpuDirectLight, incremental),
// the runtime with exact skipping against a full evaluation at checkpoints: bit-identical at
// every checkpoint, so skipping does not drift. 20 000 frames here (about a minute);
// MODRT_STRESS_FRAMES=100000 for the full length.
TEST(Stress, LongAnimatedRunDoesNotDrift) {
  const TestLevel& t = test_level("maze41");
  int frames = 20000;
  if (const char* env = std::getenv("MODRT_STRESS_FRAMES")) frames = std::max(1, std::atoi(env));
  Result<CpuDirectLight> direct = CpuDirectLight::create(t.level, t.albedo);
  ASSERT_TRUE(direct.ok()) << direct.status().to_string();
  CpuRuntimeOptions skip_options;
  skip_options.skip.enabled = true;
  Result<CpuLevelRuntime> skipping = CpuLevelRuntime::create(t.level, dict(), skip_options);
  Result<CpuLevelRuntime> full = CpuLevelRuntime::create(t.level, dict());
  ASSERT_TRUE(skipping.ok() && full.ok());
  std::vector<float> ld(t.ld.size()), lm_skip(skipping->sizes().lightmap), lm_full(lm_skip.size());
  const glm::vec3 centre(t.description.lights.at(0).position);
  std::size_t checkpoints = 0, mismatches = 0, kept_blocks = 0;
  for (int f = 0; f < frames; ++f) {
    CpuLight light;
    const float a = 0.01f * float(f);
    light.position = centre + glm::vec3(0.3f * std::cos(a), 0.1f * std::sin(3.0f * a), 0.3f * std::sin(a));
    light.intensity = 1.0f + 0.5f * std::sin(0.003f * float(f));
    ASSERT_TRUE(direct->evaluate(std::span(&light, 1), ld).ok()) << "frame " << f;
    ASSERT_TRUE(skipping->evaluate(ld, lm_skip).ok()) << "frame " << f;
    kept_blocks += skipping->skip_stats().blocks_kept + skipping->skip_stats().blocks_dark;
    if (f % 1000 == 999 || f == frames - 1) {
      ASSERT_TRUE(full->evaluate(ld, lm_full).ok());
      ++checkpoints;
      mismatches += lm_skip != lm_full;
    }
  }
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(kept_blocks, 0u);
  stress::row(
      stress::fmt("%d frames, animated light, skipping on (maze41)", frames), "incremental vs full lightmap",
      stress::fmt("%zu of %zu checkpoints differ; %.0f%% block-frames skipped", mismatches, checkpoints,
                  100.0 * double(kept_blocks) / double(std::size_t(frames) * t.level.blocks.size())),
      "bit-identical (bound 0)", mismatches == 0);
  std::printf(
      "  %d frames, %zu checkpoints bit-identical to the full path: %s; blocks skipped (kept or dark) %zu of "
      "%zu\n",
      frames, checkpoints, mismatches == 0 ? "yes" : "NO", kept_blocks,
      std::size_t(frames) * t.level.blocks.size());
}

// Resource limits: a bake or a level that would need more memory than its budget is refused
// up front, with the estimate in the message, instead of failing (or swapping) half-way.
TEST(Stress, OversizedBakesAndLevelsAreRefusedUpFront) {
  DictionarySettings huge;
  huge.res = 64;  // F alone is 24 576^2 doubles
  Result<Dictionary> d = precompute::bake_dictionary(huge);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().code(), ErrorCode::resource_limit);
  EXPECT_NE(d.status().message().find("memory budget"), std::string::npos) << d.status().message();
  const std::uint64_t default_need = precompute::estimate_bake_bytes(DictionarySettings{});
  EXPECT_LT(default_need, precompute::kDefaultBakeMemoryBudget);
  stress::row("bake res 64 (default settings otherwise)", "bake_dictionary",
              stress::fmt("refused, estimate %.1f GiB",
                          double(precompute::estimate_bake_bytes(huge)) / double(1u << 30)),
              "resource_limit (budget 8 GiB)", d.status().code() == ErrorCode::resource_limit);
  std::printf("  bake estimate: default settings %.2f GiB, res 64 %.1f GiB (budget %.0f GiB)\n",
              double(default_need) / double(1u << 30),
              double(precompute::estimate_bake_bytes(huge)) / double(1u << 30),
              double(precompute::kDefaultBakeMemoryBudget) / double(1u << 30));

  // A 250 000-block corridor at res 8: the estimate refuses it before validating a block.
  LevelDescription corridor;
  corridor.blocks.resize(250000);
  for (std::size_t i = 0; i < corridor.blocks.size(); ++i) {
    BlockDescription& b = corridor.blocks[i];
    b.cell = glm::ivec3(int(i), 0, 0);
    b.faces = kAllFaces;
    if (i > 0) b.faces &= FaceMask(~(1u << kFaceNegX));
    if (i + 1 < corridor.blocks.size()) b.faces &= FaceMask(~(1u << kFacePosX));
    b.albedo.fill(glm::dvec3(0.5));
  }
  precompute::LevelBuildSettings settings;
  Result<Level> level = precompute::build_level(corridor, dict(), settings);
  ASSERT_FALSE(level.ok());
  EXPECT_EQ(level.status().code(), ErrorCode::resource_limit);
  EXPECT_NE(level.status().message().find("250000 blocks"), std::string::npos) << level.status().message();
  // The same budget lets the test mazes through; a tiny one refuses maze41.
  const TestLevel& t = test_level("maze41");
  EXPECT_LT(precompute::estimate_level_bytes(t.description, dict()), settings.memory_budget_bytes);
  settings.memory_budget_bytes = 1 << 20;
  EXPECT_EQ(precompute::build_level(t.description, dict(), settings).status().code(),
            ErrorCode::resource_limit);
  stress::row("level of 250 000 blocks", "build_level", "refused before validating a block",
              "resource_limit (budget 4 GiB)", level.status().code() == ErrorCode::resource_limit);
  std::printf("  level estimate: maze41 %.1f MiB, 250 000-block corridor %.1f GiB (budget 4 GiB)\n",
              double(precompute::estimate_level_bytes(t.description, dict())) / double(1u << 20),
              double(precompute::estimate_level_bytes(corridor, dict())) / double(1u << 30));
}

}  // namespace
}  // namespace modrt::cpu
