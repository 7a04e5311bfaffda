// SPDX-License-Identifier: MIT
// SIMD CPU level runtime (cpu_neon/) against core's scalar reference for every ISA this CPU
// supports (the kernels alone: test_cpu_kernels.cpp); no allocation per frame; the thread
// pool bit-identical to one thread; bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <new>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "counting_allocator.h"
#include "cpu_test_support.h"
#include "level_fixtures.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/cpu/kernels.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/reduced_feedback.h"
#include "modrt/reference_runtime.h"

namespace modrt::cpu {
namespace {

using namespace cpu_test;

CpuRuntimeOptions options(Isa isa, int threads, CpuSkipOptions skip = {},
                          OperatorStorage operators = OperatorStorage::float32) {
  CpuRuntimeOptions o;
  o.isa = isa;
  o.threads = threads;
  o.skip = skip;
  o.operators = operators;
  return o;
}

const char* storage_name(OperatorStorage s) { return s == OperatorStorage::float16 ? "float16" : "float32"; }

// ---- the level runtime against core's level_evaluate ----

const Dictionary& dict() { return modrt::test::small_test_dictionary(); }

using modrt::test::level_reference;
using modrt::test::test_level;
using modrt::test::test_levels;
using modrt::test::TestLevel;
using Reference = modrt::test::LevelReference;

// (|Td_b| ld)_i per b element: the sum of the magnitudes that cancel into b_i.
std::vector<double> b_magnitudes(const Level& level, std::span<const float> ld) {
  std::vector<double> out;
  for (const LevelBlock& blk : level.blocks) {
    const Matrix& T = block_operators(dict(), level, blk).Td_b;
    for (std::uint32_t k = 0; k < level.kb; ++k)  // b's stride; zero past the block's modes
      for (int c = 0; c < 3; ++c) {
        double acc = 0.0;
        for (std::uint32_t j = 0; k < T.rows && j < T.cols; ++j)
          acc += std::abs(double(T(k, j))) * ld[3 * (std::size_t(blk.sample_offset) + j) + std::size_t(c)];
        out.push_back(acc);
      }
  }
  return out;
}

// b's high modes cancel heavily: (|Td_b| ld)_k reaches ~1e3 |b_k| (Td_b = Sm^-1 Um^T F P P^T
// has large, mixed-sign rows for small singular values), beyond what float accumulation
// resolves to 1e-5 per element. So b's per-element floor also includes 1e-2 (|Td_b| ld)_k
// (a backward-error bound of 1e-7 per element); its L2 error and every other output
// (r, lightmap, atlas, probes: b's high modes enter them scaled by their small singular
// values) are held to 1e-5 with the plain floor.
TEST(CpuLevelRuntime, EvaluateMatchesLevelEvaluateForEveryIsa) {
  for (const TestLevel& t : test_levels()) {
    const Reference ref = level_reference(t.level, t.ld);
    const std::vector<double> b_scale = b_magnitudes(t.level, t.ld);
    for (Isa isa : supported_isas()) {
      Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), options(isa, 1));
      ASSERT_TRUE(rt.ok()) << rt.status().to_string();
      EXPECT_EQ(rt->isa(), isa);
      const LevelBufferSizes& s = rt->sizes();
      std::vector<float> lightmap(s.lightmap), atlas(s.atlas), probes(s.probes), vec(s.vector_lightmap);
      for (int frame = 0; frame < 2; ++frame) {  // the second frame reuses every buffer
        const Status st = rt->evaluate(t.ld, lightmap);
        ASSERT_TRUE(st.ok()) << st.to_string();
      }
      ASSERT_TRUE(rt->fill_atlas(lightmap, atlas).ok());
      ASSERT_TRUE(rt->compute_probes(probes).ok());
      ASSERT_TRUE(rt->has_vector_irradiance());
      const Status vs = rt->compute_vector_irradiance(vec);
      ASSERT_TRUE(vs.ok()) << vs.to_string();
      const std::string what = std::string(t.name) + " " + isa_name(isa);
      Worst wb, wr, wl, wa, wp, wv;
      expect_close(rt->b(), ref.b, what + " b", &wb, b_scale);
      expect_close(rt->r(), ref.r, what + " r", &wr);
      expect_close(lightmap, ref.lightmap, what + " lightmap", &wl);
      expect_close(atlas, ref.atlas, what + " atlas", &wa);
      expect_close(probes, ref.probes, what + " probes", &wp);
      expect_close(vec, ref.vector_lightmap, what + " vector irradiance", &wv);
      std::printf("  %s\n", t.name.c_str());
      wb.print("b", isa), wr.print("r", isa), wl.print("lightmap", isa), wa.print("atlas", isa),
          wp.print("probes", isa), wv.print("vector irradiance", isa);
    }
  }
}

// The incremental solve's application against core's reference, every ISA, one and two threads:
// y and r accumulated over two sets of blocks, r read back through finish_reduced_solve (as the
// tiles read it).
TEST(CpuLevelRuntime, ReducedDeltaApplicationMatchesReference) {
  const TestLevel& t = test_level("maze41");
  const LevelDependencies deps = level_dependencies(t.level);
  Result<ReducedFeedback> op = build_reduced_feedback(t.level, dict(), deps, t.albedo);
  ASSERT_TRUE(op.ok());
  const LevelBufferSizes s = level_buffer_sizes(t.level, dict());
  std::vector<float> b0(s.b);
  ASSERT_TRUE(level_compute_b(t.level, dict(), t.ld, b0).ok());
  std::vector<std::uint8_t> first(t.level.blocks.size()), second(t.level.blocks.size());
  for (std::size_t i = 0; i < first.size(); ++i) first[i] = i % 4 == 1, second[i] = i % 5 == 2;
  std::vector<float> y_ref(s.b, 0.5f), r_ref(s.r, 0.25f), r_delta(s.r);
  reference_apply_reduced_feedback_delta(t.level, deps, op.value(), b0, first, y_ref, r_ref, r_delta);
  reference_apply_reduced_feedback_delta(t.level, deps, op.value(), b0, second, y_ref, r_ref, r_delta);
  for (int threads : {1, 2})
    for (Isa isa : supported_isas()) {
      Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), options(isa, threads));
      ASSERT_TRUE(rt.ok()) << rt.status().to_string();
      std::vector<float> y(s.b, 0.5f), r(s.r, 0.25f);
      rt->apply_reduced_feedback_delta(op.value(), b0, first, y, r);
      rt->apply_reduced_feedback_delta(op.value(), b0, second, y, r);
      rt->finish_reduced_solve(b0, r);
      const std::string what = std::string(isa_name(isa)) + " threads " + std::to_string(threads);
      Worst wy, wr;
      expect_close(y, y_ref, what + " y", &wy);
      expect_close(rt->r(), r_ref, what + " r", &wr);
      wy.print("G d", isa), wr.print("Tb->r d", isa);
    }
}

