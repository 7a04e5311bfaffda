// SPDX-License-Identifier: MIT
// modrt-bench-drt-runtime — Google Benchmark timings of DRT's run-time cost over MRT alone
// (architecture.md §5 step 7, [Loos et al. 2012] §6: 1.5 -> 2.1 ms per frame on their GPU), through the
// Backend interface, on the four-pillar corridor of tests/drt_scenes.h (small test
// dictionary: res 8, kb 32, 3 blocks, 896 samples; 4 pillars x 4 faces x 16^2 texels, operators
// built with 1024 rays).
//
//   BM_BackendFrame/<backend>/<drt>   update(ld), the ld alternating between two signals so
//                                     that every block changes (no frame is skipped); GLES
//                                     ends each frame with glFinish (wall clock)
//     backend: 0 CPU (best ISA), 1 GLES EGL surfaceless, 2 GLES OSMesa, 3 GLES EGL device
//              (unavailable contexts skip)
//     drt:     0 MRT alone, 1 MRT + DRT (c, dUb b + dUc c into the lightmap and atlas, the
//              clutter lightmap Cb b + direct)
//     counters (GLES): b_us, r_us, atlas_us, drt_us (c + delta), clutter_us (Vc b, clutter atlas)
//              per pass, from 8 extra frames with GlesLevelRuntime::set_timing after the
//              timed loop
// The ratio of a backend's drt 1 to drt 0 time is DRT's cost; compare within one run.
//   BM_DrtOverMrt/<backend>           the same two frames interleaved in one loop (an MRT
//                                     backend and an MRT + DRT backend, alternately), so that
//                                     the shared machine's load drifts over both alike;
//                                     counters mrt_us, drt_us (per frame) and ratio
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "drt_scenes.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/platform/gl_context.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "test_support.h"

namespace {

using namespace modrt;

struct Scene {
  Level level;
  DrtOperators drt;
  std::vector<float> ld[2], clutter_ld, clutter_direct;
  bool ok = false;
};

const Scene& scene() {
  static const Scene s = [] {
    Scene out;
    const Dictionary& dict = test::small_test_dictionary();
    const test::ClutterScene cs = test::maze_block_four_pillars();
    Result<Level> level = precompute::build_level(cs.description, dict);
    if (!level.ok()) {
      std::fprintf(stderr, "level: %s\n", level.status().to_string().c_str());
      return out;
    }
    out.level = std::move(level).value();
    precompute::DrtBuildSettings settings;
    settings.rays = 1024;
    Result<DrtOperators> drt = precompute::DrtBuilder(out.level, dict, settings).build(cs.clutter);
    if (!drt.ok()) {
      std::fprintf(stderr, "drt: %s\n", drt.status().to_string().c_str());
      return out;
    }
    out.drt = std::move(drt).value();
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (auto& ld : out.ld) {
      ld.resize(3 * std::size_t(out.level.sample_count));
      for (float& v : ld) v = u(rng);
    }
    const DrtBufferSizes sizes = drt_buffer_sizes(out.drt);
    out.clutter_ld.resize(sizes.clutter_ld);
    out.clutter_direct.resize(sizes.clutter_lightmap);
    for (float& v : out.clutter_ld) v = u(rng);
    for (float& v : out.clutter_direct) v = 0.5f * u(rng);
    std::fprintf(stderr, "modrt-bench-drt-runtime: %u samples, %zu clutter texels, operators %zu B\n",
                 out.level.sample_count, sizes.clutter_texels, out.drt.storage_bytes());
    out.ok = true;
    return out;
  }();
  return s;
}

// Destroyed at the end of main(), not by static destructors (OSMesa crashes if its context
// outlives Mesa's exit handlers).
std::map<int, std::unique_ptr<platform::GlContext>>& contexts() {
  static std::map<int, std::unique_ptr<platform::GlContext>> cache;
  return cache;
}

platform::GlContext* context(int backend) {
  static const platform::ContextRequest requests[] = {platform::ContextRequest::egl_surfaceless,
                                                      platform::ContextRequest::osmesa,
                                                      platform::ContextRequest::egl_device};
  std::map<int, std::unique_ptr<platform::GlContext>>& cache = contexts();
  auto it = cache.find(backend);
  if (it == cache.end()) {
    Result<std::unique_ptr<platform::GlContext>> c = platform::create_context(requests[backend - 1]);
    std::unique_ptr<platform::GlContext> ctx;
    if (c.ok()) {
      ctx = std::move(c).value();
      std::fprintf(stderr, "modrt-bench-drt-runtime: backend %d: %s | %s\n", backend,
                   ctx->info().renderer.c_str(), ctx->info().version.c_str());
    } else {
      std::fprintf(stderr, "modrt-bench-drt-runtime: backend %d: %s\n", backend,
                   c.status().to_string().c_str());
    }
    it = cache.emplace(backend, std::move(ctx)).first;
  }
  if (it->second && !it->second->make_current().ok()) return nullptr;
  return it->second.get();
}

// The backend of `kind` (see above), with the four pillars when `with_drt`; null and a reason
// in `error` when it cannot be made here.
std::unique_ptr<Backend> make_backend(int kind, bool with_drt, platform::GlContext** ctx_out,
                                      std::string* error) {
  const Scene& s = scene();
  const Dictionary& dict = test::small_test_dictionary();
  std::unique_ptr<Backend> backend;
  *ctx_out = nullptr;
  if (kind == 0) {
    Result<std::unique_ptr<Backend>> be = cpu::create_cpu_backend(s.level, dict);
    if (!be.ok()) {
      *error = be.status().to_string();
      return nullptr;
    }
    backend = std::move(be).value();
  } else {
    platform::GlContext* ctx = context(kind);
    if (!ctx) {
      *error = "no such GL context here";
      return nullptr;
    }
    Result<std::unique_ptr<gles::GlesLevelRuntime>> be =
        gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, s.level, dict);
    if (!be.ok()) {
      *error = be.status().to_string();
      return nullptr;
    }
    backend = std::move(be).value();
    *ctx_out = ctx;
  }
  if (with_drt) {
    Status st = backend->set_clutter(&s.drt);
    if (st.ok()) st = backend->set_clutter_light(s.clutter_ld, s.clutter_direct);
    if (!st.ok()) {
      *error = st.to_string();
      return nullptr;
    }
  }
  return backend;
}

