// SPDX-License-Identifier: MIT
// modrt-bench-cpu — Google Benchmark timings of the SIMD CPU runtime (cpu_neon/) against
// core's scalar reference, in the same run (architecture.md §5). Speed is measured only here.
//
//   BM_PeakFma/<threads>                       this core's FMA peak: AVX2 (NEON on aarch64)
//                                              FMAs into 12 independent accumulators
//   BM_CoreFrame/<blocks>/<res>/<kb>           core level_evaluate (b, r, lightmap)
//   BM_CpuFrame/<blocks>/<res>/<kb>/<threads>  CpuLevelRuntime::evaluate, best ISA, full update
//   BM_CpuIsa/<blocks>/<isa>                   the same with a forced ISA (res 16, kb 32;
//                                              0 scalar, 1 sse41, 2 avx2, 3 neon; unsupported skip)
//   BM_CpuMovingLight/<blocks>/<threads>/<mode> maze41/… with light 0 circling inside its block
//                                              (120 precomputed frames of shadowed direct light,
//                                              cycled): mode 0 full path, 1 exact skipping,
//                                              2 approximate skipping (ld_epsilon 0.05, dark_ld
//                                              1e-3 max ld, record_epsilon 0.05, r_epsilon 0.02)
//   BM_DirectLight/<shadows>/<influence>/<spot>  CpuDirectLight::evaluate on maze41 (res 16): the
//                                              maze's two lights, light 0 circling inside its
//                                              block (a point light, or with spot = 1 a spot with
//                                              a 0.5 rad cone turning with it); influence 0 off,
//                                              1 on with epsilon 0 (exact), 2 on with epsilon 0.02
//   BM_DirectLightFull/<shadows>                the same lights, every block recomputed each frame
//                                              (shadows 1: portal frusta where exact, 2: ray walk)
//   BM_DirectLightIsa/<isa>                     BM_DirectLightFull without shadows, forced ISA
//   BM_DirectLightWarped/<shadows>              warped 41-block maze (warp 0.2), the same moving light,
//                                              influence on (epsilon 0): shadows by the ray walk
//   BM_MovingLightFrame/<influence>/<spot>      one whole frame: CpuDirectLight (shadows) then
//                                              CpuLevelRuntime::evaluate with exact skipping
//   BM_CpuConverged/<blocks>                    the converged multi-bounce (cpu backend,
//                                              update_converged, tolerance 1e-3, one thread, best
//                                              ISA, res 16, kb 32) on a moving light: maze41's
//                                              light 0 circling, maze1000's ld dimmed and
//                                              brightened by 10 % over 8 frames (/1000/moving:1:
//                                              instead one block of 12 tripled in turn, walking
//                                              37 blocks a frame, the rest dimmed 0..3 %; both
//                                              cycle). Time: the converged
//                                              frame. Counters: ratio_one_bounce = converged /
//                                              one-bounce update() time of the same frames (same
//                                              backend kind, no skipping, measured alternately);
//                                              ratio_8_steps = converged / update() + 8
//                                              multi_bounce_step(); iterations per frame, the
//                                              last residual and error bound, build_ms;
//                                              /incremental:1 the incremental solve (the
//                                              default, ReducedSolver::solve_incremental), 0 the
//                                              full iteration; applications = blocks G was
//                                              applied to per frame / blocks
//   BM_ReducedDirectSolve/<blocks>              the converged solve's fixed point b = c + G b
//                                              (reduced_feedback.h) solved directly: I - G
//                                              assembled per channel from op.A, op.B and the
//                                              Tb->r records, factored once (Eigen SparseLU, COLAMD),
//                                              each frame c = P b0 (b0 = Td_b ld), three sparse
//                                              triangular solve pairs; the frames of
//                                              BM_CpuConverged/<blocks>/0. Time: that solve.
//                                              Counters: ratio_frame = (one-bounce update() +
//                                              the direct solve) / update_converged() of the same
//                                              frames (cpu backend, one thread, alternately): the
//                                              direct solve replaces the iteration, the rest of a
//                                              frame is the one-bounce update's; factor_ms, nnz
//                                              of I - G and of L + U per channel, residual
//                                              |(I - G) b - c| / |c| (scalar reference G)
//   BM_CpuCameraSkip/<blocks>/<converged>        the camera skip (set_visible_blocks from
//                                              CameraVisibility) against the same backend without
//                                              it, measured alternately, cpu backend, one thread,
//                                              res 16, kb 32, exact skipping: a camera flying
//                                              through the maze (block centre to block centre,
//                                              turning) while maze41's light 0 circles; converged
//                                              0: one bounce (update), 1: update_converged. Time:
//                                              the frame with the skip (the walk included).
//                                              Counters: ratio = with / without, ratio_full = with /
//                                              a one-bounce full update (no skipping, no camera: the
//                                              issue's baseline), visible blocks and tiles written
//                                              per frame with and without, blocks_b (blocks whose
//                                              b, or b0, was computed per frame); the frame with the
//                                              skip per stage (its stage times): b_us, solve_us,
//                                              tiles_us (r and tiles), atlas_us, probes_us (probes
//                                              and vector irradiance), iterations (applications
//                                              of G per converged frame), probe_blocks (blocks whose
//                                              probes the evaluation computed; every frame reads
//                                              two blocks' probes, the camera's and the next one's
//                                              of the flight, a hidden one's computed on read)
//
// Counters: GFLOPs = 2 flops per multiply-add of every GEMV of the frame (Td_b, Tb->r records,
// Ub, mapped Ur rows; 3 channels) per second; roofline = GFLOPs / BM_PeakFma's rate for the
// same thread count (measured once at start). Moving light: blocks/records/tiles computed per
// frame and the mean stated error bound relative to ||lightmap||.
//
// Dictionaries: res 16 / kb 32 is the DEFAULT (bench_levels.h: $MODRT_BENCH_DICTIONARY or the
// cache); the other (res, kb) pairs are the default settings with res and kb changed (kb 12 at
// res 6 is bench_runtime's mobile preset), loaded from the cache or baked on first use
// (~40 s at res 6, ~70 s at res 16). Mazes: maze_level(blocks), dmax 8; ld a fixed synthetic
// non-negative pattern for full updates (their cost does not depend on it).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <Eigen/SparseCore>
#include <Eigen/SparseLU>
#include <glm/gtc/matrix_transform.hpp>

#include "modrt/cpu/cpu_backend.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/cpu/direct_light.h"
#include "modrt/level_dirty.h"
#include "modrt/level_runtime.h"
#include "modrt/level_visibility.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/maze.h"
#include "modrt/reduced_feedback.h"

#include "bench_levels.h"

#if defined(__x86_64__)
#include <immintrin.h>
#elif defined(__aarch64__)
#include <arm_neon.h>
#endif