TEST(CpuLevelRuntime, ScalarAtlasIsExact) {
  const TestLevel& t = test_level("maze11");
  const Reference ref = level_reference(t.level, t.ld);
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), options(Isa::scalar, 1));
  ASSERT_TRUE(rt.ok());
  std::vector<float> atlas(rt->sizes().atlas);
  ASSERT_TRUE(rt->fill_atlas(ref.lightmap, atlas).ok());
  EXPECT_EQ(atlas, ref.atlas);
}

TEST(CpuLevelRuntime, MultiBounceStepsMatchLevelMultiBounce) {
  constexpr int kSteps = 6;
  for (const TestLevel& t : test_levels()) {
    std::vector<float> albedo = t.albedo;
    for (std::size_t i = 0; i < albedo.size(); i += 7) albedo[i] = 0.99f;  // some get clamped to 0.95
    const LevelBufferSizes s = level_buffer_sizes(t.level, dict());
    std::vector<float> b(s.b), r(s.r), ref(s.lightmap);
    MultiBounceSettings settings;
    settings.max_iterations = kSteps;
    settings.tolerance = 0.0f;
    const Result<MultiBounceReport> rep =
        level_multi_bounce(t.level, dict(), t.ld, albedo, settings, b, r, ref);
    ASSERT_TRUE(rep.ok()) << rep.status().to_string();
    ASSERT_EQ(rep->iterations, kSteps);
    for (Isa isa : supported_isas()) {
      Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), options(isa, 1));
      ASSERT_TRUE(rt.ok());
      ASSERT_TRUE(rt->set_albedo(albedo, settings.max_albedo).ok());
      std::vector<float> lightmap(s.lightmap);
      ASSERT_TRUE(rt->evaluate(t.ld, lightmap).ok());
      bool any_clamped = false;
      for (int k = 0; k < kSteps; ++k) {
        bool clamped = false;
        const Status st = rt->multi_bounce_step(t.ld, lightmap, &clamped);
        ASSERT_TRUE(st.ok()) << st.to_string();
        any_clamped |= clamped;
      }
      EXPECT_EQ(any_clamped, rep->value_clamped);
      Worst w;
      expect_close(lightmap, ref, std::string(t.name) + " " + isa_name(isa) + " multi-bounce", &w);
      w.print((std::string(t.name) + " multi-bounce").c_str(), isa);
    }
  }
}

// No allocation per frame, with one thread and with the pool (threads = 2 and 3), with
// skipping off and on, with float32 and float16 operators (ld alternating between two signals so that
// skipping has work to do).
TEST(CpuLevelRuntime, NoAllocationPerFrame) {
  const TestLevel& t = test_level("maze41");
  std::vector<float> ld2 = t.ld;
  for (std::size_t i = 0; i < ld2.size(); ++i) ld2[i] *= i < ld2.size() / 2 ? 1.5f : 1.0f;
  CpuSkipOptions skip;
  skip.enabled = true;
  skip.ld_epsilon = 0.01f;
  skip.record_epsilon = 0.01f;
  for (OperatorStorage ops : {OperatorStorage::float32, OperatorStorage::float16})
    for (bool skipping : {false, true})
      for (int threads : {1, 2, 3})
        for (Isa isa : supported_isas()) {
          const std::string what = std::string(isa_name(isa)) + " threads " + std::to_string(threads) +
                                   (skipping ? " skipping " : " ") + storage_name(ops);
          Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(
              t.level, dict(), options(isa, threads, skipping ? skip : CpuSkipOptions{}, ops));
          ASSERT_TRUE(rt.ok()) << rt.status().to_string();
          EXPECT_EQ(rt->threads(), threads);
          const LevelBufferSizes& s = rt->sizes();
          std::vector<float> lightmap(s.lightmap), atlas(s.atlas), probes(s.probes), vec(s.vector_lightmap);
          ASSERT_TRUE(rt->set_albedo(t.albedo).ok());
          bool ok = true;
          g_allocations = 0;
          g_count_allocations = true;
          for (int frame = 0; frame < 10; ++frame) ok &= rt->evaluate(frame % 2 ? ld2 : t.ld, lightmap).ok();
          const long evaluate_allocations = g_allocations.load();
          for (int frame = 0; frame < 10; ++frame) {
            ok &= rt->multi_bounce_step(frame % 2 ? ld2 : t.ld, lightmap).ok();
            ok &= rt->fill_atlas(lightmap, atlas).ok();
            ok &= rt->compute_probes(probes).ok();
            ok &= rt->compute_vector_irradiance(vec).ok();
          }
          g_count_allocations = false;
          const long other_allocations = g_allocations.load() - evaluate_allocations;
          EXPECT_EQ(evaluate_allocations, 0) << what;
          EXPECT_EQ(other_allocations, 0) << what;
          EXPECT_TRUE(ok);
          if (skipping) {
            EXPECT_GT(rt->skip_stats().blocks_computed, 0u) << what;
          }
          // The counter works: a failing call builds its error message on the heap.
          std::vector<float> bad = t.ld;
          bad[0] = -1.0f;
          g_count_allocations = true;
          const bool failed = !rt->evaluate(bad, lightmap).ok();
          g_count_allocations = false;
          EXPECT_TRUE(failed);
          EXPECT_GT(g_allocations.load(), 0);
          g_allocations = 0;
        }
}

