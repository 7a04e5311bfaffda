// SPDX-License-Identifier: MIT
// modrt-bench-gles — Google Benchmark timings of the OpenGL ES backend (gles/) per frame,
// with the CPU backend's AVX2/NEON/best-ISA frame on the same level in the same run for a
// ratio. Speed is measured only here.
//
//   BM_GlesLevelFrame/<blocks>/<context>/<moving>/<vector>   update(ld) + glFinish, wall clock;
//     moving 0: the full path (skipping off); 1: one block's ld changes per frame, skipping on
//     vector 1: the vector irradiance pass runs too (GlesRuntimeOptions::vector_irradiance)
//     counters:
//        gpu_us  sum of the passes' GPU timer-query times (0 when the context has none)
//        b_us, r_us, atlas_us, probes_us, vector_us, upload_us  per pass
//     context: 0 auto, 1 egl-surfaceless, 2 osmesa, 3 egl-device (unavailable ones skip)
//   BM_TbrOnCpu/<blocks>/<context>         Tb->r done on the CPU instead: read b back, SIMD
//                                          records, upload r (compare with r_us above)
//   BM_GlesLdSource/<blocks>/<context>/<gpu>  ld from an app's GPU pass: read back and uploaded
//                                          (gpu 0) or read on the GPU (gpu 1, update_from_texture)
//   BM_GlesCameraSkip/<blocks>/<context>   the camera skip (set_visible_blocks from
//                                          CameraVisibility, bench_levels.h's camera flight)
//                                          against the full path (skipping off, no camera),
//                                          measured alternately, ld scaled every frame (every
//                                          block's b and r change), vector irradiance on; time:
//                                          the frame with the skip, walk included, glFinish.
//                                          Counters: ratio_full = with / full, visible blocks,
//                                          redrawn blocks per frame with the skip
//   BM_GlesConverged/<blocks>/<context>    the converged multi-bounce (update_converged: the
//                                          reduced solve's passes, an a-priori iteration count)
//                                          against a one-bounce full update (skipping off),
//                                          measured alternately, ld scaled every frame, the
//                                          level's albedo; time: the converged frame, glFinish.
//                                          Counters: ratio_one_bounce, iterations per frame,
//                                          error_bound (the a-priori bound q^iterations)
//   BM_CpuBackendFrame/<blocks>/<vector>   the CPU backend's update (best ISA), for the ratio;
//                                          vector 1: + read_vector_lightmap (computed on read)
//
// Levels: maze11 and maze41 against the default full dictionary (bench_levels.h;
// MODRT_BENCH_DICTIONARY=FILE loads a dictionary file instead of the cache).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <vector>

#include "bench_levels.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/cpu/kernels.h"
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/level_geometry.h"
#include "modrt/level_visibility.h"
#include "modrt/platform/gl_context.h"
#include "modrt/platform/gl_program.h"
#include "modrt/reference_runtime.h"

