// SPDX-License-Identifier: MIT
// The scalar reference runtime against direct double-precision linear algebra.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "modrt/feedback_policy.h"
#include "modrt/reference_runtime.h"

namespace modrt {
namespace {

Matrix random_matrix(std::uint32_t rows, std::uint32_t cols, std::mt19937& rng, float scale) {
  std::uniform_real_distribution<float> dist(-scale, scale);
  Matrix m(rows, cols);
  for (float& v : m.data) v = dist(rng);
  return m;
}

Eigen::MatrixXd to_eigen(const Matrix& m) {
  Eigen::MatrixXd e(m.rows, m.cols);
  for (std::uint32_t r = 0; r < m.rows; ++r)
    for (std::uint32_t c = 0; c < m.cols; ++c) e(r, c) = m(r, c);
  return e;
}

// Synthetic operators: n samples, kb modes, Ub with small gain so feedback converges.
ShapeOperators synthetic(std::uint32_t n, std::uint32_t kb, std::uint32_t probes, std::mt19937& rng) {
  ShapeOperators op;
  op.Ub = random_matrix(n, kb, rng, 0.3f);
  op.Td_b = random_matrix(kb, n, rng, 1.0f / float(n));
  op.Limp = random_matrix(n, kb, rng, 1.0f);
  op.Ub_vec = random_matrix(4 * n, kb, rng, 1.0f);
  op.Ubvol = random_matrix(9 * probes, kb, rng, 1.0f);
  return op;
}

std::vector<float> random_signal(std::size_t count, std::mt19937& rng) {
  std::uniform_real_distribution<float> dist(0.0f, 2.0f);
  std::vector<float> v(count);
  for (float& x : v) x = dist(rng);
  return v;
}

Eigen::MatrixXd channels(const std::vector<float>& rgb) {  // 3-interleaved -> rows x 3
  Eigen::MatrixXd m(Eigen::Index(rgb.size() / 3), 3);
  for (std::size_t i = 0; i < rgb.size(); ++i) m(Eigen::Index(i / 3), Eigen::Index(i % 3)) = rgb[i];
  return m;
}

// validate_light_signal's vectorised fast pass must catch every bad value wherever it sits (in
// a block of 16 or the tail) and accept every good one, with the message naming the value.
TEST(ReferenceRuntime, LightSignalCheckCatchesEveryBadValueAnywhere) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::size_t samples = 23;  // 69 floats: four blocks of 16 and a tail of 5
  for (float bad : {nan, -nan, inf, -inf, -1e-30f, -1.0f, 2e30f, std::nextafter(kMaxLightValue, inf)})
    for (std::size_t at :
         {std::size_t(0), std::size_t(17), std::size_t(63), std::size_t(64), std::size_t(68)}) {
      std::vector<float> ld(3 * samples, 0.25f);
      ld[at] = bad;
      const Status s = validate_light_signal(ld, samples, "ld");
      ASSERT_FALSE(s.ok()) << bad << " at " << at;
      EXPECT_NE(s.message().find("sample " + std::to_string(at / 3)), std::string::npos) << s.message();
    }
  for (float good : {0.0f, -0.0f, 1e-45f, 1.0f, kMaxLightValue}) {
    std::vector<float> ld(3 * samples, good);
    EXPECT_TRUE(validate_light_signal(ld, samples, "ld").ok()) << good;
  }
}

TEST(ReferenceRuntime, EveryStageEqualsDoubleLinearAlgebra) {
  std::mt19937 rng(5);
  for (std::uint32_t n : {1u, 7u, 64u, 150u})
    for (std::uint32_t kb : {1u, 5u, 32u}) {
      const ShapeOperators op = synthetic(n, kb, 8, rng);
      const std::vector<float> ld = random_signal(3 * n, rng);
      std::vector<float> b(3 * kb), lightmap(3 * n), vec(12 * n), probes(3 * 72);
      ASSERT_TRUE(compute_b(op, ld, b).ok());
      apply_Ub(op, b, lightmap);
      apply_Ub_vec(op, b, vec);
      apply_Ubvol(op, b, probes);
      const Eigen::MatrixXd b_ref = to_eigen(op.Td_b) * channels(ld);
      EXPECT_LE((channels(b) - b_ref).norm(), 1e-5 * b_ref.norm() + 1e-7);
      const Eigen::MatrixXd B = channels(b);
      const Eigen::MatrixXd l_ref = (to_eigen(op.Ub) * B).cwiseMax(0.0);  // the lightmap policy
      EXPECT_LE((channels(lightmap) - l_ref).norm(), 1e-5 * l_ref.norm() + 1e-7);
      const Eigen::MatrixXd v_ref = to_eigen(op.Ub_vec) * B;
      EXPECT_LE((channels(vec) - v_ref).norm(), 1e-5 * v_ref.norm() + 1e-7);
      const Eigen::MatrixXd p_ref = to_eigen(op.Ubvol) * B;
      EXPECT_LE((channels(probes) - p_ref).norm(), 1e-5 * p_ref.norm() + 1e-7);
    }
}

// Converged feedback solves b = Td_b (ld + rho * Ub b) exactly when no clamp is active.
TEST(ReferenceRuntime, MultiBounceSolvesTheFeedbackEquation) {
  std::mt19937 rng(9);
  const std::uint32_t n = 40, kb = 6;
  ShapeOperators op = synthetic(n, kb, 1, rng);
  for (float& v : op.Ub.data) v = std::abs(v);  // keep the lightmap positive (no max(.,0) clamp)
  for (float& v : op.Td_b.data) v = std::abs(v);
  const std::vector<float> ld = random_signal(3 * n, rng);
  const std::vector<float> albedo(3 * n, 0.4f);
  std::vector<float> b(3 * kb), lightmap(3 * n);
  MultiBounceSettings settings;
  settings.tolerance = 1e-7f;
  Result<MultiBounceReport> r = multi_bounce(op, ld, albedo, settings, b, lightmap);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_TRUE(r->converged);
  ASSERT_FALSE(r->value_clamped);
  const Eigen::MatrixXd T = to_eigen(op.Td_b), U = to_eigen(op.Ub);
  const Eigen::MatrixXd K = Eigen::MatrixXd::Identity(kb, kb) - 0.4 * T * U;
  const Eigen::MatrixXd b_ref = K.lu().solve(T * channels(ld));
  EXPECT_LE((channels(b) - b_ref).norm(), 1e-4 * b_ref.norm());
  EXPECT_LE((channels(lightmap) - U * b_ref).norm(), 1e-4 * (U * b_ref).norm());
}

// Issue 18 item 7: low-rank operators ring negative around a spike in ld; the lightmap is
// clamped at 0 (nonnegative_light), also after multi-bounce. Without the clamp, this
// operator's Ub b is negative on about half of the samples (asserted, so the test can fail).
TEST(ReferenceRuntime, SpikeInLdGivesNoNegativeTexel) {
  std::mt19937 rng(21);
  const std::uint32_t n = 50, kb = 8;
  const ShapeOperators op = synthetic(n, kb, 1, rng);
  std::vector<float> ld(3 * n, 0.0f);
  ld[3 * 17 + 1] = 1e6f;  // one sample, green
  std::vector<float> b(3 * kb), lightmap(3 * n);
  ASSERT_TRUE(compute_b(op, ld, b).ok());
  const Eigen::MatrixXd unclamped = to_eigen(op.Ub) * channels(b);
  ASSERT_LT(unclamped.minCoeff(), -1.0);  // the ringing is there
  apply_Ub(op, b, lightmap);
  for (std::size_t i = 0; i < lightmap.size(); ++i) {
    EXPECT_GE(lightmap[i], 0.0f) << i;
    EXPECT_FLOAT_EQ(lightmap[i], float(std::max(unclamped(Eigen::Index(i / 3), Eigen::Index(i % 3)), 0.0)));
  }
  const std::vector<float> albedo(3 * n, 0.5f);
  Result<MultiBounceReport> r = multi_bounce(op, ld, albedo, {}, b, lightmap);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  for (float v : lightmap) EXPECT_GE(v, 0.0f);
}

TEST(ReferenceRuntime, DivergentOperatorIsHeldByTheEnergyBound) {
  std::mt19937 rng(3);
  const std::uint32_t n = 16, kb = 4;
  ShapeOperators op = synthetic(n, kb, 1, rng);
  for (float& v : op.Ub.data) v = 5.0f + std::abs(v);  // gain far above 1: would diverge
  for (float& v : op.Td_b.data) v = std::abs(v) + 0.1f;
  const std::vector<float> ld(3 * n, 1.0f), albedo(3 * n, 0.9f);
  std::vector<float> b(3 * kb), lightmap(3 * n);
  Result<MultiBounceReport> r = multi_bounce(op, ld, albedo, {}, b, lightmap);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->value_clamped);
  for (float v : lightmap) EXPECT_TRUE(std::isfinite(v));
}