// The pool changes who computes a block, not how: b, r, lightmap, atlas, probes and
// multi-bounce results are bit-identical for 1, 2, 3 and 8 threads, float32 and float16 operators (more
// threads than this machine's cores, and than the single block has).
TEST(CpuLevelRuntime, ThreadsAreBitIdentical) {
  for (const TestLevel& t : test_levels())
    for (OperatorStorage ops : {OperatorStorage::float32, OperatorStorage::float16})
      for (Isa isa : supported_isas()) {
        struct Out {
          std::vector<float> b, r, lightmap, atlas, probes, bounced, vec;
        };
        auto run = [&](int threads) {
          Result<CpuLevelRuntime> rt =
              CpuLevelRuntime::create(t.level, dict(), options(isa, threads, {}, ops));
          EXPECT_TRUE(rt.ok()) << rt.status().to_string();
          if (!rt.ok()) return Out{};
          const LevelBufferSizes& s = rt->sizes();
          Out o{{},
                {},
                std::vector<float>(s.lightmap),
                std::vector<float>(s.atlas),
                std::vector<float>(s.probes),
                {},
                std::vector<float>(s.vector_lightmap)};
          EXPECT_TRUE(rt->evaluate(t.ld, o.lightmap).ok());
          EXPECT_TRUE(rt->fill_atlas(o.lightmap, o.atlas).ok());
          EXPECT_TRUE(rt->compute_probes(o.probes).ok());
          EXPECT_TRUE(rt->compute_vector_irradiance(o.vec).ok());
          o.b.assign(rt->b().begin(), rt->b().end());
          o.r.assign(rt->r().begin(), rt->r().end());
          o.bounced = o.lightmap;
          EXPECT_TRUE(rt->set_albedo(t.albedo).ok());
          for (int k = 0; k < 3; ++k) EXPECT_TRUE(rt->multi_bounce_step(t.ld, o.bounced).ok());
          return o;
        };
        const Out one = run(1);
        ASSERT_FALSE(one.lightmap.empty());
        EXPECT_TRUE(std::any_of(one.lightmap.begin(), one.lightmap.end(), [](float v) { return v != 0.0f; }));
        for (int threads : {2, 3, 8}) {
          const Out many = run(threads);
          const std::string what =
              t.name + " " + isa_name(isa) + " " + storage_name(ops) + " threads " + std::to_string(threads);
          EXPECT_EQ(many.b, one.b) << what;
          EXPECT_EQ(many.r, one.r) << what;
          EXPECT_EQ(many.lightmap, one.lightmap) << what;
          EXPECT_EQ(many.atlas, one.atlas) << what;
          EXPECT_EQ(many.probes, one.probes) << what;
          EXPECT_EQ(many.vec, one.vec) << what;
          EXPECT_EQ(many.bounced, one.bounced) << what;
        }
      }
}

// ---- skipping (CpuSkipOptions) over an animated light ----

constexpr int kFrames = 300;

// 300 frames of ld on maze41: light 0 circles inside its block (radius 0.25 cells, bobbing),
// is switched off for frames 100-129 (its blocks go dark) and pauses for frames 200-229 (ld
// repeats exactly); light 1 stays put. Direct light with shadows, as the fixtures make it.
const std::vector<std::vector<float>>& moving_light_frames() {
  static const std::vector<std::vector<float>> frames = [] {
    const TestLevel& t = test_level("maze41");
    const precompute::LevelScene scene(t.level, t.level.res);
    const glm::dvec3 centre = t.description.lights.at(0).position;
    const double cell = t.description.cell_size;
    std::vector<std::vector<float>> out;
    for (int f = 0; f < kFrames; ++f) {
      std::vector<LightDescription> lights = t.description.lights;
      const int g = f >= 200 && f < 230 ? 200 : f;
      const double a = 2.0 * 3.14159265358979 * double(g) / double(kFrames);
      lights[0].position =
          centre + cell * glm::dvec3(0.25 * std::cos(a), 0.1 * std::sin(3.0 * a), 0.25 * std::sin(a));
      if (f >= 100 && f < 130) lights[0].intensity = 0.0;
      out.push_back(precompute::level_direct_light(scene, lights, t.albedo, 4));
    }
    return out;
  }();
  return frames;
}

double l2_distance(std::span<const float> a, std::span<const float> b) {
  double acc = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) acc += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
  return std::sqrt(acc);
}

struct SkipTotals {
  CpuSkipStats sum;
  double max_error = 0, max_bound = 0, max_ratio = 0;  // relative to ||lightmap||; error / bound
  void add(const CpuSkipStats& s) {
    sum.blocks_computed += s.blocks_computed;
    sum.blocks_kept += s.blocks_kept;
    sum.blocks_dark += s.blocks_dark;
    sum.records_computed += s.records_computed;
    sum.records_skipped += s.records_skipped;
    sum.slots_kept += s.slots_kept;
    sum.slots_close += s.slots_close;
    sum.tiles_written += s.tiles_written;
    sum.tiles_skipped += s.tiles_skipped;
  }
  void print(const char* what) const {
    std::printf(
        "  %-10s blocks computed %zu kept %zu dark %zu | records computed %zu skipped %zu | slots kept %zu "
        "close %zu | tiles written %zu skipped %zu | max rel error %.3g, max rel bound %.3g, "
        "max error/bound %.3g\n",
        what, sum.blocks_computed, sum.blocks_kept, sum.blocks_dark, sum.records_computed,
        sum.records_skipped, sum.slots_kept, sum.slots_close, sum.tiles_written, sum.tiles_skipped, max_error,
        max_bound, max_ratio);
  }
};