namespace {

using namespace modrt;

using bench::bench_level;
using bench::BenchLevel;
using bench::dictionary;

// Destroyed at the end of main(), not by static destructors (OSMesa crashes if its context
// outlives Mesa's exit handlers).
std::map<int, std::unique_ptr<platform::GlContext>>& contexts() {
  static std::map<int, std::unique_ptr<platform::GlContext>> cache;
  return cache;
}

platform::GlContext* context(int index) {
  static const platform::ContextRequest requests[] = {
      platform::ContextRequest::auto_select, platform::ContextRequest::egl_surfaceless,
      platform::ContextRequest::osmesa, platform::ContextRequest::egl_device};
  std::map<int, std::unique_ptr<platform::GlContext>>& cache = contexts();
  auto it = cache.find(index);
  if (it == cache.end()) {
    Result<std::unique_ptr<platform::GlContext>> c = platform::create_context(requests[index]);
    std::unique_ptr<platform::GlContext> ctx;
    if (c.ok()) {
      ctx = std::move(c).value();
      std::fprintf(stderr, "modrt-bench-gles: context %d: %s | %s | %s\n%s", index,
                   platform::context_kind_name(ctx->info().kind), ctx->info().renderer.c_str(),
                   ctx->info().version.c_str(), ctx->info().selection_report.c_str());
      std::fputc('\n', stderr);
    } else {
      std::fprintf(stderr, "modrt-bench-gles: context %d: %s\n", index, c.status().to_string().c_str());
    }
    it = cache.emplace(index, std::move(ctx)).first;
  }
  if (it->second && !it->second->make_current().ok()) return nullptr;
  return it->second.get();
}

void BM_GlesLevelFrame(benchmark::State& state) {
  const BenchLevel* bl = bench_level(int(state.range(0)));
  platform::GlContext* ctx = context(int(state.range(1)));
  if (!bl || !ctx) {
    state.SkipWithError("no dictionary/level or no such GL context here");
    return;
  }
  const bool moving_light = state.range(2) != 0;
  gles::GlesRuntimeOptions options;
  options.skip_unchanged = moving_light;  // the full path recomputes everything every frame
  options.vector_irradiance = state.range(3) != 0;
  Result<std::unique_ptr<gles::GlesLevelRuntime>> rt =
      gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, bl->level, *dictionary(), options);
  if (!rt.ok()) {
    state.SkipWithError(rt.status().to_string().c_str());
    return;
  }
  gles::GlesLevelRuntime& runtime = *rt.value();
  // Moving light: each frame the ld of one block (cycling through the level) changes, as
  // when a light moves inside it; the rest of the level's ld stays bit-identical.
  std::vector<float> ld = bl->ld;
  std::size_t frame = 0;
  auto next_ld = [&]() -> const std::vector<float>& {
    if (!moving_light) return bl->ld;
    const LevelBlock& blk = bl->level.blocks[(frame * 7) % bl->level.blocks.size()];
    const float scale = 1.0f + 0.01f * float(frame % 17);
    for (std::size_t i = 0; i < 3 * std::size_t(blk.sample_count); ++i)
      ld[3 * std::size_t(blk.sample_offset) + i] = bl->ld[3 * std::size_t(blk.sample_offset) + i] * scale;
    ++frame;
    return ld;
  };
  for (int warm = 0; warm < 3; ++warm) (void)runtime.update(next_ld());
  ctx->gl().glFinish();
  for (auto _ : state) {
    if (!runtime.update(next_ld()).ok()) state.SkipWithError("update failed");
    ctx->gl().glFinish();
  }
  // Per-pass times from a separate, timed run of frames (timer queries where available).
  runtime.set_timing(true);
  gles::GlesPassTimes sum{};
  constexpr int kTimedFrames = 20;
  for (int i = 0; i < kTimedFrames; ++i) {
    (void)runtime.update(next_ld());
    const gles::GlesPassTimes& t = runtime.pass_times();
    sum.upload += t.upload, sum.b += t.b, sum.r += t.r, sum.atlas += t.atlas, sum.probes += t.probes,
        sum.vector += t.vector;
  }
  auto us = [](std::uint64_t ns) { return double(ns) / kTimedFrames / 1000.0; };
  state.counters["upload_us"] = us(sum.upload);
  state.counters["b_us"] = us(sum.b);
  state.counters["r_us"] = us(sum.r);
  state.counters["atlas_us"] = us(sum.atlas);
  state.counters["probes_us"] = us(sum.probes);
  state.counters["vector_us"] = us(sum.vector);
  state.counters["gpu_us"] = us(sum.b + sum.r + sum.atlas + sum.probes + sum.vector);
  state.counters["blocks"] = double(bl->level.blocks.size());
  state.counters["records"] = double(bl->level.records.size());
  const gles::GlesSkipStats& skip = runtime.skip_stats();
  state.counters["redrawn_blocks"] =
      double(skip.blocks_redrawn) / double(std::max<std::uint64_t>(skip.frames, 1));
  state.SetLabel(std::string(platform::context_kind_name(ctx->info().kind)) + " " + runtime.description());
}
BENCHMARK(BM_GlesLevelFrame)
    ->ArgsProduct({{11, 41}, {0, 1, 2, 3}, {0, 1}, {0}})
    ->ArgsProduct({{11, 41}, {0, 3}, {0}, {1}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

// Tb->r on the CPU instead of the GPU (gles/README.md: the runtime does it on the GPU). Per
// frame this alternative reads b back (a pipeline sync), runs every record with the best
// SIMD kernel and uploads r (three RGBA32UI planes, as the r pass writes them), then
// glFinish. Compare with r_us of BM_GlesLevelFrame on the same context.
void BM_TbrOnCpu(benchmark::State& state) {
  const BenchLevel* bl = bench_level(int(state.range(0)));
  platform::GlContext* ctx = context(int(state.range(1)));
  if (!bl || !ctx) {
    state.SkipWithError("no dictionary/level or no such GL context here");
    return;
  }
  const Level& level = bl->level;
  Result<std::unique_ptr<gles::GlesLevelRuntime>> rt =
      gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, level, *dictionary(), {});
  if (!rt.ok() || !rt.value()->update(bl->ld).ok()) {
    state.SkipWithError("GLES runtime failed");
    return;
  }
  const platform::GlFunctions& gl = ctx->gl();
  const std::size_t kb = level.kb, kr = level.kr, groups = (kr + 3) / 4;
  std::vector<float> b(3 * kb * level.blocks.size()), b_planar(b.size()), r(3 * kr * level.slots.size());
  const std::size_t texels = level.slots.size() * groups;
  const int width = 2048, rows = int((texels + width - 1) / width);
  std::vector<float> planes(3 * std::size_t(width) * std::size_t(rows) * 4, 0.0f);
  GLuint textures[3];
  gl.glGenTextures(3, textures);
  for (GLuint t : textures) {
    gl.glBindTexture(GL_TEXTURE_2D, t);
    gl.glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32UI, width, rows);
  }
  const cpu::Isa isa = cpu::active_isa();
  for (auto _ : state) {
    if (!rt.value()->read_b(b).ok()) state.SkipWithError("read_b failed");
    for (std::size_t i = 0; i < level.blocks.size(); ++i)
      cpu::deinterleave_rgb(b.data() + 3 * kb * i, kb, b_planar.data() + 3 * kb * i, kb);
    std::fill(r.begin(), r.end(), 0.0f);
    for (const ResponseRecord& rec : level.records)
      cpu::gemv_rgb(isa, rec.T.data.data(), kr, kb, kb, b_planar.data() + 3 * kb * rec.source_block, kb,
                    r.data() + 3 * kr * rec.slot, true);
    for (std::size_t c = 0; c < 3; ++c) {
      float* plane = planes.data() + c * std::size_t(width) * std::size_t(rows) * 4;
      for (std::size_t slot = 0; slot < level.slots.size(); ++slot)
        for (std::size_t k = 0; k < kr; ++k)
          plane[4 * (slot * groups + k / 4) + k % 4] = r[3 * kr * slot + 3 * k + c];
      gl.glBindTexture(GL_TEXTURE_2D, textures[c]);
      gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, rows, GL_RGBA_INTEGER, GL_UNSIGNED_INT, plane);
    }
    gl.glFinish();
  }
  gl.glDeleteTextures(3, textures);
  state.counters["records"] = double(level.records.size());
  state.SetLabel(std::string(platform::context_kind_name(ctx->info().kind)) + " readback b + " +
                 cpu::isa_name(isa) + " records + upload r");
}
BENCHMARK(BM_TbrOnCpu)->ArgsProduct({{11, 41}, {0, 1, 2, 3}})->Unit(benchmark::kMicrosecond)->UseRealTime();

