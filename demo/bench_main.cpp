// SPDX-License-Identifier: MIT
// modrt-bench: run time versus error (issue 4, architecture.md §5, §7). For a suite of levels and
// light placements it compares, against a path-traced ground truth at the lightmap texels,
//   - a constant ambient term (the ground truth's mean per channel: the "no GI" baseline),
//   - the exact one-bounce F ld (a dense F gathered on the block for single-block scenes,
//     or F_level ld ray traced per frame for mazes, labelled so),
//   - a truncated SVD of the dense F at the same rank as MRT (single-block scenes),
//   - MRT (the scalar reference runtime) for several kb and two texel resolutions, one
//     bounce and multi-bounce feedback,
//   - the same MRT frames on the SIMD CPU runtime (modrt::cpu, its best ISA) and on the
//     GLES backend (modrt::gles, on the context `auto` picks: llvmpipe here), timed the
//     same way; their error is measured from their own output.
// Per-frame cost is the median of many frames of the scalar code (steady_clock); error is
// relative L2 over texels (all channels) and the 90th percentile of per-texel relative
// error. Every ground truth states its noise floor (RMS standard error / RMS value).
// Light placements outside the lighting prior (next to a wall, beyond the prior's
// neighbouring-cell lattice) are reported separately, never averaged with in-prior ones.
//
// Output: a table on stdout, --csv / --json files, a chart (scripts/plot_bench.py via
// matplotlib), and --report, a Markdown report (docs/accuracy.md).
// --quick: a small suite for CI that fails when MRT's in-prior error exceeds the stored
// thresholds (tests/bench_quick_thresholds.json).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include "modrt/precompute/svd.h"

#include "cli_checks.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/dictionary.h"
#include "modrt/file_io.h"
#include "modrt/level.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/bake.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/maze.h"
#include "modrt/precompute/path_tracer.h"
#include "modrt/precompute/transport.h"
#include "modrt/reduced_feedback.h"
#include "modrt/reference_runtime.h"
#ifdef MODRT_BENCH_HAS_GLES
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/platform/gl_context.h"
#endif

