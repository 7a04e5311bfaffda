// SPDX-License-Identifier: MIT
// The reduced-space converged multi-bounce (core's reduced_feedback.h, issue 20) against
// brute-force references: one application of M against the n-space bounce it replaces, the
// spectral radius estimate against the eigenvalues of the dense operator, the converged solve
// against the n-space feedback iterated to convergence (with DRT clutter too), and the
// convergence guarantee at albedos near 1.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "compare_support.h"
#include "drt_backend_fixture.h"
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
    const Matrix& Ub = block_operators(dict(), level, blk).Ub;
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

// M b by brute force: r = Tb->r b, the unclamped lightmap, the fed-back ld rho L, Td_b of it.
std::vector<float> brute_force_bounce(const Level& level, std::span<const float> rho,
                                      const std::vector<float>& b) {
  std::vector<float> r(3 * std::size_t(level.kr) * level.slots.size());
  level_compute_r(level, b, r);
  const std::vector<double> L = unclamped_lightmap(level, b, r);
  std::vector<float> out(b.size(), 0.0f);
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const LevelBlock& blk = level.blocks[i];
    const Matrix& Td = block_operators(dict(), level, blk).Td_b;
    for (std::uint32_t k = 0; k < Td.rows; ++k)
      for (int c = 0; c < 3; ++c) {
        double acc = 0.0;
        for (std::uint32_t s = 0; s < Td.cols; ++s) {
          const std::size_t g = 3 * (std::size_t(blk.sample_offset) + s) + std::size_t(c);
          acc += double(Td(k, s)) * double(rho[g]) * L[g];
        }
        out[3 * (level.kb * i + k) + std::size_t(c)] = float(acc);
      }
  }
  return out;
}

// The solve's b* is a fixed point of the n-space bounce without its clamp: b* = b0 + M b*, M by
// brute force (the block-Jacobi operators P, B, G are checked through what they solve). The
// level's albedo is constant per face (the build's per-face products); the varied one differs
// per sample (the general products).
TEST(ReducedFeedback, SolutionIsAFixedPointOfTheUnclampedBounce) {
  for (const char* name : {"corridor", "maze11", "maze11 varied"}) {
    const bool varied = std::string(name).find("varied") != std::string::npos;
    const TestLevel& t = test_level(varied ? "maze11" : name);
    std::vector<float> albedo = t.albedo;
    if (varied)
      for (std::size_t i = 0; i < albedo.size(); ++i)
        albedo[i] *= 0.6f + 0.4f * float((i * 7919) % 101) / 100.0f;
    const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
    std::vector<float> b(sz.b), r(sz.r), lightmap(sz.lightmap), b0(sz.b);
    ConvergedBounceSettings cs;
    cs.solve.tolerance = 1e-6f;
    Result<ConvergedBounceReport> rep =
        level_converged_bounce(t.level, dict(), t.ld, albedo, cs, b, r, lightmap);
    ASSERT_TRUE(rep.ok()) << rep.status().to_string();
    ASSERT_TRUE(rep->solve.converged);
    EXPECT_EQ(rep->damping, 1.0f) << name;
    EXPECT_TRUE(rep->block_jacobi) << name;
    ASSERT_TRUE(level_compute_b(t.level, dict(), t.ld, b0).ok());
    std::vector<float> rhs = brute_force_bounce(t.level, albedo, b);
    for (std::size_t i = 0; i < rhs.size(); ++i) rhs[i] += b0[i];
    const double e = test::rel_l2(b, rhs);
    std::printf("%-13s block Jacobi contraction %.3f (M %.3f), %d iterations: |b0 + M b* - b*| / |b*| %.2e\n",
                name, rep->contraction, rep->spectral_radius, rep->solve.iterations, e);
    EXPECT_LE(e, 1e-5) << name;
  }
}