// ld from a GPU pass (issue 19 item 2). The app's direct-light pass leaves ld in an RGBA32F
// render target of the runtime's ld layout; per frame, full evaluation (no skipping), glFinish:
//   gpu 0: the round trip the demo did: glReadPixels of the target, NaN/negative/range
//          sanitised on the CPU, update(ld) uploads it again
//   gpu 1: update_from_texture(target): the b pass reads it on the GPU
void BM_GlesLdSource(benchmark::State& state) {
  const BenchLevel* bl = bench_level(int(state.range(0)));
  platform::GlContext* ctx = context(int(state.range(1)));
  if (!bl || !ctx) {
    state.SkipWithError("no dictionary/level or no such GL context here");
    return;
  }
  const bool gpu = state.range(2) != 0;
  gles::GlesRuntimeOptions options;
  options.skip_unchanged = false;
  Result<std::unique_ptr<gles::GlesLevelRuntime>> rt =
      gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, bl->level, *dictionary(), options);
  if (!rt.ok()) {
    state.SkipWithError(rt.status().to_string().c_str());
    return;
  }
  gles::GlesLevelRuntime& runtime = *rt.value();
  const platform::GlFunctions& gl = ctx->gl();
  const gles::GlesLevelRuntime::LinearLayout layout = runtime.ld_layout();
  const std::size_t texels = std::size_t(layout.width) * std::size_t(layout.height);
  std::vector<float> rgba(4 * texels, 0.0f), ld(bl->ld.size());
  for (std::size_t s = 0; s < bl->ld.size() / 3; ++s)
    for (std::size_t c = 0; c < 3; ++c) rgba[4 * s + c] = bl->ld[3 * s + c];
  GLuint target = 0;
  gl.glGenTextures(1, &target);
  gl.glBindTexture(GL_TEXTURE_2D, target);
  gl.glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, layout.width, layout.height);
  gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, layout.width, layout.height, GL_RGBA, GL_FLOAT, rgba.data());
  Result<GLuint> fbo = platform::create_framebuffer(gl, "bench ld", {target}, "RGBA32F");
  if (!fbo.ok()) {
    gl.glDeleteTextures(1, &target);
    state.SkipWithError(fbo.status().to_string().c_str());
    return;
  }
  const auto frame = [&]() -> bool {
    if (gpu) return runtime.update_from_texture(target).ok();
    gl.glBindFramebuffer(GL_FRAMEBUFFER, fbo.value());
    gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
    gl.glPixelStorei(GL_PACK_ALIGNMENT, 4);
    gl.glReadPixels(0, 0, layout.width, layout.height, GL_RGBA, GL_FLOAT, rgba.data());
    gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
    for (std::size_t s = 0; s < ld.size() / 3; ++s)
      for (std::size_t c = 0; c < 3; ++c) {
        const float v = rgba[4 * s + c];
        ld[3 * s + c] = v > 0.0f ? std::min(v, kMaxLightValue) : 0.0f;
      }
    return runtime.update(ld).ok();
  };
  for (int warm = 0; warm < 3; ++warm) (void)frame();
  gl.glFinish();
  for (auto _ : state) {
    if (!frame()) state.SkipWithError("frame failed");
    gl.glFinish();
  }
  gl.glDeleteFramebuffers(1, &fbo.value());
  gl.glDeleteTextures(1, &target);
  state.counters["samples"] = double(bl->ld.size() / 3);
  state.SetLabel(std::string(platform::context_kind_name(ctx->info().kind)) +
                 (gpu ? " ld texture read on the GPU" : " ld read back, sanitised, uploaded"));
}
BENCHMARK(BM_GlesLdSource)
    ->ArgsProduct({{11, 41}, {0, 1, 2}, {0, 1}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

void BM_GlesCameraSkip(benchmark::State& state) {
  const BenchLevel* bl = bench_level(int(state.range(0)));
  platform::GlContext* ctx = context(int(state.range(1)));
  if (!bl || !ctx) return state.SkipWithError("no dictionary/level or no such GL context here");
  gles::GlesRuntimeOptions options;
  options.vector_irradiance = true;
  Result<std::unique_ptr<gles::GlesLevelRuntime>> with =
      gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, bl->level, *dictionary(), options);
  options.skip_unchanged = false;
  Result<std::unique_ptr<gles::GlesLevelRuntime>> full =
      gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, bl->level, *dictionary(), options);
  if (!with.ok() || !full.ok()) return state.SkipWithError("gles runtime");
  gles::GlesLevelRuntime& a = *with.value();
  gles::GlesLevelRuntime& f = *full.value();
  const bench::CameraFlight flight = bench::camera_flight(bl->level);
  CameraVisibility camera(bl->level);
  std::vector<float> ld = bl->ld;
  std::size_t frame = 0;
  double t_with = 0.0, t_full = 0.0, visible = 0.0;
  bool ok = a.update(ld).ok() && f.update(ld).ok();
  ctx->gl().glFinish();
  const gles::GlesSkipStats before = a.skip_stats();
  for (auto _ : state) {
    const float scale = 1.0f + 0.01f * float(frame % 17);
    for (std::size_t i = 0; i < ld.size(); ++i) ld[i] = bl->ld[i] * scale;
    const std::size_t cam = frame++ % flight.eye.size();
    auto t0 = std::chrono::steady_clock::now();
    const Result<VisibilityStats> seen = camera.update(flight.view_projection[cam], flight.eye[cam]);
    ok &= seen.ok() && a.set_visible_blocks(camera.visible()).ok() && a.update(ld).ok();
    ctx->gl().glFinish();
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t0 = std::chrono::steady_clock::now();
    ok &= f.update(ld).ok();
    ctx->gl().glFinish();
    t_full += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t_with += dt;
    visible += seen.ok() ? double(seen->visible) : 0.0;
    state.SetIterationTime(dt);
  }
  if (!ok) return state.SkipWithError("a frame failed");
  const double n = double(state.iterations());
  state.counters["ratio_full"] = t_with / t_full;
  state.counters["visible"] = visible / n;
  state.counters["redrawn_blocks"] = double(a.skip_stats().blocks_redrawn - before.blocks_redrawn) / n;
  state.counters["blocks"] = double(bl->level.blocks.size());
  state.SetLabel(std::string(platform::context_kind_name(ctx->info().kind)) + " " + a.description());
}
BENCHMARK(BM_GlesCameraSkip)
    ->ArgsProduct({{41}, {0, 3}})
    ->ArgNames({"blocks", "context"})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

