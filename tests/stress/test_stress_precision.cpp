// SPDX-License-Identifier: MIT
// Numerical stress (issue 9): the float16 error budget per stage, and determinism of the CPU
// runtime (run to run, across thread counts) and of the bake (across TBB thread counts).
#include <gtest/gtest.h>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "level_fixtures.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/dictionary_io.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/bake.h"
#include "stress/stress_report.h"

namespace modrt::cpu {
namespace {

using stress::fmt;
using stress::row;
using test::test_level;
using test::TestLevel;

const Dictionary& dict() { return test::small_test_dictionary(); }

double rel_l2(std::span<const float> a, std::span<const float> b) {
  double num = 0, den = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    num += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
    den += double(b[i]) * b[i];
  }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

// Every per-frame output of a level, in the layouts of level_runtime.h.
struct Stages {
  std::vector<float> b, r, lightmap, atlas, probes, vector;
};
constexpr const char* kStageNames[] = {"b", "r", "lightmap", "atlas", "probes", "vector irradiance"};
std::vector<const std::vector<float>*> stage_list(const Stages& s) {
  return {&s.b, &s.r, &s.lightmap, &s.atlas, &s.probes, &s.vector};
}

Stages cpu_stages(CpuLevelRuntime& rt, std::span<const float> ld) {
  const LevelBufferSizes& sz = rt.sizes();
  Stages s{{},
           {},
           std::vector<float>(sz.lightmap),
           std::vector<float>(sz.atlas),
           std::vector<float>(sz.probes),
           std::vector<float>(sz.vector_lightmap)};
  EXPECT_TRUE(rt.evaluate(ld, s.lightmap).ok());
  s.b.assign(rt.b().begin(), rt.b().end());
  s.r.assign(rt.r().begin(), rt.r().end());
  EXPECT_TRUE(rt.fill_atlas(s.lightmap, s.atlas).ok());
  EXPECT_TRUE(rt.compute_probes(s.probes).ok());
  EXPECT_TRUE(rt.compute_vector_irradiance(s.vector).ok());
  return s;
}

// Core's scalar reference for a level and dictionary.
Stages reference_stages(const Level& level, const Dictionary& d, std::span<const float> ld) {
  const LevelBufferSizes sz = level_buffer_sizes(level, d);
  Stages s{std::vector<float>(sz.b),        std::vector<float>(sz.r),
           std::vector<float>(sz.lightmap), std::vector<float>(sz.atlas),
           std::vector<float>(sz.probes),   std::vector<float>(sz.vector_lightmap)};
  EXPECT_TRUE(level_evaluate(level, d, ld, s.b, s.r, s.lightmap).ok());
  level_fill_atlas(level, s.lightmap, s.atlas);
  level_compute_probes(level, d, s.b, s.r, s.probes);
  EXPECT_TRUE(level_compute_vector_irradiance(level, d, s.b, s.r, s.vector).ok());
  return s;
}

// The float16 error budget. A half keeps 11 significant bits: rounding an operator entry costs
// at most u = 2^-11 = 4.9e-4 relative. An output passes through at most three rounded
// operators in a chain (Td_b, then a record's T, then Ur or a probe / vector response), so
// with no cancellation its relative error is at most ~3u = 1.5e-3; the budget is 2e-3 per
// stage (the GLES backend's stated bound for float16, docs/gles.md). b, one rounded operator
// deep, gets u x 2 = 1e-3. Measured on maze41 (41 blocks, test dictionary res 8, kb 32, kr 32):
//   float16 CPU operators (CpuRuntimeOptions::operators) against the float32 runtime;
//   float16 dictionary storage (DictionaryWriteOptions::float16: save, load, build the level
//   from the loaded dictionary) against the float32 dictionary, both through core's reference.
constexpr double kBudget[] = {1e-3, 2e-3, 2e-3, 2e-3, 2e-3, 2e-3};

TEST(StressPrecision, Float16ErrorBudgetPerStage) {
  const TestLevel& t = test_level("maze41");
  Result<CpuLevelRuntime> f32 = CpuLevelRuntime::create(t.level, dict());
  CpuRuntimeOptions half;
  half.operators = OperatorStorage::float16;
  Result<CpuLevelRuntime> f16 = CpuLevelRuntime::create(t.level, dict(), half);
  ASSERT_TRUE(f32.ok() && f16.ok()) << f16.status().to_string();
  const Stages a = cpu_stages(f32.value(), t.ld), h = cpu_stages(f16.value(), t.ld);
  for (std::size_t i = 0; i < std::size(kStageNames); ++i) {
    const double e = rel_l2(*stage_list(h)[i], *stage_list(a)[i]);
    EXPECT_TRUE(row("float16 CPU operators (maze41)", kStageNames[i], fmt("%.2e", e),
                    fmt("<= %.0e", kBudget[i]), e <= kBudget[i]))
        << kStageNames[i];
  }

  // Dictionary storage: serialize as float16, parse, rebuild the level from it.
  DictionaryWriteOptions write;
  write.float16 = true;
  Result<std::vector<std::byte>> bytes = serialize_dictionary(dict(), write);
  ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
  Result<Dictionary> loaded = parse_dictionary(bytes.value(), "float16 test dictionary");
  ASSERT_TRUE(loaded.ok()) << loaded.status().to_string();
  Result<Level> level16 = precompute::build_level(t.description, loaded.value());
  ASSERT_TRUE(level16.ok()) << level16.status().to_string();
  const Stages ref = reference_stages(t.level, dict(), t.ld);
  const Stages stored = reference_stages(level16.value(), loaded.value(), t.ld);
  for (std::size_t i = 0; i < std::size(kStageNames); ++i) {
    const double e = rel_l2(*stage_list(stored)[i], *stage_list(ref)[i]);
    EXPECT_TRUE(row("float16 dictionary storage (maze41)", kStageNames[i], fmt("%.2e", e),
                    fmt("<= %.0e", kBudget[i]), e <= kBudget[i]))
        << kStageNames[i];
  }
}

bool same_bits(std::span<const float> a, std::span<const float> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Everything a CPU runtime computes for a short animated sequence: per frame the stages above
// with skipping on (kept blocks, skipped records), then 20 multi-bounce steps.
std::vector<Stages> cpu_sequence(const TestLevel& t, int threads, OperatorStorage storage) {
  CpuRuntimeOptions options;
  options.threads = threads;
  options.operators = storage;
  options.skip.enabled = true;
  options.skip.ld_epsilon = 1e-3f;
  options.skip.record_epsilon = 1e-3f;
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), options);
  EXPECT_TRUE(rt.ok()) << rt.status().to_string();
  std::vector<Stages> out;
  std::vector<float> ld(t.ld);
  for (int f = 0; f < 8; ++f) {
    // Brighten one block per frame (ld sample order is block by block).
    const std::size_t per_block = ld.size() / t.level.blocks.size();
    const std::size_t blk = std::size_t(f * 5) % t.level.blocks.size();
    for (std::size_t i = blk * per_block; i < (blk + 1) * per_block; ++i) ld[i] *= 1.5f;
    out.push_back(cpu_stages(rt.value(), ld));
  }
  EXPECT_TRUE(rt->set_albedo(t.albedo).ok());
  Stages bounce;
  bounce.lightmap.assign(rt->sizes().lightmap, 0.0f);
  EXPECT_TRUE(rt->evaluate(t.ld, bounce.lightmap).ok());
  for (int step = 0; step < 20; ++step) EXPECT_TRUE(rt->multi_bounce_step(t.ld, bounce.lightmap).ok());
  out.push_back(bounce);
  return out;
}

// The same inputs give bit-identical CPU outputs run to run and for 1, 2 and 4 threads: every
// output has one writer and one summation order whatever the thread count
// (cpu_level_runtime.h). Not across ISAs: AVX2 uses FMA and 8-wide partial sums, SSE4.1 and
// NEON 4-wide, the scalar path one sum; those agree within 1e-5 (test_cpu_backend), not bitwise.
TEST(StressDeterminism, CpuOutputsBitIdenticalRunToRunAndAcrossThreads) {
  const TestLevel& t = test_level("maze41");
  for (OperatorStorage storage : {OperatorStorage::float32, OperatorStorage::float16}) {
    const std::vector<Stages> first = cpu_sequence(t, 1, storage);
    for (int threads : {1, 2, 4}) {
      const std::vector<Stages> again = cpu_sequence(t, threads, storage);
      std::size_t compared = 0, differing = 0;
      for (std::size_t f = 0; f < first.size(); ++f)
        for (std::size_t i = 0; i < std::size(kStageNames); ++i) {
          if (stage_list(first[f])[i]->empty()) continue;  // the multi-bounce entry has a lightmap only
          ++compared;
          differing += !same_bits(*stage_list(first[f])[i], *stage_list(again[f])[i]);
        }
      const std::string name = std::string("CPU runtime, ") +
                               (storage == OperatorStorage::float32 ? "float32" : "float16") +
                               " operators, maze41, skipping on";
      EXPECT_TRUE(row(name, fmt("threads %d vs threads 1 (new runtime)", threads),
                      fmt("%zu of %zu outputs differ", differing, compared), "bit-identical",
                      differing == 0));
    }
  }
}

// The bake under 1, 2 and 4 TBB threads: byte-identical dictionaries. Every parallel loop of
// the bake writes disjoint rows (F's gather, direct light, lightfields) and every reduction is
// serial (Eigen's SVDs, the products), so the thread count cannot change a sum's order.
TEST(StressDeterminism, BakeByteIdenticalAcrossTbbThreadCounts) {
  DictionarySettings s;
  s.res = 3;
  s.rays = 256;
  s.kd = 16;
  s.kb = 8;
  s.prior_grid = 2;
  s.light_samples = 4;
  s.sh_rays = 32;
  s.probe_grid = 2;
  s.lightfield_spatial = 2;
  s.lightfield_directional = 4;
  s.lightfield_supersample = 2;
  s.krlf = 16;
  s.kr = 8;
  s.interface_enrichment_iterations = 1;
  s.response_rays = 64;
  std::vector<std::vector<std::byte>> files;
  std::vector<int> used;
  for (int threads : {1, 2, 4, 4}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    // At most the machine's cores: on 2 cores "4" runs 2 threads (the row says so).
    used.push_back(std::min(threads, tbb::this_task_arena::max_concurrency()));
    Result<Dictionary> d = precompute::bake_dictionary(s);
    ASSERT_TRUE(d.ok()) << d.status().to_string();
    Result<std::vector<std::byte>> bytes = serialize_dictionary(d.value());
    ASSERT_TRUE(bytes.ok());
    files.push_back(std::move(bytes).value());
  }
  for (std::size_t i = 1; i < files.size(); ++i) {
    const bool same = files[i] == files[0];
    EXPECT_TRUE(
        row("bake (res 3, interfaces), dictionary file",
            fmt("TBB limit %d (%d threads) vs 1%s", i == 1 ? 2 : 4, used[i], i == 3 ? ", second run" : ""),
            fmt("%zu bytes, %s", files[i].size(), same ? "identical" : "DIFFERENT"), "byte-identical", same));
  }
}

}  // namespace
}  // namespace modrt::cpu