// Exact skipping (every epsilon 0, tiles kept) equals the full path bit for bit, frame after
// frame, for every ISA and with the pool; and it does skip (dark blocks, the paused frames).
TEST(CpuLevelRuntime, ExactSkippingIsBitIdenticalToFullPath) {
  const TestLevel& t = test_level("maze41");
  const auto& frames = moving_light_frames();
  CpuSkipOptions exact;
  exact.enabled = true;
  for (int threads : {1, 2})
    for (Isa isa : supported_isas()) {
      const std::string what = std::string(isa_name(isa)) + " threads " + std::to_string(threads);
      Result<CpuLevelRuntime> full = CpuLevelRuntime::create(t.level, dict(), options(isa, 1));
      Result<CpuLevelRuntime> skip = CpuLevelRuntime::create(t.level, dict(), options(isa, threads, exact));
      ASSERT_TRUE(full.ok() && skip.ok());
      std::vector<float> lm_full(full->sizes().lightmap), lm_skip(lm_full.size());
      std::vector<float> pr_full(full->sizes().probes), pr_skip(pr_full.size());
      SkipTotals totals;
      int mismatched = 0;
      for (int f = 0; f < kFrames; ++f) {
        ASSERT_TRUE(full->evaluate(frames[std::size_t(f)], lm_full).ok());
        ASSERT_TRUE(skip->evaluate(frames[std::size_t(f)], lm_skip).ok());
        totals.add(skip->skip_stats());
        EXPECT_EQ(skip->skip_stats().lightmap_error_bound, 0.0) << what << " frame " << f;
        const bool same = lm_skip == lm_full && std::ranges::equal(skip->b(), full->b()) &&
                          std::ranges::equal(skip->r(), full->r());
        mismatched += !same;
      }
      EXPECT_EQ(mismatched, 0) << what;
      ASSERT_TRUE(full->compute_probes(pr_full).ok());
      ASSERT_TRUE(skip->compute_probes(pr_skip).ok());
      EXPECT_EQ(pr_skip, pr_full) << what;
      std::vector<float> v_full(full->sizes().vector_lightmap), v_skip(v_full.size());
      ASSERT_TRUE(full->compute_vector_irradiance(v_full).ok());
      ASSERT_TRUE(skip->compute_vector_irradiance(v_skip).ok());
      EXPECT_EQ(v_skip, v_full) << what;
      EXPECT_GT(totals.sum.blocks_dark, 0u) << what;
      EXPECT_GT(totals.sum.blocks_kept, 0u) << what;
      EXPECT_GT(totals.sum.records_skipped, 0u) << what;
      EXPECT_GT(totals.sum.slots_kept, 0u) << what;
      EXPECT_GT(totals.sum.tiles_skipped, 0u) << what;
      EXPECT_GT(totals.sum.blocks_computed, 0u) << what;
      if (threads == 1 && isa == best_isa()) totals.print("exact");
    }
}

// Approximate skipping over the 300 frames: every frame's lightmap is within the runtime's
// stated bound (CpuSkipOptions; skip_stats().lightmap_error_bound) of the full path, plus a
// float-rounding allowance of 1e-5 ||lightmap||; each skip alone and all of them together.
TEST(CpuLevelRuntime, SkippingStaysWithinStatedBound) {
  const TestLevel& t = test_level("maze41");
  const auto& frames = moving_light_frames();
  float ld_max = 0.0f;
  for (const auto& ld : frames) ld_max = std::max(ld_max, *std::max_element(ld.begin(), ld.end()));
  struct Case {
    const char* name;
    CpuSkipOptions skip;
  };
  std::vector<Case> cases(5);
  for (Case& c : cases) c.skip.enabled = true;
  cases[0].name = "(a) ld", cases[0].skip.ld_epsilon = 0.05f;
  cases[1].name = "(b) dark", cases[1].skip.dark_ld = 1e-3f * ld_max;
  cases[2].name = "(c) record", cases[2].skip.record_epsilon = 0.05f;
  cases[3].name = "(e) r", cases[3].skip.r_epsilon = 0.02f;
  cases[4].name = "all", cases[4].skip = {true, 0.05f, 1e-3f * ld_max, 0.05f, true, 0.02f};
  const Isa isa = best_isa();
  Result<CpuLevelRuntime> full = CpuLevelRuntime::create(t.level, dict(), options(isa, 1));
  ASSERT_TRUE(full.ok());
  std::vector<std::vector<float>> lm_full(frames.size(), std::vector<float>(full->sizes().lightmap));
  for (std::size_t f = 0; f < frames.size(); ++f) ASSERT_TRUE(full->evaluate(frames[f], lm_full[f]).ok());
  for (const Case& c : cases) {
    Result<CpuLevelRuntime> skip = CpuLevelRuntime::create(t.level, dict(), options(isa, 2, c.skip));
    ASSERT_TRUE(skip.ok());
    std::vector<float> lm(full->sizes().lightmap);
    SkipTotals totals;
    int outside = 0;
    for (std::size_t f = 0; f < frames.size(); ++f) {
      ASSERT_TRUE(skip->evaluate(frames[f], lm).ok());
      const CpuSkipStats& st = skip->skip_stats();
      totals.add(st);
      const double norm =
          std::sqrt(std::inner_product(lm_full[f].begin(), lm_full[f].end(), lm_full[f].begin(), 0.0));
      const double err = l2_distance(lm, lm_full[f]);
      outside += err > st.lightmap_error_bound + 1e-5 * norm;
      totals.max_error = std::max(totals.max_error, err / norm);
      totals.max_bound = std::max(totals.max_bound, st.lightmap_error_bound / norm);
      if (st.lightmap_error_bound > 0)
        totals.max_ratio = std::max(totals.max_ratio, err / st.lightmap_error_bound);
    }
    EXPECT_EQ(outside, 0) << c.name;
    totals.print(c.name);
    if (c.skip.ld_epsilon > 0) {
      EXPECT_GT(totals.sum.blocks_kept, 0u) << c.name;
    }
    if (c.skip.dark_ld > 0) {
      EXPECT_GT(totals.sum.blocks_dark, 0u) << c.name;
    }
    if (c.skip.r_epsilon > 0) {
      EXPECT_GT(totals.sum.slots_close, 0u) << c.name;
    }
    if (c.skip.record_epsilon > 0) {
      EXPECT_GT(totals.sum.records_skipped, 0u) << c.name;
    }
    EXPECT_GT(totals.sum.tiles_skipped, 0u) << c.name;
  }
}