void BM_GlesConverged(benchmark::State& state) {
  const BenchLevel* bl = bench_level(int(state.range(0)));
  platform::GlContext* ctx = context(int(state.range(1)));
  if (!bl || !ctx) return state.SkipWithError("no dictionary/level or no such GL context here");
  gles::GlesRuntimeOptions options;
  Result<std::unique_ptr<gles::GlesLevelRuntime>> converged =
      gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, bl->level, *dictionary(), options);
  options.skip_unchanged = false;
  Result<std::unique_ptr<gles::GlesLevelRuntime>> one =
      gles::GlesLevelRuntime::create(ctx->gl(), ctx->info().gles, bl->level, *dictionary(), options);
  if (!converged.ok() || !one.ok()) return state.SkipWithError("gles runtime");
  gles::GlesLevelRuntime& a = *converged.value();
  gles::GlesLevelRuntime& f = *one.value();
  std::vector<float> ld = bl->ld;
  // The synthetic ld is not albedo x E / pi of a real light: scaled into a level's usual range.
  for (std::size_t i = 0; i < ld.size(); ++i) ld[i] = 0.1f * bl->ld[i];
  const std::vector<float> base = ld;
  bool ok =
      a.set_albedo(level_sample_albedo(bl->level)).ok() && a.update_converged(ld).ok() && f.update(ld).ok();
  ctx->gl().glFinish();
  const ConvergedStats before = a.converged_stats();
  double t_converged = 0.0, t_one = 0.0;
  std::size_t frame = 0;
  for (auto _ : state) {
    const float scale = 1.0f + 0.01f * float(frame++ % 17);
    for (std::size_t i = 0; i < ld.size(); ++i) ld[i] = base[i] * scale;
    auto t0 = std::chrono::steady_clock::now();
    ok &= a.update_converged(ld).ok();
    ctx->gl().glFinish();
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t0 = std::chrono::steady_clock::now();
    ok &= f.update(ld).ok();
    ctx->gl().glFinish();
    t_one += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t_converged += dt;
    state.SetIterationTime(dt);
  }
  if (!ok) return state.SkipWithError("a frame failed");
  const ConvergedStats st = a.converged_stats();
  const double n = double(state.iterations());
  state.counters["ratio_one_bounce"] = t_converged / t_one;
  state.counters["iterations"] = double(st.iterations - before.iterations) / n;
  state.counters["error_bound"] = double(st.last.error_bound);
  state.counters["contraction"] = st.contraction;
  state.counters["blocks"] = double(bl->level.blocks.size());
  state.SetLabel(std::string(platform::context_kind_name(ctx->info().kind)) + " " + a.description());
}
BENCHMARK(BM_GlesConverged)
    ->ArgsProduct({{41, 1000}, {0, 3}})
    ->ArgNames({"blocks", "context"})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

void BM_CpuBackendFrame(benchmark::State& state) {
  const BenchLevel* bl = bench_level(int(state.range(0)));
  if (!bl) {
    state.SkipWithError("no dictionary/level");
    return;
  }
  Result<std::unique_ptr<Backend>> be = cpu::create_cpu_backend(bl->level, *dictionary());
  if (!be.ok()) {
    state.SkipWithError(be.status().to_string().c_str());
    return;
  }
  const bool vector = state.range(1) != 0;
  std::vector<float> vector_lightmap(vector ? be.value()->sizes().vector_lightmap : 0);
  for (auto _ : state) {
    if (!be.value()->update(bl->ld).ok()) state.SkipWithError("update failed");
    if (vector && !be.value()->read_vector_lightmap(vector_lightmap).ok())
      state.SkipWithError("read_vector_lightmap failed");
  }
  state.SetLabel(std::string(be.value()->description()) + (vector ? " + vector irradiance" : ""));
}
BENCHMARK(BM_CpuBackendFrame)->ArgsProduct({{11, 41}, {0, 1}})->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  contexts().clear();
  return 0;
}