namespace {

using namespace modrt;

// ---- peak FMA throughput ----

// 12 independent accumulators (FMA latency 4 x 2 ports = 8 in flight on recent x86 cores;
// 12 covers 3 ports or latency 5 too). Returns flops done: `iterations` x 12 FMAs x lanes x 2.
#if defined(__x86_64__)
__attribute__((target("avx2,fma"))) double fma_loop(long iterations) {
  __m256 a[12];
  for (int i = 0; i < 12; ++i) a[i] = _mm256_set1_ps(float(i) * 1e-3f);
  const __m256 x = _mm256_set1_ps(0.999999f), y = _mm256_set1_ps(1e-7f);
  for (long it = 0; it < iterations; ++it) {
    for (int i = 0; i < 12; ++i) a[i] = _mm256_fmadd_ps(a[i], x, y);
    // Keep the accumulators in registers; stop the compiler from collapsing the loop.
    __asm__ volatile(""
                     : "+x"(a[0]), "+x"(a[1]), "+x"(a[2]), "+x"(a[3]), "+x"(a[4]), "+x"(a[5]), "+x"(a[6]),
                       "+x"(a[7]), "+x"(a[8]), "+x"(a[9]), "+x"(a[10]), "+x"(a[11]));
  }
  __m256 s = a[0];
  for (int i = 1; i < 12; ++i) s = _mm256_add_ps(s, a[i]);
  benchmark::DoNotOptimize(s);
  return double(iterations) * 12 * 8 * 2;
}
bool fma_supported() { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"); }
#elif defined(__aarch64__)
double fma_loop(long iterations) {
  float32x4_t a[12];
  for (int i = 0; i < 12; ++i) a[i] = vdupq_n_f32(float(i) * 1e-3f);
  const float32x4_t x = vdupq_n_f32(0.999999f), y = vdupq_n_f32(1e-7f);
  for (long it = 0; it < iterations; ++it) {
    for (int i = 0; i < 12; ++i) a[i] = vfmaq_f32(y, a[i], x);
    __asm__ volatile(""
                     : "+w"(a[0]), "+w"(a[1]), "+w"(a[2]), "+w"(a[3]), "+w"(a[4]), "+w"(a[5]), "+w"(a[6]),
                       "+w"(a[7]), "+w"(a[8]), "+w"(a[9]), "+w"(a[10]), "+w"(a[11]));
  }
  float32x4_t s = a[0];
  for (int i = 1; i < 12; ++i) s = vaddq_f32(s, a[i]);
  benchmark::DoNotOptimize(s);
  return double(iterations) * 12 * 4 * 2;
}
bool fma_supported() { return true; }
#else
double fma_loop(long) { return 0.0; }
bool fma_supported() { return false; }
#endif

// `threads` threads each run the loop; flops / wall seconds.
double run_fma(int threads, long iterations) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> workers;
  for (int t = 1; t < threads; ++t) workers.emplace_back([iterations] { fma_loop(iterations); });
  double flops = fma_loop(iterations) * threads;
  for (std::thread& w : workers) w.join();
  return flops / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Best of 5 runs of ~50 ms each, measured once per thread count.
double peak_flops(int threads) {
  static std::map<int, double> cache;
  if (auto it = cache.find(threads); it != cache.end()) return it->second;
  double best = 0.0;
  if (fma_supported())
    for (int k = 0; k < 5; ++k) best = std::max(best, run_fma(threads, 2'000'000));
  return cache[threads] = best;
}

void BM_PeakFma(benchmark::State& state) {
  if (!fma_supported()) return state.SkipWithError("no AVX2+FMA / NEON");
  const int threads = int(state.range(0));
  double flops = 0.0;
  for (auto _ : state) flops = std::max(flops, run_fma(threads, 1'000'000));
  state.counters["GFLOPs"] = flops * 1e-9;
}

// ---- dictionaries and levels per (res, kb) ----

const Dictionary* preset_dictionary(int res, int kb) {
  if (res == 16 && kb == 32) return bench::dictionary();
  static std::map<std::pair<int, int>, std::unique_ptr<Dictionary>> cache;
  const auto key = std::make_pair(res, kb);
  if (auto it = cache.find(key); it != cache.end()) return it->second.get();
  DictionarySettings s;
  s.res = std::uint32_t(res);
  s.kb = std::uint32_t(kb);
  std::fprintf(stderr, "bench: dictionary res %d kb %d (cache or bake)\n", res, kb);
  Result<Dictionary> d = precompute::load_or_bake_dictionary(s, precompute::default_cache_dir());
  if (!d.ok())
    std::fprintf(stderr, "bench: dictionary res %d kb %d: %s\n", res, kb, d.status().to_string().c_str());
  return (cache[key] = d.ok() ? std::make_unique<Dictionary>(std::move(d).value()) : nullptr).get();
}

struct PresetLevel {
  const Dictionary* dict = nullptr;
  LevelDescription description;
  Level level;
  std::vector<float> ld;
  double flops = 0.0;  // per frame
};

// 2 flops per multiply-add, 3 channels: Td_b and Ub per block, T per record, mapped Ur rows per slot.
double frame_flops(const Level& level, const Dictionary& dict) {
  double madds = 0.0;
  for (const LevelBlock& blk : level.blocks) {
    const ShapeOperators& op = block_operators(dict, level, blk);
    madds += double(op.Td_b.rows) * op.Td_b.cols + double(op.Ub.rows) * op.Ub.cols;
  }
  for (const ResponseRecord& rec : level.records) madds += double(rec.T.rows) * rec.T.cols;
  for (const ResponseSlot& slot : level.slots)
    madds += double(std::count_if(slot.ur_row_to_sample.begin(), slot.ur_row_to_sample.end(),
                                  [](std::int32_t s) { return s >= 0; })) *
             level.kr;
  return 2.0 * 3.0 * madds;
}

const PresetLevel* preset_level(int blocks, int res, int kb) {
  static std::map<std::tuple<int, int, int>, std::unique_ptr<PresetLevel>> cache;
  const auto key = std::make_tuple(blocks, res, kb);
  if (auto it = cache.find(key); it != cache.end()) return it->second.get();
  std::unique_ptr<PresetLevel> out;
  if (const Dictionary* dict = preset_dictionary(res, kb)) {
    Result<LevelDescription> desc = precompute::maze_level(blocks);
    Result<Level> level =
        desc.ok() ? precompute::build_level(desc.value(), *dict) : Result<Level>(desc.status());
    if (level.ok()) {
      out = std::make_unique<PresetLevel>();
      out->dict = dict;
      out->description = desc.value();
      out->level = std::move(level).value();
      out->ld.resize(3 * std::size_t(out->level.sample_count));
      for (std::size_t i = 0; i < out->ld.size(); ++i) out->ld[i] = float((i * 7919) % 1000) / 1000.0f;
      out->flops = frame_flops(out->level, *dict);
    } else {
      std::fprintf(stderr, "bench: maze %d res %d kb %d: %s\n", blocks, res, kb,
                   level.status().to_string().c_str());
    }
  }
  return (cache[key] = std::move(out)).get();
}

void set_counters(benchmark::State& state, const PresetLevel& pl, double seconds, int threads) {
  state.counters["samples"] = double(pl.level.sample_count);
  state.counters["records"] = double(pl.level.records.size());
  const double rate = pl.flops * double(state.iterations()) / seconds;
  state.counters["GFLOPs"] = rate * 1e-9;
  const double peak = peak_flops(threads);
  if (peak > 0) state.counters["roofline"] = rate / peak;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// ---- per-frame cost, full update ----

void BM_CoreFrame(benchmark::State& state) {
  const PresetLevel* pl = preset_level(int(state.range(0)), int(state.range(1)), int(state.range(2)));
  if (!pl) return state.SkipWithError("no dictionary or level");
  const LevelBufferSizes s = level_buffer_sizes(pl->level, *pl->dict);
  std::vector<float> b(s.b), r(s.r), lightmap(s.lightmap);
  const LevelDependencies deps = level_dependencies(pl->level);  // built once, as a runtime would
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const Status st = level_evaluate(pl->level, *pl->dict, deps, pl->ld, b, r, lightmap);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
  }
  set_counters(state, *pl, seconds_since(t0), 1);
}

void cpu_frame(benchmark::State& state, const PresetLevel* pl, cpu::Isa isa, int threads) {
  if (!pl) return state.SkipWithError("no dictionary or level");
  cpu::CpuRuntimeOptions o;
  o.isa = isa;
  o.threads = threads;
  Result<cpu::CpuLevelRuntime> rt = cpu::CpuLevelRuntime::create(pl->level, *pl->dict, o);
  if (!rt.ok()) return state.SkipWithError(rt.status().message().c_str());
  std::vector<float> lightmap(rt->sizes().lightmap);
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const Status st = rt->evaluate(pl->ld, lightmap);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
  }
  state.SetLabel(cpu::isa_name(isa));
  set_counters(state, *pl, seconds_since(t0), threads);
}

void BM_CpuFrame(benchmark::State& state) {
  cpu_frame(state, preset_level(int(state.range(0)), int(state.range(1)), int(state.range(2))),
            cpu::best_isa(), int(state.range(3)));
}

void BM_CpuIsa(benchmark::State& state) {
  const cpu::Isa isa = cpu::Isa(state.range(1));
  if (!cpu::isa_supported(isa)) return state.SkipWithError("ISA not supported here");
  cpu_frame(state, preset_level(int(state.range(0)), 16, 32), isa, 1);
}

// ---- blocks of different modes (issue 21) ----
// The 11-block maze alone (room 0), with a 3 x 1 x 1 room of its own, away from the maze, on
// its box's operators (1: three cubes' modes, so b's stride is 96 for every block) and on the
// cube's (2: 32 modes). A cube block costs its own modes whatever the stride: (1) - (0) should
// be about three times (2) - (0), the room's modes, and the maze's part the same in all three.
const PresetLevel* mixed_modes_level(int room) {
  static std::map<int, std::unique_ptr<PresetLevel>> cache;
  if (auto it = cache.find(room); it != cache.end()) return it->second.get();
  std::unique_ptr<PresetLevel> out;
  Result<LevelDescription> desc = precompute::maze_level(11);
  const Dictionary* dict = preset_dictionary(16, 32);
  if (dict && desc.ok()) {
    LevelDescription d = desc.value();
    if (room > 0) {
      BlockDescription b;
      b.cell = {40, 0, 0};
      b.faces = FaceMask(kAllFaces & ~(1u << kFacePosZ));
      b.warped = true;
      for (int k = 0; k < 8; ++k)
        b.corners[std::size_t(k)] =
            glm::dvec3(40.0 + ((k & 1) ? 3.0 : 0.0), (k >> 1) & 1, (k >> 2) & 1) * d.cell_size;
      d.blocks.push_back(b);
    }
    precompute::LevelBuildSettings settings;
    settings.shaped_operators = room == 1;
    Result<Level> level = precompute::build_level(d, *dict, settings);
    if (level.ok()) {
      out = std::make_unique<PresetLevel>();
      out->dict = dict;
      out->description = d;
      out->level = std::move(level).value();
      out->ld.resize(3 * std::size_t(out->level.sample_count));
      for (std::size_t i = 0; i < out->ld.size(); ++i) out->ld[i] = float((i * 7919) % 1000) / 1000.0f;
      out->flops = frame_flops(out->level, *dict);
    } else {
      std::fprintf(stderr, "bench: mixed modes %d: %s\n", room, level.status().to_string().c_str());
    }
  }
  return (cache[room] = std::move(out)).get();
}

void BM_CpuMixedModes(benchmark::State& state) {
  const PresetLevel* pl = mixed_modes_level(int(state.range(0)));
  cpu_frame(state, pl, cpu::best_isa(), 1);
  if (pl) state.counters["kb_stride"] = double(pl->level.kb);
}

// ---- a moving light, with and without skipping ----

constexpr int kLightFrames = 120;

struct LightSequence {
  std::vector<std::vector<float>> ld;
  float ld_max = 0.0f;
};

// Light 0 circles (radius 0.25 cells, bobbing) inside its block; the other lights stay put.
const LightSequence* light_sequence(int blocks) {
  static std::map<int, std::unique_ptr<LightSequence>> cache;
  if (auto it = cache.find(blocks); it != cache.end()) return it->second.get();
  std::unique_ptr<LightSequence> out;
  if (const PresetLevel* pl = preset_level(blocks, 16, 32)) {
    out = std::make_unique<LightSequence>();
    const precompute::LevelScene scene(pl->level, pl->level.res);
    const std::vector<float> albedo = level_sample_albedo(pl->level);
    const glm::dvec3 centre = pl->description.lights.at(0).position;
    for (int f = 0; f < kLightFrames; ++f) {
      std::vector<LightDescription> lights = pl->description.lights;
      const double a = 2.0 * 3.14159265358979 * double(f) / double(kLightFrames);
      lights[0].position =
          centre + pl->description.cell_size *
                       glm::dvec3(0.25 * std::cos(a), 0.1 * std::sin(3.0 * a), 0.25 * std::sin(a));
      out->ld.push_back(precompute::level_direct_light(scene, lights, albedo, 4));
      out->ld_max = std::max(out->ld_max, *std::max_element(out->ld.back().begin(), out->ld.back().end()));
    }
  }
  return (cache[blocks] = std::move(out)).get();
}

void BM_CpuMovingLight(benchmark::State& state) {
  const int blocks = int(state.range(0)), threads = int(state.range(1)), mode = int(state.range(2));
  const PresetLevel* pl = preset_level(blocks, 16, 32);
  const LightSequence* seq = light_sequence(blocks);
  if (!pl || !seq) return state.SkipWithError("no dictionary or level");
  cpu::CpuRuntimeOptions o;
  o.threads = threads;
  if (mode > 0) o.skip.enabled = true;
  if (mode == 2) o.skip = {true, 0.05f, 1e-3f * seq->ld_max, 0.05f, true, 0.02f};
  Result<cpu::CpuLevelRuntime> rt = cpu::CpuLevelRuntime::create(pl->level, *pl->dict, o);
  if (!rt.ok()) return state.SkipWithError(rt.status().message().c_str());
  std::vector<float> lightmap(rt->sizes().lightmap);
  for (const auto& ld : seq->ld)  // one lap first: the steady state of a running game
    if (!rt->evaluate(ld, lightmap).ok()) return state.SkipWithError("evaluate failed");
  std::size_t frame = 0;
  double blocks_computed = 0, records_computed = 0, tiles_written = 0, rel_bound = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const Status st = rt->evaluate(seq->ld[frame], lightmap);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
    const cpu::CpuSkipStats& s = rt->skip_stats();
    blocks_computed += double(s.blocks_computed), records_computed += double(s.records_computed);
    tiles_written += double(s.tiles_written), rel_bound += s.lightmap_error_bound;
    frame = (frame + 1) % seq->ld.size();
  }
  const double seconds = seconds_since(t0), n = double(state.iterations());
  double norm = 0.0;
  for (float v : lightmap) norm += double(v) * v;
  state.counters["GFLOPs_full_equiv"] = pl->flops * n / seconds * 1e-9;
  if (mode > 0) {
    state.counters["blocks_computed"] = blocks_computed / n;
    state.counters["records_computed"] = records_computed / n;
    state.counters["tiles_written"] = tiles_written / n;
    state.counters["rel_bound"] = rel_bound / n / std::sqrt(norm);
  }
  state.counters["blocks"] = double(pl->level.blocks.size());
  state.counters["records"] = double(pl->level.records.size());
  state.SetLabel(mode == 0 ? "full" : mode == 1 ? "exact skipping" : "approximate skipping");
}

