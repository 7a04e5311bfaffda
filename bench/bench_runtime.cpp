// SPDX-License-Identifier: MIT
// modrt-bench-runtime — Google Benchmark timings of the level build and the scalar
// reference runtime (architecture.md §4, §5). Speed is measured only here, never in the tests.
//
//   BM_LevelBuild/<blocks>                 build_level (dmax 8) of maze11, maze41, a 1000-block maze
//   BM_ScalarLevelFrame/<blocks>           one level_evaluate (b, r, lightmap), full-quality dictionary
//   BM_ScalarLevelFrameMobile/<blocks>     the same with the mobile preset (res 6, kb 12)
//   BM_ScalarBlock/<kb>                    compute_b + apply_Ub for the closed shape (kb 32 full, 12 mobile)
//   BM_LevelMultiBounceIteration/<blocks>  one feedback step: apply_feedback + level_evaluate
//
// The dictionaries are loaded from the cache ($MODRT_CACHE_DIR, else $XDG_CACHE_HOME/modrt,
// else ~/.cache/modrt) or baked on first use; the full-quality bake takes about a minute.
// Every buffer is allocated in the setup, outside the timed loops.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/level_dirty.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/maze.h"
#include "modrt/reference_runtime.h"

namespace {

using namespace modrt;

constexpr int kLightSamples = 16;  // points per sphere light for the fixed direct light

DictionarySettings full_settings() { return DictionarySettings{}; }

DictionarySettings mobile_settings() {
  DictionarySettings s;
  s.res = 6;
  s.kb = 12;
  return s;
}

std::string describe(const DictionarySettings& s) {
  return "res " + std::to_string(s.res) + ", kb " + std::to_string(s.kb) + ", kr " + std::to_string(s.kr) +
         ", krlf " + std::to_string(s.krlf);
}

// Loads the dictionary from the cache or bakes it, reporting on stderr. Null on failure
// (the message is printed and kept in `error`).
std::unique_ptr<Dictionary> load_dictionary_for_bench(const DictionarySettings& settings, const char* label,
                                                      std::string& error) {
  const std::string cache_dir = precompute::default_cache_dir();
  const bool cached =
      std::filesystem::exists(std::filesystem::path(cache_dir) / precompute::cache_file_name(settings));
  if (!cached)
    std::fprintf(stderr,
                 "modrt-bench-runtime: baking the %s dictionary (%s) into %s on first use; "
                 "this takes a while (about a minute at full quality)...\n",
                 label, describe(settings).c_str(), cache_dir.c_str());
  precompute::BakeProgress progress;
  progress.on_stage = [](const std::string& stage, int shape, double seconds) {
    if (shape >= 0)
      std::fprintf(stderr, "  bake shape %d (%s): %-18s %7.2f s\n", shape, dictionary_shape_name(shape),
                   stage.c_str(), seconds);
    else
      std::fprintf(stderr, "  bake %-40s %7.2f s\n", stage.c_str(), seconds);
  };
  const auto t0 = std::chrono::steady_clock::now();
  Result<Dictionary> dict = precompute::load_or_bake_dictionary(
      settings, cache_dir, progress,
      [](const std::string& m) { std::fprintf(stderr, "modrt-bench-runtime: %s\n", m.c_str()); });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!dict.ok()) {
    error = std::string(label) + " dictionary: " + dict.status().to_string();
    std::fprintf(stderr, "modrt-bench-runtime: %s\n", error.c_str());
    return nullptr;
  }
  std::fprintf(stderr, "modrt-bench-runtime: %s dictionary (%s) %s in %.1f s\n", label,
               describe(settings).c_str(), cached ? "loaded" : "baked", seconds);
  return std::make_unique<Dictionary>(std::move(dict).value());
}

struct DictionarySlot {
  std::unique_ptr<Dictionary> dict;
  std::string error;
};

// The dictionaries are loaded once, on first use, so that a --benchmark_filter that needs
// only one of them never bakes the other.
const DictionarySlot& full_dictionary() {
  static const DictionarySlot slot = [] {
    DictionarySlot s;
    s.dict = load_dictionary_for_bench(full_settings(), "full-quality", s.error);
    return s;
  }();
  return slot;
}

const DictionarySlot& mobile_dictionary() {
  static const DictionarySlot slot = [] {
    DictionarySlot s;
    s.dict = load_dictionary_for_bench(mobile_settings(), "mobile", s.error);
    return s;
  }();
  return slot;
}