// The estimates against dense eigenvalues on the 11-block maze, one channel at a time: M written
// out column by column by brute force (M e_j), G by the operator the solve applies.
TEST(ReducedFeedback, SpectralRadiiMatchTheDenseOperators) {
  const TestLevel& t = test_level("maze11");
  const LevelDependencies deps = level_dependencies(t.level);
  for (const float a : {0.5f, 0.9f}) {
    std::vector<float> rho = uniform_albedo(t.level, a);
    for (std::size_t i = 0; i < rho.size(); i += 3) rho[i + 1] *= 0.5f;  // channels differ
    Result<ReducedFeedback> op = build_reduced_feedback(t.level, dict(), deps, rho);
    ASSERT_TRUE(op.ok());
    ASSERT_TRUE(op->block_jacobi);
    const std::size_t n = 3 * std::size_t(t.level.kb) * t.level.blocks.size(), m = n / 3;
    std::vector<float> e(n), col(n), r(3 * std::size_t(t.level.kr) * t.level.slots.size());
    double largest_m = 0.0, largest_g = 0.0;
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixXd M(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m)), G = M;
      for (std::size_t j = 0; j < m; ++j) {
        std::fill(e.begin(), e.end(), 0.0f);
        e[3 * j + std::size_t(c)] = 1.0f;
        const std::vector<float> mcol = brute_force_bounce(t.level, rho, e);
        reference_apply_reduced_feedback(t.level, deps, op.value(), e, r, col);
        for (std::size_t i = 0; i < m; ++i) {
          M(Eigen::Index(i), Eigen::Index(j)) = mcol[3 * i + std::size_t(c)];
          G(Eigen::Index(i), Eigen::Index(j)) = col[3 * i + std::size_t(c)];
        }
      }
      const auto radius = [](const Eigen::MatrixXd& X) {
        const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(X, false).eigenvalues();
        double q = 0.0;
        for (Eigen::Index i = 0; i < ev.size(); ++i) q = std::max(q, std::abs(ev(i)));
        return q;
      };
      largest_m = std::max(largest_m, radius(M));
      largest_g = std::max(largest_g, radius(G));
    }
    std::printf("albedo %.1f: M %.4f (dense %.4f), block Jacobi G %.4f (dense %.4f)\n", a,
                op->spectral_radius, largest_m, op->contraction, largest_g);
    EXPECT_NEAR(op->spectral_radius, largest_m, 0.02 * largest_m) << a;
    EXPECT_NEAR(op->contraction, largest_g, 0.02 * largest_m) << a;
    EXPECT_LT(largest_m, 1.0) << a;
    EXPECT_LT(largest_g, largest_m) << a;
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