// ---- the CPU direct-light evaluator ----

struct DirectLightScene {
  std::vector<float> albedo;
  std::vector<std::vector<cpu::CpuLight>> frames[2];  // [spot]: kLightFrames light sets
};

const DirectLightScene* direct_light_scene() {
  static std::unique_ptr<DirectLightScene> scene;
  if (scene) return scene.get();
  const PresetLevel* pl = preset_level(41, 16, 32);
  if (!pl) return nullptr;
  scene = std::make_unique<DirectLightScene>();
  scene->albedo = level_sample_albedo(pl->level);
  const glm::dvec3 centre = pl->description.lights.at(0).position;
  for (int spot = 0; spot < 2; ++spot)
    for (int f = 0; f < kLightFrames; ++f) {
      std::vector<cpu::CpuLight> lights;
      for (const LightDescription& d : pl->description.lights) {
        cpu::CpuLight l;
        l.position = glm::vec3(d.position);
        l.radius = float(d.radius);
        l.intensity = float(d.intensity);
        lights.push_back(l);
      }
      const double a = 2.0 * 3.14159265358979 * double(f) / double(kLightFrames);
      lights[0].position =
          glm::vec3(centre + pl->description.cell_size *
                                 glm::dvec3(0.25 * std::cos(a), 0.1 * std::sin(3.0 * a), 0.25 * std::sin(a)));
      if (spot) {
        lights[0].type = cpu::LightType::spot;
        lights[0].direction = glm::vec3(float(std::cos(a)), -0.2f, float(std::sin(a)));
        lights[0].inner_angle = 0.3f;
        lights[0].outer_angle = 0.5f;
      }
      scene->frames[spot].push_back(std::move(lights));
    }
  return scene.get();
}