TEST(CpuLevelRuntime, RejectsBadSkipOptions) {
  const TestLevel& t = test_level("maze11");
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict());
  ASSERT_TRUE(rt.ok());
  for (float bad : {-1.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    EXPECT_FALSE(rt->set_skip_options({true, bad, 0.0f, 0.0f, true, 0.0f}).ok());
    EXPECT_FALSE(rt->set_skip_options({true, 0.0f, bad, 0.0f, true, 0.0f}).ok());
    EXPECT_FALSE(rt->set_skip_options({true, 0.0f, 0.0f, bad, true, 0.0f}).ok());
    EXPECT_FALSE(rt->set_skip_options({true, 0.0f, 0.0f, 0.0f, true, bad}).ok());
  }
  EXPECT_FALSE(rt->set_skip_options({true, 0.0f, 0.0f, 1.5f, true, 0.0f}).ok());
  EXPECT_FALSE(
      CpuLevelRuntime::create(t.level, dict(), options(Isa::scalar, 1, {true, -1.0f, 0.0f, 0.0f, true, 0.0f}))
          .ok());
  EXPECT_TRUE(rt->set_skip_options({true, 0.1f, 0.0f, 0.1f, true, 0.0f}).ok());
  EXPECT_TRUE(rt->skip_options().enabled);
}

TEST(CpuLevelRuntime, RejectsBadLightSignal) {
  const TestLevel& t = test_level("maze11");
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict());
  ASSERT_TRUE(rt.ok());
  std::vector<float> lightmap(rt->sizes().lightmap, 0.0f);
  std::vector<float> ld = t.ld;
  ld[3 * 7 + 1] = std::numeric_limits<float>::quiet_NaN();
  Status s = rt->evaluate(ld, lightmap);
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_NE(s.message().find("sample 7 channel G is NaN"), std::string::npos) << s.message();
  EXPECT_TRUE(std::all_of(lightmap.begin(), lightmap.end(), [](float v) { return v == 0.0f; }));
  ld = t.ld;
  ld[3 * 12 + 2] = std::numeric_limits<float>::infinity();
  s = rt->evaluate(ld, lightmap);
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_NE(s.message().find("sample 12 channel B is Inf"), std::string::npos) << s.message();
  ld = t.ld;
  ld[0] = -1.0f;
  s = rt->evaluate(ld, lightmap);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("sample 0 channel R is negative"), std::string::npos) << s.message();
  ld.pop_back();
  EXPECT_EQ(rt->evaluate(ld, lightmap).code(), ErrorCode::invalid_argument);
  std::vector<float> short_lightmap(lightmap.size() - 1);
  EXPECT_EQ(rt->evaluate(t.ld, short_lightmap).code(), ErrorCode::invalid_argument);
  EXPECT_EQ(rt->multi_bounce_step(t.ld, lightmap).code(), ErrorCode::invalid_argument);  // no albedo yet
}

// Issue 18 item 7: a huge spike on one sample of ld makes the low-rank operators ring below
// zero; the lightmap policy (core reference_runtime.h) clamps every texel at 0, on every ISA,
// with skipping on and off, and after multi-bounce steps; the atlas copies it. The unclamped
// lightmap (Ub b + Ur r in double from core's b and r) is asserted negative, so this fails
// without the clamp.
TEST(CpuLevelRuntime, SpikeInLdGivesNoNegativeTexelOnEveryIsa) {
  const TestLevel& t = test_level("maze11");
  std::vector<float> ld(t.ld.size(), 0.0f);
  ld[3 * 40 + 0] = 1e6f;
  const LevelBufferSizes sizes = level_buffer_sizes(t.level, dict());
  std::vector<float> b(sizes.b), r(sizes.r);
  ASSERT_TRUE(level_compute_b(t.level, dict(), ld, b).ok());
  level_compute_r(t.level, b, r);
  double unclamped_min = 0.0;
  for (std::size_t i = 0; i < t.level.blocks.size(); ++i) {
    const LevelBlock& blk = t.level.blocks[i];
    const Matrix& Ub = block_operators(dict(), t.level, blk).Ub;
    std::vector<double> tile(3 * std::size_t(blk.sample_count), 0.0);
    for (std::uint32_t s = 0; s < blk.sample_count; ++s)
      for (std::uint32_t k = 0; k < Ub.cols; ++k)
        for (std::size_t c = 0; c < 3; ++c)
          tile[3 * s + c] += double(Ub(s, k)) * b[3 * (t.level.kb * i + k) + c];
    for (std::size_t q = 0; q < t.level.slots.size(); ++q) {
      const ResponseSlot& slot = t.level.slots[q];
      if (slot.block != i) continue;
      const Matrix& Ur = dict().interfaces.Ur;
      for (std::uint32_t row = 0; row < Ur.rows; ++row) {
        const std::int32_t s = slot.ur_row_to_sample[row];
        if (s < 0) continue;
        for (std::uint32_t k = 0; k < t.level.kr; ++k)
          for (std::size_t c = 0; c < 3; ++c)
            tile[3 * std::size_t(s) + c] += double(Ur(row, k)) * r[3 * (t.level.kr * q + k) + c];
      }
    }
    for (double v : tile) unclamped_min = std::min(unclamped_min, v);
  }
  ASSERT_LT(unclamped_min, -1.0) << "the spike should ring negative without the clamp";
  std::printf("unclamped lightmap minimum %.4g (spike 1e6)\n", unclamped_min);
  const std::vector<float> albedo(t.ld.size(), 0.6f);
  for (Isa isa : supported_isas())
    for (bool skip : {false, true}) {
      CpuSkipOptions so;
      so.enabled = skip;
      Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), options(isa, 2, so));
      ASSERT_TRUE(rt.ok()) << rt.status().to_string();
      std::vector<float> lightmap(rt->sizes().lightmap), atlas(rt->sizes().atlas);
      ASSERT_TRUE(rt->evaluate(ld, lightmap).ok());
      const std::string what = std::string(isa_name(isa)) + (skip ? " skip" : "");
      EXPECT_GE(*std::min_element(lightmap.begin(), lightmap.end()), 0.0f) << what;
      ASSERT_TRUE(rt->fill_atlas(lightmap, atlas).ok());
      EXPECT_GE(*std::min_element(atlas.begin(), atlas.end()), 0.0f) << what;
      ASSERT_TRUE(rt->set_albedo(albedo, 0.95f).ok());
      for (int step = 0; step < 3; ++step) ASSERT_TRUE(rt->multi_bounce_step(ld, lightmap).ok());
      EXPECT_GE(*std::min_element(lightmap.begin(), lightmap.end()), 0.0f) << what << " multi-bounce";
    }
}