// maze11 and maze41 are the paper-sized presets; other sizes are generate_maze({blocks, seed 1}).
Result<LevelDescription> bench_maze(int blocks) {
  if (blocks == 11 || blocks == 41) return precompute::maze_level(blocks);
  precompute::MazeSettings m;
  m.blocks = blocks;
  m.seed = 1;
  return precompute::generate_maze(m);
}

// A built level with its fixed direct light and every per-frame buffer.
struct LevelFixture {
  Level level;
  std::vector<float> albedo, ld_direct, ld, b, r, lightmap;
  FeedbackClamp clamp;
};

struct FixtureSlot {
  std::unique_ptr<LevelFixture> fixture;
  std::string error;
};

const FixtureSlot& level_fixture(const Dictionary& dict, int blocks) {
  static std::map<std::pair<const Dictionary*, int>, FixtureSlot> cache;
  const auto key = std::make_pair(&dict, blocks);
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  FixtureSlot& slot = cache[key];
  Result<LevelDescription> desc = bench_maze(blocks);
  if (!desc.ok()) {
    slot.error = "maze: " + desc.status().to_string();
    return slot;
  }
  Result<Level> level = precompute::build_level(desc.value(), dict);
  if (!level.ok()) {
    slot.error = "build_level: " + level.status().to_string();
    return slot;
  }
  auto f = std::make_unique<LevelFixture>();
  f->level = std::move(level).value();
  try {
    const precompute::LevelScene scene(f->level, f->level.res);
    f->albedo = level_sample_albedo(f->level);
    f->ld_direct = precompute::level_direct_light(scene, desc->lights, f->albedo, kLightSamples);
  } catch (const std::exception& e) {
    slot.error = std::string("direct light: ") + e.what();
    return slot;
  }
  Result<FeedbackClamp> clamp =
      prepare_feedback(f->ld_direct, f->albedo, f->level.sample_count, MultiBounceSettings{});
  if (!clamp.ok()) {
    slot.error = "prepare_feedback: " + clamp.status().to_string();
    return slot;
  }
  f->clamp = std::move(clamp).value();
  const LevelBufferSizes sizes = level_buffer_sizes(f->level, dict);
  f->ld = f->ld_direct;
  f->b.assign(sizes.b, 0.0f);
  f->r.assign(sizes.r, 0.0f);
  f->lightmap.assign(sizes.lightmap, 0.0f);
  slot.fixture = std::move(f);
  return slot;
}

void set_level_counters(benchmark::State& state, const Level& level) {
  state.counters["blocks"] = static_cast<double>(level.blocks.size());
  state.counters["samples"] = static_cast<double>(level.sample_count);
  state.counters["records"] = static_cast<double>(level.records.size());
}

// --- BM_LevelBuild/<blocks> ---------------------------------------------------------------

void BM_LevelBuild(benchmark::State& state) {
  const DictionarySlot& d = full_dictionary();
  if (!d.dict) {
    state.SkipWithError(d.error.c_str());
    return;
  }
  const int blocks = static_cast<int>(state.range(0));
  const Result<LevelDescription> desc = bench_maze(blocks);
  if (!desc.ok()) {
    state.SkipWithError(desc.status().to_string().c_str());
    return;
  }
  const precompute::LevelBuildSettings settings;  // dmax 8
  std::size_t records = 0, samples = 0, block_count = 0;
  for (auto _ : state) {
    Result<Level> level = precompute::build_level(desc.value(), *d.dict, settings);
    if (!level.ok()) {
      state.SkipWithError(level.status().to_string().c_str());
      break;
    }
    benchmark::DoNotOptimize(level.value().records.data());
    benchmark::ClobberMemory();
    records = level->records.size();
    samples = level->sample_count;
    block_count = level->blocks.size();
  }
  state.counters["blocks"] = static_cast<double>(block_count);
  state.counters["samples"] = static_cast<double>(samples);
  state.counters["records"] = static_cast<double>(records);
}
BENCHMARK(BM_LevelBuild)->Arg(11)->Arg(41)->Arg(1000)->Unit(benchmark::kMillisecond);

// --- BM_ScalarLevelFrame/<blocks>, BM_ScalarLevelFrameMobile/<blocks> ----------------------