cpu::CpuDirectLightOptions direct_light_options(bool shadows, int influence) {
  cpu::CpuDirectLightOptions o;
  o.shadows = shadows;
  o.influence = influence > 0;
  o.influence_epsilon = influence == 2 ? 0.02f : 0.0f;
  return o;
}

void BM_DirectLight(benchmark::State& state) {
  const bool shadows = state.range(0) != 0;
  const int influence = int(state.range(1)), spot = int(state.range(2));
  const PresetLevel* pl = preset_level(41, 16, 32);
  const DirectLightScene* sc = direct_light_scene();
  if (!pl || !sc) return state.SkipWithError("no dictionary or level");
  Result<cpu::CpuDirectLight> dl =
      cpu::CpuDirectLight::create(pl->level, sc->albedo, direct_light_options(shadows, influence));
  if (!dl.ok()) return state.SkipWithError(dl.status().message().c_str());
  std::vector<float> ld(3 * std::size_t(pl->level.sample_count));
  const auto& frames = sc->frames[spot];
  for (const auto& lights : frames)  // one lap first
    if (!dl->evaluate(lights, ld).ok()) return state.SkipWithError("evaluate failed");
  std::size_t frame = 0;
  double blocks = 0, pairs = 0, rays = 0, bound = 0;
  for (auto _ : state) {
    const Status st = dl->evaluate(frames[frame], ld);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
    const cpu::CpuDirectLightStats& s = dl->stats();
    blocks += double(s.blocks_recomputed), pairs += double(s.pairs_evaluated), rays += double(s.shadow_rays);
    bound = std::max(bound, s.ld_error_max);
    frame = (frame + 1) % frames.size();
  }
  const double n = double(state.iterations());
  state.counters["blocks_recomputed"] = blocks / n;
  state.counters["pairs"] = pairs / n;
  state.counters["shadow_rays"] = rays / n;
  state.counters["culled_light0"] = double(dl->blocks_culled()[0]);
  state.counters["max_ld_bound"] = bound;
  state.counters["samples"] = double(pl->level.sample_count);
  state.SetLabel(std::string(spot ? "spot" : "point") + (shadows ? ", shadows" : "") +
                 (influence == 0   ? ", influence off"
                  : influence == 1 ? ", influence eps 0"
                                   : ", influence eps 0.02"));
}