TEST(CpuLevelRuntime, RejectsMismatchedDictionaryAndOptions) {
  const TestLevel& t = test_level("maze11");
  {
    Dictionary other = dict();
    other.settings.res = 4;
    const Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, other);
    ASSERT_FALSE(rt.ok());
    EXPECT_EQ(rt.status().code(), ErrorCode::invalid_argument);
    EXPECT_NE(rt.status().message().find("rebuild the level"), std::string::npos) << rt.status().message();
  }
  {
    Dictionary other = dict();
    ShapeOperators& op = other.shapes[std::size_t(t.level.blocks[0].shape)];
    op.Ub = Matrix(op.Ub.rows - 1, op.Ub.cols);
    const Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, other);
    ASSERT_FALSE(rt.ok());
    EXPECT_NE(rt.status().message().find("block 0"), std::string::npos) << rt.status().message();
  }
  {
    Dictionary other = dict();
    other.interfaces.Ur = Matrix(other.interfaces.Ur.rows + 1, other.interfaces.Ur.cols);
    EXPECT_FALSE(CpuLevelRuntime::create(t.level, other).ok());
  }
  for (Isa isa : {Isa::scalar, Isa::sse41, Isa::avx2, Isa::neon})
    EXPECT_EQ(CpuLevelRuntime::create(t.level, dict(), options(isa, 1)).ok(), isa_supported(isa))
        << isa_name(isa);
  EXPECT_FALSE(CpuLevelRuntime::create(t.level, dict(), options(Isa::scalar, 0)).ok());
  EXPECT_FALSE(CpuLevelRuntime::create(t.level, dict(), options(Isa::scalar, 257)).ok());
  EXPECT_TRUE(CpuLevelRuntime::create(t.level, dict(), options(Isa::scalar, 2)).ok());
}

// ---- float16 operators (CpuRuntimeOptions::operators) ----

void round_to_half(Matrix& m) {
  for (float& v : m.data) {
    std::uint16_t h = 0;
    EXPECT_TRUE(float_to_half(v, &h)) << v;
    v = half_to_float(h);
  }
}

// The test dictionary and a level with every operator a float16 runtime converts rounded to
// the nearest half, as floats: what that runtime computes with.
struct RoundedOperators {
  Dictionary dict;
  Level level;
};

RoundedOperators rounded_operators(const Level& level) {
  RoundedOperators out{dict(), level};
  for (ShapeOperators& op : out.dict.shapes) {
    round_to_half(op.Td_b), round_to_half(op.Ub), round_to_half(op.Ubvol), round_to_half(op.Ub_vec);
  }
  for (ShapedOperators& so : out.level.shaped) {
    ShapeOperators& op = so.operators;
    round_to_half(op.Td_b), round_to_half(op.Ub), round_to_half(op.Ubvol), round_to_half(op.Ub_vec);
  }
  round_to_half(out.dict.interfaces.Ur);
  for (ResponseRecord& rec : out.level.records) round_to_half(rec.T);
  for (Matrix& m : out.level.probe_response) round_to_half(m);
  for (Matrix& m : out.level.vector_response) round_to_half(m);
  return out;
}

// level_reference for another dictionary: core's scalar reference on the rounded operators.
Reference reference_on(const Level& level, const Dictionary& d, std::span<const float> ld) {
  const LevelBufferSizes s = level_buffer_sizes(level, d);
  Reference ref{std::vector<float>(s.b),        std::vector<float>(s.r),
                std::vector<float>(s.lightmap), std::vector<float>(s.atlas),
                std::vector<float>(s.probes),   std::vector<float>(s.vector_lightmap)};
  EXPECT_TRUE(level_evaluate(level, d, ld, ref.b, ref.r, ref.lightmap).ok());
  level_fill_atlas(level, ref.lightmap, ref.atlas);
  level_compute_probes(level, d, ref.b, ref.r, ref.probes);
  EXPECT_TRUE(level_compute_vector_irradiance(level, d, ref.b, ref.r, ref.vector_lightmap).ok());
  return ref;
}

// Float16 rounding against float32 operators, relative L2 per output (printed by the test;
// docs/cpu.md): the largest measured on the test levels is 1.05e-3 (r of "stretched", whose
// shaped sets keep up to three cubes' modes; b of "single" 5.3e-4, lightmaps <= 2e-4), the
// same on every ISA; the limit is about twice that.
constexpr double kFloat16Tolerance = 2e-3;

