// SPDX-License-Identifier: MIT
// modrt-bench-drt — Google Benchmark timings of the DRT operator build (architecture.md §6,
// [Loos et al. 2012] §4–5) on the four-pillar corridor of tests/drt_scenes.h, with the small
// test dictionary (res 8, kb 32; tests/test_support.h, baked into the test cache on first use).
//
//   BM_DrtBuildFourPillars/<rays>/<extra>  DrtBuilder::build of the four pillars (1024 rays is the
//                                     paper's setting; extra 1: also the vector deltas and U_dyn
//                                     probes, timed in scene_s); counters: scene pass and clutter pass
//                                     wall seconds, storage bytes of the operators, cpu_s the
//                                     process CPU seconds (all threads) per build
//   BM_DrtBuildPillarMeshes/<rays>/<prior>  the same four pillars given as triangle meshes (12
//                                     triangles, 16 x 16 texels per face, all six faces lit, so
//                                     6144 texels instead of 4096): Embree ray entry instead of the
//                                     analytic slab test; prior > 0: that many lighting-prior
//                                     modes for c (clutter_prior_modes) instead of a constant per face
//   BM_DrtRebuildOnePillar/<rays>     rebuild_object after one pillar moved (alternately
//                                     +-0.05 in x), everything it affects included (texels: the
//                                     clutter texels it re-traced, of 4096)
//
// The DrtBuilder (its Embree scene of the walls) is made once per benchmark, outside the
// timing, as an editor would keep it while clutter moves.
#include <benchmark/benchmark.h>

#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>

#include "clutter_meshes.h"
#include "drt_scenes.h"
#include "modrt/precompute/clutter_mesh.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "test_support.h"

namespace {

using namespace modrt;
using namespace modrt::precompute;

// User + system CPU seconds of the whole process (all threads): the work a build costs,
// which the shared machine's load does not inflate the way it inflates wall time.
double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  auto s = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
  return s(u.ru_utime) + s(u.ru_stime);
}

const Level& four_pillar_level() {
  static const Level level = [] {
    Result<Level> l = build_level(test::maze_block_four_pillars().description, test::small_test_dictionary());
    if (!l.ok()) {
      std::fprintf(stderr, "bench_drt: %s\n", l.status().to_string().c_str());
      std::abort();
    }
    return std::move(l).value();
  }();
  return level;
}

// Full builds of `objects`, with the report's pass times, the storage and the CPU time.
void time_builds(benchmark::State& state, const DrtBuilder& builder, std::span<const ClutterObject> objects) {
  DrtBuildReport report;
  std::size_t storage = 0;
  const double cpu0 = process_cpu_seconds();
  for (auto _ : state) {
    Result<DrtOperators> drt = builder.build(objects, &report);
    if (!drt.ok()) {
      state.SkipWithError(drt.status().to_string().c_str());
      return;
    }
    storage = drt.value().storage_bytes();
    benchmark::DoNotOptimize(drt);
  }
  const double n = double(state.iterations());
  state.counters["scene_s"] = report.scene_seconds / n;
  state.counters["clutter_s"] = report.clutter_seconds / n;
  state.counters["bytes"] = double(storage);
  state.counters["cpu_s"] = (process_cpu_seconds() - cpu0) / n;
}

void BM_DrtBuildFourPillars(benchmark::State& state) {
  const test::ClutterScene s = test::maze_block_four_pillars();
  DrtBuildSettings settings;
  settings.rays = int(state.range(0));
  settings.vector = settings.probes = state.range(1) != 0;
  settings.gather = state.range(2) != 0;  // the real-radiance gather (the default) or the paper's Cb, Cc
  time_builds(state, DrtBuilder(four_pillar_level(), test::small_test_dictionary(), settings), s.clutter);
}
// Args: rays, vector and probe operators, gather.
BENCHMARK(BM_DrtBuildFourPillars)
    ->Args({1024, 0, 1})
    ->Args({1024, 0, 0})
    ->Args({256, 0, 1})
    ->Args({1024, 1, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_DrtBuildPillarMeshes(benchmark::State& state) {
  const test::ClutterScene s = test::maze_block_four_pillars();
  std::vector<ClutterObject> meshes;
  for (const ClutterObject& pillar : s.clutter) {
    Result<ClutterObject> o =
        make_mesh_clutter(test::box_mesh(pillar.box, 16, 54), pillar.block, pillar.albedo, 54, "pillar mesh");
    if (!o.ok()) {
      state.SkipWithError(o.status().to_string().c_str());
      return;
    }
    meshes.push_back(std::move(o).value());
  }
  DrtBuildSettings settings;
  settings.rays = int(state.range(0));
  settings.clutter_prior_modes = int(state.range(1));
  time_builds(state, DrtBuilder(four_pillar_level(), test::small_test_dictionary(), settings), meshes);
}
BENCHMARK(BM_DrtBuildPillarMeshes)
    ->Args({1024, 0})
    ->Args({1024, 8})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_DrtRebuildOnePillar(benchmark::State& state) {
  test::ClutterScene s = test::maze_block_four_pillars();
  DrtBuildSettings settings;
  settings.rays = int(state.range(0));
  const DrtBuilder builder(four_pillar_level(), test::small_test_dictionary(), settings);
  DrtBuildState build_state;
  DrtOperators drt = builder.build(s.clutter, nullptr, &build_state).value();
  int step = 0;
  DrtBuildReport report;
  const double cpu0 = process_cpu_seconds();
  for (auto _ : state) {
    s.clutter[1].box.center.x += (step++ % 2 == 0) ? 0.05 : -0.05;
    if (Status st = builder.rebuild_object(s.clutter, 1, drt, build_state, &report); !st.ok()) {
      state.SkipWithError(st.to_string().c_str());
      return;
    }
    benchmark::DoNotOptimize(drt);
  }
  const double n = double(state.iterations());
  state.counters["bytes"] = double(drt.storage_bytes());
  state.counters["cpu_s"] = (process_cpu_seconds() - cpu0) / n;
  state.counters["scene_s"] = report.scene_seconds / n;
  state.counters["clutter_s"] = report.clutter_seconds / n;
  state.counters["texels"] = double(report.traced_texels) / n;
}
BENCHMARK(BM_DrtRebuildOnePillar)->Arg(1024)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