void BM_DrtOverMrt(benchmark::State& state) {
  const Scene& s = scene();
  if (!s.ok) {
    state.SkipWithError("no level or DRT operators");
    return;
  }
  std::string error;
  platform::GlContext* ctx = nullptr;
  std::unique_ptr<Backend> mrt = make_backend(int(state.range(0)), false, &ctx, &error);
  std::unique_ptr<Backend> drt = mrt ? make_backend(int(state.range(0)), true, &ctx, &error) : nullptr;
  if (!mrt || !drt) {
    state.SkipWithError(error.c_str());
    return;
  }
  using Clock = std::chrono::steady_clock;
  std::size_t frame = 0;
  double mrt_s = 0.0, drt_s = 0.0;
  auto timed = [&](Backend& be) {
    const Clock::time_point t0 = Clock::now();
    const Status st = be.update(s.ld[frame % 2]);
    if (ctx) ctx->gl().glFinish();
    if (!st.ok()) state.SkipWithError(st.to_string().c_str());
    return std::chrono::duration<double>(Clock::now() - t0).count();
  };
  // Both backends get the same ld each round, and it alternates between rounds, so that no
  // frame is skipped.
  for (int warm = 0; warm < 3; ++warm, ++frame) timed(*mrt), timed(*drt);
  for (auto _ : state) {
    mrt_s += timed(*mrt);
    drt_s += timed(*drt);
    ++frame;
  }
  const double n = double(state.iterations());
  state.counters["mrt_us"] = 1e6 * mrt_s / n;
  state.counters["drt_us"] = 1e6 * drt_s / n;
  state.counters["ratio"] = mrt_s > 0.0 ? drt_s / mrt_s : 0.0;
  state.SetLabel(drt->description());
}

BENCHMARK(BM_DrtOverMrt)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_BackendFrame(benchmark::State& state) {
  const Scene& s = scene();
  const int kind = int(state.range(0));
  const bool with_drt = state.range(1) != 0;
  if (!s.ok) {
    state.SkipWithError("no level or DRT operators");
    return;
  }
  const Dictionary& dict = test::small_test_dictionary();
  std::unique_ptr<Backend> backend;
  platform::GlContext* ctx = nullptr;
  if (kind == 0) {
    Result<std::unique_ptr<Backend>> be = cpu::create_cpu_backend(s.level, dict);
    if (!be.ok()) {
      state.SkipWithError(be.status().to_string().c_str());
      return;
    }
    backend = std::move(be).value();
  } else {
    ctx = context(kind);
    if (!ctx) {
      state.SkipWithError("no such GL context here");
      return;
    }
    Result<std::unique_ptr<gles::GlesLevelRuntime>> be =
        gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, s.level, dict);
    if (!be.ok()) {
      state.SkipWithError(be.status().to_string().c_str());
      return;
    }
    backend = std::move(be).value();
  }
  if (with_drt) {
    if (Status st = backend->set_clutter(&s.drt); !st.ok()) {
      state.SkipWithError(st.to_string().c_str());
      return;
    }
    if (Status st = backend->set_clutter_light(s.clutter_ld, s.clutter_direct); !st.ok()) {
      state.SkipWithError(st.to_string().c_str());
      return;
    }
  }
  std::size_t frame = 0;
  for (int warm = 0; warm < 3; ++warm) (void)backend->update(s.ld[frame++ % 2]);
  if (ctx) ctx->gl().glFinish();
  for (auto _ : state) {
    if (Status st = backend->update(s.ld[frame++ % 2]); !st.ok()) {
      state.SkipWithError(st.to_string().c_str());
      break;
    }
    if (ctx) ctx->gl().glFinish();
  }
  if (ctx) {  // per-pass times of a few extra frames, outside the timed loop
    auto* rt = static_cast<gles::GlesLevelRuntime*>(backend.get());
    rt->set_timing(true);
    gles::GlesPassTimes sum;
    constexpr int kFrames = 8;
    for (int k = 0; k < kFrames; ++k) {
      (void)backend->update(s.ld[frame++ % 2]);
      const gles::GlesPassTimes& t = rt->pass_times();
      sum.b += t.b, sum.r += t.r, sum.atlas += t.atlas, sum.drt += t.drt, sum.clutter += t.clutter;
    }
    auto us = [&](std::uint64_t ns) { return double(ns) / (1e3 * kFrames); };
    state.counters["b_us"] = us(sum.b);
    state.counters["r_us"] = us(sum.r);
    state.counters["atlas_us"] = us(sum.atlas);
    state.counters["drt_us"] = us(sum.drt);
    state.counters["clutter_us"] = us(sum.clutter);
  }
  state.SetLabel(backend->description());
}

BENCHMARK(BM_BackendFrame)->ArgsProduct({{0, 1, 2, 3}, {0, 1}})->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  contexts().clear();
  return 0;
}
