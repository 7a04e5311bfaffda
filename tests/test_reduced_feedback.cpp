// SPDX-License-Identifier: MIT
// The reduced-space converged multi-bounce (core's reduced_feedback.h, issue 20) against
// brute-force references: one application of M against the n-space bounce it replaces, the
// spectral radius estimate against the eigenvalues of the dense operator, the converged solve
// against the n-space feedback iterated to convergence, and the convergence guarantee at
// albedos near 1.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "compare_support.h"
#include "level_fixtures.h"
#include "modrt/reduced_feedback.h"

namespace modrt {
namespace {

using test::test_level;
using test::TestLevel;

const Dictionary& dict() { return test::small_test_dictionary(); }

// The unclamped lightmap Ub b + Ur r in double, written out from the level's matrices (the
// fed-back light of one n-space bounce without the clamp).
std::vector<double> unclamped_lightmap(const Level& level, const std::vector<float>& b,
                                       const std::vector<float>& r) {
  std::vector<double> L(3 * std::size_t(level.sample_count), 0.0);
  const LevelDependencies deps = level_dependencies(level);
  const Matrix& Ur = dict().interfaces.Ur;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    const Matrix& Ub = dict().shapes[std::size_t(blk.shape)].Ub;
    double* dst = L.data() + 3 * std::size_t(blk.sample_offset);
    for (std::uint32_t s = 0; s < Ub.rows; ++s)
      for (std::uint32_t k = 0; k < Ub.cols; ++k)
        for (int c = 0; c < 3; ++c) dst[3 * s + c] += double(Ub(s, k)) * b[3 * (level.kb * i + k) + c];
    for (std::uint32_t sl : deps.slots_of_block(i))
      for (std::uint32_t row = 0; row < Ur.rows; ++row) {
        const std::int32_t sample = level.slots[sl].ur_row_to_sample[row];
        if (sample < 0) continue;
        for (std::uint32_t k = 0; k < Ur.cols; ++k)
          for (int c = 0; c < 3; ++c)
            dst[3 * std::size_t(sample) + c] += double(Ur(row, k)) * r[3 * (level.kr * sl + k) + c];
      }
  }
  return L;
}

std::vector<float> uniform_albedo(const Level& level, float a) {
  return std::vector<float>(3 * std::size_t(level.sample_count), a);
}

// One application of M is one n-space bounce without its clamp: s M b = Td_b (rho (Ub b + Ur r)).
TEST(ReducedFeedback, OneApplicationIsOneUnclampedBounce) {
  for (const char* name : {"corridor", "maze11"}) {
    const TestLevel& t = test_level(name);
    const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
    std::vector<float> b(sz.b), r(sz.r), lightmap(sz.lightmap);
    ASSERT_TRUE(level_evaluate(t.level, dict(), t.ld, b, r, lightmap).ok());
    const LevelDependencies deps = level_dependencies(t.level);
    Result<ReducedFeedback> op = build_reduced_feedback(t.level, dict(), deps, t.albedo);
    ASSERT_TRUE(op.ok()) << op.status().to_string();
    ASSERT_EQ(op->damping, 1.0f) << name;
    std::vector<float> Mb(sz.b), r_scratch(sz.r);
    reference_apply_reduced_feedback(t.level, deps, op.value(), b, r_scratch, Mb);
    // Brute force: the fed-back ld, then Td_b of it per block.
    const std::vector<double> L = unclamped_lightmap(t.level, b, r);
    std::vector<float> expected(sz.b, 0.0f);
    for (std::size_t i = 0; i < t.level.blocks.size(); ++i) {
      const LevelBlock& blk = t.level.blocks[i];
      const Matrix& Td = dict().shapes[std::size_t(blk.shape)].Td_b;
      for (std::uint32_t k = 0; k < Td.rows; ++k)
        for (int c = 0; c < 3; ++c) {
          double acc = 0.0;
          for (std::uint32_t s = 0; s < Td.cols; ++s) {
            const std::size_t g = 3 * (std::size_t(blk.sample_offset) + s) + std::size_t(c);
            acc += double(Td(k, s)) * double(t.albedo[g]) * L[g];
          }
          expected[3 * (t.level.kb * i + k) + std::size_t(c)] = float(acc);
        }
    }
    EXPECT_LE(test::rel_l2(Mb, expected), 1e-5) << name;
  }
}

// The estimate against the dense operator's eigenvalues: the 11-block maze's M for one channel
// written out column by column (M e_j), its largest |eigenvalue| by Eigen.
TEST(ReducedFeedback, SpectralRadiusMatchesTheDenseOperator) {
  const TestLevel& t = test_level("maze11");
  const LevelDependencies deps = level_dependencies(t.level);
  for (const float a : {0.5f, 0.9f}) {
    std::vector<float> rho = uniform_albedo(t.level, a);
    for (std::size_t i = 0; i < rho.size(); i += 3) rho[i + 1] *= 0.5f;  // channels differ
    Result<ReducedFeedback> op = build_reduced_feedback(t.level, dict(), deps, rho);
    ASSERT_TRUE(op.ok());
    const std::size_t n = 3 * std::size_t(t.level.kb) * t.level.blocks.size(), m = n / 3;
    std::vector<float> e(n), col(n), r(3 * std::size_t(t.level.kr) * t.level.slots.size());
    double largest = 0.0;
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixXd M(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m));
      for (std::size_t j = 0; j < m; ++j) {
        std::fill(e.begin(), e.end(), 0.0f);
        e[3 * j + std::size_t(c)] = 1.0f;
        reference_apply_reduced_feedback(t.level, deps, op.value(), e, r, col);
        for (std::size_t i = 0; i < m; ++i) M(Eigen::Index(i), Eigen::Index(j)) = col[3 * i + std::size_t(c)];
      }
      const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(M, false).eigenvalues();
      double q = 0.0;
      for (Eigen::Index i = 0; i < ev.size(); ++i) q = std::max(q, std::abs(ev(i)));
      largest = std::max(largest, q);
    }
    std::printf("albedo %.1f: spectral radius estimate %.4f, dense %.4f\n", a, op->spectral_radius, largest);
    EXPECT_NEAR(op->spectral_radius, largest, 0.02 * largest) << a;
    EXPECT_LT(largest, 1.0) << a;
  }
}

