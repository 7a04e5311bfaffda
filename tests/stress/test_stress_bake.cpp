// SPDX-License-Identifier: MIT
// Numerical stress of the bake (issue 9): near-singular lighting priors (duplicate, nearly
// duplicate and colinear lights, lights on the walls, a single light, kd above the prior's
// rank), kb 1 and kb = rank, res 1, through the real bake_shape / bake_dictionary, the level
// build and the SIMD CPU runtime. Each SVD's conditioning is logged.
//
// What is asserted, per shape bake (exact arithmetic; 1e-9 relative slack for rounding):
//   every operator finite (double and float);
//   ||F||_inf <= 1: a row of F sums the cosine-weighted hemisphere fraction that sees present
//     faces (transport.h), at most 1;
//   ||Ub Td_b||_2 <= ||F||_2: Ub Td_b = Um~ Um~^T F P P^T (reduction.h; modes whose inverse
//     reduce_transfer zeroes only shrink it), two orthogonal projections around F;
//   ||Td_b||_2 <= ||F||_2 / sigma_min: Td_b = Sm~^-1 Um~^T F P P^T, sigma_min the smallest
//     singular value of M that reduce_transfer inverts (> 1e-12 sigma_0 by construction, so
//     ||Td_b||_2 <= 1e12 ||F||_2 / sigma_0 whatever the prior);
//   when the truncations keep the whole numerical rank (kd >= rank Ld, kb >= rank M), the low
//     rank operator is exact on the prior: Ub Td_b Ld = F Ld within 1e-10 + 1e-14 cond(M).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "modrt/precompute/svd.h"

#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/bake.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/maze.h"
#include "stress/stress_report.h"