void BM_DirectLightFull(benchmark::State& state) {
  const bool shadows = state.range(0) != 0;
  const PresetLevel* pl = preset_level(41, 16, 32);
  const DirectLightScene* sc = direct_light_scene();
  if (!pl || !sc) return state.SkipWithError("no dictionary or level");
  cpu::CpuDirectLightOptions o = direct_light_options(shadows, 0);
  o.portal_frusta = state.range(0) != 2;
  Result<cpu::CpuDirectLight> dl = cpu::CpuDirectLight::create(pl->level, sc->albedo, o);
  if (!dl.ok()) return state.SkipWithError(dl.status().message().c_str());
  std::vector<float> ld(3 * std::size_t(pl->level.sample_count));
  std::size_t frame = 0;
  double rays = 0;
  for (auto _ : state) {
    dl->invalidate();
    const Status st = dl->evaluate(sc->frames[0][frame], ld);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
    rays += double(dl->stats().shadow_rays);
    frame = (frame + 1) % sc->frames[0].size();
  }
  state.counters["shadow_rays"] = rays / double(state.iterations());
  state.counters["samples"] = double(pl->level.sample_count);
  state.counters["ns_per_sample"] =
      benchmark::Counter(double(pl->level.sample_count),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.SetLabel(!shadows          ? "no shadows"
                 : o.portal_frusta ? "shadows (portal frusta)"
                                   : "shadows (ray walk)");
}

void BM_DirectLightIsa(benchmark::State& state) {
  const cpu::Isa isa = cpu::Isa(state.range(0));
  if (!cpu::isa_supported(isa)) return state.SkipWithError("ISA not supported here");
  const PresetLevel* pl = preset_level(41, 16, 32);
  const DirectLightScene* sc = direct_light_scene();
  if (!pl || !sc) return state.SkipWithError("no dictionary or level");
  cpu::CpuDirectLightOptions o = direct_light_options(false, 0);
  o.isa = isa;
  Result<cpu::CpuDirectLight> dl = cpu::CpuDirectLight::create(pl->level, sc->albedo, o);
  if (!dl.ok()) return state.SkipWithError(dl.status().message().c_str());
  std::vector<float> ld(3 * std::size_t(pl->level.sample_count));
  std::size_t frame = 0;
  for (auto _ : state) {
    dl->invalidate();
    const Status st = dl->evaluate(sc->frames[0][frame], ld);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
    frame = (frame + 1) % sc->frames[0].size();
  }
  state.SetLabel(cpu::isa_name(isa));
}

// A warped 41-block maze (generate_maze, warp 0.2, seed 1): bent walls, so the ray walk decides
// shadows (portal frusta need planar, convex blocks).
void BM_DirectLightWarped(benchmark::State& state) {
  const bool shadows = state.range(0) != 0;
  const Dictionary* dict = preset_dictionary(16, 32);
  if (!dict) return state.SkipWithError("no dictionary");
  static const std::unique_ptr<std::pair<Level, std::vector<float>>> warped = [dict] {
    precompute::MazeSettings ms;
    ms.blocks = 41;
    ms.warp = 0.2;
    Result<LevelDescription> desc = precompute::generate_maze(ms);
    Result<Level> level =
        desc.ok() ? precompute::build_level(desc.value(), *dict) : Result<Level>(desc.status());
    if (!level.ok()) return std::unique_ptr<std::pair<Level, std::vector<float>>>();
    std::vector<float> albedo = level_sample_albedo(level.value());
    return std::make_unique<std::pair<Level, std::vector<float>>>(std::move(level).value(),
                                                                  std::move(albedo));
  }();
  const DirectLightScene* sc = direct_light_scene();
  if (!warped || !sc) return state.SkipWithError("no level");
  Result<cpu::CpuDirectLight> dl =
      cpu::CpuDirectLight::create(warped->first, warped->second, direct_light_options(shadows, 1));
  if (!dl.ok()) return state.SkipWithError(dl.status().message().c_str());
  std::vector<float> ld(3 * std::size_t(warped->first.sample_count));
  std::size_t frame = 0;
  double rays = 0, blocks = 0;
  for (auto _ : state) {
    const Status st = dl->evaluate(sc->frames[0][frame], ld);
    benchmark::DoNotOptimize(st.ok());
    benchmark::ClobberMemory();
    rays += double(dl->stats().shadow_rays);
    blocks += double(dl->stats().blocks_recomputed);
    frame = (frame + 1) % sc->frames[0].size();
  }
  state.counters["shadow_rays"] = rays / double(state.iterations());
  state.counters["blocks_recomputed"] = blocks / double(state.iterations());
  state.counters["triangles"] = double(dl->triangle_count());
  state.SetLabel(shadows ? "warped, shadows (ray walk), moving light" : "warped, no shadows, moving light");
}

void BM_MovingLightFrame(benchmark::State& state) {
  const int influence = int(state.range(0)), spot = int(state.range(1));
  const PresetLevel* pl = preset_level(41, 16, 32);
  const DirectLightScene* sc = direct_light_scene();
  if (!pl || !sc) return state.SkipWithError("no dictionary or level");
  Result<cpu::CpuDirectLight> dl =
      cpu::CpuDirectLight::create(pl->level, sc->albedo, direct_light_options(true, influence));
  cpu::CpuRuntimeOptions o;
  o.skip.enabled = true;
  Result<cpu::CpuLevelRuntime> rt = cpu::CpuLevelRuntime::create(pl->level, *pl->dict, o);
  if (!dl.ok() || !rt.ok()) return state.SkipWithError("create failed");
  std::vector<float> ld(3 * std::size_t(pl->level.sample_count)), lightmap(rt->sizes().lightmap);
  const auto& frames = sc->frames[spot];
  for (const auto& lights : frames)
    if (!dl->evaluate(lights, ld).ok() || !rt->evaluate(ld, lightmap).ok())
      return state.SkipWithError("failed");
  std::size_t frame = 0;
  double dl_blocks = 0, b_blocks = 0, tiles = 0;
  for (auto _ : state) {
    const bool ok = dl->evaluate(frames[frame], ld).ok() && rt->evaluate(ld, lightmap).ok();
    benchmark::DoNotOptimize(ok);
    benchmark::ClobberMemory();
    dl_blocks += double(dl->stats().blocks_recomputed);
    b_blocks += double(rt->skip_stats().blocks_computed);
    tiles += double(rt->skip_stats().tiles_written);
    frame = (frame + 1) % frames.size();
  }
  const double n = double(state.iterations());
  state.counters["ld_blocks"] = dl_blocks / n;
  state.counters["b_blocks"] = b_blocks / n;
  state.counters["tiles_written"] = tiles / n;
  state.SetLabel(std::string(spot ? "spot" : "point") + (influence == 0   ? ", influence off"
                                                         : influence == 1 ? ", influence eps 0"
                                                                          : ", influence eps 0.02"));
}

// ---- float16 operators (CpuRuntimeOptions::operators) ----
//
// BM_CpuFloat16/<blocks>/<threads>: the full-update frame (res 16, kb 32, best ISA) of a
// float16-operator runtime against a float32 one in the same loop: each iteration runs a
// chunk of frames of each (16, or 2 at 1000 blocks), the first frame of a chunk untimed so
// that each chunk starts with its own operators in cache, as BM_CpuFrame's steady state does.
// The reported time is the float16 frame's. Counters: float32_us and float16_us per frame,
// speedup = float32 / float16 time, the operator bytes of each (operator_bytes(), MB),
// rel_l2 = ||lightmap16 - lightmap32|| / ||lightmap32||; GFLOPs and roofline as BM_CpuFrame,
// for the float16 time.
void BM_CpuFloat16(benchmark::State& state) {
  const int blocks = int(state.range(0)), threads = int(state.range(1));
  const PresetLevel* pl = preset_level(blocks, 16, 32);
  if (!pl) return state.SkipWithError("no dictionary or level");
  cpu::CpuRuntimeOptions o32;
  o32.threads = threads;
  cpu::CpuRuntimeOptions o16 = o32;
  o16.operators = cpu::OperatorStorage::float16;
  Result<cpu::CpuLevelRuntime> rt32 = cpu::CpuLevelRuntime::create(pl->level, *pl->dict, o32);
  Result<cpu::CpuLevelRuntime> rt16 = cpu::CpuLevelRuntime::create(pl->level, *pl->dict, o16);
  if (!rt32.ok()) return state.SkipWithError(rt32.status().message().c_str());
  if (!rt16.ok()) return state.SkipWithError(rt16.status().message().c_str());
  std::vector<float> lm32(rt32->sizes().lightmap), lm16(lm32.size());
  const int chunk = blocks >= 1000 ? 2 : 16;
  // Seconds for frames 2..chunk of a chunk (frame 1 brings the operators into cache).
  auto run_chunk = [&](cpu::CpuLevelRuntime& rt, std::vector<float>& lightmap) {
    bool ok = rt.evaluate(pl->ld, lightmap).ok();
    const auto t0 = std::chrono::steady_clock::now();
    for (int f = 1; f < chunk; ++f) ok &= rt.evaluate(pl->ld, lightmap).ok();
    benchmark::DoNotOptimize(ok);
    benchmark::ClobberMemory();
    return seconds_since(t0);
  };
  double t32 = 0.0, t16 = 0.0;
  for (auto _ : state) {
    t32 += run_chunk(rt32.value(), lm32);
    const double c16 = run_chunk(rt16.value(), lm16);
    t16 += c16;
    state.SetIterationTime(c16 / double(chunk - 1));
  }
  const double frames = double(state.iterations()) * double(chunk - 1);
  double diff = 0.0, norm = 0.0;
  for (std::size_t i = 0; i < lm32.size(); ++i) {
    diff += (double(lm16[i]) - lm32[i]) * (double(lm16[i]) - lm32[i]);
    norm += double(lm32[i]) * lm32[i];
  }
  state.counters["float32_us"] = t32 / frames * 1e6;
  state.counters["float16_us"] = t16 / frames * 1e6;
  state.counters["speedup"] = t32 / t16;
  state.counters["float32_MB"] = double(rt32->operator_bytes()) * 1e-6;
  state.counters["float16_MB"] = double(rt16->operator_bytes()) * 1e-6;
  state.counters["rel_l2"] = norm > 0.0 ? std::sqrt(diff / norm) : 0.0;
  state.SetLabel(cpu::isa_name(rt16->isa()));
  set_counters(state, *pl, t16 * double(state.iterations()) / frames, threads);
}

// ---- converged multi-bounce (issue 20) ----

void BM_CpuConverged(benchmark::State& state) {
  const int blocks = int(state.range(0));
  const bool moving = state.range(1) != 0;
  ReducedSolveSettings solve;
  solve.incremental = state.range(2) != 0;
  const PresetLevel* pl = preset_level(blocks, 16, 32);
  if (!pl) return state.SkipWithError("no dictionary or level");
  std::vector<std::vector<float>> frames;
  if (blocks <= 41) {
    const LightSequence* seq = light_sequence(blocks);
    if (!seq) return state.SkipWithError("no light sequence");
    frames = seq->ld;
  } else if (!moving) {
    for (int f = 0; f < 8; ++f) {
      frames.push_back(pl->ld);
      const float scale = 1.0f + 0.1f * float(std::sin(2.0 * 3.14159265358979 * f / 8.0));
      for (float& v : frames.back()) v *= scale;
    }
  } else {
    for (int f = 0; f < 12; ++f) {
      frames.push_back(pl->ld);
      for (float& v : frames.back()) v *= 1.0f - 0.01f * float(f % 4);
      const LevelBlock& blk = pl->level.blocks[std::size_t(f * 37) % pl->level.blocks.size()];
      for (std::size_t i = 0; i < 3 * std::size_t(blk.sample_count); ++i)
        frames.back()[3 * std::size_t(blk.sample_offset) + i] *= 3.0f;
    }
  }
  cpu::CpuBackendOptions o;
  o.runtime.threads = 1;
  o.runtime.skip.enabled = false;
  Result<std::unique_ptr<Backend>> conv = cpu::create_cpu_backend(pl->level, *pl->dict, o);
  Result<std::unique_ptr<Backend>> steps = cpu::create_cpu_backend(pl->level, *pl->dict, o);
  if (!conv.ok() || !steps.ok()) return state.SkipWithError("cpu backend");
  Backend& c = *conv.value();
  Backend& n = *steps.value();
  const std::vector<float> albedo = level_sample_albedo(pl->level);
  if (!c.set_albedo(albedo).ok() || !n.set_albedo(albedo).ok()) return state.SkipWithError("set_albedo");
  if (!c.update_converged(frames[0], solve).ok())
    return state.SkipWithError("update_converged");  // build + cold solve
  const ConvergedStats built = c.converged_stats();
  double t_conv = 0.0, t_one = 0.0, t_steps = 0.0;
  std::size_t f = 1;
  bool ok = true;
  for (auto _ : state) {
    const std::vector<float>& ld = frames[f++ % frames.size()];
    auto t0 = std::chrono::steady_clock::now();
    ok &= c.update_converged(ld, solve).ok();
    const double dc = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    ok &= n.update(ld).ok();
    t_one += seconds_since(t0);
    for (int k = 0; k < 8; ++k) ok &= n.multi_bounce_step(ld).ok();
    t_steps += seconds_since(t0);
    t_conv += dc;
    state.SetIterationTime(dc);
    benchmark::ClobberMemory();
  }
  if (!ok) return state.SkipWithError("a frame failed");
  const ConvergedStats st = c.converged_stats();
  const double solves = double(st.solves - built.solves);
  state.counters["ratio_one_bounce"] = t_conv / t_one;
  state.counters["ratio_8_steps"] = t_conv / t_steps;
  state.counters["iterations"] = solves > 0 ? double(st.iterations - built.iterations) / solves : 0.0;
  state.counters["applications"] =
      solves > 0 ? double(st.blocks_applied - built.blocks_applied) / (solves * double(blocks)) : 0.0;
  state.counters["residual"] = st.last.residual;
  state.counters["error_bound"] = st.last.error_bound;
  state.counters["contraction"] = st.contraction;
  state.counters["build_ms"] = double(st.build_ns) * 1e-6;
  state.SetLabel(c.description());
}

// ---- the converged solve against a direct one (issue 20) ----

// The frames of BM_CpuConverged/<blocks>/0.
std::vector<std::vector<float>> converged_frames(const PresetLevel& pl, int blocks) {
  if (blocks <= 41) {
    const LightSequence* seq = light_sequence(blocks);
    return seq ? seq->ld : std::vector<std::vector<float>>{};
  }
  std::vector<std::vector<float>> frames;
  for (int f = 0; f < 8; ++f) {
    frames.push_back(pl.ld);
    const float scale = 1.0f + 0.1f * float(std::sin(2.0 * 3.14159265358979 * f / 8.0));
    for (float& v : frames.back()) v *= scale;
  }
  return frames;
}

// I - G of channel ch (reduced_feedback.h): G(i, i) = A_i (plain iteration only), and for each
// slot s entering block i and each record m of s, G(i, source(m)) += B_s T_m (kb x kr x kb).
Eigen::SparseMatrix<double> reduced_system(const Level& level, const LevelDependencies& deps,
                                           const ReducedFeedback& op, int ch) {
  const std::size_t kb = op.kb, kr = op.kr, n = kb * level.blocks.size();
  std::vector<Eigen::Triplet<double>> entries;
  for (std::size_t k = 0; k < n; ++k) entries.emplace_back(int(k), int(k), 1.0);
  const auto channel = [ch](const ChannelMatrix& m, std::size_t r, std::size_t k) {
    return double(m.data[3 * (r * m.cols + k) + std::size_t(ch)]);
  };
  std::vector<double> BT(kb * kb);
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    if (!op.A.empty())
      for (std::size_t r = 0; r < kb; ++r)
        for (std::size_t k = 0; k < kb; ++k)
          entries.emplace_back(int(kb * i + r), int(kb * i + k), -channel(op.A[i], r, k));
    for (std::uint32_t s : deps.slots_of_block(i))
      for (std::uint32_t m : deps.records_of_slot(s)) {
        const ResponseRecord& rec = level.records[m];
        std::fill(BT.begin(), BT.end(), 0.0);
        for (std::size_t r = 0; r < kb; ++r)
          for (std::size_t q = 0; q < kr; ++q) {
            const double bq = channel(op.B[s], r, q);
            for (std::size_t k = 0; k < kb; ++k)
              BT[r * kb + k] += bq * double(rec.T(std::uint32_t(q), std::uint32_t(k)));
          }
        for (std::size_t r = 0; r < kb; ++r)
          for (std::size_t k = 0; k < kb; ++k)
            entries.emplace_back(int(kb * i + r), int(kb * rec.source_block + k), -BT[r * kb + k]);
      }
  }
  Eigen::SparseMatrix<double> M(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  M.setFromTriplets(entries.begin(), entries.end());  // duplicates summed
  return M;
}

void BM_ReducedDirectSolve(benchmark::State& state) {
  const int blocks = int(state.range(0));
  const PresetLevel* pl = preset_level(blocks, 16, 32);
  if (!pl) return state.SkipWithError("no dictionary or level");
  const Level& level = pl->level;
  const std::vector<std::vector<float>> frames = converged_frames(*pl, blocks);
  if (frames.empty()) return state.SkipWithError("no frames");
  const LevelDependencies deps = level_dependencies(level);
  const std::vector<float> albedo = level_sample_albedo(level);
  std::vector<float> rho(albedo.size());
  clamp_albedo(albedo, kDefaultMaxAlbedo, rho);
  Result<ReducedFeedback> built = build_reduced_feedback(level, *pl->dict, deps, rho);
  if (!built.ok()) return state.SkipWithError(built.status().to_string().c_str());
  const ReducedFeedback& op = built.value();
  // I - G's nonzeros per channel: kb^2 per pair of coupled blocks (a record couples its slot's
  // block with its source) and the diagonal. Past kMaxNonzeros the assembly alone outweighs the
  // iteration's matrix-free G (records kr x kb plus slots kb x kr) and the factor's fill would
  // not fit in memory: reported, not factored.
  constexpr double kMaxNonzeros = 8e6;
  std::set<std::pair<std::uint32_t, std::uint32_t>> coupled;
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    for (std::uint32_t s : deps.slots_of_block(i))
      for (std::uint32_t m : deps.records_of_slot(s))
        coupled.emplace(std::uint32_t(i), level.records[m].source_block);
  const double kb2 = double(op.kb) * op.kb;
  const double nnz_estimate = double(coupled.size()) * kb2 + double(op.kb) * double(level.blocks.size());
  if (nnz_estimate > kMaxNonzeros) {
    const std::string why = "I - G has " + std::to_string(std::llround(nnz_estimate)) +
                            " nonzeros per channel (" + std::to_string(coupled.size()) +
                            " coupled block pairs x kb^2): not factored";
    return state.SkipWithError(why.c_str());
  }
  // Factor I - G per channel, once (as a runtime would when the albedo is set).
  using Lu = Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>>;
  std::vector<std::unique_ptr<Lu>> lu;
  double nnz = 0.0, nnz_lu = 0.0;
  const auto f0 = std::chrono::steady_clock::now();
  for (int ch = 0; ch < 3; ++ch) {
    const Eigen::SparseMatrix<double> M = reduced_system(level, deps, op, ch);
    nnz += double(M.nonZeros()) / 3.0;
    lu.push_back(std::make_unique<Lu>());
    lu.back()->compute(M);
    if (lu.back()->info() != Eigen::Success) return state.SkipWithError("SparseLU failed");
    nnz_lu += double(lu.back()->nnzL() + lu.back()->nnzU()) / 3.0;
  }
  const double factor_s = seconds_since(f0);
  // The iterative solve on the same frames (cpu backend, one thread), for the frame ratio.
  cpu::CpuBackendOptions o;
  o.runtime.threads = 1;
  o.runtime.skip.enabled = false;
  Result<std::unique_ptr<Backend>> conv = cpu::create_cpu_backend(level, *pl->dict, o);
  Result<std::unique_ptr<Backend>> one = cpu::create_cpu_backend(level, *pl->dict, o);
  if (!conv.ok() || !one.ok()) return state.SkipWithError("cpu backend");
  if (!conv.value()->set_albedo(albedo).ok() || !one.value()->set_albedo(albedo).ok() ||
      !conv.value()->update_converged(frames[0]).ok())  // operators built, cold solve
    return state.SkipWithError("cpu backend frame");
  const std::size_t n = op.unknowns(level);
  std::vector<float> b0(n), c(n), x(n), r_scratch(3 * std::size_t(op.kr) * level.slots.size()), gx(n);
  Eigen::VectorXd rhs(int(n / 3)), sol(int(n / 3));
  double t_direct = 0.0, t_one = 0.0, t_conv = 0.0;
  std::size_t f = 1;
  bool ok = true;
  for (auto _ : state) {
    const std::vector<float>& ld = frames[f++ % frames.size()];
    ok &= level_compute_b(level, *pl->dict, ld, b0).ok();  // in the one-bounce update's time below
    auto t0 = std::chrono::steady_clock::now();
    reference_reduced_rhs(level, op, b0, c);
    for (int ch = 0; ch < 3; ++ch) {
      for (std::size_t k = 0; k < n / 3; ++k) rhs[Eigen::Index(k)] = double(c[3 * k + std::size_t(ch)]);
      sol = lu[std::size_t(ch)]->solve(rhs);
      for (std::size_t k = 0; k < n / 3; ++k) x[3 * k + std::size_t(ch)] = float(sol[Eigen::Index(k)]);
    }
    const double dt = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    ok &= one.value()->update(ld).ok();
    t_one += seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    ok &= conv.value()->update_converged(ld).ok();
    t_conv += seconds_since(t0);
    t_direct += dt;
    state.SetIterationTime(dt);
    benchmark::ClobberMemory();
  }
  if (!ok) return state.SkipWithError("a frame failed");
  // The last frame's residual |x - c - G x| / |c|, with the scalar reference G.
  reference_apply_reduced_feedback(level, deps, op, x, r_scratch, gx);
  double res = 0.0, norm = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double d = double(x[k]) - double(c[k]) - double(gx[k]);
    res += d * d;
    norm += double(c[k]) * double(c[k]);
  }
  state.counters["ratio_frame"] = (t_one + t_direct) / t_conv;
  state.counters["factor_ms"] = factor_s * 1e3;
  state.counters["nnz"] = nnz;
  state.counters["nnz_lu"] = nnz_lu;
  state.counters["residual"] = norm > 0.0 ? std::sqrt(res / norm) : 0.0;
  state.SetLabel(conv.value()->description());
}