// A float16 runtime computes what core's scalar reference computes with the half-rounded
// operators (within 1e-5, like float32 against the original ones), and is ~1e-3 from the
// float32 reference; b is held to the same per-element floor as in the float32 test.
TEST(CpuLevelRuntime, Float16OperatorsMatchReferenceOnRoundedOperators) {
  for (const TestLevel& t : test_levels()) {
    const RoundedOperators rounded = rounded_operators(t.level);
    const Reference ref = reference_on(rounded.level, rounded.dict, t.ld);
    const Reference ref32 = level_reference(t.level, t.ld);
    const std::vector<double> b_scale = b_magnitudes(t.level, t.ld);
    for (Isa isa : supported_isas()) {
      Result<CpuLevelRuntime> rt =
          CpuLevelRuntime::create(t.level, dict(), options(isa, 1, {}, OperatorStorage::float16));
      ASSERT_TRUE(rt.ok()) << rt.status().to_string();
      EXPECT_EQ(rt->operators(), OperatorStorage::float16);
      const LevelBufferSizes& s = rt->sizes();
      std::vector<float> lightmap(s.lightmap), atlas(s.atlas), probes(s.probes), vec(s.vector_lightmap);
      for (int frame = 0; frame < 2; ++frame) ASSERT_TRUE(rt->evaluate(t.ld, lightmap).ok());
      ASSERT_TRUE(rt->fill_atlas(lightmap, atlas).ok());
      ASSERT_TRUE(rt->compute_probes(probes).ok());
      ASSERT_TRUE(rt->compute_vector_irradiance(vec).ok());
      const std::string what = std::string(t.name) + " " + isa_name(isa) + " float16";
      Worst wb, wr, wl, wa, wp, wv;
      expect_close(rt->b(), ref.b, what + " b", &wb, b_scale);
      expect_close(rt->r(), ref.r, what + " r", &wr);
      expect_close(lightmap, ref.lightmap, what + " lightmap", &wl);
      expect_close(atlas, ref.atlas, what + " atlas", &wa);
      expect_close(probes, ref.probes, what + " probes", &wp);
      expect_close(vec, ref.vector_lightmap, what + " vector irradiance", &wv);
      std::printf("  %s, float16 against the reference on rounded operators\n", t.name.c_str());
      wb.print("b", isa), wr.print("r", isa), wl.print("lightmap", isa), wa.print("atlas", isa),
          wp.print("probes", isa), wv.print("vector irradiance", isa);
      const std::pair<const char*, double> against_float32[] = {
          {"b", compare(rt->b(), ref32.b).rel_l2},
          {"r", compare(rt->r(), ref32.r).rel_l2},
          {"lightmap", compare(lightmap, ref32.lightmap).rel_l2},
          {"probes", compare(probes, ref32.probes).rel_l2},
          {"vector irradiance", compare(vec, ref32.vector_lightmap).rel_l2}};
      std::printf("  %s %s float16 against float32 operators, rel L2:", t.name.c_str(), isa_name(isa));
      for (const auto& [name, err] : against_float32) {
        std::printf(" %s %.3g", name, err);
        EXPECT_LE(err, kFloat16Tolerance) << what << " " << name << " against float32";
      }
      std::printf("\n");
      // The rounding does show: float16 is not float32 under another name.
      EXPECT_GT(compare(lightmap, ref32.lightmap).rel_l2, 1e-6) << what;
    }
  }
}

// Every path (full, multi-bounce, exact and approximate skipping, probes, vector irradiance)
// gives the bits a float32 runtime gives on the half-rounded operators: the f16 kernels are
// the float kernels with a conversion on load, and the skip norms come from the rounded
// operators (so the skip decisions and bounds are the same too).
TEST(CpuLevelRuntime, Float16EqualsFloat32OnRoundedOperators) {
  CpuSkipOptions approx{true, 0.05f, 1e-4f, 0.05f, true, 0.02f};
  for (const TestLevel& t : test_levels()) {
    const RoundedOperators rounded = rounded_operators(t.level);
    std::vector<float> ld2 = t.ld;
    for (std::size_t i = 0; i < ld2.size(); i += 5) ld2[i] *= 1.02f;
    for (Isa isa : supported_isas())
      for (const CpuSkipOptions& skip : {CpuSkipOptions{}, CpuSkipOptions{true}, approx}) {
        Result<CpuLevelRuntime> f16 =
            CpuLevelRuntime::create(t.level, dict(), options(isa, 2, skip, OperatorStorage::float16));
        Result<CpuLevelRuntime> f32 =
            CpuLevelRuntime::create(rounded.level, rounded.dict, options(isa, 1, skip));
        ASSERT_TRUE(f16.ok() && f32.ok());
        const LevelBufferSizes& s = f16->sizes();
        std::vector<float> lm16(s.lightmap), lm32(s.lightmap);
        ASSERT_TRUE(f16->set_albedo(t.albedo).ok() && f32->set_albedo(t.albedo).ok());
        const std::string what = t.name + " " + isa_name(isa) + (skip.enabled ? " skipping" : "");
        for (int frame = 0; frame < 4; ++frame) {
          const std::vector<float>& ld = frame % 2 ? ld2 : t.ld;
          ASSERT_TRUE(f16->evaluate(ld, lm16).ok() && f32->evaluate(ld, lm32).ok());
          EXPECT_EQ(lm16, lm32) << what << " frame " << frame;
          EXPECT_EQ(f16->skip_stats().lightmap_error_bound, f32->skip_stats().lightmap_error_bound) << what;
          EXPECT_EQ(f16->skip_stats().records_computed, f32->skip_stats().records_computed) << what;
        }
        for (int k = 0; k < 2; ++k) ASSERT_TRUE(f16->multi_bounce_step(t.ld, lm16).ok());
        for (int k = 0; k < 2; ++k) ASSERT_TRUE(f32->multi_bounce_step(t.ld, lm32).ok());
        EXPECT_EQ(lm16, lm32) << what << " multi-bounce";
        EXPECT_TRUE(std::ranges::equal(f16->b(), f32->b())) << what;
        EXPECT_TRUE(std::ranges::equal(f16->r(), f32->r())) << what;
        std::vector<float> p16(s.probes), p32(s.probes), v16(s.vector_lightmap), v32(s.vector_lightmap);
        ASSERT_TRUE(f16->compute_probes(p16).ok() && f32->compute_probes(p32).ok());
        ASSERT_TRUE(f16->compute_vector_irradiance(v16).ok() && f32->compute_vector_irradiance(v32).ok());
        EXPECT_EQ(p16, p32) << what;
        EXPECT_EQ(v16, v32) << what;
      }
  }
}