namespace modrt::precompute {
namespace {

using stress::fmt;
using stress::report;
using stress::row;

// Small enough that a shape bakes in milliseconds: 3 x 3 texels per face, 256 gather rays.
DictionarySettings tiny_settings() {
  DictionarySettings s;
  s.res = 3;
  s.rays = 256;
  s.kd = 16;
  s.kb = 8;
  s.prior_grid = 2;
  s.light_samples = 1;
  s.sh_rays = 16;
  s.probe_grid = 1;
  s.lightfield_spatial = 0;
  return s;
}

// The interface part at its smallest, for dictionaries a level is built from.
DictionarySettings with_tiny_interfaces(DictionarySettings s) {
  s.lightfield_spatial = 2;
  s.lightfield_directional = 2;
  s.lightfield_supersample = 1;
  s.krlf = 8;
  s.kr = 4;
  s.interface_enrichment_iterations = 1;
  s.response_rays = 16;
  return s;
}

// Ld with one column per light (unit L2 norm as light_prior_matrix makes them; a light no
// sample sees keeps its zero column, which the SVD must tolerate).
MatrixXd prior_from_lights(FaceMask mask, int res, const std::vector<glm::dvec3>& lights, double radius) {
  const BlockScene scene(mask);
  const SampleLayout layout = SampleLayout::make(mask, res);
  const int n = layout.sample_count();
  MatrixXd Ld(n, Eigen::Index(lights.size()));
  std::vector<double> column(static_cast<std::size_t>(n));
  for (std::size_t j = 0; j < lights.size(); ++j) {
    direct_light(scene, layout, SphereLight{lights[j], radius, 1.0}, 1, column);
    const Eigen::Map<const VectorXd> c(column.data(), n);
    const double norm = c.norm();
    Ld.col(Eigen::Index(j)) = norm > 0 ? VectorXd(c / norm) : VectorXd(c);
  }
  return Ld;
}

double spectral_norm(const MatrixXd& a) {
  if (a.size() == 0) return 0.0;
  return Eigen::BDCSVD<MatrixXd>(a).singularValues()(0);
}

VectorXd singular_values(const MatrixXd& a) { return Eigen::BDCSVD<MatrixXd>(a).singularValues(); }

// Count of values above `relative` x the largest.
Eigen::Index numerical_rank(const VectorXd& sigma, double relative) {
  Eigen::Index r = 0;
  while (r < sigma.size() && sigma(r) > relative * sigma(0)) ++r;
  return r;
}

bool finite(const MatrixXd& m) { return m.allFinite(); }
bool finite(const Matrix& m) {
  return std::all_of(m.data.begin(), m.data.end(), [](float v) { return std::isfinite(v); });
}

// What check_shape_bake measured, worst over the shapes of a case (CaseStats::add).
struct CaseStats {
  double ld_cond = 0, m_cond = 0, enrich_cond = 0;      // sigma_0 / smallest kept value
  Eigen::Index ld_kept_min = 1 << 30, ld_kept_max = 0;  // prior modes kept
  Eigen::Index m_kept_min = 1 << 30, m_kept_max = 0;    // M modes kept
  bool finite = true;
  double F_inf = 0;
  double UT_ratio = 0;            // ||Ub Td_b||_2 / ||F||_2
  double Td_2 = 0, Td_ratio = 0;  // ||Td_b||_2 and its share of ||F||_2 / sigma_min
  float Td_max = 0;               // largest |Td_b| entry (float)
  int exact_shapes = 0;           // shapes where the prior's whole rank was kept
  double exact_residual = 0, exact_tol = 0;
  double truncated_residual = 0;                       // the same residual where it was truncated
  double float_error = 0, float_bound = 0, kappa = 0;  // float32 Ub (Td_b ld) against double
};

// Ub (Td_b ld) as the run time computes it: float operators, float ld, float accumulation.
// Its rounding error against double is at most (n + kb + 2) u || |Ub| |Td_b| |ld| ||_2
// (u = 2^-24; products of rounded operators and sums of n then kb terms), relative to ||Ub Td_b ld||
// that is (n + kb + 2) u kappa with kappa = || |Ub| |Td_b| |ld| || / || Ub Td_b ld ||: cancellation
// between large modes of b is what a near-singular prior costs at run time.
void float_runtime_error(const ReducedTransfer& t, CaseStats& st, const std::string& name) {
  const Eigen::Index n = t.Ub.rows(), kb = t.Ub.cols();
  VectorXd ld(n);
  for (Eigen::Index i = 0; i < n; ++i)
    ld(i) = 0.5 + 0.45 * std::sin(1.7 * double(i) + 0.3);  // not in the prior
  const VectorXd y = t.Ub * (t.Td_b * ld);
  const VectorXd y_abs = t.Ub.cwiseAbs() * (t.Td_b.cwiseAbs() * ld.cwiseAbs());
  std::vector<float> b(static_cast<std::size_t>(kb), 0.0f);
  for (Eigen::Index j = 0; j < kb; ++j)
    for (Eigen::Index i = 0; i < n; ++i) b[std::size_t(j)] += float(t.Td_b(j, i)) * float(ld(i));
  double num = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    float yi = 0.0f;
    for (Eigen::Index j = 0; j < kb; ++j) yi += float(t.Ub(i, j)) * b[std::size_t(j)];
    num += (double(yi) - y(i)) * (double(yi) - y(i));
  }
  const double err = std::sqrt(num) / y.norm(), kappa = y_abs.norm() / y.norm();
  const double bound = double(n + kb + 2) * 0x1p-24 * kappa;
  EXPECT_LE(err, bound) << name;
  st.float_error = std::max(st.float_error, err);
  st.float_bound = std::max(st.float_bound, bound);
  st.kappa = std::max(st.kappa, kappa);
}

// The checks of the header comment on one shape's bake (asserted per shape), folded into `st`.
void check_shape_bake(const std::string& name, const ShapeBake& bake, const DictionarySettings& s,
                      CaseStats& st) {
  const ReducedTransfer& t = bake.transfer;
  // Conditioning of the three SVDs: the prior (Ld), M = F P S (final prior), the enrichment.
  const VectorXd sigma_Ld = singular_values(bake.Ld);
  const Eigen::Index ld_kept = bake.raw_prior.S.size();
  const Eigen::Index k = cluster_safe_rank(t.sigma_M, s.kb);
  st.ld_kept_min = std::min(st.ld_kept_min, ld_kept);
  st.ld_kept_max = std::max(st.ld_kept_max, ld_kept);
  st.m_kept_min = std::min(st.m_kept_min, k);
  st.m_kept_max = std::max(st.m_kept_max, k);
  if (ld_kept > 0) st.ld_cond = std::max(st.ld_cond, sigma_Ld(0) / sigma_Ld(ld_kept - 1));
  if (k > 0) st.m_cond = std::max(st.m_cond, t.sigma_M(0) / t.sigma_M(k - 1));
  if (s.enrichment_iterations > 0 && bake.prior.S.size() > 0)
    st.enrich_cond = std::max(st.enrich_cond, bake.prior.S(0) / bake.prior.S(bake.prior.S.size() - 1));

  const ShapeOperators op = to_operators(bake);
  const bool all_finite = finite(t.Ub) && finite(t.Td_b) && finite(t.Limp) && finite(bake.Ub_vec) &&
                          finite(bake.Ubvol) && finite(op.Ub) && finite(op.Td_b) && finite(op.Limp) &&
                          finite(op.Ub_vec) && finite(op.Ubvol);
  EXPECT_TRUE(all_finite) << name;
  st.finite &= all_finite;

  const double F_inf = bake.F.rowwise().sum().maxCoeff();
  EXPECT_LE(F_inf, 1.0 + 1e-12) << name;
  st.F_inf = std::max(st.F_inf, F_inf);
  const double F_2 = spectral_norm(bake.F);
  const double UT_2 = spectral_norm(t.Ub * t.Td_b);
  EXPECT_LE(UT_2, F_2 * (1 + 1e-9)) << name;
  st.UT_ratio = std::max(st.UT_ratio, UT_2 / F_2);
  // Inverted modes: the kept ones above reduce_transfer's 1e-12 sigma_0 threshold.
  Eigen::Index inverted = 0;
  while (inverted < k && t.sigma_M(inverted) > 1e-12 * t.sigma_M(0)) ++inverted;
  ASSERT_GT(inverted, 0) << name;
  const double Td_2 = spectral_norm(t.Td_b);
  const double Td_bound = F_2 / t.sigma_M(inverted - 1);
  EXPECT_LE(Td_2, Td_bound * (1 + 1e-9)) << name;
  st.Td_2 = std::max(st.Td_2, Td_2);
  st.Td_ratio = std::max(st.Td_ratio, Td_2 / Td_bound);
  for (float v : op.Td_b.data) st.Td_max = std::max(st.Td_max, std::abs(v));

  float_runtime_error(t, st, name);

  // Exact on the prior when nothing of numerical rank was truncated (raw prior and transfer).
  const Eigen::Index ld_rank = numerical_rank(sigma_Ld, 1e-13);
  const Eigen::Index k_raw = cluster_safe_rank(bake.raw_transfer.sigma_M, s.kb);
  const Eigen::Index m_rank = numerical_rank(bake.raw_transfer.sigma_M, 1e-12);
  const MatrixXd FLd = bake.F * bake.Ld;
  const double residual =
      (bake.raw_transfer.Ub * (bake.raw_transfer.Td_b * bake.Ld) - FLd).norm() / std::max(FLd.norm(), 1e-300);
  if (ld_kept >= ld_rank && k_raw >= m_rank && m_rank > 0) {
    const double cond = bake.raw_transfer.sigma_M(0) / bake.raw_transfer.sigma_M(m_rank - 1);
    const double tol = 1e-10 + 1e-14 * cond;
    EXPECT_LE(residual, tol) << name;
    ++st.exact_shapes;
    st.exact_residual = std::max(st.exact_residual, residual);
    st.exact_tol = std::max(st.exact_tol, tol);
  } else {
    st.truncated_residual = std::max(st.truncated_residual, residual);
  }
  std::printf(
      "  %s: Ld kept %lld (rank %lld of %lld lights, cond %.3g), M kept %lld of %u (cond %.3g), ||F||_2 "
      "%.4f, "
      "||Ub Td_b||_2 %.4f, ||Td_b||_2 %.4g <= %.4g, residual on prior %.2e\n",
      name.c_str(), static_cast<long long>(ld_kept), static_cast<long long>(ld_rank),
      static_cast<long long>(bake.Ld.cols()), ld_kept > 0 ? sigma_Ld(0) / sigma_Ld(ld_kept - 1) : 0.0,
      static_cast<long long>(k), s.kb, k > 0 ? t.sigma_M(0) / t.sigma_M(k - 1) : 0.0, F_2, UT_2, Td_2,
      Td_bound, residual);
}

// The table's rows for one case (worst over its shapes).
void report_case(const std::string& name, const DictionarySettings& s, const CaseStats& st) {
  report(name, "SVD conditioning (worst shape)",
         fmt("Ld: kept %lld-%lld of kd %u, cond %.3g; M = F P S: kept %lld-%lld of kb %u, cond %.3g",
             static_cast<long long>(st.ld_kept_min), static_cast<long long>(st.ld_kept_max), s.kd, st.ld_cond,
             static_cast<long long>(st.m_kept_min), static_cast<long long>(st.m_kept_max), s.kb, st.m_cond) +
             (s.enrichment_iterations > 0 ? fmt("; enrichment: cond %.3g", st.enrich_cond) : std::string()));
  row(name, "operators finite; ‖F‖∞", fmt("%s; %.4f", st.finite ? "finite" : "NON-FINITE", st.F_inf),
      "finite; <= 1", st.finite && st.F_inf <= 1.0 + 1e-12);
  row(name, "‖Ub Td_b‖₂ / ‖F‖₂", fmt("%.4f", st.UT_ratio), "<= 1", st.UT_ratio <= 1.0 + 1e-9);
  row(name, "‖Td_b‖₂ (largest entry)",
      fmt("%.4g (%.3g), %.2f of bound", st.Td_2, double(st.Td_max), st.Td_ratio), "<= ‖F‖₂ / σ_min(M)",
      st.Td_ratio <= 1.0 + 1e-9);
  row(name, "float32 Ub (Td_b ld) vs double", fmt("%.2e (κ %.3g)", st.float_error, st.kappa),
      fmt("<= (n + kb + 2) u κ = %.1e", st.float_bound), st.float_error <= st.float_bound);
  if (st.exact_shapes > 0)
    row(name, "Ub Td_b Ld vs F Ld, rank kept", fmt("%.2e (%d shapes)", st.exact_residual, st.exact_shapes),
        fmt("<= %.1e", st.exact_tol), st.exact_residual <= st.exact_tol);
  if (st.exact_shapes < kDictionaryShapeCount)
    report(name, "Ub Td_b Ld vs F Ld, truncated", fmt("%.3g rel", st.truncated_residual));
}

struct PriorCase {
  const char* name;
  std::vector<glm::dvec3> lights;
  double radius = 0.05;
  int kd = 16, kb = 8;
  int enrichment = 1;
};

std::vector<glm::dvec3> lattice(int grid) { return prior_light_positions(kAllFaces, grid); }

std::vector<PriorCase> prior_cases() {
  std::vector<PriorCase> cases;
  {  // every one of 8 lattice lights four times: m = 32, rank 8 < kd
    PriorCase c{"duplicate lights", {}};
    for (int copy = 0; copy < 4; ++copy)
      for (const glm::dvec3& p : lattice(2)) c.lights.push_back(p);
    cases.push_back(c);
  }
  {  // 8 lights and copies moved by 1e-7: rank 16 in exact arithmetic, 8 pairs 1e-7 apart
    PriorCase c{"nearly duplicate lights (1e-7 apart)", {}};
    for (const glm::dvec3& p : lattice(2)) {
      c.lights.push_back(p);
      c.lights.push_back(p + glm::dvec3(1e-7, 0, 0));
    }
    cases.push_back(c);
  }
  {  // 24 lights on one line across the block
    PriorCase c{"colinear lights", {}};
    for (int i = 0; i < 24; ++i) c.lights.push_back({0.05 + 0.9 * i / 23.0, 0.5, 0.5});
    cases.push_back(c);
  }
  {  // centres on the floor, on a wall, in an edge and a corner, and 1e-9 inside them
    PriorCase c{"lights on walls", {}};
    for (double eps : {0.0, 1e-9})
      for (const glm::dvec3& p :
           {glm::dvec3(0.5, 0.0, 0.5), glm::dvec3(0.0, 0.5, 0.5), glm::dvec3(0.3, 0.0, 0.0),
            glm::dvec3(0.0, 0.0, 0.0), glm::dvec3(1.0, 1.0, 0.7), glm::dvec3(0.25, 0.75, 1.0)})
        c.lights.push_back(glm::clamp(p, glm::dvec3(eps), glm::dvec3(1.0 - eps)));
    cases.push_back(c);
  }
  cases.push_back({"single light, no enrichment", {glm::dvec3(0.5)}, 0.05, 16, 8, 0});
  cases.push_back({"single light, enriched", {glm::dvec3(0.5)}, 0.05, 16, 8, 1});
  cases.push_back({"point lights (radius 0) on walls",
                   {glm::dvec3(0.5, 0.0, 0.5), glm::dvec3(0.0, 0.5, 0.5)},
                   0.0,
                   16,
                   8,
                   1});
  {  // as above with every mode kept: M has singular values ~1e-7 sigma_0, all inverted
    PriorCase c{"nearly duplicate lights, kb = kd = 16", {}, 0.05, 16, 16, 0};
    for (const glm::dvec3& p : lattice(2)) {
      c.lights.push_back(p);
      c.lights.push_back(p + glm::dvec3(1e-7, 0, 0));
    }
    cases.push_back(c);
  }
  cases.push_back({"kb 1", lattice(2), 0.05, 16, 1, 1});
  cases.push_back({"kb = kd = rank", lattice(2), 0.05, 8, 8, 0});
  return cases;
}

// Each prior through bake_shape_with_prior on the closed box and the corridor (missing faces:
// rays that leave change F's row sums).
TEST(StressBake, NearSingularPriorsGiveBoundedOperators) {
  for (const PriorCase& c : prior_cases()) {
    DictionarySettings s = tiny_settings();
    s.kd = std::uint32_t(c.kd);
    s.kb = std::uint32_t(c.kb);
    s.enrichment_iterations = std::uint32_t(c.enrichment);
    CaseStats st;
    for (int shape = 0; shape < kDictionaryShapeCount; ++shape) {
      const FaceMask mask = dictionary_shape_mask(shape);
      const MatrixXd Ld = prior_from_lights(mask, int(s.res), c.lights, c.radius);
      const ShapeBake bake = bake_shape_with_prior(mask, s, Ld, /*with_sh=*/true);
      check_shape_bake(std::string(c.name) + " (" + dictionary_shape_name(shape) + ")", bake, s, st);
    }
    report_case(c.name, s, st);
  }
}

// bake_shape_with_prior refuses an Ld of the wrong shape or with NaN, naming the problem.
TEST(StressBake, BadPriorMatrixIsRefused) {
  const DictionarySettings s = tiny_settings();
  MatrixXd Ld = MatrixXd::Ones(6 * 9, 3);
  Ld(4, 1) = std::nan("");
  EXPECT_THROW(bake_shape_with_prior(kAllFaces, s, Ld, false), std::invalid_argument);
  EXPECT_THROW(bake_shape_with_prior(kAllFaces, s, MatrixXd::Ones(7, 3), false), std::invalid_argument);
  const bool refused = true;
  EXPECT_TRUE(row("prior Ld with NaN / wrong rows", "bake_shape_with_prior", "invalid_argument thrown",
                  "refused", refused));
}

// Whole dictionaries at the extremes of the settings, each checked shape by shape as above,
// then a level built from it (maze11) and evaluated by the SIMD CPU runtime: finite, and
// equal to core's scalar reference within 1e-5 relative L2 (the backends' conformance bound).
struct DictionaryCase {
  const char* name;
  DictionarySettings settings;
};

std::vector<DictionaryCase> dictionary_cases() {
  std::vector<DictionaryCase> cases;
  DictionarySettings s = with_tiny_interfaces(tiny_settings());
  {
    DictionarySettings r1 = s;
    r1.res = 1;  // one texel per face: n = 6 on the closed box, kd 16 > n
    r1.kb = 4;
    r1.probe_grid = 1;
    cases.push_back({"res 1", r1});
  }
  {
    DictionarySettings one = s;
    one.prior_grid = 1;  // one light per cell: the closed box's prior has rank 1
    one.kd = 16;
    one.kb = 8;
    cases.push_back({"prior_grid 1 (kd > rank)", one});
  }
  {
    DictionarySettings k1 = s;
    k1.kb = 1;
    k1.kr = 1;
    cases.push_back({"kb 1, kr 1", k1});
  }
  {
    DictionarySettings kr = s;
    kr.kd = 8;  // the closed box's 2^3 lattice has rank 8: kb = kd = rank
    kr.kb = 8;
    kr.enrichment_iterations = 0;
    cases.push_back({"kb = kd = rank 8", kr});
  }
  return cases;
}

double rel_l2(std::span<const float> a, std::span<const float> b) {
  double num = 0, den = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    num += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
    den += double(b[i]) * b[i];
  }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

TEST(StressBake, ExtremeDictionarySettingsBakeBuildAndRun) {
  const LevelDescription maze = maze_level(11).value();
  for (const DictionaryCase& c : dictionary_cases()) {
    CaseStats st;
    for (int shape = 0; shape < kDictionaryShapeCount; ++shape)
      check_shape_bake(std::string(c.name) + " (" + dictionary_shape_name(shape) + ")",
                       bake_shape(dictionary_shape_mask(shape), c.settings, true), c.settings, st);
    report_case(c.name, c.settings, st);
    Result<Dictionary> baked = bake_dictionary(c.settings);
    ASSERT_TRUE(baked.ok()) << c.name << ": " << baked.status().to_string();
    const Dictionary& dict = baked.value();
    Result<Level> built = build_level(maze, dict);
    ASSERT_TRUE(built.ok()) << c.name << ": " << built.status().to_string();
    const Level& level = built.value();
    const LevelScene scene(level, level.res);
    const std::vector<float> albedo = level_sample_albedo(level);
    const std::vector<float> ld = level_direct_light(scene, maze.lights, albedo, 1);
    Result<cpu::CpuLevelRuntime> rt = cpu::CpuLevelRuntime::create(level, dict);
    ASSERT_TRUE(rt.ok()) << rt.status().to_string();
    std::vector<float> lightmap(rt->sizes().lightmap);
    ASSERT_TRUE(rt->evaluate(ld, lightmap).ok());
    const LevelBufferSizes sz = level_buffer_sizes(level, dict);
    std::vector<float> b(sz.b), r(sz.r), ref(sz.lightmap);
    ASSERT_TRUE(level_evaluate(level, dict, ld, b, r, ref).ok());
    const bool ok = std::all_of(lightmap.begin(), lightmap.end(), [](float v) { return std::isfinite(v); });
    const double e = rel_l2(lightmap, ref);
    EXPECT_TRUE(row(std::string(c.name) + " dictionary, maze11", "CPU lightmap vs core reference",
                    fmt("%.2e%s", e, ok ? "" : " NON-FINITE"), "<= 1e-5, finite", ok && e <= 1e-5))
        << c.name;
  }
}

// res 64 does not fit the default 8 GiB bake budget (F alone is 24 576^2 doubles): refused up
// front with the estimate, before anything is allocated (test_stress.cpp checks the message).
TEST(StressBake, Res64IsRefusedByTheMemoryBudget) {
  DictionarySettings s = tiny_settings();
  s.res = 64;
  const Result<Dictionary> d = bake_dictionary(s);
  const bool refused = !d.ok() && d.status().code() == ErrorCode::resource_limit;
  EXPECT_TRUE(row("res 64 (no interfaces)", "bake_dictionary",
                  fmt("refused, estimate %.1f GiB", double(estimate_bake_bytes(s)) / double(1u << 30)),
                  "resource_limit (budget 8 GiB)", refused));
}

}  // namespace
}  // namespace modrt::precompute