// ---- the camera skip (issue 20) ----

void BM_CpuCameraSkip(benchmark::State& state) {
  const int blocks = int(state.range(0));
  const bool converged = state.range(1) != 0;
  const PresetLevel* pl = preset_level(blocks, 16, 32);
  const LightSequence* seq = pl ? light_sequence(blocks) : nullptr;
  if (!pl || !seq) return state.SkipWithError("no dictionary, level or light sequence");
  const Level& level = pl->level;
  const bench::CameraFlight flight = bench::camera_flight(level);
  const std::vector<glm::dmat4>& view_projection = flight.view_projection;
  const std::vector<glm::dvec3>& eyes = flight.eye;
  cpu::CpuBackendOptions o;
  o.runtime.threads = 1;
  Result<std::unique_ptr<Backend>> with = cpu::create_cpu_backend(level, *pl->dict, o);
  Result<std::unique_ptr<Backend>> without = cpu::create_cpu_backend(level, *pl->dict, o);
  cpu::CpuBackendOptions full_options = o;
  full_options.runtime.skip.enabled = false;
  Result<std::unique_ptr<Backend>> full = cpu::create_cpu_backend(level, *pl->dict, full_options);
  if (!with.ok() || !without.ok() || !full.ok()) return state.SkipWithError("cpu backend");
  Backend& a = *with.value();
  Backend& b = *without.value();
  const std::vector<float> albedo = level_sample_albedo(level);
  if (!a.set_albedo(albedo).ok() || !b.set_albedo(albedo).ok()) return state.SkipWithError("set_albedo");
  CameraVisibility camera(level);
  // A frame, and the probes a renderer reads for two dynamic objects: one in the camera's block,
  // one in the block the flight goes to next (camera_flight: block cam / 4).
  std::vector<float> object_probes(a.sizes().probes / level.blocks.size());
  const auto frame = [&](Backend& be, const std::vector<float>& ld, std::size_t cam) {
    bool done = converged ? be.update_converged(ld).ok() : be.update(ld).ok();
    for (std::size_t k = 0; k < 2 && done && !object_probes.empty(); ++k)
      done = be.read_block_probes((cam / 4 + k) % level.blocks.size(), object_probes).ok();
    return done;
  };
  bool ok = frame(a, seq->ld[0], 0) && frame(b, seq->ld[0], 0);
  const BackendEvaluationStats a0 = a.evaluation_stats(), b0 = b.evaluation_stats();
  a.set_timing(true);  // where the frame with the skip spends its time (the steady clock per stage)
  BackendStageTimes stages;
  const ConvergedStats c0 = a.converged_stats();
  double t_with = 0.0, t_without = 0.0, t_full = 0.0, visible = 0.0;
  std::size_t f = 1;
  for (auto _ : state) {
    const std::vector<float>& ld = seq->ld[f % seq->ld.size()];
    const std::size_t cam = f++ % eyes.size();
    auto t0 = std::chrono::steady_clock::now();
    const Result<VisibilityStats> seen = camera.update(view_projection[cam], eyes[cam]);
    ok &= seen.ok() && a.set_visible_blocks(camera.visible()).ok() && frame(a, ld, cam);
    const double dt = seconds_since(t0);
    const BackendStageTimes& st = a.stage_times();
    stages.b += st.b, stages.feedback += st.feedback, stages.lightmap += st.lightmap;
    stages.atlas += st.atlas, stages.probes += st.probes, stages.vector += st.vector;
    t0 = std::chrono::steady_clock::now();
    ok &= frame(b, ld, cam);
    t_without += seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    ok &= full.value()->update(ld).ok();
    for (std::size_t k = 0; k < 2 && ok && !object_probes.empty(); ++k)
      ok &= full.value()->read_block_probes((cam / 4 + k) % level.blocks.size(), object_probes).ok();
    t_full += seconds_since(t0);
    t_with += dt;
    visible += seen.ok() ? double(seen->visible) : 0.0;
    state.SetIterationTime(dt);
    benchmark::ClobberMemory();
  }
  if (!ok) return state.SkipWithError("a frame failed");
  const BackendEvaluationStats as = a.evaluation_stats(), bs = b.evaluation_stats();
  const double n = double(state.iterations());
  state.counters["ratio"] = t_with / t_without;
  state.counters["ratio_full"] = t_with / t_full;
  state.counters["visible"] = visible / n;
  state.counters["tiles_with"] =
      double(as.tiles_written + as.tiles_caught_up - a0.tiles_written - a0.tiles_caught_up) / n;
  state.counters["tiles_without"] = double(bs.tiles_written - b0.tiles_written) / n;
  state.counters["blocks_b"] = double(as.blocks_computed - a0.blocks_computed) / n;
  state.counters["probe_blocks"] = double(as.probe_blocks_computed - a0.probe_blocks_computed) / n;
  const auto us = [n](std::uint64_t ns) { return double(ns) * 1e-3 / n; };
  state.counters["b_us"] = us(stages.b);
  state.counters["solve_us"] = us(stages.feedback);
  state.counters["tiles_us"] = us(stages.lightmap);
  state.counters["atlas_us"] = us(stages.atlas);
  state.counters["probes_us"] = us(stages.probes + stages.vector);
  if (converged) {
    const ConvergedStats cs = a.converged_stats();
    state.counters["iterations"] = double(cs.iterations - c0.iterations) / n;
    state.counters["applications"] = double(cs.blocks_applied - c0.blocks_applied) / (n * double(blocks));
  }
  state.SetLabel(a.description());
}