// Approximate skipping with float16 operators over the 300 moving-light frames stays within its
// stated bound of the float16 full path (the bound's norms are those of the rounded operators).
TEST(CpuLevelRuntime, Float16SkippingStaysWithinStatedBound) {
  const TestLevel& t = test_level("maze41");
  const auto& frames = moving_light_frames();
  float ld_max = 0.0f;
  for (const auto& ld : frames) ld_max = std::max(ld_max, *std::max_element(ld.begin(), ld.end()));
  const Isa isa = best_isa();
  const CpuSkipOptions all{true, 0.05f, 1e-3f * ld_max, 0.05f, true, 0.02f};
  Result<CpuLevelRuntime> full =
      CpuLevelRuntime::create(t.level, dict(), options(isa, 1, {}, OperatorStorage::float16));
  Result<CpuLevelRuntime> skip =
      CpuLevelRuntime::create(t.level, dict(), options(isa, 2, all, OperatorStorage::float16));
  ASSERT_TRUE(full.ok() && skip.ok());
  std::vector<float> lm_full(full->sizes().lightmap), lm(lm_full.size());
  SkipTotals totals;
  int outside = 0;
  for (const auto& ld : frames) {
    ASSERT_TRUE(full->evaluate(ld, lm_full).ok());
    ASSERT_TRUE(skip->evaluate(ld, lm).ok());
    const CpuSkipStats& st = skip->skip_stats();
    totals.add(st);
    const double norm = std::sqrt(std::inner_product(lm_full.begin(), lm_full.end(), lm_full.begin(), 0.0));
    const double err = l2_distance(lm, lm_full);
    outside += err > st.lightmap_error_bound + 1e-5 * norm;
    totals.max_error = std::max(totals.max_error, err / norm);
    totals.max_bound = std::max(totals.max_bound, st.lightmap_error_bound / norm);
    if (st.lightmap_error_bound > 0)
      totals.max_ratio = std::max(totals.max_ratio, err / st.lightmap_error_bound);
  }
  EXPECT_EQ(outside, 0);
  EXPECT_GT(totals.sum.records_skipped, 0u);
  EXPECT_GT(totals.max_error, 0.0);
  totals.print("f16 all");
}

// An operator value beyond the half range fails create() with float16 (naming the operator,
// the element and the value) and is fine with float32; 65504 itself fits. Since issue 18 the
// value must also be plausible (operator_limits.h): a Td_b row of a mode with a tiny singular
// value (Ub's column scaled down) is, 1e6 in a record's T or FLT_MAX in a probe response is
// not, and creation refuses it with either storage, naming the gain it would give.
TEST(CpuLevelRuntime, Float16RejectsOperatorsBeyondHalfRange) {
  const TestLevel& t = test_level("maze11");
  const CpuRuntimeOptions f16 = options(Isa::scalar, 1, {}, OperatorStorage::float16);
  {
    Dictionary d = dict();
    const std::size_t shape = std::size_t(t.level.blocks[0].shape);
    Matrix& Ub = d.shapes[shape].Ub;
    for (std::uint32_t r = 0; r < Ub.rows; ++r) Ub(r, 1) *= 1e-6f;
    d.shapes[shape].Td_b(1, 3) = 7e4f;
    const Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, d, f16);
    ASSERT_FALSE(rt.ok());
    EXPECT_EQ(rt.status().code(), ErrorCode::invalid_argument);
    EXPECT_NE(rt.status().message().find("shape " + std::to_string(shape) +
                                         " Td_b value 70000 at row 1, column 3 exceeds float16 range"),
              std::string::npos)
        << rt.status().message();
    EXPECT_TRUE(CpuLevelRuntime::create(t.level, d).ok());
    d.shapes[shape].Td_b(1, 3) = -kHalfMax;
    EXPECT_TRUE(CpuLevelRuntime::create(t.level, d, f16).ok());
  }
  ASSERT_GT(t.level.records.size(), 17u);
  {
    Level level = t.level;
    level.records[17].T(2, 5) = 1e6f;
    for (const CpuRuntimeOptions& o : {options(Isa::scalar, 1), f16}) {
      const Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(level, dict(), o);
      ASSERT_FALSE(rt.ok());
      EXPECT_EQ(rt.status().code(), ErrorCode::invalid_argument);
      EXPECT_NE(rt.status().message().find("gain ld -> r = "), std::string::npos) << rt.status().message();
    }
  }
  {
    Level level = t.level;
    for (Matrix& m : level.probe_response)
      if (!m.empty()) m.data.back() = std::numeric_limits<float>::max();
    const Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(level, dict(), f16);
    ASSERT_FALSE(rt.ok());
    EXPECT_NE(rt.status().message().find("gain ld -> probes = "), std::string::npos) << rt.status().message();
  }
}

// The float16 copy holds every operator the runtime reads at 2 bytes per value: half the
// float32 bytes.
TEST(CpuLevelRuntime, Float16HalvesOperatorBytes) {
  for (const TestLevel& t : test_levels()) {
    Result<CpuLevelRuntime> a = CpuLevelRuntime::create(t.level, dict());
    Result<CpuLevelRuntime> b =
        CpuLevelRuntime::create(t.level, dict(), options(Isa::scalar, 1, {}, OperatorStorage::float16));
    ASSERT_TRUE(a.ok() && b.ok());
    std::size_t values = 0;
    for (const ResponseRecord& rec : t.level.records) values += rec.T.data.size();
    EXPECT_GT(a->operator_bytes(), 4 * values) << t.name;  // records plus shapes and Ur
    EXPECT_EQ(2 * b->operator_bytes(), a->operator_bytes()) << t.name;
    std::printf("  %-8s operators: float32 %zu bytes, float16 %zu bytes\n", t.name.c_str(),
                a->operator_bytes(), b->operator_bytes());
  }
}

}  // namespace
}  // namespace modrt::cpu