// With clutter the converged solve (b and c, drt_converged_bounce) is drt_multi_bounce's fixed
// point: the lightmap and c of n-space feedback iterated to convergence, the clutter's light fed
// back (clutter albedo 0.5, and 0.95: the near-white clutter) or not; every lightmap
// texel non-negative. Leaving out the clutter terms of the application fails it (the shadow
// and the clutter's own light would bounce only once).
TEST(ReducedFeedback, ConvergedSolveWithClutterMatchesDrtMultiBounce) {
  const test::DrtFixture& f = test::drt_fixture();
  const LevelBufferSizes sz = level_buffer_sizes(f.level, dict());
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  for (float clutter_rho : {0.0f, 0.5f, 0.95f}) {
    const std::vector<float> clutter_albedo =
        clutter_rho > 0.0f ? std::vector<float>(d.clutter_ld, clutter_rho) : std::vector<float>{};
    std::vector<float> b(sz.b), r(sz.r), nspace(sz.lightmap), c_nspace(d.c);
    MultiBounceSettings ms;
    ms.tolerance = 1e-7f;
    ms.max_iterations = 2000;
    Result<MultiBounceReport> mb = drt_multi_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld,
                                                    clutter_albedo, ms, b, r, nspace, c_nspace);
    ASSERT_TRUE(mb.ok()) << mb.status().to_string();
    ASSERT_TRUE(mb->converged);
    std::vector<float> b1(sz.b), r1(sz.r), one(sz.lightmap), c1(d.c);
    ms.max_iterations = 1;  // two bounces, for the size of what the later bounces carry
    ASSERT_TRUE(drt_multi_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld, clutter_albedo, ms, b1,
                                 r1, one, c1)
                    .ok());
    ConvergedBounceSettings cs;
    cs.solve.tolerance = 1e-6f;
    std::vector<float> bc(sz.b), rc(sz.r), lightmap(sz.lightmap), c(d.c);
    Result<ConvergedBounceReport> rep = drt_converged_bounce(
        f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld, clutter_albedo, cs, bc, rc, lightmap, c);
    ASSERT_TRUE(rep.ok()) << rep.status().to_string();
    ASSERT_TRUE(rep->solve.converged);
    const double e = test::rel_l2(lightmap, nspace), ec = test::rel_l2(c, c_nspace),
                 bounces = test::rel_l2(one, nspace);
    std::printf(
        "clutter albedo %.2f: q %.3f (%s), %d iterations (n-space %d, clamped %s): lightmap rel L2 %.2e, "
        "c %.2e; two bounces differ by %.2e\n",
        double(clutter_rho), rep->spectral_radius, rep->block_jacobi ? "block Jacobi" : "plain",
        rep->solve.iterations, mb->iterations, mb->value_clamped ? "yes" : "no", e, ec, bounces);
    EXPECT_LT(rep->spectral_radius, 1.0);
    EXPECT_LE(e, 1e-4) << clutter_rho;
    EXPECT_LE(ec, 1e-4) << clutter_rho;
    EXPECT_GT(bounces, 100 * e) << "the bounces after the second are large enough to test";
    for (float v : lightmap) ASSERT_GE(v, 0.0f);
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
  ReducedSolveSettings tight;
  tight.tolerance = 1e-5f;
  ASSERT_TRUE(level_compute_b(t.level, dict(), t.ld, b0).ok());
  x = b0;
  reference_reduced_rhs(t.level, op.value(), b0, solver.rhs());
  const ReducedSolveReport cold = solver.solve(apply, x, op->contraction, tight);
  // The light dims by 2 %: the next frame starts from this one's b*.
  std::vector<float> ld = t.ld;
  for (float& v : ld) v *= 0.98f;
  std::vector<float> b0_next(sz.b), x_cold(sz.b);
  ASSERT_TRUE(level_compute_b(t.level, dict(), ld, b0_next).ok());
  reference_reduced_rhs(t.level, op.value(), b0_next, solver.rhs());
  std::vector<float> x_plain = x;  // the same warm start without the extrapolation
  const ReducedSolveReport warm = solver.solve(apply, x, op->contraction, tight, true);
  const ReducedSolveReport plain = solver.solve(apply, x_plain, op->contraction, tight);
  x_cold = b0_next;
  const ReducedSolveReport again = solver.solve(apply, x_cold, op->contraction, tight);
  std::printf(
      "q %.3f: cold %d iterations, warm %d (without the extrapolation %d, cold again %d); residual %.1e\n",
      op->contraction, cold.iterations, warm.iterations, plain.iterations, again.iterations, warm.residual);
  EXPECT_TRUE(cold.converged && warm.converged && plain.converged && again.converged);
  EXPECT_LT(plain.iterations, again.iterations);
  EXPECT_LE(warm.iterations, plain.iterations);
  EXPECT_LE(test::rel_l2(x_plain, x_cold), 3e-5);
  EXPECT_LE(test::rel_l2(x, x_cold), 3e-5);
}