BENCHMARK(BM_PeakFma)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CoreFrame)
    ->ArgsProduct({{11, 41, 1000}, {6, 16}, {12, 32}})
    ->ArgNames({"blocks", "res", "kb"})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuFrame)
    ->ArgsProduct({{11, 41, 1000}, {6, 16}, {12, 32}, {1, 2}})
    ->ArgNames({"blocks", "res", "kb", "threads"})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuMixedModes)->DenseRange(0, 2)->ArgName("room")->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuIsa)
    ->ArgsProduct({{11, 41}, {0, 1, 2, 3}})
    ->ArgNames({"blocks", "isa"})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuFloat16)
    ->ArgsProduct({{11, 41, 1000}, {1, 2}})
    ->ArgNames({"blocks", "threads"})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuConverged)
    ->ArgsProduct({{41}, {0}, {0, 1}})
    ->ArgsProduct({{1000}, {0, 1}, {0, 1}})
    ->ArgNames({"blocks", "moving", "incremental"})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReducedDirectSolve)
    ->Arg(41)
    ->Arg(1000)
    ->ArgNames({"blocks"})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuCameraSkip)
    ->ArgsProduct({{41}, {0, 1}})
    ->ArgNames({"blocks", "converged"})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CpuMovingLight)
    ->ArgsProduct({{41}, {1, 2}, {0, 1, 2}})
    ->ArgNames({"blocks", "threads", "mode"})
    ->Unit(benchmark::kMicrosecond);

BENCHMARK(BM_DirectLight)
    ->ArgsProduct({{0, 1}, {0, 1, 2}, {0, 1}})
    ->ArgNames({"shadows", "influence", "spot"})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DirectLightFull)->ArgsProduct({{0, 1, 2}})->ArgNames({"shadows"})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DirectLightIsa)->DenseRange(0, 3)->ArgName("isa")->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DirectLightWarped)->Arg(0)->Arg(1)->ArgName("shadows")->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MovingLightFrame)
    ->ArgsProduct({{0, 1, 2}, {0, 1}})
    ->ArgNames({"influence", "spot"})
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
