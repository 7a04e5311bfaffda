// SPDX-License-Identifier: MIT
// modrt-bench-c-api — what the C API costs over calling the CPU runtime directly (issue 19:
// at most 2 % on maze41). Both paths do the same frame, full evaluation (skipping off), one
// thread, on the default full dictionary (bench_levels.h):
//   BM_CApiFrame/<blocks>/0   CpuLevelRuntime: evaluate(ld) + fill_atlas + compute_probes
//   BM_CApiFrame/<blocks>/1   modrt_context_set_ld(ld) + modrt_context_update (the same calls,
//                             behind the handle, the argument checks and the stats)
// Levels: maze11 and maze41. Run both in one invocation and compare the ratio.
#include <benchmark/benchmark.h>

#include <vector>

#include "bench_levels.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/level_io.h"
#include "modrt/modrt.h"

namespace {

using namespace modrt;

void BM_CApiFrame(benchmark::State& state) {
  const bench::BenchLevel* bl = bench::bench_level(int(state.range(0)));
  const Dictionary* dict = bench::dictionary();
  if (!bl || !dict) {
    state.SkipWithError("no dictionary or level");
    return;
  }
  const std::vector<float>& ld = bl->ld;
  // Both paths run on a level and a dictionary parsed from their file images, as an app loads
  // them: the operators of a level built in memory lie scattered over the heap (allocated
  // during the build), which alone made maze41's frame 20-40 % slower than the parsed copy's.
  const std::vector<std::byte> dict_bytes = serialize_dictionary(*dict).value();
  const std::vector<std::byte> level_bytes = serialize_level(bl->level).value();
  if (state.range(1) == 0) {
    static const Dictionary parsed_dict = parse_dictionary(dict_bytes, "bench").value();
    const Level parsed_level = parse_level(level_bytes, "bench").value();
    cpu::CpuRuntimeOptions options;  // one thread, skipping off
    Result<cpu::CpuLevelRuntime> rt = cpu::CpuLevelRuntime::create(parsed_level, parsed_dict, options);
    if (!rt.ok()) {
      state.SkipWithError(rt.status().to_string().c_str());
      return;
    }
    const LevelBufferSizes& s = rt->sizes();
    std::vector<float> lightmap(s.lightmap), atlas(s.atlas), probes(s.probes);
    for (auto _ : state) {
      bool ok = rt->evaluate(ld, lightmap).ok() && rt->fill_atlas(lightmap, atlas).ok();
      if (!probes.empty()) ok = ok && rt->compute_probes(probes).ok();
      if (!ok) state.SkipWithError("frame failed");
      benchmark::DoNotOptimize(atlas.data());
    }
    state.SetLabel(std::string("CpuLevelRuntime ") + cpu::isa_name(rt->isa()));
    return;
  }
  modrt_dictionary* d = nullptr;
  modrt_level* l = nullptr;
  modrt_context* c = nullptr;
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.skip_unchanged = 0;
  o.bounces = 0;  // one bounce, the direct path's frame (the default is the converged solve)
  if (modrt_dictionary_load_memory(dict_bytes.data(), dict_bytes.size(), "bench", nullptr, &d) != MODRT_OK ||
      modrt_level_load_memory(level_bytes.data(), level_bytes.size(), "bench", nullptr, &l) != MODRT_OK ||
      modrt_context_create(d, l, &o, nullptr, &c) != MODRT_OK) {
    state.SkipWithError(modrt_last_error());
  } else {
    for (auto _ : state) {
      if (modrt_context_set_ld(c, ld.data(), ld.size()) != MODRT_OK || modrt_context_update(c) != MODRT_OK)
        state.SkipWithError(modrt_last_error());
    }
    state.SetLabel(std::string("C API ") + modrt_context_description(c));
  }
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}
BENCHMARK(BM_CApiFrame)->ArgsProduct({{11, 41}, {0, 1}})->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