// Over a moving light (each frame a different block brightens, the rest dims a little) the
// history's prediction (ReducedSolveSettings::history 4) needs no more applications in all than
// the last solution moved by the change of rhs (history 0), and both reach the cold solve's
// answer within the tolerance every frame.
TEST(ReducedFeedback, HistoryPredictionHelpsAMovingLight) {
  const TestLevel& t = test_level("maze41");
  const LevelDependencies deps = level_dependencies(t.level);
  Result<ReducedFeedback> op = build_reduced_feedback(t.level, dict(), deps, t.albedo);
  ASSERT_TRUE(op.ok());
  const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
  std::vector<float> r(sz.r), b0(sz.b);
  const auto apply = [&](std::span<const float> in, std::span<float> out) {
    reference_apply_reduced_feedback(t.level, deps, op.value(), in, r, out);
  };
  ReducedSolveSettings settings;
  settings.tolerance = 1e-5f;
  int total[2] = {0, 0};
  for (int h = 0; h < 2; ++h) {
    settings.history = h == 0 ? 0 : 4;
    ReducedSolver solver = ReducedSolver::create(sz.b, 4), cold_solver = ReducedSolver::create(sz.b);
    std::vector<float> x(sz.b), x_cold(sz.b);
    for (int frame = 0; frame < 12; ++frame) {
      std::vector<float> ld = t.ld;
      const LevelBlock& blk = t.level.blocks[std::size_t(frame * 5) % t.level.blocks.size()];
      for (float& v : ld) v *= 1.0f - 0.01f * float(frame % 4);
      for (std::size_t i = 0; i < 3 * std::size_t(blk.sample_count); ++i)
        ld[3 * blk.sample_offset + i] *= 3.0f;
      ASSERT_TRUE(level_compute_b(t.level, dict(), ld, b0).ok());
      reference_reduced_rhs(t.level, op.value(), b0, solver.rhs());
      if (frame == 0) x = b0;
      const ReducedSolveReport rep = solver.solve(apply, x, op->contraction, settings, frame > 0);
      if (frame > 0) total[h] += rep.iterations;
      reference_reduced_rhs(t.level, op.value(), b0, cold_solver.rhs());
      x_cold = b0;
      ASSERT_TRUE(cold_solver.solve(apply, x_cold, op->contraction, settings).converged);
      ASSERT_TRUE(rep.converged);
      EXPECT_LE(test::rel_l2(x, x_cold), 3e-5) << "history " << settings.history << " frame " << frame;
    }
  }
  std::printf("moving light, 11 warm frames: %d applications from the last solution, %d with the history\n",
              total[0], total[1]);
  EXPECT_LE(total[1], total[0]);
}

// The incremental application over two disjoint sets of blocks, the second added to the first,
// is the full application: y = G x and r = Tb->r x (both iterations: block Jacobi and plain).
TEST(ReducedFeedback, DeltaApplicationsAddUpToTheFullOne) {
  const TestLevel& t = test_level("maze41");
  const LevelDependencies deps = level_dependencies(t.level);
  const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
  Result<ReducedFeedback> jacobi = build_reduced_feedback(t.level, dict(), deps, t.albedo);
  ASSERT_TRUE(jacobi.ok());
  ASSERT_TRUE(jacobi->A.empty());
  // The plain iteration's form (A per block): any A serves for the sum, so a fixed pattern.
  ReducedFeedback plain = jacobi.value();
  plain.block_jacobi = false;
  plain.A.assign(t.level.blocks.size(), ChannelMatrix{t.level.kb, t.level.kb, {}});
  for (std::size_t i = 0; i < plain.A.size(); ++i) {
    plain.A[i].data.resize(3 * std::size_t(t.level.kb) * t.level.kb);
    for (std::size_t k = 0; k < plain.A[i].data.size(); ++k)
      plain.A[i].data[k] = 0.01f * float((k * 7 + i * 3) % 11) - 0.04f;
  }
  std::vector<float> b0(sz.b);
  ASSERT_TRUE(level_compute_b(t.level, dict(), t.ld, b0).ok());
  std::vector<std::uint8_t> even(t.level.blocks.size()), odd(t.level.blocks.size());
  for (std::size_t i = 0; i < even.size(); ++i) even[i] = i % 3 == 0, odd[i] = i % 3 != 0;
  std::vector<float> y_full(sz.b), r_full(sz.r), y(sz.b), r(sz.r), r_delta(sz.r);
  for (const ReducedFeedback* o : {&plain, &jacobi.value()}) {
    reference_apply_reduced_feedback(t.level, deps, *o, b0, r_full, y_full);
    std::fill(y.begin(), y.end(), 0.0f);
    std::fill(r.begin(), r.end(), 0.0f);
    reference_apply_reduced_feedback_delta(t.level, deps, *o, b0, even, y, r, r_delta);
    reference_apply_reduced_feedback_delta(t.level, deps, *o, b0, odd, y, r, r_delta);
    EXPECT_LE(test::rel_l2(y, y_full), 1e-6) << (o == &plain ? "plain" : "block Jacobi");
    EXPECT_LE(test::rel_l2(r, r_full), 1e-6);
  }
  const ReducedFeedback& op = jacobi.value();
  // A set reaching no slot leaves r and y as they were.
  std::vector<std::uint8_t> none(t.level.blocks.size(), 0);
  const std::vector<float> y_before = y, r_before = r;
  reference_apply_reduced_feedback_delta(t.level, deps, op, b0, none, y, r, r_delta);
  EXPECT_EQ(y, y_before);
  EXPECT_EQ(r, r_before);
}