struct Solved {
  std::vector<float> b, r, lightmap;
  ConvergedBounceReport report;
};

Solved converged(const Level& level, std::span<const float> ld, std::span<const float> albedo,
                 const ConvergedBounceSettings& settings = {}) {
  const LevelBufferSizes sz = level_buffer_sizes(level, dict());
  Solved s{std::vector<float>(sz.b), std::vector<float>(sz.r), std::vector<float>(sz.lightmap), {}};
  Result<ConvergedBounceReport> rep =
      level_converged_bounce(level, dict(), ld, albedo, settings, s.b, s.r, s.lightmap);
  EXPECT_TRUE(rep.ok()) << rep.status().to_string();
  if (rep.ok()) s.report = rep.value();
  return s;
}

// The converged solve against n-space feedback iterated to convergence (tolerance 1e-7): they
// differ only where n-space clamped a negative fed-back texel to 0 (none reached the bound here).
// The difference is measured, with the share of clamped texels, and bounded.
TEST(ReducedFeedback, ConvergedSolveMatchesNSpaceFeedback) {
  for (const char* name : {"single", "corridor", "maze11", "maze41"}) {
    const TestLevel& t = test_level(name);
    const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
    std::vector<float> b(sz.b), r(sz.r), nspace(sz.lightmap);
    MultiBounceSettings ms;
    ms.tolerance = 1e-7f;
    ms.max_iterations = 1000;
    Result<MultiBounceReport> mb = level_multi_bounce(t.level, dict(), t.ld, t.albedo, ms, b, r, nspace);
    ASSERT_TRUE(mb.ok());
    ASSERT_TRUE(mb->converged);
    EXPECT_FALSE(mb->value_clamped);
    ConvergedBounceSettings cs;
    cs.solve.tolerance = 1e-5f;
    const Solved s = converged(t.level, t.ld, t.albedo, cs);
    ASSERT_TRUE(s.report.solve.converged) << name;
    // The texels n-space clamped at 0 in its last bounce: the unclamped lightmap of its b.
    const std::vector<double> L = unclamped_lightmap(t.level, b, r);
    std::size_t negative = 0;
    double negative_mass = 0.0, mass = 0.0;
    for (double v : L) {
      negative += v < 0.0;
      negative_mass += std::max(-v, 0.0), mass += std::fabs(v);
    }
    const double diff = test::rel_l2(s.lightmap, nspace);
    std::printf(
        "%-8s q %.3f, %3d iterations (n-space %3d): rel L2 %.2e; n-space clamped %zu of %zu texels "
        "(%.2e of the light)\n",
        name, s.report.spectral_radius, s.report.solve.iterations, mb->iterations, diff, negative, L.size(),
        negative_mass / mass);
    // Zero where no clamp acts (the solve's tolerance); else of the order of the clamped light.
    EXPECT_LE(diff, 1e-4 + 4.0 * negative_mass / mass) << name;
    for (float v : s.lightmap) ASSERT_GE(v, 0.0f);
  }
}