namespace {

using namespace modrt;
using Clock = std::chrono::steady_clock;

// ---------------------------------------------------------------- suite description

struct LightCase {
  std::string name;
  bool in_prior = true;
  std::vector<LightDescription> lights;
};

struct SceneCase {
  std::string name;
  LevelDescription desc;
  bool single_block = false;
  std::vector<LightCase> lights;
};

struct SuiteConfig {
  std::string name;
  std::vector<SceneCase> scenes;
  std::vector<DictionarySettings> dictionaries;  // one per resolution
  std::vector<std::uint32_t> kbs;
  int multi_bounces = 8;          // MRT/dense/SVD multi-bounce rows: bounces - 1 feedback iterations
  int truth_bounces = 16;         // multi-bounce ground-truth path segments (near converged, issue 20)
  int gt_paths_one = 256;         // ground-truth paths per texel (one bounce), before the budget cap
  int gt_paths_multi = 256;       // ... multi-bounce
  double gt_path_budget = 4.0e6;  // cap: texels * paths <= budget (big levels get fewer paths)
  int gt_min_paths = 32;
  int dense_rays = 4096;       // gather rays per texel for the dense F baseline (single-block scenes)
  int raytraced_rays = 64;     // rays per texel for the ray-traced F_level ld baseline (mazes)
  int frames = 50;             // timed frames per method (median)
  bool cpu_backend = true;     // also time MRT on modrt::cpu
  bool gles_backend = true;    // ... and on modrt::gles (when built and a context exists)
  double time_budget_s = 1.0;  // ... but stop after this long once 5 frames are in
};

LightDescription light_at(const glm::dvec3& p, double radius = 0.05) {
  LightDescription l;
  l.position = p;
  l.radius = radius;
  return l;
}

LevelDescription single_block_level(const std::string& name, FaceMask faces) {
  LevelDescription d;
  d.name = name;
  BlockDescription b;
  b.faces = faces;
  b.name = name;
  for (auto& a : b.albedo) a = glm::dvec3(0.7);
  d.blocks.push_back(b);
  return d;
}

// The closed box: grey 0.7 walls. In-prior lights: the centre and an upper off-centre
// point; out of prior: 0.03 from the -X wall (the prior's lattice stays 1/12 away).
SceneCase closed_box_scene(bool quick) {
  SceneCase s{"closed_box", single_block_level("closed_box", kAllFaces), true, {}};
  s.lights.push_back({"centre", true, {light_at({0.5, 0.5, 0.5})}});
  if (!quick) {
    s.lights.push_back({"upper", true, {light_at({0.3, 0.8, 0.6})}});
    s.lights.push_back({"near_wall", false, {light_at({0.03, 0.5, 0.5}, 0.02)}});
  }
  return s;
}

// Cornell-style box: one block with -Z missing (the dead-end shape, opening onto empty
// space), red -X and green +X walls, white 0.725 elsewhere. Out of prior: near the red
// wall, and a light outside the level beyond the opening, farther than the prior's
// neighbouring-cell lattice (z = -1.5).
SceneCase cornell_scene(bool quick) {
  LevelDescription d = single_block_level("cornell_box", FaceMask(kAllFaces & ~(1u << kFaceNegZ)));
  for (auto& a : d.blocks[0].albedo) a = glm::dvec3(0.725);
  d.blocks[0].albedo[kFaceNegX] = glm::dvec3(0.63, 0.065, 0.05);
  d.blocks[0].albedo[kFacePosX] = glm::dvec3(0.14, 0.45, 0.091);
  SceneCase s{"cornell_box", d, true, {}};
  s.lights.push_back({"centre", true, {light_at({0.5, 0.5, 0.5})}});
  if (!quick) {
    s.lights.push_back({"upper", true, {light_at({0.5, 0.85, 0.6})}});
    s.lights.push_back({"near_wall", false, {light_at({0.03, 0.5, 0.5}, 0.02)}});
    s.lights.push_back({"outside", false, {light_at({0.5, 0.7, -1.5})}});
  }
  return s;
}

// A maze preset with its own lights (block centres: in prior) and, out of prior, one light
// 0.03 from a present side wall of block 0.
Result<SceneCase> maze_scene(int blocks, bool quick) {
  Result<LevelDescription> d = precompute::maze_level(blocks);
  if (!d.ok()) return d.status();
  SceneCase s{"maze" + std::to_string(blocks), d.value(), false, {}};
  s.lights.push_back({"own", true, d->lights});
  if (!quick) {
    const BlockDescription& b0 = d->blocks[0];
    const glm::dvec3 c = glm::dvec3(b0.cell) * d->cell_size;
    const double e = 0.03 * d->cell_size, h = 0.5 * d->cell_size;
    for (int f : {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ}) {
      if (!face_present(b0.faces, f)) continue;
      glm::dvec3 p = c + glm::dvec3(h, h, h);
      if (f == kFaceNegX) p.x = c.x + e;
      if (f == kFacePosX) p.x = c.x + d->cell_size - e;
      if (f == kFaceNegZ) p.z = c.z + e;
      if (f == kFacePosZ) p.z = c.z + d->cell_size - e;
      s.lights.push_back({"near_wall", false, {light_at(p, 0.02)}});
      break;
    }
  }
  return s;
}

Result<SuiteConfig> make_suite(bool quick) {
  SuiteConfig cfg;
  cfg.scenes.push_back(closed_box_scene(quick));
  cfg.scenes.push_back(cornell_scene(quick));
  for (int blocks : quick ? std::vector<int>{11} : std::vector<int>{11, 41}) {
    Result<SceneCase> m = maze_scene(blocks, quick);
    if (!m.ok()) return m.status();
    cfg.scenes.push_back(std::move(m).value());
  }
  if (quick) {
    cfg.name = "quick";
    DictionarySettings s =
        precompute::quick_dictionary_settings(6);  // the tests' bake at the mobile resolution
    s.kb = 12;
    cfg.dictionaries = {s};
    cfg.kbs = {4, 12};
    cfg.gt_paths_one = 256;
    cfg.gt_paths_multi = 128;
    cfg.dense_rays = 1024;
    cfg.frames = 20;
    cfg.time_budget_s = 0.2;
  } else {
    cfg.name = "default";
    DictionarySettings mobile;  // mobile resolution, kb 32 so that every kb can be cut from it
    mobile.res = 6;
    cfg.dictionaries = {mobile, DictionarySettings{}};
    cfg.kbs = {1, 2, 4, 8, 12, 16, 32};
  }
  return cfg;
}

// ---------------------------------------------------------------- measurements

struct Row {
  std::string scene, lights, method, note;
  int res = 0;
  bool in_prior = true;
  int bounces = 1;
  int kb = 0;  // 0: not a rank-k method
  double time_ms = 0, rel_l2 = 0, p90 = 0, noise_floor = 0;
  int gt_paths = 0;
};

struct Truth {
  std::vector<float> value;
  double noise_floor = 0;
  int paths = 0;
};

struct ErrorStats {
  double rel_l2 = 0, p90 = 0;
};

ErrorStats error_of(std::span<const float> x, const std::vector<float>& ref) {
  double num = 0, den = 0, max_mag = 0;
  const std::size_t n = ref.size() / 3;
  std::vector<double> mag(n), err(n);
  for (std::size_t s = 0; s < n; ++s) {
    double m2 = 0, e2 = 0;
    for (std::size_t c = 0; c < 3; ++c) {
      const double r = ref[3 * s + c], d = double(x[3 * s + c]) - r;
      m2 += r * r;
      e2 += d * d;
    }
    num += e2;
    den += m2;
    mag[s] = std::sqrt(m2);
    err[s] = std::sqrt(e2);
    max_mag = std::max(max_mag, mag[s]);
  }
  std::vector<double> rel;
  rel.reserve(n);
  for (std::size_t s = 0; s < n; ++s)
    if (mag[s] >= 1e-3 * max_mag && mag[s] > 0) rel.push_back(err[s] / mag[s]);
  ErrorStats e;
  e.rel_l2 = den > 0 ? std::sqrt(num / den) : 0.0;
  if (!rel.empty()) {
    const std::size_t k = std::min(rel.size() - 1, std::size_t(std::ceil(0.9 * double(rel.size()))) - 1);
    std::nth_element(rel.begin(), rel.begin() + std::ptrdiff_t(k), rel.end());
    e.p90 = rel[k];
  }
  return e;
}

// Median wall time of f() in milliseconds: one warm-up call, then up to `frames` calls, but
// stop once `budget_s` has passed and at least 5 frames are in.
double median_ms(const std::function<void()>& f, int frames, double budget_s) {
  f();
  std::vector<double> t;
  const auto start = Clock::now();
  for (int i = 0; i < frames; ++i) {
    const auto t0 = Clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    if (i >= 4 && std::chrono::duration<double>(Clock::now() - start).count() > budget_s) break;
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

template <class M>
Matrix to_matrix(const M& m) {
  Matrix out(std::uint32_t(m.rows()), std::uint32_t(m.cols()));
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out(std::uint32_t(r), std::uint32_t(c)) = float(m(r, c));
  return out;
}

Matrix first_cols(const Matrix& m, std::uint32_t k) {
  if (m.empty() || k >= m.cols) return m;
  Matrix out(m.rows, k);
  for (std::uint32_t r = 0; r < m.rows; ++r)
    for (std::uint32_t c = 0; c < k; ++c) out(r, c) = m(r, c);
  return out;
}

Matrix first_rows(const Matrix& m, std::uint32_t k) {
  if (m.empty() || k >= m.rows) return m;
  Matrix out(k, m.cols);
  std::copy(m.data.begin(), m.data.begin() + std::ptrdiff_t(std::size_t(k) * m.cols), out.data.begin());
  return out;
}

// MRT at a smaller kb without a re-bake: Ub's columns and Td_b's rows are ordered by
// singular value, so kb = k keeps the first k modes of every per-mode operator.
Result<Dictionary> truncate_dictionary(const Dictionary& d, std::uint32_t k) {
  Dictionary t = d;
  t.settings.kb = k;
  for (ShapeOperators& s : t.shapes) {
    if (k > s.kb())
      return Status::error(
          ErrorCode::invalid_argument,
          "kb " + std::to_string(k) + " exceeds the dictionary's kb " + std::to_string(s.kb()));
    s.Ub = first_cols(s.Ub, k);
    s.Ub_vec = first_cols(s.Ub_vec, k);
    s.Ubvol = first_cols(s.Ubvol, k);
    s.Limp = first_cols(s.Limp, k);
    s.Td_b = first_rows(s.Td_b, k);
    for (Matrix& R : s.Rb_rlf) R = first_cols(R, k);
  }
  if (Status v = validate_dictionary(t, "truncated dictionary (kb " + std::to_string(k) + ")"); !v.ok())
    return v;
  return t;
}

// out = A in per channel (RGB) by the runtime's scalar kernel, so that every method's
// matrix-vector products cost the same per multiply-add.
using Apply = std::function<void(const float* in, float* out)>;

// Multi-bounce with the runtime's feedback (clamps included): out = A ld_direct, then
// `iterations` times ld = ld_direct + albedo * out, out = A ld.
void feedback_solve(const Apply& apply, const FeedbackClamp& clamp, std::span<const float> ld_direct,
                    int iterations, std::vector<float>& ld, std::vector<float>& out) {
  apply(ld_direct.data(), out.data());
  for (int it = 0; it < iterations; ++it) {
    apply_feedback(clamp, ld_direct, out, ld);
    apply(ld.data(), out.data());
  }
}

class Progress {
 public:
  explicit Progress(int total) : total_(total), start_(Clock::now()) {}
  void step(const std::string& label) {
    ++done_;
    draw(label);
  }
  void draw(const std::string& label) const {
    const int width = 30, filled = total_ > 0 ? width * done_ / total_ : width;
    const double s = std::chrono::duration<double>(Clock::now() - start_).count();
    std::fprintf(stderr, "\r[%s%s] %d/%d %6.0f s  %-48.48s", std::string(std::size_t(filled), '#').c_str(),
                 std::string(std::size_t(width - filled), ' ').c_str(), done_, total_, s, label.c_str());
    std::fflush(stderr);
  }
  void finish() const { std::fprintf(stderr, "\n"); }

 private:
  int total_, done_ = 0;
  Clock::time_point start_;
};

int gt_paths_for(std::size_t texels, int wanted, double budget, int min_paths) {
  const double cap = budget / double(std::max<std::size_t>(texels, 1));
  return std::clamp(int(std::min<double>(wanted, cap)), std::min(min_paths, wanted), wanted);
}

Truth ground_truth(const precompute::LevelScene& scene, const LevelDescription& desc, int bounces,
                   int paths) {
  const precompute::LevelSampleGeometry& g = scene.samples();
  precompute::PathTracerSettings pts;
  pts.paths = paths;
  pts.bounces = bounces;
  // Light vertices join every path vertex to the lit spots directly: without them a light
  // close to a wall leaves the truth at a 0.4-0.6 noise floor (test_path_tracer.cpp).
  pts.light_vertex_sources = precompute::level_light_centres(desc);
  const precompute::IndirectEstimate est = precompute::trace_indirect(
      scene, g.position, g.normal, precompute::level_direct_radiance(scene, desc, 8),
      precompute::level_surface_albedo(scene, desc), pts);
  Truth t;
  t.value = est.value;
  t.paths = paths;
  t.noise_floor = precompute::relative_noise_floor(est);
  return t;
}

struct RankOps {
  Matrix A, B;  // F ~ A B: A = U_k S_k (n x k), B = V_k^T (k x n)
};

// The GL context the GLES rows run on (none: GLES rows are left out, with the reason
// printed once).
struct GlesTarget {
#ifdef MODRT_BENCH_HAS_GLES
  std::unique_ptr<platform::GlContext> context;
#endif
  std::string description;  // e.g. "gles egl-surfaceless llvmpipe (LLVM 15.0.6, 256 bits)"
};

// Runs every method on one scene at one resolution, for each of its light cases.
Status run_scene(const SuiteConfig& cfg, const SceneCase& sc, const Dictionary& dict,
                 const std::map<std::uint32_t, Dictionary>& truncated, GlesTarget& gles, Progress& progress,
                 std::vector<Row>& rows) {
  const int res = int(dict.settings.res);
  const std::string tag = sc.name + " res " + std::to_string(res);
  progress.draw(tag + ": build");
  Result<Level> level_full = precompute::build_level(sc.desc, dict);
  if (!level_full.ok())
    return Status::error(level_full.status().code(), tag + ": " + level_full.status().to_string());
  std::map<std::uint32_t, Level> levels;
  for (const auto& [k, d] : truncated) {
    Result<Level> l = precompute::build_level(sc.desc, d);
    if (!l.ok())
      return Status::error(l.status().code(),
                           tag + " kb " + std::to_string(k) + ": " + l.status().to_string());
    levels.emplace(k, std::move(l).value());
  }
  const Level& level = level_full.value();
  const std::size_t n = level.sample_count;

  try {
    const precompute::LevelScene scene(level, 2);
    const std::vector<float> albedo = level_sample_albedo(level);

    // Single-block baselines: the dense F of the block and its truncated SVD.
    Matrix F;
    std::map<std::uint32_t, RankOps> svd_ops;
    if (sc.single_block) {
      progress.draw(tag + ": dense F + SVD");
      const LevelBlock& blk = level.blocks.at(0);
      const FaceMask mask = dictionary_shape_mask(blk.shape);
      if (level.blocks.size() != 1 || blk.quarter_turns != 0 || mask != sc.desc.blocks[0].faces)
        return Status::error(ErrorCode::internal_error,
                             tag + ": single-block scene is not a canonical dictionary shape");
      const precompute::BlockScene bs(mask);
      const SampleLayout layout = SampleLayout::make(mask, res);
      precompute::RowMatrixXd Fd = precompute::gather_transport(bs, layout, cfg.dense_rays, 12345);
      precompute::symmetrize_transport(Fd, layout);
      F = to_matrix(Fd);
      const Eigen::MatrixXd Fc = Fd;
      Eigen::BDCSVD<Eigen::MatrixXd> svd(Fc, Eigen::ComputeThinU | Eigen::ComputeThinV);
      for (std::uint32_t k : cfg.kbs) {
        const Eigen::Index kk = std::min<Eigen::Index>(k, svd.singularValues().size());
        const Eigen::MatrixXd A = svd.matrixU().leftCols(kk) * svd.singularValues().head(kk).asDiagonal();
        const Eigen::MatrixXd B = svd.matrixV().leftCols(kk).transpose();
        svd_ops[k] = RankOps{to_matrix(A), to_matrix(B)};
      }
    }

    const LevelBufferSizes sizes = level_buffer_sizes(level, dict);
    std::vector<float> out(3 * n), ld_work(3 * n), tmp(3 * 32);
    for (const LightCase& lc : sc.lights) {
      const std::string ltag = tag + " " + lc.name;
      LevelDescription desc = sc.desc;
      desc.lights = lc.lights;
      const std::vector<float> ld = precompute::level_direct_light(scene, desc.lights, albedo, 16);
      progress.draw(ltag + ": ground truth");
      const int paths1 = gt_paths_for(n, cfg.gt_paths_one, 4.0 * cfg.gt_path_budget, cfg.gt_min_paths);
      const int pathsm = gt_paths_for(n, cfg.gt_paths_multi, cfg.gt_path_budget, cfg.gt_min_paths);
      const Truth truth1 = ground_truth(scene, desc, 1, paths1);
      const Truth truthm = ground_truth(scene, desc, cfg.truth_bounces, pathsm);
      Result<FeedbackClamp> clamp = prepare_feedback(ld, albedo, n, MultiBounceSettings{});
      if (!clamp.ok()) return Status::error(clamp.status().code(), ltag + ": " + clamp.status().to_string());
      const int iterations = cfg.multi_bounces - 1;

      auto add = [&](const std::string& method, int bounces, int kb, double ms, std::span<const float> x,
                     const std::string& note = {}) {
        const Truth& t = bounces == 1 ? truth1 : truthm;
        const ErrorStats e = error_of(x, t.value);
        rows.push_back(Row{sc.name, lc.name, method, note, res, lc.in_prior, bounces, kb, ms, e.rel_l2, e.p90,
                           t.noise_floor, t.paths});
      };

      // Constant ambient: the ground truth's mean per channel everywhere.
      for (const Truth* t : {&truth1, &truthm}) {
        double mean[3] = {0, 0, 0};
        for (std::size_t s = 0; s < n; ++s)
          for (std::size_t c = 0; c < 3; ++c) mean[c] += t->value[3 * s + c];
        const float m[3] = {float(mean[0] / double(n)), float(mean[1] / double(n)),
                            float(mean[2] / double(n))};
        const double ms = median_ms(
            [&] {
              for (std::size_t s = 0; s < n; ++s)
                for (std::size_t c = 0; c < 3; ++c) out[3 * s + c] = m[c];
            },
            cfg.frames, cfg.time_budget_s);
        add("ambient", t == &truth1 ? 1 : cfg.multi_bounces, 0, ms, out, "mean of the ground truth");
      }

      if (sc.single_block) {
        const Apply dense = [&](const float* in, float* o) { reference_gemv_rgb(F, in, o, false); };
        double ms = median_ms([&] { dense(ld.data(), out.data()); }, cfg.frames, cfg.time_budget_s);
        add("dense_F", 1, 0, ms, out, std::to_string(cfg.dense_rays) + " rays/texel");
        ms = median_ms([&] { feedback_solve(dense, clamp.value(), ld, iterations, ld_work, out); },
                       cfg.frames, cfg.time_budget_s);
        add("dense_F", cfg.multi_bounces, 0, ms, out, std::to_string(cfg.dense_rays) + " rays/texel");
        for (const auto& entry : svd_ops) {
          // Named copies, not a structured binding: clang 14 cannot capture one in a lambda (C++20 P1091).
          const auto& k = entry.first;
          const auto& ops = entry.second;
          std::vector<float> t(3 * std::size_t(ops.B.rows));
          const Apply low = [&](const float* in, float* o) {
            reference_gemv_rgb(ops.B, in, t.data(), false);
            reference_gemv_rgb(ops.A, t.data(), o, false);
          };
          ms = median_ms([&] { low(ld.data(), out.data()); }, cfg.frames, cfg.time_budget_s);
          add("svd_F", 1, int(k), ms, out);
          ms = median_ms([&] { feedback_solve(low, clamp.value(), ld, iterations, ld_work, out); },
                         cfg.frames, cfg.time_budget_s);
          add("svd_F", cfg.multi_bounces, int(k), ms, out);
        }
      } else {
        progress.draw(ltag + ": ray-traced F ld");
        std::vector<float> one;
        const double ms =
            median_ms([&] { one = precompute::level_one_bounce(scene, ld, cfg.raytraced_rays, 99); }, 1, 0.0);
        add("raytraced_F", 1, 0, ms, one,
            "F_level ld ray traced per frame (" + std::to_string(cfg.raytraced_rays) +
                " rays/texel), 2 threads");
      }

      progress.draw(ltag + ": MRT");
      for (const auto& entry : levels) {
        const auto& k = entry.first;
        const auto& lvl = entry.second;
        const Dictionary& d = truncated.at(k);
        const LevelBufferSizes sz = level_buffer_sizes(lvl, d);
        std::vector<float> b(sz.b), r(sz.r);
        Status st;
        double ms =
            median_ms([&] { st = level_evaluate(lvl, d, ld, b, r, out); }, cfg.frames, cfg.time_budget_s);
        if (!st.ok())
          return Status::error(st.code(), ltag + " MRT kb " + std::to_string(k) + ": " + st.to_string());
        add("mrt", 1, int(k), ms, out);
        MultiBounceSettings mbs;
        mbs.max_iterations = iterations;
        Result<MultiBounceReport> rep = MultiBounceReport{};
        ms = median_ms([&] { rep = level_multi_bounce(lvl, d, ld, albedo, mbs, b, r, out); }, cfg.frames,
                       cfg.time_budget_s);
        if (!rep.ok())
          return Status::error(rep.status().code(), ltag + " MRT multi-bounce: " + rep.status().to_string());
        add("mrt", cfg.multi_bounces, int(k), ms, out,
            std::to_string(rep->iterations) + " feedback iterations" +
                (rep->value_clamped ? ", clamped" : ""));
        // The converged multi-bounce (reduced_feedback.h), in the multi-bounce column. The scalar
        // oracle builds the reduced operators in every call: its time is not a frame's
        // (BM_CpuConverged in modrt-bench-cpu times the backend's warm-started frames).
        Result<ConvergedBounceReport> conv = ConvergedBounceReport{};
        ms = median_ms([&] { conv = level_converged_bounce(lvl, d, ld, albedo, {}, b, r, out); }, cfg.frames,
                       cfg.time_budget_s);
        if (!conv.ok())
          return Status::error(conv.status().code(), ltag + " MRT converged: " + conv.status().to_string());
        add("mrt_converged", cfg.multi_bounces, int(k), ms, out,
            std::to_string(conv->solve.iterations) + " iterations, operators built per call");
      }
      if (cfg.cpu_backend) {
        progress.draw(ltag + ": MRT on modrt::cpu");
        for (const auto& entry : levels) {
          const auto& k = entry.first;
          const auto& lvl = entry.second;
          const std::string ktag = ltag + " MRT cpu kb " + std::to_string(k);
          Result<cpu::CpuLevelRuntime> rt = cpu::CpuLevelRuntime::create(lvl, truncated.at(k));
          if (!rt.ok()) return Status::error(rt.status().code(), ktag + ": " + rt.status().to_string());
          const std::string isa = std::string("cpu ") + cpu::isa_name(rt->isa()) + ", 1 thread";
          Status st;
          double ms = median_ms([&] { st = rt->evaluate(ld, out); }, cfg.frames, cfg.time_budget_s);
          if (!st.ok()) return Status::error(st.code(), ktag + ": " + st.to_string());
          add("mrt_cpu", 1, int(k), ms, out, isa);
          if (Status a = rt->set_albedo(albedo); !a.ok())
            return Status::error(a.code(), ktag + ": " + a.to_string());
          ms = median_ms(
              [&] {
                st = rt->evaluate(ld, out);
                for (int it = 0; it < iterations && st.ok(); ++it) st = rt->multi_bounce_step(ld, out);
              },
              cfg.frames, cfg.time_budget_s);
          if (!st.ok()) return Status::error(st.code(), ktag + " multi-bounce: " + st.to_string());
          add("mrt_cpu", cfg.multi_bounces, int(k), ms, out,
              isa + ", " + std::to_string(iterations) + " feedback steps");
        }
      }
#ifdef MODRT_BENCH_HAS_GLES
      if (gles.context) {
        progress.draw(ltag + ": MRT on modrt::gles");
        if (Status c = gles.context->make_current(); !c.ok())
          return Status::error(c.code(), ltag + ": " + c.to_string());
        for (const auto& entry : levels) {
          const auto& k = entry.first;
          const auto& lvl = entry.second;
          const std::string ktag = ltag + " MRT gles kb " + std::to_string(k);
          gles::GlesRuntimeOptions options;
          options.skip_unchanged = false;  // every timed frame does the whole update
          options.probes = false;          // as the other rows: lightmaps only
          Result<std::unique_ptr<gles::GlesLevelRuntime>> rt = gles::GlesLevelRuntime::create(
              gles.context->gl(), gles.context->info().gles, lvl, truncated.at(k), options);
          if (!rt.ok()) return Status::error(rt.status().code(), ktag + ": " + rt.status().to_string());
          gles::GlesLevelRuntime& g = *rt.value();
          // A frame: upload ld, every pass (b, r, atlas with padding), read the lightmap back
          // (which waits for the GPU).
          Status st;
          double ms = median_ms(
              [&] {
                st = g.update(ld);
                if (st.ok()) st = g.read_lightmap(out);
              },
              cfg.frames, cfg.time_budget_s);
          if (!st.ok()) return Status::error(st.code(), ktag + ": " + st.to_string());
          add("mrt_gles", 1, int(k), ms, out, gles.description + "; update + read_lightmap");
          if (Status a = g.set_albedo(albedo); !a.ok())
            return Status::error(a.code(), ktag + ": " + a.to_string());
          ms = median_ms(
              [&] {
                st = g.update(ld);
                for (int it = 0; it < iterations && st.ok(); ++it) st = g.multi_bounce_step(ld);
                if (st.ok()) st = g.read_lightmap(out);
              },
              cfg.frames, cfg.time_budget_s);
          if (!st.ok()) return Status::error(st.code(), ktag + " multi-bounce: " + st.to_string());
          add("mrt_gles", cfg.multi_bounces, int(k), ms, out,
              gles.description + "; " + std::to_string(iterations) + " feedback steps + read_lightmap");
        }
      }
#else
      (void)gles;
#endif
      (void)sizes;
      progress.step(ltag);
    }
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::internal_error, tag + ": " + e.what());
  }
  return Status::success();
}

// ---------------------------------------------------------------- output

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string method_label(const Row& r) {
  if (r.kb > 0) return r.method + " k" + std::to_string(r.kb);
  return r.method;
}

void print_table(const std::vector<Row>& rows) {
  std::printf("%-12s %-4s %-10s %-6s %-3s %-16s %10s %9s %9s %8s %6s\n", "scene", "res", "lights", "prior",
              "bnc", "method", "ms/frame", "relL2", "p90", "noise", "paths");
  for (const Row& r : rows)
    std::printf("%-12s %-4d %-10s %-6s %-3d %-16s %10.4f %9.4f %9.4f %8.4f %6d\n", r.scene.c_str(), r.res,
                r.lights.c_str(), r.in_prior ? "in" : "OUT", r.bounces, method_label(r).c_str(), r.time_ms,
                r.rel_l2, r.p90, r.noise_floor, r.gt_paths);
}

// Output files are built in memory and written atomically (file_io.h): an interrupted run
// never leaves a half-written report, CSV or JSON behind.
Status write_text(const std::string& path, const std::string& text) {
  return write_file_atomic(path, std::as_bytes(std::span(text.data(), text.size())));
}

Status write_csv(const std::string& path, const std::vector<Row>& rows) {
  std::ostringstream f;
  f << "scene,res,lights,in_prior,bounces,method,kb,time_ms,rel_l2,p90,noise_floor,gt_paths,note\n";
  for (const Row& r : rows)
    f << r.scene << ',' << r.res << ',' << r.lights << ',' << (r.in_prior ? 1 : 0) << ',' << r.bounces << ','
      << r.method << ',' << r.kb << ',' << fmt("%.6g", r.time_ms) << ',' << fmt("%.6g", r.rel_l2) << ','
      << fmt("%.6g", r.p90) << ',' << fmt("%.6g", r.noise_floor) << ',' << r.gt_paths << ",\"" << r.note
      << "\"\n";
  return write_text(path, f.str());
}

nlohmann::json settings_json(const SuiteConfig& cfg) {
  nlohmann::json j;
  j["suite"] = cfg.name;
  j["multi_bounces"] = cfg.multi_bounces;
  j["truth_bounces"] = cfg.truth_bounces;
  j["gt_paths_one_bounce"] = cfg.gt_paths_one;
  j["gt_paths_multi_bounce"] = cfg.gt_paths_multi;
  j["gt_path_budget"] = cfg.gt_path_budget;
  j["dense_rays"] = cfg.dense_rays;
  j["raytraced_rays"] = cfg.raytraced_rays;
  j["frames"] = cfg.frames;
  j["kbs"] = cfg.kbs;
  for (const DictionarySettings& d : cfg.dictionaries)
    j["dictionaries"].push_back(
        {{"res", d.res},
         {"kd", d.kd},
         {"kb", d.kb},
         {"rays", d.rays},
         {"lightfield", {d.lightfield_spatial, d.lightfield_directional, d.lightfield_supersample}},
         {"file", precompute::cache_file_name(d)}});
  return j;
}

Status write_json(const std::string& path, const SuiteConfig& cfg, const std::vector<Row>& rows) {
  nlohmann::json j;
  j["settings"] = settings_json(cfg);
  for (const Row& r : rows)
    j["rows"].push_back({{"scene", r.scene},
                         {"res", r.res},
                         {"lights", r.lights},
                         {"in_prior", r.in_prior},
                         {"bounces", r.bounces},
                         {"method", r.method},
                         {"kb", r.kb},
                         {"time_ms", r.time_ms},
                         {"rel_l2", r.rel_l2},
                         {"p90", r.p90},
                         {"noise_floor", r.noise_floor},
                         {"gt_paths", r.gt_paths},
                         {"note", r.note}});
  return write_text(path, j.dump(1) + "\n");
}

// Finds a python3 with matplotlib and runs the plot script; returns a message either way.
std::string draw_chart(const std::string& script, const std::string& csv, const std::string& png) {
  if (!std::filesystem::exists(script))
    return "chart not drawn: " + script + " not found (run from the source dir)";
  for (const char* py : {"python3", "/usr/bin/python3"}) {
    const std::string probe = std::string(py) + " -c \"import matplotlib\" >/dev/null 2>&1";
    if (std::system(probe.c_str()) != 0) continue;
    const std::string cmd = std::string(py) + " \"" + script + "\" \"" + csv + "\" \"" + png + "\"";
    if (std::system(cmd.c_str()) == 0) return "chart: " + png;
    return "chart not drawn: '" + cmd + "' failed";
  }
  return "chart not drawn: no python3 with matplotlib (Debian: apt-get install python3-matplotlib)";
}

// Average over in-prior light cases (never over out-of-prior ones) per (scene, res, bounces, method, kb).
struct Agg {
  double time_ms = 0, rel_l2 = 0, p90 = 0;
  int count = 0;
};
using AggKey = std::tuple<std::string, int, int, std::string, int>;
std::map<AggKey, Agg> aggregate_in_prior(const std::vector<Row>& rows) {
  std::map<AggKey, Agg> m;
  for (const Row& r : rows) {
    if (!r.in_prior) continue;
    Agg& a = m[{r.scene, r.res, r.bounces, r.method, r.kb}];
    a.time_ms += r.time_ms;
    a.rel_l2 += r.rel_l2;
    a.p90 += r.p90;
    ++a.count;
  }
  for (auto& [k, a] : m) {
    a.time_ms /= a.count;
    a.rel_l2 /= a.count;
    a.p90 /= a.count;
  }
  return m;
}

// Per single-block scene, resolution and bounce count: does MRT at rank k beat SVD(F) at rank k?
std::vector<std::string> mrt_vs_svd(const std::vector<Row>& rows, const SuiteConfig& cfg) {
  std::vector<std::string> lines;
  const auto agg = aggregate_in_prior(rows);
  for (const SceneCase& sc : cfg.scenes) {
    if (!sc.single_block) continue;
    for (const DictionarySettings& d : cfg.dictionaries)
      for (int bounces : {1, cfg.multi_bounces}) {
        std::string mrt_wins, svd_wins;
        for (std::uint32_t k : cfg.kbs) {
          auto m = agg.find({sc.name, int(d.res), bounces, "mrt", int(k)});
          auto s = agg.find({sc.name, int(d.res), bounces, "svd_F", int(k)});
          if (m == agg.end() || s == agg.end()) continue;
          std::string item = std::to_string(k) + " (" + fmt("%.3f", m->second.rel_l2) + " vs " +
                             fmt("%.3f", s->second.rel_l2) + ", " + fmt("%.3g", m->second.time_ms) + " vs " +
                             fmt("%.3g", s->second.time_ms) + " ms)";
          std::string& dst = m->second.rel_l2 <= s->second.rel_l2 ? mrt_wins : svd_wins;
          dst += (dst.empty() ? "" : ", ") + item;
        }
        lines.push_back(sc.name + ", res " + std::to_string(d.res) + ", " +
                        (bounces == 1 ? "one bounce" : std::to_string(bounces) + " bounces") +
                        ": MRT error <= SVD(F) at k = " + (mrt_wins.empty() ? "none" : mrt_wins) +
                        "; SVD(F) better at k = " + (svd_wins.empty() ? "none" : svd_wins) + ".");
      }
  }
  return lines;
}

// Per scene and resolution, in-prior mean at the largest kb: the converged multi-bounce against
// the 8-bounce feedback, both against the near-converged ground truth (issue 20: the converged
// error must not exceed the 8 bounces' on any scene). The solve stops within its tolerance (1e-3
// of max |b|), so where the bounces past 8 carry less than that (a dark scene) the two agree to
// it: the converged error may exceed the 8 bounces' by the tolerance. (The truth's noise adds the
// same term to both squared errors.) Empty `failures` when it holds everywhere.
struct ConvergedComparison {
  std::string table, failures;
};
ConvergedComparison converged_vs_feedback(const std::vector<Row>& rows, const SuiteConfig& cfg) {
  const auto agg = aggregate_in_prior(rows);
  const int kmax = int(*std::max_element(cfg.kbs.begin(), cfg.kbs.end()));
  ConvergedComparison c;
  std::ostringstream f;
  f << "## Converged multi-bounce against " << cfg.multi_bounces << " bounces\n\n"
    << "MRT at kb " << kmax << ", in-prior lights, both against the ground truth of " << cfg.truth_bounces
    << " path segments; relative L2 / p90:\n\n"
    << "| scene | res | " << cfg.multi_bounces << " bounces | converged | converged <= " << cfg.multi_bounces
    << " bounces + 1e-3 (the solve's tolerance) |\n|---|---|---|---|---|\n";
  for (const SceneCase& sc : cfg.scenes)
    for (const DictionarySettings& d : cfg.dictionaries) {
      auto m = agg.find({sc.name, int(d.res), cfg.multi_bounces, "mrt", kmax});
      auto v = agg.find({sc.name, int(d.res), cfg.multi_bounces, "mrt_converged", kmax});
      if (m == agg.end() || v == agg.end()) continue;
      const bool ok = v->second.rel_l2 <= m->second.rel_l2 + double(ReducedSolveSettings{}.tolerance);
      f << "| " << sc.name << " | " << d.res << " | " << fmt("%.3f", m->second.rel_l2) << " / "
        << fmt("%.3f", m->second.p90) << " | " << fmt("%.3f", v->second.rel_l2) << " / "
        << fmt("%.3f", v->second.p90) << " | " << (ok ? "yes" : "**no**") << " |\n";
      if (!ok)
        c.failures += "\n  " + sc.name + " res " + std::to_string(d.res) + ": converged relL2 " +
                      fmt("%.4f", v->second.rel_l2) + " > " + std::to_string(cfg.multi_bounces) +
                      " bounces' " + fmt("%.4f", m->second.rel_l2);
    }
  c.table = f.str() + "\n";
  return c;
}

// MRT on the SIMD CPU runtime and on GLES against the scalar reference, same frames: time
// ratios measured in one run and the largest error difference (they compute the same thing,
// so only float rounding separates them).
bool is_backend_row(const Row& r) { return r.method == "mrt_cpu" || r.method == "mrt_gles"; }

std::string backends_section(const std::vector<Row>& rows, const SuiteConfig& cfg) {
  const auto agg = aggregate_in_prior(rows);
  const int kmax = int(*std::max_element(cfg.kbs.begin(), cfg.kbs.end()));
  std::ostringstream f;
  std::string cpu_note, gles_note;
  for (const Row& r : rows) {
    if (r.method == "mrt_cpu" && cpu_note.empty()) cpu_note = r.note;
    if (r.method == "mrt_gles" && gles_note.empty()) gles_note = r.note.substr(0, r.note.find(';'));
  }
  if (cpu_note.empty() && gles_note.empty()) return {};
  f << "## The backends: SIMD CPU and GLES against the scalar reference\n\n"
    << "MRT at kb " << kmax
    << ", in-prior lights, the same frames on the scalar reference (`mrt`), on `modrt::cpu` ("
    << (cpu_note.empty() ? "not run" : cpu_note) << ") and on `modrt::gles` ("
    << (gles_note.empty() ? "not run" : gles_note)
    << "; a frame is upload + every pass + reading the lightmap back, so on a software rasteriser it "
       "measures "
       "llvmpipe, not a GPU: docs/gles.md has GPU timings). Speed-up = scalar time / backend time, measured "
       "in "
       "this run. |ΔrelL2| is the largest difference of relative L2 error from the scalar rows.\n\n"
    << "| scene | res | bounces | scalar ms | cpu ms | cpu speed-up | gles ms | gles speed-up | max |ΔrelL2| "
       "|\n"
    << "|---|---|---|---|---|---|---|---|---|\n";
  for (const SceneCase& sc : cfg.scenes)
    for (const DictionarySettings& d : cfg.dictionaries)
      for (int bounces : {1, cfg.multi_bounces}) {
        auto ref = agg.find({sc.name, int(d.res), bounces, "mrt", kmax});
        if (ref == agg.end()) continue;
        auto c = agg.find({sc.name, int(d.res), bounces, "mrt_cpu", kmax});
        auto g = agg.find({sc.name, int(d.res), bounces, "mrt_gles", kmax});
        double diff = 0.0;
        f << "| " << sc.name << " | " << d.res << " | " << bounces << " | "
          << fmt("%.3g", ref->second.time_ms);
        for (auto it : {c, g}) {
          if (it == agg.end()) {
            f << " | — | —";
            continue;
          }
          f << " | " << fmt("%.3g", it->second.time_ms) << " | "
            << fmt("%.3g×", ref->second.time_ms / std::max(it->second.time_ms, 1e-9));
          diff = std::max(diff, std::abs(it->second.rel_l2 - ref->second.rel_l2));
        }
        f << " | " << fmt("%.1e", diff) << " |\n";
      }
  f << "\n";
  return f.str();
}

// The report of modrt-proportion-accuracy --markdown (blocks that are not cubes), one heading
// level down, as a section of this report: both are generated, neither is edited by hand.
Result<std::string> proportions_section(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Status::error(ErrorCode::io_error, "--proportions: cannot read " + path);
  std::ostringstream o;
  o << "## Blocks that are not cubes (`" << path << "`)\n\n";
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with("# ")) continue;  // its title: this section's heading replaces it
    if (line.starts_with("#")) line = "#" + line;
    o << line << "\n";
  }
  return o.str();
}