// The incremental solve over a moving light (each frame a different block brightens, the rest
// dims a little): every frame within its own error bound of the tight cold solve, an unchanged
// frame applies nothing, and over the frames it applies G to fewer blocks than the full
// iteration with the history's prediction; a refresh every solve gives the same answers.
TEST(ReducedFeedback, IncrementalSolveAppliesFewerBlocksWithinTheBound) {
  const TestLevel& t = test_level("maze41");
  const LevelDependencies deps = level_dependencies(t.level);
  Result<ReducedFeedback> op = build_reduced_feedback(t.level, dict(), deps, t.albedo);
  ASSERT_TRUE(op.ok());
  const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
  const std::size_t blocks = t.level.blocks.size(), per_block = 3 * std::size_t(t.level.kb);
  std::vector<float> r(sz.r), r_delta(sz.r), b0(sz.b);
  const auto apply = [&](std::span<const float> in, std::span<float> out) {
    reference_apply_reduced_feedback(t.level, deps, op.value(), in, r, out);
  };
  const auto apply_delta = [&](std::span<const float> d, std::span<const std::uint8_t> flags,
                               std::span<float> y, std::span<float> r_acc) {
    reference_apply_reduced_feedback_delta(t.level, deps, op.value(), d, flags, y, r_acc, r_delta);
  };
  ReducedSolveSettings settings;  // the default tolerance (1e-3), as the runtimes use it
  ReducedSolveSettings tight;
  tight.tolerance = 1e-7f;
  for (int refresh : {64, 1}) {
    settings.refresh_interval = refresh;
    ReducedSolver inc = ReducedSolver::create(sz.b, 4, per_block, sz.r),
                  full = ReducedSolver::create(sz.b, 4, per_block), cold = ReducedSolver::create(sz.b);
    std::vector<float> x(sz.b), x_full(sz.b), x_cold(sz.b), r_tight(sz.r);
    std::uint64_t applied_inc = 0, applied_full = 0;
    for (int frame = 0; frame < 14; ++frame) {
      std::vector<float> ld = t.ld;
      const int k = frame >= 12 ? 11 : frame;  // frames 12 and 13 repeat frame 11
      const LevelBlock& blk = t.level.blocks[std::size_t(k * 5) % blocks];
      for (float& v : ld) v *= 1.0f - 0.01f * float(k % 4);
      for (std::size_t i = 0; i < 3 * std::size_t(blk.sample_count); ++i)
        ld[3 * blk.sample_offset + i] *= 3.0f;
      ASSERT_TRUE(level_compute_b(t.level, dict(), ld, b0).ok());
      reference_reduced_rhs(t.level, op.value(), b0, inc.rhs());
      reference_reduced_rhs(t.level, op.value(), b0, full.rhs());
      reference_reduced_rhs(t.level, op.value(), b0, cold.rhs());
      const ReducedSolveReport rep =
          inc.solve_incremental(apply_delta, x, op->contraction, settings, frame > 0);
      if (frame == 0) x_full = b0;
      const ReducedSolveReport rep_full = full.solve(apply, x_full, op->contraction, settings, frame > 0);
      const std::vector<float> r_full = r;  // the full iteration's last application's
      x_cold = b0;
      ASSERT_TRUE(cold.solve(apply, x_cold, op->contraction, tight).converged);
      r_tight = r;  // Tb->r of the tight solve's last iterate
      ASSERT_TRUE(rep.converged) << frame;
      if (frame > 0) {
        applied_inc += rep.blocks_applied;
        applied_full += rep_full.blocks_applied;
      }
      // |x - b*| <= error_bound max |x| (the bound the stopping rule states), checked with margin
      // for the estimate q of the contraction.
      double err = 0.0, largest = 0.0;
      for (std::size_t i = 0; i < x.size(); ++i)
        err = std::max(err, double(std::fabs(x[i] - x_cold[i]))),
        largest = std::max(largest, double(std::fabs(x[i])));
      EXPECT_LE(err, 1.5 * op->contraction * double(settings.tolerance) * largest)
          << "refresh " << refresh << " frame " << frame;
      EXPECT_LE(rep.error_bound, settings.tolerance);
      // r for the tiles: Tb->r of the x that G was last applied to, within the bound too.
      // r = Tb->r x_a with max |x_a - b*| <= tolerance max |x| (ReducedSolver): per element
      // within that times the row's absolute sum over the slot's records.
      const std::span<const float> r_inc = inc.r();
      for (std::size_t sl = 0; sl < t.level.slots.size(); ++sl)
        for (std::uint32_t row_k = 0; row_k < t.level.kr; ++row_k) {
          double row = 0.0;
          for (std::uint32_t m : deps.records_of_slot(sl))
            for (std::uint32_t j = 0; j < t.level.records[m].T.cols; ++j)
              row += std::fabs(t.level.records[m].T(row_k, j));
          for (std::size_t c = 0; c < 3; ++c) {
            const std::size_t e = 3 * (t.level.kr * sl + row_k) + c;
            ASSERT_LE(std::fabs(double(r_inc[e]) - r_tight[e]),
                      1.5 * double(settings.tolerance) * largest * row + 1e-9)
                << "refresh " << refresh << " frame " << frame << " slot " << sl;
          }
        }
      const double er = test::rel_l2(r_inc, r_tight), er_full = test::rel_l2(r_full, r_tight);
      if (refresh > 1)
        std::printf("  frame %2d: r rel L2 %.2e (the full iteration's %.2e)\n", frame, er, er_full);
      if (frame == 13) {
        EXPECT_EQ(rep.iterations, 0) << "an unchanged rhs applies nothing";
        if (refresh > 1) {
          EXPECT_EQ(rep.blocks_applied, 0u);
        }
      }
    }
    std::printf(
        "refresh %d: 13 warm frames: incremental %llu block applications, full iteration %llu (%zu blocks)\n",
        refresh, (unsigned long long)applied_inc, (unsigned long long)applied_full, blocks);
    if (refresh > 1) {
      EXPECT_LT(applied_inc, applied_full);
    }
  }
}