// A warm start from the last solution takes fewer applications of M to the same answer.
TEST(ReducedFeedback, WarmStartReachesTheSameAnswerFaster) {
  const TestLevel& t = test_level("maze41");
  const LevelDependencies deps = level_dependencies(t.level);
  Result<ReducedFeedback> op = build_reduced_feedback(t.level, dict(), deps, t.albedo);
  ASSERT_TRUE(op.ok());
  const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
  std::vector<float> b0(sz.b), x(sz.b), r(sz.r), lightmap(sz.lightmap);
  ReducedSolver solver = ReducedSolver::create(sz.b);
  const auto apply = [&](std::span<const float> in, std::span<float> out) {
    reference_apply_reduced_feedback(t.level, deps, op.value(), in, r, out);
  };
  ASSERT_TRUE(level_compute_b(t.level, dict(), t.ld, b0).ok());
  x = b0;
  const ReducedSolveReport cold = solver.solve(apply, b0, x, op->contraction(), {});
  // The light dims by 2 %: the next frame starts from this one's b*.
  std::vector<float> ld = t.ld;
  for (float& v : ld) v *= 0.98f;
  std::vector<float> b0_next(sz.b), x_cold(sz.b);
  ASSERT_TRUE(level_compute_b(t.level, dict(), ld, b0_next).ok());
  const ReducedSolveReport warm = solver.solve(apply, b0_next, x, op->contraction(), {});
  x_cold = b0_next;
  const ReducedSolveReport again = solver.solve(apply, b0_next, x_cold, op->contraction(), {});
  std::printf("q %.3f: cold %d iterations, warm %d (cold again %d); residual %.1e\n", op->contraction(),
              cold.iterations, warm.iterations, again.iterations, warm.residual);
  EXPECT_TRUE(cold.converged && warm.converged && again.converged);
  EXPECT_LT(warm.iterations, again.iterations);
  EXPECT_LE(test::rel_l2(x, x_cold), 3e-3);
}

// Albedo near 1 (max_albedo 0.999): everywhere, and one white block among dark ones. The
// estimate is damped to kReducedMaxSpectralRadius where it passes it; the solve converges and
// every lightmap is finite, non-negative and within the energy bound ld_max / (1 - q).
TEST(ReducedFeedback, ConvergesAtAlbedoNearOne) {
  for (const char* name : {"single", "maze41"}) {
    const TestLevel& t = test_level(name);
    for (const bool one_white : {false, true}) {
      std::vector<float> albedo = uniform_albedo(t.level, one_white ? 0.1f : 0.999f);
      if (one_white) {
        const LevelBlock& blk = t.level.blocks[0];
        std::fill(albedo.begin() + 3 * std::ptrdiff_t(blk.sample_offset),
                  albedo.begin() + 3 * std::ptrdiff_t(blk.sample_offset + blk.sample_count), 0.999f);
      }
      ConvergedBounceSettings cs;
      cs.max_albedo = 0.999f;
      cs.solve.max_iterations = 4000;
      const Solved s = converged(t.level, t.ld, albedo, cs);
      const double q = s.report.spectral_radius * s.report.damping;
      std::printf("%-7s %s: spectral radius %.4f, damping %.4f, %d iterations, error bound %.1e\n", name,
                  one_white ? "one white block" : "albedo 0.999   ", s.report.spectral_radius,
                  s.report.damping, s.report.solve.iterations, s.report.solve.error_bound);
      EXPECT_LE(q, kReducedMaxSpectralRadius * (1 + 1e-6));
      if (s.report.spectral_radius > kReducedMaxSpectralRadius) {
        EXPECT_NEAR(s.report.damping, kReducedMaxSpectralRadius / s.report.spectral_radius, 1e-6);
      }
      EXPECT_TRUE(s.report.solve.converged);
      const float ld_max = *std::max_element(t.ld.begin(), t.ld.end());
      // Twice the n-space bound at the contraction used: a diverging solve passes it by far.
      const float bound = 2.0f * feedback_energy_bound(ld_max, float(q));
      for (float v : s.lightmap) {
        ASSERT_TRUE(std::isfinite(v));
        ASSERT_GE(v, 0.0f);
        ASSERT_LE(v, bound);
      }
    }
  }
}

TEST(ReducedFeedback, BadInputIsNamed) {
  const TestLevel& t = test_level("corridor");
  const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
  std::vector<float> b(sz.b), r(sz.r), lightmap(sz.lightmap), albedo = t.albedo, ld = t.ld;
  albedo[7] = std::nanf("");
  Result<ConvergedBounceReport> rep = level_converged_bounce(t.level, dict(), ld, albedo, {}, b, r, lightmap);
  ASSERT_FALSE(rep.ok());
  EXPECT_NE(rep.status().message().find("albedo"), std::string::npos) << rep.status().message();
  ld[5] = -1.0f;
  rep = level_converged_bounce(t.level, dict(), ld, t.albedo, {}, b, r, lightmap);
  ASSERT_FALSE(rep.ok());
  EXPECT_NE(rep.status().message().find("ld"), std::string::npos) << rep.status().message();
  ConvergedBounceSettings bad;
  bad.max_albedo = 1.0f;
  EXPECT_FALSE(level_converged_bounce(t.level, dict(), t.ld, t.albedo, bad, b, r, lightmap).ok());
}

}  // namespace
}  // namespace modrt