Status write_report(const std::string& path, const std::string& chart_rel, const std::string& chart_msg,
                    const SuiteConfig& cfg, const std::vector<Row>& rows, const std::string& command,
                    double total_s, const std::string& proportions) {
  std::ostringstream f;
  const std::time_t now = std::time(nullptr);
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  f << "# Accuracy and run time (generated)\n\n"
    << "Generated by `" << command << "` on " << date << " (" << fmt("%.0f", total_s)
    << " s, dictionary bakes excluded when cached). Do not edit by hand: re-run the benchmark.\n\n"
    << "Every method is compared with a path-traced ground truth at the level's lightmap texels "
       "(`trace_indirect`, same direct-light model). Error: relative L2 over texels and channels "
       "(‖x − ref‖₂ / ‖ref‖₂) and the 90th percentile of per-texel relative error (texels whose truth "
       "is below 1e-3 of the maximum are skipped). Time: median per-frame wall time (`steady_clock`, up to "
    << cfg.frames
    << " frames), on this machine, of the scalar single-threaded code except the `mrt_cpu` / `mrt_gles` rows "
       "(the backends, compared below); the ray-traced F_level·ld baseline uses all cores and is timed "
       "once.\n\n";
  if (!chart_rel.empty()) f << "![run time versus error](" << chart_rel << ")\n\n";
  f << "Chart status: " << chart_msg
    << ". Panels: rows = in-prior one bounce, in-prior multi-bounce, "
       "out-of-prior one bounce; columns = scenes; hollow markers res 6, filled res 16; black step line = "
       "Pareto "
       "front; dotted = the largest ground-truth noise floor in the panel.\n\n";
  f << "## Settings\n\n"
    << "- suite `" << cfg.name << "`; MRT kb ∈ {";
  for (std::size_t i = 0; i < cfg.kbs.size(); ++i) f << (i ? ", " : "") << cfg.kbs[i];
  f << "} cut from one bake per resolution (Ub columns / Td_b rows are ordered by singular value).\n";
  for (const DictionarySettings& d : cfg.dictionaries)
    f << "- dictionary res " << d.res << ": kd " << d.kd << ", kb " << d.kb << ", " << d.rays
      << " rays, lightfield " << d.lightfield_spatial << "/" << d.lightfield_directional << "/"
      << d.lightfield_supersample << ", krlf " << d.krlf << ", kr " << d.kr << " (`"
      << precompute::cache_file_name(d) << "`)\n";
  f << "- multi-bounce: ground truth " << cfg.truth_bounces
    << " path segments (near converged); MRT `level_multi_bounce` with " << cfg.multi_bounces - 1
    << " feedback iterations (= " << cfg.multi_bounces
    << " bounces); dense/SVD baselines the same feedback with the same clamps; `mrt_converged`: the "
       "converged multi-bounce (`level_converged_bounce`, reduced space, tolerance 1e-3; its time includes "
       "building the reduced operators, which a backend does once per albedo).\n"
    << "- ground truth: up to " << cfg.gt_paths_one << " (one bounce) / " << cfg.gt_paths_multi
    << " (multi) paths per texel, capped so texels × paths ≤ " << fmt("%.3g", 4 * cfg.gt_path_budget) << " / "
    << fmt("%.3g", cfg.gt_path_budget) << " (at least " << cfg.gt_min_paths
    << "); the noise floor column is RMS standard error / RMS value (conservative).\n"
    << "- dense F baseline: the block's F gathered with " << cfg.dense_rays
    << " stratified rays per texel, symmetrised like the bake; SVD(F) baseline: Eigen BDCSVD of that F, "
       "rank k, run time = two GEMVs (k×n then n×k). Both use the runtime's scalar GEMV kernel.\n"
    << "- ambient baseline: the ground truth's mean per channel at every texel (an oracle constant; its "
       "cost is a fill).\n\n";

  f << "## Does MRT beat a truncated SVD of F at equal rank (equal run time)?\n\n"
    << "In-prior lights, averaged over the in-prior light placements; relative L2 (MRT vs SVD), time (MRT vs "
       "SVD):\n\n";
  for (const std::string& l : mrt_vs_svd(rows, cfg)) f << "- " << l << "\n";
  f << "\n" << converged_vs_feedback(rows, cfg).table;

  // Noise floors.
  f << "## Ground-truth noise floors\n\n| scene | res | lights | prior | bounces | paths | noise floor |\n"
       "|---|---|---|---|---|---|---|\n";
  std::set<std::tuple<std::string, int, std::string, int>> seen;
  for (const Row& r : rows)
    if (seen.insert({r.scene, r.res, r.lights, r.bounces}).second)
      f << "| " << r.scene << " | " << r.res << " | " << r.lights << " | " << (r.in_prior ? "in" : "**out**")
        << " | " << r.bounces << " | " << r.gt_paths << " | " << fmt("%.4f", r.noise_floor) << " |\n";
  f << "\n";

  // In-prior pivot tables per scene.
  const auto agg = aggregate_in_prior(rows);
  f << "## In-prior lights (mean over in-prior light placements)\n\n"
       "Cells: relative L2 / p90 / ms per frame.\n\n";
  for (const SceneCase& sc : cfg.scenes) {
    std::vector<std::pair<int, int>> cols;
    for (const DictionarySettings& d : cfg.dictionaries)
      for (int bounces : {1, cfg.multi_bounces}) cols.push_back({int(d.res), bounces});
    std::vector<std::pair<std::string, int>> methods;
    std::set<std::pair<std::string, int>> mset;
    for (const Row& r : rows)
      if (r.scene == sc.name && r.in_prior && !is_backend_row(r) && mset.insert({r.method, r.kb}).second)
        methods.push_back({r.method, r.kb});
    f << "### " << sc.name << "\n\n| method |";
    for (auto [res, b] : cols) f << " res " << res << ", " << (b == 1 ? "1 bounce" : "multi-bounce") << " |";
    f << "\n|---|";
    for (std::size_t i = 0; i < cols.size(); ++i) f << "---|";
    f << "\n";
    for (const auto& [m, k] : methods) {
      f << "| " << m << (k ? " k" + std::to_string(k) : "") << " |";
      for (auto [res, b] : cols) {
        auto it = agg.find({sc.name, res, b, m, k});
        if (it == agg.end())
          f << " — |";
        else
          f << " " << fmt("%.3f", it->second.rel_l2) << " / " << fmt("%.3f", it->second.p90) << " / "
            << fmt("%.3g", it->second.time_ms) << " |";
      }
      f << "\n";
    }
    f << "\n";
  }

  f << "## Out-of-prior lights (reported separately, never averaged in)\n\n"
       "| scene | res | lights | bounces | method | relL2 | p90 | ms | noise floor "
       "|\n|---|---|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows)
    if (!r.in_prior && !is_backend_row(r) && (r.method != "mrt" || r.kb == 4 || r.kb == 12 || r.kb == 32) &&
        (r.method != "svd_F" || r.kb == 12 || r.kb == 32))
      f << "| " << r.scene << " | " << r.res << " | " << r.lights << " | " << r.bounces << " | "
        << method_label(r) << " | " << fmt("%.3f", r.rel_l2) << " | " << fmt("%.3f", r.p90) << " | "
        << fmt("%.3g", r.time_ms) << " | " << fmt("%.4f", r.noise_floor) << " |\n";
  f << "\n(Only kb 4, 12, 32 for MRT and 12, 32 for SVD here; every row is in the CSV/JSON output.)\n\n"
    << backends_section(rows, cfg);
  double out_floor = 0.0;
  for (const Row& r : rows)
    if (!r.in_prior) out_floor = std::max(out_floor, r.noise_floor);
  f << proportions;
  f << "## Notes\n\n"
    << "- `mrt` rows are the scalar reference runtime (`level_evaluate`, `level_multi_bounce`); `mrt_cpu` "
       "and "
       "`mrt_gles` rows are the same frames on the SIMD CPU runtime and on the GLES backend (see above).\n"
    << "- The ray-traced F_level·ld row (mazes) is the exact one bounce on the proxy level; its time is a "
       "ray tracer's, not a real-time method's, and its error includes its own Monte Carlo noise.\n"
    << "- An error near a scene's noise floor cannot be resolved further by this ground truth. The floor is "
       "conservative (it treats the stratified first direction as independent paths): the dense F rows often "
       "land below it. All methods of one row group share the same ground truth, so differences between them "
       "are less noisy than the floor suggests.\n"
    << "- The ground truth joins every path vertex to light vertices (points first hit by rays from the "
       "light "
       "centres), combined with the cosine-weighted paths by the balance heuristic. Without them the "
       "near-wall "
       "placements (a small, very bright lit spot that cosine-weighted paths rarely hit) sat at noise floors "
       "of "
       "0.35–0.6; the largest out-of-prior floor in this run is "
    << fmt("%.3f", out_floor) << ".\n";
  return write_text(path, f.str());
}