void scalar_level_frame(benchmark::State& state, const DictionarySlot& d) {
  if (!d.dict) {
    state.SkipWithError(d.error.c_str());
    return;
  }
  const FixtureSlot& fs = level_fixture(*d.dict, static_cast<int>(state.range(0)));
  if (!fs.fixture) {
    state.SkipWithError(fs.error.c_str());
    return;
  }
  LevelFixture& f = *fs.fixture;
  const LevelDependencies deps = level_dependencies(f.level);  // built once, as a runtime would
  for (auto _ : state) {
    const Status s = level_evaluate(f.level, *d.dict, deps, f.ld_direct, f.b, f.r, f.lightmap);
    if (!s.ok()) {
      state.SkipWithError(s.to_string().c_str());
      break;
    }
    benchmark::DoNotOptimize(f.lightmap.data());
    benchmark::ClobberMemory();
  }
  set_level_counters(state, f.level);
}

void BM_ScalarLevelFrame(benchmark::State& state) { scalar_level_frame(state, full_dictionary()); }
BENCHMARK(BM_ScalarLevelFrame)->Arg(11)->Arg(41)->Unit(benchmark::kMicrosecond);

void BM_ScalarLevelFrameMobile(benchmark::State& state) { scalar_level_frame(state, mobile_dictionary()); }
BENCHMARK(BM_ScalarLevelFrameMobile)->Arg(11)->Arg(41)->Unit(benchmark::kMicrosecond);

// --- BM_ScalarBlock/<kb> -------------------------------------------------------------------

void BM_ScalarBlock(benchmark::State& state) {
  const int kb = static_cast<int>(state.range(0));
  const DictionarySlot& d =
      kb == static_cast<int>(mobile_settings().kb) ? mobile_dictionary() : full_dictionary();
  if (!d.dict) {
    state.SkipWithError(d.error.c_str());
    return;
  }
  if (d.dict->settings.kb != static_cast<std::uint32_t>(kb)) {
    state.SkipWithError("no dictionary with this kb");
    return;
  }
  const ShapeOperators& op = d.dict->shapes[0];  // closed box
  const std::size_t n = op.sample_count();
  // A smooth, positive, deterministic direct-light signal (the operators are dense, so the
  // timing does not depend on the values).
  std::vector<float> ld(3 * n);
  for (std::size_t i = 0; i < ld.size(); ++i)
    ld[i] = 0.5f + 0.25f * static_cast<float>(std::sin(0.01 * static_cast<double>(i)));
  std::vector<float> b(3 * std::size_t(op.kb())), lightmap(3 * n);
  for (auto _ : state) {
    const Status s = compute_b(op, ld, b);
    if (!s.ok()) {
      state.SkipWithError(s.to_string().c_str());
      break;
    }
    apply_Ub(op, b, lightmap);
    benchmark::DoNotOptimize(lightmap.data());
    benchmark::ClobberMemory();
  }
  state.counters["samples"] = static_cast<double>(n);
  state.counters["res"] = static_cast<double>(d.dict->settings.res);
}
BENCHMARK(BM_ScalarBlock)->Arg(32)->Arg(12)->Unit(benchmark::kMicrosecond);

// --- BM_LevelMultiBounceIteration/<blocks> --------------------------------------------------
// One iteration of level_multi_bounce's feedback loop: ld = ld_direct + rho * clamp(lightmap),
// then b, r, lightmap from ld (level_evaluate). The clamp is prepared in the setup.

void BM_LevelMultiBounceIteration(benchmark::State& state) {
  const DictionarySlot& d = full_dictionary();
  if (!d.dict) {
    state.SkipWithError(d.error.c_str());
    return;
  }
  const FixtureSlot& fs = level_fixture(*d.dict, static_cast<int>(state.range(0)));
  if (!fs.fixture) {
    state.SkipWithError(fs.error.c_str());
    return;
  }
  LevelFixture& f = *fs.fixture;
  // Start from the one-bounce lightmap so the feedback sees realistic values.
  if (const Status s = level_evaluate(f.level, *d.dict, f.ld_direct, f.b, f.r, f.lightmap); !s.ok()) {
    state.SkipWithError(s.to_string().c_str());
    return;
  }
  const LevelDependencies deps = level_dependencies(f.level);
  for (auto _ : state) {
    const bool clamped = apply_feedback(f.clamp, f.ld_direct, f.lightmap, f.ld);
    benchmark::DoNotOptimize(clamped);
    const Status s = level_evaluate(f.level, *d.dict, deps, f.ld, f.b, f.r, f.lightmap);
    if (!s.ok()) {
      state.SkipWithError(s.to_string().c_str());
      break;
    }
    benchmark::DoNotOptimize(f.lightmap.data());
    benchmark::ClobberMemory();
  }
  set_level_counters(state, f.level);
}
BENCHMARK(BM_LevelMultiBounceIteration)->Arg(41)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
