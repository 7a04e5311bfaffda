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

#include "bench_levels.h"

namespace {

using namespace modrt;

using bench::bench_level;
using bench::BenchLevel;
using bench::dictionary;

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