// The feedback policy (feedback_policy.h) is the furnace limit: a closed box whose every texel
// receives all the light that leaves the box (Ub Td_b = I, F conserves energy) with uniform
// albedo rho and direct light E converges to E / (1 - rho), exactly feedback_energy_bound.
// So the bound never clamps a physical operator, and it is reached only in the limit.
TEST(ReferenceRuntime, FeedbackBoundIsTheFurnaceLimit) {
  const std::uint32_t n = 6;
  ShapeOperators op;
  op.Ub = Matrix(n, n);
  op.Td_b = Matrix(n, n);
  for (std::uint32_t i = 0; i < n; ++i) op.Ub(i, i) = op.Td_b(i, i) = 1.0f;
  const float rho = 0.8f, e = 0.5f;
  const std::vector<float> ld(3 * n, e), albedo(3 * n, rho);
  std::vector<float> b(3 * n), lightmap(3 * n);
  MultiBounceSettings settings;
  settings.tolerance = 1e-7f;
  settings.max_iterations = 1000;
  Result<MultiBounceReport> r = multi_bounce(op, ld, albedo, settings, b, lightmap);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_TRUE(r->converged);
  EXPECT_FLOAT_EQ(r->energy_bound, feedback_energy_bound(e, rho));
  EXPECT_NEAR(r->energy_bound, e / (1.0f - rho), 1e-6f);
  for (float v : lightmap) {
    EXPECT_NEAR(v, e / (1.0f - rho), 1e-4f);
    EXPECT_LE(v, r->energy_bound);
  }

  // The albedo clamp: one statement, reporting what it clamped.
  const std::vector<float> a = {0.2f, 0.97f, 0.95f, 1.5f};
  std::vector<float> clamped(a.size());
  const ClampedAlbedo c = clamp_albedo(a, kDefaultMaxAlbedo, clamped);
  EXPECT_TRUE(c.clamped);
  EXPECT_EQ(c.rho_max, kDefaultMaxAlbedo);
  EXPECT_EQ(clamped, (std::vector<float>{0.2f, 0.95f, 0.95f, 0.95f}));
  EXPECT_FALSE(clamp_albedo(std::vector<float>{0.1f, 0.5f}, kDefaultMaxAlbedo, clamped).clamped);
  for (float bad : {1.0f, -0.1f, std::numeric_limits<float>::quiet_NaN()}) {
    const Status s = check_max_albedo(bad, "test");
    EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
    EXPECT_NE(s.message().find("test: max_albedo must be in [0, 1)"), std::string::npos) << s.message();
  }
}

TEST(ReferenceRuntime, BadSignalsAreClearErrors) {
  std::mt19937 rng(1);
  const ShapeOperators op = synthetic(10, 3, 1, rng);
  std::vector<float> b(9);
  std::vector<float> ld(30, 1.0f);
  ld[4] = std::numeric_limits<float>::infinity();
  Status s = compute_b(op, ld, b);
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_NE(s.message().find("sample 1 channel G is Inf"), std::string::npos) << s.message();
  ld[4] = -1.0f;
  EXPECT_EQ(compute_b(op, ld, b).code(), ErrorCode::invalid_argument);
  std::vector<float> short_ld(29, 1.0f);
  s = compute_b(op, short_ld, b);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("expected 3 x 10"), std::string::npos) << s.message();
  std::vector<float> good(30, 1.0f), albedo(30, 0.5f), lm(30);
  MultiBounceSettings bad;
  bad.max_albedo = 1.0f;
  EXPECT_FALSE(multi_bounce(op, good, albedo, bad, b, lm).ok());
}

}  // namespace
}  // namespace modrt
