// SPDX-License-Identifier: MIT
// modrt-bench-stress: the cost of hostile numbers on the SIMD CPU path (issue 9,
// docs/robustness.md). Small test dictionary (res 8, kb 32; tests/test_support.h) and maze41,
// so that it runs without the full dictionary.
//
// BM_CpuDenormalLd/<isa>/<flush>: one runtime evaluates, in the same loop, a normal ld (the
// fixture's) and a denormal one (the same scaled to max 1e-39, below FLT_MIN = 1.2e-38, so every
// product and partial sum of Td_b ld and Ub b is subnormal), in alternating chunks of 16 frames.
// flush = CpuRuntimeOptions::flush_denormals (1, the default: FTZ + DAZ while the runtime
// computes; 0: IEEE gradual underflow). The reported time is the denormal frame's; counters
// normal_us, denormal_us and ratio = denormal / normal, from the same run, and lightmap_max of
// the denormal frame (0 when flushed).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <vector>

#include "level_fixtures.h"
#include "modrt/cpu/cpu_level_runtime.h"

namespace modrt {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void BM_CpuDenormalLd(benchmark::State& state) {
  const auto isa = cpu::Isa(state.range(0));
  if (!cpu::isa_supported(isa)) return state.SkipWithError("ISA not supported here");
  const test::TestLevel& t = test::test_level("maze41");
  cpu::CpuRuntimeOptions options;
  options.isa = isa;
  options.flush_denormals = state.range(1) != 0;
  Result<cpu::CpuLevelRuntime> rt =
      cpu::CpuLevelRuntime::create(t.level, test::small_test_dictionary(), options);
  if (!rt.ok()) return state.SkipWithError(rt.status().message().c_str());
  const float ld_max = *std::max_element(t.ld.begin(), t.ld.end());
  std::vector<float> denormal(t.ld);
  for (float& v : denormal) v = v / ld_max * 1e-39f;
  std::vector<float> lightmap(rt->sizes().lightmap);
  constexpr int kChunk = 16;
  auto run_chunk = [&](const std::vector<float>& ld) {
    bool ok = rt->evaluate(ld, lightmap).ok();  // untimed: the chunk starts warm
    const auto t0 = std::chrono::steady_clock::now();
    for (int f = 1; f < kChunk; ++f) ok &= rt->evaluate(ld, lightmap).ok();
    benchmark::DoNotOptimize(ok);
    benchmark::ClobberMemory();
    return seconds_since(t0);
  };
  double t_normal = 0.0, t_denormal = 0.0;
  for (auto _ : state) {
    t_normal += run_chunk(t.ld);
    const double d = run_chunk(denormal);
    t_denormal += d;
    state.SetIterationTime(d / double(kChunk - 1));
  }
  const float out_max = *std::max_element(lightmap.begin(), lightmap.end());
  const double frames = double(state.iterations()) * double(kChunk - 1);
  state.counters["normal_us"] = t_normal / frames * 1e6;
  state.counters["denormal_us"] = t_denormal / frames * 1e6;
  state.counters["ratio"] = t_denormal / t_normal;
  state.counters["lightmap_max"] = double(out_max);  // 0 when flushed
  state.SetLabel(cpu::isa_name(isa));
}

// BM_CpuFlushOverhead/<threads>: what the flush guard costs a normal frame (maze41, best ISA,
// the fixture's ld): a runtime with flush_denormals and one without, alternating chunks of 16
// frames in the same loop. Reported time: the flushing frame; ratio = flushing / not flushing.
void BM_CpuFlushOverhead(benchmark::State& state) {
  const test::TestLevel& t = test::test_level("maze41");
  cpu::CpuRuntimeOptions on;
  on.threads = int(state.range(0));
  cpu::CpuRuntimeOptions off = on;
  off.flush_denormals = false;
  Result<cpu::CpuLevelRuntime> rt_on =
      cpu::CpuLevelRuntime::create(t.level, test::small_test_dictionary(), on);
  Result<cpu::CpuLevelRuntime> rt_off =
      cpu::CpuLevelRuntime::create(t.level, test::small_test_dictionary(), off);
  if (!rt_on.ok() || !rt_off.ok()) return state.SkipWithError("runtime");
  std::vector<float> lightmap(rt_on->sizes().lightmap);
  constexpr int kChunk = 16;
  auto run_chunk = [&](cpu::CpuLevelRuntime& rt) {
    bool ok = rt.evaluate(t.ld, lightmap).ok();
    const auto t0 = std::chrono::steady_clock::now();
    for (int f = 1; f < kChunk; ++f) ok &= rt.evaluate(t.ld, lightmap).ok();
    benchmark::DoNotOptimize(ok);
    benchmark::ClobberMemory();
    return seconds_since(t0);
  };
  double t_on = 0.0, t_off = 0.0;
  for (auto _ : state) {
    t_off += run_chunk(rt_off.value());
    const double c = run_chunk(rt_on.value());
    t_on += c;
    state.SetIterationTime(c / double(kChunk - 1));
  }
  const double frames = double(state.iterations()) * double(kChunk - 1);
  state.counters["flush_us"] = t_on / frames * 1e6;
  state.counters["no_flush_us"] = t_off / frames * 1e6;
  state.counters["ratio"] = t_on / t_off;
}

BENCHMARK(BM_CpuDenormalLd)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1}})
    ->ArgNames({"isa", "flush"})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuFlushOverhead)
    ->Arg(1)
    ->Arg(2)
    ->ArgName("threads")
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace modrt

BENCHMARK_MAIN();
