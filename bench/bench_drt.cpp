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
//   BM_DrtCacheStart/<rays>/<start>/<scene>  precompute's load_or_build_drt across program starts,
//                                     as modrt-demo runs it (a builder per call), on the four
//                                     pillars (scene 0) or the 11-block maze with a box per block
//                                     (scene 1): start 0, the first start (full build, the
//                                     operators and the build state saved; both files removed
//                                     after each); 1, a start after object 1 moved (alternately
//                                     +-0.05 in x: the state's operators rebuilt for it and both
//                                     files saved; the operators of the place it left removed
//                                     after each, so that the next start, moving it back,
//                                     rebuilds again); 2, a start with nothing moved (loaded).
//                                     Counters: the operator and state file bytes, cpu_s.
//
// The DrtBuilder (its Embree scene of the walls) is made once per benchmark, outside the
// timing, as an editor would keep it while clutter moves (not in BM_DrtCacheStart).
#include <benchmark/benchmark.h>

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "clutter_meshes.h"
#include "drt_scenes.h"
#include "modrt/precompute/clutter_mesh.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/drt_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/maze.h"
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

// The paper's small maze (maze_level(11)) with a box on the floor of every block, off its
// centre: clutter spread over rooms that see a few of the others, where a moved box changes
// what a few blocks see.
test::ClutterScene maze_with_a_box_per_block() {
  test::ClutterScene s;
  Result<LevelDescription> maze = maze_level(11);
  if (!maze.ok()) {
    std::fprintf(stderr, "bench_drt: %s\n", maze.status().to_string().c_str());
    std::abort();
  }
  s.description = std::move(maze).value();
  for (std::size_t b = 0; b < s.description.blocks.size(); ++b) {
    const glm::ivec3 cell = s.description.blocks[b].cell;
    ClutterObject box;
    box.block = int(b);
    box.box.center = glm::dvec3(cell.x + 0.3, 0.15, cell.z + 0.35);
    box.box.half_extent = glm::dvec3(0.08, 0.15, 0.08);
    box.faces = test::without(kAllFaces, {kFaceNegY});
    box.albedo = glm::dvec3(0.6, 0.5, 0.4);
    s.clutter.push_back(box);
  }
  return s;
}

const Level& maze_level_with_boxes() {
  static const Level level = [] {
    Result<Level> l = build_level(maze_with_a_box_per_block().description, test::small_test_dictionary());
    if (!l.ok()) {
      std::fprintf(stderr, "bench_drt: %s\n", l.status().to_string().c_str());
      std::abort();
    }
    return std::move(l).value();
  }();
  return level;
}

void BM_DrtCacheStart(benchmark::State& state) {
  const bool maze = state.range(2) != 0;
  test::ClutterScene s = maze ? maze_with_a_box_per_block() : test::maze_block_four_pillars();
  DrtBuildSettings settings;
  settings.rays = int(state.range(0));
  const int start = int(state.range(1));
  namespace fs = std::filesystem;
  const fs::path dir =
      fs::temp_directory_path() / ("modrt-bench-drt-cache-" + std::to_string(long(::getpid())));
  fs::remove_all(dir);
  const Level& level = maze ? maze_level_with_boxes() : four_pillar_level();
  const Dictionary& dict = test::small_test_dictionary();
  auto start_once = [&]() -> Result<DrtCacheResult> {
    return load_or_build_drt(level, dict, s.clutter, settings, dir.string());
  };
  Result<DrtCacheResult> first = start_once();  // the cache of the starts before
  if (!first.ok()) {
    state.SkipWithError(first.status().to_string().c_str());
    return;
  }
  const DrtCacheSource expected = start == 0   ? DrtCacheSource::built
                                  : start == 1 ? DrtCacheSource::incremental
                                               : DrtCacheSource::loaded;
  std::uintmax_t drt_bytes = 0, state_bytes = 0;
  std::string previous = first->path;
  int step = 0;
  const double cpu0 = process_cpu_seconds();
  for (auto _ : state) {
    state.PauseTiming();
    if (start == 0) fs::remove_all(dir);
    if (start == 1) s.clutter[1].box.center.x += (step++ % 2 == 0) ? 0.05 : -0.05;
    state.ResumeTiming();
    Result<DrtCacheResult> r = start_once();
    if (!r.ok() || r->source != expected) {
      state.SkipWithError(
          r.ok()
              ? ("source: " + std::string(drt_cache_source_name(r->source)) + "; " + r->state_unused).c_str()
              : r.status().to_string().c_str());
      break;
    }
    state.PauseTiming();
    std::error_code ec;
    drt_bytes = fs::file_size(r->path, ec);
    state_bytes = fs::file_size(r->state_path, ec);
    if (start == 1) {  // the next start moves the pillar back: those operators must be missing
      fs::remove(previous, ec);
      previous = r->path;
    }
    state.ResumeTiming();
  }
  state.counters["cpu_s"] = (process_cpu_seconds() - cpu0) / double(state.iterations());
  state.counters["drt_file_bytes"] = double(drt_bytes);
  state.counters["state_file_bytes"] = double(state_bytes);
  fs::remove_all(dir);
}
// Args: rays, start (0 first, 1 one object moved, 2 nothing moved), scene (0 four pillars, 1
// the 11-block maze with a box per block).
BENCHMARK(BM_DrtCacheStart)
    ->Args({1024, 0, 0})
    ->Args({1024, 1, 0})
    ->Args({1024, 2, 0})
    ->Args({1024, 0, 1})
    ->Args({1024, 1, 1})
    ->Args({1024, 2, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