// Albedo near 1 (max_albedo 0.999): everywhere, and one white block among dark ones. The
// estimate is damped to kReducedMaxSpectralRadius where it passes it; the solve converges and
// every lightmap is finite, non-negative and within the energy bound ld_max / (1 - s q), q the
// spectral radius of M.
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
      const double q = s.report.contraction;
      std::printf(
          "%-7s %s: spectral radius %.4f, damping %.4f, %s contraction %.4f, %d iterations, error bound "
          "%.1e\n",
          name, one_white ? "one white block" : "albedo 0.999   ", s.report.spectral_radius, s.report.damping,
          s.report.block_jacobi ? "block Jacobi" : "plain", q, s.report.solve.iterations,
          s.report.solve.error_bound);
      EXPECT_LE(q, kReducedMaxSpectralRadius * (1 + 1e-6));
      if (s.report.spectral_radius > kReducedMaxSpectralRadius) {
        EXPECT_NEAR(s.report.damping, kReducedMaxSpectralRadius / s.report.spectral_radius, 1e-6);
      }
      EXPECT_TRUE(s.report.solve.converged);
      const float ld_max = *std::max_element(t.ld.begin(), t.ld.end());
      // Twice the n-space bound at the contraction used: a diverging solve passes it by far.
      const float bound =
          2.0f * feedback_energy_bound(ld_max, float(s.report.damping * s.report.spectral_radius));
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