// Thresholds: {"max_rel_l2": {"<scene>/b<bounces>": value}}, checked against the worst
// in-prior MRT row at the suite's largest kb.
Status check_thresholds(const std::string& path, const SuiteConfig& cfg, const std::vector<Row>& rows,
                        double write_headroom) {
  const int kmax = int(*std::max_element(cfg.kbs.begin(), cfg.kbs.end()));
  std::map<std::string, double> worst;
  for (const Row& r : rows)
    if (r.method == "mrt" && r.in_prior && r.kb == kmax) {
      const std::string key = r.scene + "/b" + std::to_string(r.bounces);
      worst[key] = std::max(worst[key], r.rel_l2);
    }
  if (write_headroom > 0) {
    nlohmann::json j;
    j["comment"] = "bench_quick: max in-prior relative L2 of MRT (kb " + std::to_string(kmax) +
                   ") per scene and bounce count; measured x " + fmt("%.2f", write_headroom);
    for (const auto& [k, v] : worst) j["max_rel_l2"][k] = std::round(v * write_headroom * 1e4) / 1e4;
    std::ofstream f(path);
    if (!f) return Status::error(ErrorCode::io_error, "cannot write " + path);
    f << j.dump(2) << "\n";
    std::printf("wrote thresholds %s\n", path.c_str());
    return Status::success();
  }
  std::ifstream f(path);
  if (!f) return Status::error(ErrorCode::io_error, "cannot read thresholds " + path);
  nlohmann::json j;
  try {
    f >> j;
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::invalid_argument, path + ": " + e.what());
  }
  if (!j.contains("max_rel_l2") || !j["max_rel_l2"].is_object())
    return Status::error(ErrorCode::invalid_argument, path + ": expected an object \"max_rel_l2\"");
  std::string failures;
  for (const auto& [key, value] : j["max_rel_l2"].items()) {
    if (!value.is_number())
      return Status::error(ErrorCode::invalid_argument, path + ": " + key + " is not a number");
    auto it = worst.find(key);
    if (it == worst.end()) {
      failures += "\n  " + key + ": no MRT result measured";
      continue;
    }
    const double limit = value.get<double>();
    const bool ok = it->second <= limit;
    std::printf("threshold %-20s MRT kb %d relL2 %.4f (limit %.4f) %s\n", key.c_str(), kmax, it->second,
                limit, ok ? "ok" : "FAILED");
    if (!ok) failures += "\n  " + key + ": " + fmt("%.4f", it->second) + " > " + fmt("%.4f", limit);
  }
  const ConvergedComparison converged = converged_vs_feedback(rows, cfg);
  std::printf("converged multi-bounce <= %d bounces on every scene: %s\n", cfg.multi_bounces,
              converged.failures.empty() ? "ok" : "FAILED");
  failures += converged.failures;
  if (!failures.empty())
    return Status::error(ErrorCode::internal_error, "accuracy thresholds exceeded:" + failures);
  return Status::success();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modrt-bench: run time versus error of MRT and baselines against a path-traced ground truth"};
  bool quick = false;
  std::string json_path, csv_path, report_path, chart_path, thresholds_path,
      cache_dir = precompute::default_cache_dir();
  std::string plot_script = "scripts/plot_bench.py";
  double write_headroom = 0;
  int frames = 0;
  std::vector<std::string> only;
  app.add_flag("--quick", quick, "tiny CI suite (res 6 small bakes, in-prior lights only)");
  app.add_option("--json", json_path, "write every row as JSON");
  app.add_option("--csv", csv_path, "write every row as CSV");
  app.add_option("--chart", chart_path, "draw the time-vs-error chart (PNG) with --plot-script")
      ->default_str("");
  app.add_option("--plot-script", plot_script, "matplotlib script that draws the chart")
      ->capture_default_str();
  app.add_option("--report", report_path,
                 "write a Markdown report (e.g. docs/accuracy.md); implies a chart, "
                 "by default next to it (<report>.png)");
  std::string proportions_path;
  app.add_option("--proportions", proportions_path,
                 "with --report: include this modrt-proportion-accuracy --markdown report (blocks that are "
                 "not cubes) as a section");
  app.add_option("--check-thresholds", thresholds_path,
                 "fail (exit 3) when MRT's in-prior relative L2 exceeds these");
  app.add_option("--write-thresholds", write_headroom,
                 "instead of checking, write --check-thresholds FILE from this run x HEADROOM (e.g. 1.3)")
      ->check(modrt::demo::FiniteRange(0.0, 100.0));
  app.add_option("--cache-dir", cache_dir, "dictionary cache directory")->capture_default_str();
  app.add_option("--frames", frames, "timed frames per method (median)")->check(CLI::Range(1, 100000));
  app.add_option("--scenes", only, "run only these scenes (closed_box, cornell_box, maze11, maze41)");
  std::vector<std::string> backends = {"cpu", "gles"};
  app.add_option("--backends", backends,
                 "time MRT also on these backends (cpu, gles; none: only the scalar reference)")
      ->check(CLI::IsMember({"cpu", "gles", "none"}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (write_headroom > 0 && thresholds_path.empty()) {
    std::fprintf(stderr, "modrt-bench: --write-thresholds needs --check-thresholds FILE\n");
    return 2;
  }
  // Before the suite's minutes, not after them.
  if (!proportions_path.empty() && !proportions_section(proportions_path).ok()) {
    std::fprintf(stderr, "modrt-bench: --proportions: cannot read %s\n", proportions_path.c_str());
    return 2;
  }
  std::string command = "modrt-bench";
  for (int i = 1; i < argc; ++i) command += std::string(" ") + argv[i];

  Result<SuiteConfig> suite = make_suite(quick);
  if (!suite.ok()) {
    std::fprintf(stderr, "modrt-bench: %s\n", suite.status().to_string().c_str());
    return 1;
  }
  SuiteConfig cfg = std::move(suite).value();
  if (frames > 0) cfg.frames = frames;
  if (!only.empty()) {
    std::vector<SceneCase> kept;
    for (const SceneCase& s : cfg.scenes)
      if (std::find(only.begin(), only.end(), s.name) != only.end()) kept.push_back(s);
    if (kept.empty()) {
      std::fprintf(stderr, "modrt-bench: --scenes matched no scene\n");
      return 2;
    }
    cfg.scenes = kept;
  }
  if (!report_path.empty() && chart_path.empty())
    chart_path = (std::filesystem::path(report_path).replace_extension(".png")).string();
  auto wanted = [&](const char* b) {
    return std::find(backends.begin(), backends.end(), b) != backends.end();
  };
  cfg.cpu_backend = wanted("cpu");
  cfg.gles_backend = wanted("gles");
  GlesTarget gles;
  if (cfg.gles_backend) {
#ifdef MODRT_BENCH_HAS_GLES
    Result<std::unique_ptr<platform::GlContext>> c =
        platform::create_context(platform::ContextRequest::auto_select);
    if (c.ok()) {
      gles.context = std::move(c).value();
      const platform::ContextInfo& info = gles.context->info();
      gles.description = std::string("gles ") + platform::context_kind_name(info.kind) + ", " + info.renderer;
      std::fprintf(stderr, "GLES rows on: %s\n", gles.description.c_str());
    } else {
      std::fprintf(stderr, "modrt-bench: no GL context, GLES rows left out: %s\n",
                   c.status().to_string().c_str());
    }
#else
    std::fprintf(stderr, "modrt-bench: built without MODRT_BUILD_GLES, GLES rows left out\n");
#endif
  }

  const auto start = Clock::now();
  std::vector<Row> rows;
  int total = 0;
  for (const SceneCase& s : cfg.scenes) total += int(s.lights.size());
  total *= int(cfg.dictionaries.size());
  Progress progress(total);
  for (const DictionarySettings& ds : cfg.dictionaries) {
    std::fprintf(stderr, "dictionary res %u kb %u (%s): loading or baking in %s ...\n", ds.res, ds.kb,
                 precompute::cache_file_name(ds).c_str(), cache_dir.c_str());
    const auto tb = Clock::now();
    Result<Dictionary> dict = precompute::load_or_bake_dictionary(
        ds, cache_dir, {}, [](const std::string& m) { std::fprintf(stderr, "%s\n", m.c_str()); });
    if (!dict.ok()) {
      std::fprintf(stderr, "modrt-bench: dictionary: %s\n", dict.status().to_string().c_str());
      return 1;
    }
    std::fprintf(stderr, "  ready in %.1f s\n", std::chrono::duration<double>(Clock::now() - tb).count());
    std::map<std::uint32_t, Dictionary> truncated;
    for (std::uint32_t k : cfg.kbs) {
      Result<Dictionary> t = truncate_dictionary(dict.value(), k);
      if (!t.ok()) {
        std::fprintf(stderr, "modrt-bench: %s\n", t.status().to_string().c_str());
        return 1;
      }
      truncated.emplace(k, std::move(t).value());
    }
    for (const SceneCase& sc : cfg.scenes) {
      if (Status s = run_scene(cfg, sc, dict.value(), truncated, gles, progress, rows); !s.ok()) {
        progress.finish();
        std::fprintf(stderr, "modrt-bench: %s\n", s.to_string().c_str());
        return 1;
      }
    }
  }
  progress.finish();
  const double total_s = std::chrono::duration<double>(Clock::now() - start).count();
  print_table(rows);
  std::printf("suite %s: %zu rows in %.1f s\n", cfg.name.c_str(), rows.size(), total_s);
  for (const std::string& l : mrt_vs_svd(rows, cfg)) std::printf("%s\n", l.c_str());

  for (const auto& [path, st] :
       {std::pair{json_path, json_path.empty() ? Status::success() : write_json(json_path, cfg, rows)},
        std::pair{csv_path, csv_path.empty() ? Status::success() : write_csv(csv_path, rows)}}) {
    if (!st.ok()) {
      std::fprintf(stderr, "modrt-bench: %s\n", st.to_string().c_str());
      return 1;
    }
    if (!path.empty()) std::printf("wrote %s\n", path.c_str());
  }
  std::string chart_msg = "not requested";
  if (!chart_path.empty()) {
    std::string csv_for_chart = csv_path;
    if (csv_for_chart.empty()) {
      csv_for_chart = chart_path + ".csv";
      if (Status st = write_csv(csv_for_chart, rows); !st.ok()) {
        std::fprintf(stderr, "modrt-bench: %s\n", st.to_string().c_str());
        return 1;
      }
    }
    chart_msg = draw_chart(plot_script, csv_for_chart, chart_path);
    std::printf("%s\n", chart_msg.c_str());
  }
  if (!report_path.empty()) {
    std::string chart_rel;
    if (!chart_path.empty() && std::filesystem::exists(chart_path))
      chart_rel = std::filesystem::relative(chart_path, std::filesystem::absolute(report_path).parent_path())
                      .string();
    std::string proportions;
    if (!proportions_path.empty()) {
      Result<std::string> section = proportions_section(proportions_path);
      if (!section.ok()) {
        std::fprintf(stderr, "modrt-bench: %s\n", section.status().to_string().c_str());
        return 1;
      }
      proportions = std::move(section).value() + "\n";
    }
    if (Status st = write_report(report_path, chart_rel, chart_msg, cfg, rows, command, total_s, proportions);
        !st.ok()) {
      std::fprintf(stderr, "modrt-bench: %s\n", st.to_string().c_str());
      return 1;
    }
    std::printf("wrote %s\n", report_path.c_str());
  }
  if (!thresholds_path.empty()) {
    if (Status st = check_thresholds(thresholds_path, cfg, rows, write_headroom); !st.ok()) {
      std::fprintf(stderr, "modrt-bench: %s\n", st.to_string().c_str());
      return 3;
    }
  }
  return 0;
}
