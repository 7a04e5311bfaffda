// modrt-bench-cpu — Google Benchmark timings of the SIMD CPU runtime (cpu_neon/) against
// core's scalar reference, in the same run (SPEC §5). Speed is measured only here.
//
//   BM_CoreLevelFrame/<blocks>        core level_evaluate (b, r, lightmap)
//   BM_CpuLevelFrame/<blocks>/<isa>   CpuLevelRuntime::evaluate with a forced ISA
//                                     (0 scalar, 1 sse41, 2 avx2, 3 neon; unsupported ones skip)
//
// Levels: maze11, maze41 and a 1000-block maze, built (dmax 8) against the DEFAULT full
// dictionary, loaded from the cache ($MODRT_CACHE_DIR, ...) or baked on first use (~70 s).
// ld is a fixed synthetic non-negative pattern: the cost of a frame does not depend on it.
// Ratio core / cpu = speed-up; the counters report samples and records per level.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
#include <memory>
#include <vector>

#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/maze.h"

namespace {

using namespace modrt;

const Dictionary* dictionary() {
  static const std::unique_ptr<Dictionary> dict = [] {
    Result<Dictionary> d = precompute::load_or_bake_dictionary(DictionarySettings{}, precompute::default_cache_dir());
    if (!d.ok()) {
      std::fprintf(stderr, "modrt-bench-cpu: %s\n", d.status().to_string().c_str());
      return std::unique_ptr<Dictionary>();
    }
    return std::make_unique<Dictionary>(std::move(d).value());
  }();
  return dict.get();
}

struct BenchLevel {
  Level level;
  std::vector<float> ld;
};

const BenchLevel* bench_level(int blocks) {
  static std::map<int, std::unique_ptr<BenchLevel>> cache;
  auto it = cache.find(blocks);
  if (it != cache.end()) return it->second.get();
  std::unique_ptr<BenchLevel> out;
  if (const Dictionary* dict = dictionary()) {
    Result<LevelDescription> desc = precompute::maze_level(blocks);
    Result<Level> level = desc.ok() ? precompute::build_level(desc.value(), *dict) : Result<Level>(desc.status());
    if (level.ok()) {
      out = std::make_unique<BenchLevel>();
      out->level = std::move(level).value();
      out->ld.resize(3 * std::size_t(out->level.sample_count));
      for (std::size_t i = 0; i < out->ld.size(); ++i) out->ld[i] = float((i * 7919) % 1000) / 1000.0f;
    } else {
      std::fprintf(stderr, "modrt-bench-cpu: maze %d: %s\n", blocks, level.status().to_string().c_str());
    }
  }
  return cache.emplace(blocks, std::move(out)).first->second.get();
}

void set_counters(benchmark::State& state, const Level& level) {
  state.counters["samples"] = double(level.sample_count);
  state.counters["records"] = double(level.records.size());
}

void BM_CoreLevelFrame(benchmark::State& state) {
  const BenchLevel* bl = bench_level(int(state.range(0)));
  if (!bl) return state.SkipWithError("no dictionary or level");
  const LevelBufferSizes s = level_buffer_sizes(bl->level, *dictionary());
  std::vector<float> b(s.b), r(s.r), lightmap(s.lightmap);
  for (auto _ : state) {
    const Status st = level_evaluate(bl->level, *dictionary(), bl->ld, b, r, lightmap);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
  }
  set_counters(state, bl->level);
}

void BM_CpuLevelFrame(benchmark::State& state) {
  const cpu::Isa isa = cpu::Isa(state.range(1));
  if (!cpu::isa_supported(isa)) return state.SkipWithError("ISA not supported here");
  const BenchLevel* bl = bench_level(int(state.range(0)));
  if (!bl) return state.SkipWithError("no dictionary or level");
  Result<cpu::CpuLevelRuntime> rt = cpu::CpuLevelRuntime::create(bl->level, *dictionary(), {isa, 1});
  if (!rt.ok()) return state.SkipWithError(rt.status().message().c_str());
  std::vector<float> lightmap(rt->sizes().lightmap);
  for (auto _ : state) {
    const Status st = rt->evaluate(bl->ld, lightmap);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
  }
  state.SetLabel(cpu::isa_name(isa));
  set_counters(state, bl->level);
}

BENCHMARK(BM_CoreLevelFrame)->Arg(11)->Arg(41)->Arg(1000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuLevelFrame)->ArgsProduct({{11, 41, 1000}, {0, 1, 2, 3}})->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
