// SPDX-License-Identifier: MIT
// Tests for core/sh: SH9 basis, clamped-cosine convolution, OHLSH (MRT appendix B).
//
// All integrals use Gauss-Legendre in cosθ (in a frame whose z axis is the kink of the
// integrand, if any) times a uniform midpoint rule in φ. Every integrand here is, after
// the φ sum, a low-degree polynomial in cosθ on each piece, so the quadrature is exact to
// rounding and tolerances can be far tighter than the 1e-4 the issue asks for.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "modrt/sh.h"

namespace {

using modrt::kOhlshCount;
using modrt::kSh9Count;
constexpr double kPi = std::numbers::pi;

struct QuadNode {
  glm::dvec3 dir;
  double weight;
};

// n-point Gauss-Legendre nodes/weights on [a, b] (Newton on P_n, Numerical Recipes style).
void gauss_legendre(int n, double a, double b, std::vector<double>& x, std::vector<double>& w) {
  x.assign(static_cast<std::size_t>(n), 0.0);
  w.assign(static_cast<std::size_t>(n), 0.0);
  const double mid = 0.5 * (a + b);
  const double half = 0.5 * (b - a);
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 0.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0;
      double p1 = 0.0;
      for (int j = 0; j < n; ++j) {
        const double p2 = p1;
        p1 = p0;
        p0 = ((2.0 * j + 1.0) * z * p1 - j * p2) / (j + 1.0);
      }
      dp = n * (z * p0 - p1) / (z * z - 1.0);
      const double dz = p0 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-15) break;
    }
    const double wt = 2.0 * half / ((1.0 - z * z) * dp * dp);
    x[static_cast<std::size_t>(i)] = mid - half * z;
    x[static_cast<std::size_t>(n - 1 - i)] = mid + half * z;
    w[static_cast<std::size_t>(i)] = wt;
    w[static_cast<std::size_t>(n - 1 - i)] = wt;
  }
}

// Quadrature over the zone {z0 <= ω·axis <= z1} of the unit sphere (axis = unit vector).
std::vector<QuadNode> zone_quadrature(double z0, double z1, const glm::dvec3& axis = {0, 0, 1}, int nz = 12,
                                      int nphi = 24) {
  // Orthonormal frame (t, s, axis); its handedness does not matter for an integral.
  const glm::dvec3 helper = std::abs(axis.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 t = glm::normalize(glm::cross(helper, axis));
  const glm::dvec3 s = glm::cross(axis, t);
  std::vector<double> zs, ws;
  gauss_legendre(nz, z0, z1, zs, ws);
  std::vector<QuadNode> nodes;
  const double dphi = 2.0 * kPi / nphi;
  for (std::size_t i = 0; i < zs.size(); ++i) {
    const double r = std::sqrt(std::max(0.0, 1.0 - zs[i] * zs[i]));
    for (int j = 0; j < nphi; ++j) {
      const double phi = (j + 0.5) * dphi;
      const glm::dvec3 d = r * std::cos(phi) * t + r * std::sin(phi) * s + zs[i] * axis;
      nodes.push_back({d, ws[i] * dphi});
    }
  }
  return nodes;
}

std::vector<QuadNode> sphere_quadrature() { return zone_quadrature(-1.0, 1.0); }
std::vector<QuadNode> hemisphere_quadrature() { return zone_quadrature(0.0, 1.0); }

// SH projection c_k = ∫_S f y_k dω. Split at the equator so that a kink at z = 0
// (clamped cosine) falls on a piece boundary.
modrt::Sh9 project(const std::function<double(const glm::dvec3&)>& f) {
  modrt::Sh9 c{};
  for (const auto& quad : {zone_quadrature(-1.0, 0.0), zone_quadrature(0.0, 1.0)}) {
    for (const QuadNode& q : quad) {
      const modrt::Sh9 y = modrt::sh9_eval(q.dir);
      const double v = f(q.dir);
      for (int k = 0; k < kSh9Count; ++k)
        c[static_cast<std::size_t>(k)] += q.weight * v * y[static_cast<std::size_t>(k)];
    }
  }
  return c;
}

modrt::Sh9 random_sh9(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  modrt::Sh9 b{};
  for (double& v : b) v = u(rng);
  return b;
}

// ∫_H (Σ b_j y_j − Σ a_i y_i)² dω over z >= 0.
double hemisphere_error(const modrt::Sh9& b, const std::array<double, 4>& a) {
  static const std::vector<QuadNode> quad = hemisphere_quadrature();
  double e = 0.0;
  for (const QuadNode& q : quad) {
    const double diff = modrt::sh9_eval_sum(b.data(), q.dir) - modrt::ohlsh_eval(a.data(), q.dir);
    e += q.weight * diff * diff;
  }
  return e;
}

const std::vector<glm::dvec3>& test_directions() {
  static const std::vector<glm::dvec3> dirs = {
      {0, 0, 1},
      {0, 0, -1},
      {1, 0, 0},
      {0, 1, 0},
      glm::normalize(glm::dvec3(0.3, -0.5, 0.8)),
      glm::normalize(glm::dvec3(-0.7, 0.2, 0.1)),
      glm::normalize(glm::dvec3(0.1, 0.9, -0.4)),
      glm::normalize(glm::dvec3(-1, -1, 1)),
  };
  return dirs;
}

// ---------------------------------------------------------------------------------------

TEST(SphericalHarmonics, ConstantsAreExact) {
  const double sqrt_pi = std::sqrt(kPi);
  EXPECT_NEAR(modrt::kShC0, 1.0 / (2.0 * sqrt_pi), 1e-15);
  EXPECT_NEAR(modrt::kShC1, std::sqrt(3.0) / (2.0 * sqrt_pi), 1e-15);
  EXPECT_NEAR(modrt::kShC2, std::sqrt(15.0) / (2.0 * sqrt_pi), 1e-15);
  EXPECT_NEAR(modrt::kShC6, std::sqrt(5.0) / (4.0 * sqrt_pi), 1e-15);
  EXPECT_NEAR(modrt::kShC8, std::sqrt(15.0) / (4.0 * sqrt_pi), 1e-15);
  EXPECT_NEAR(modrt::kOhlshC1, 3.0 * std::sqrt(5.0) / 4.0, 1e-15);
  EXPECT_NEAR(modrt::kOhlshC2, 3.0 * std::sqrt(5.0) / 8.0, 1e-15);
  EXPECT_NEAR(modrt::kOhlshC3, std::sqrt(15.0) / 2.0, 1e-15);
  for (int k = 0; k < 9; ++k) EXPECT_EQ(modrt::sh9_band(k), static_cast<int>(std::sqrt(k + 0.5))) << k;
}

// Pins ordering and signs (orthonormality alone cannot see a sign flip or a swap).
TEST(SphericalHarmonics, MatchesGraphicsTable) {
  for (const glm::dvec3& d : test_directions()) {
    const double x = d.x, y = d.y, z = d.z;
    const std::array<double, 9> expect = {0.282095,
                                          0.488603 * y,
                                          0.488603 * z,
                                          0.488603 * x,
                                          1.092548 * x * y,
                                          1.092548 * y * z,
                                          0.315392 * (3 * z * z - 1),
                                          1.092548 * x * z,
                                          0.546274 * (x * x - y * y)};
    double out[9];
    modrt::sh9_eval(d, out);
    const modrt::Sh9 arr = modrt::sh9_eval(d);
    float outf[9];
    modrt::sh9_eval(glm::vec3(d), outf);
    for (int k = 0; k < 9; ++k) {
      const auto uk = static_cast<std::size_t>(k);
      EXPECT_NEAR(out[k], expect[uk], 2e-6) << "k=" << k;
      EXPECT_EQ(arr[uk], out[k]);
      EXPECT_NEAR(static_cast<double>(outf[k]), out[k], 1e-6) << "k=" << k;
    }
  }
}

TEST(SphericalHarmonics, OrthonormalOverSphere) {
  const std::vector<QuadNode> quad = sphere_quadrature();
  std::array<std::array<double, 9>, 9> gram{};
  for (const QuadNode& q : quad) {
    const modrt::Sh9 y = modrt::sh9_eval(q.dir);
    for (std::size_t i = 0; i < 9; ++i)
      for (std::size_t j = 0; j < 9; ++j) gram[i][j] += q.weight * y[i] * y[j];
  }
  for (std::size_t i = 0; i < 9; ++i)
    for (std::size_t j = 0; j < 9; ++j) EXPECT_NEAR(gram[i][j], i == j ? 1.0 : 0.0, 1e-12) << i << "," << j;
}

TEST(SphericalHarmonics, ProjectConstant) {
  const modrt::Sh9 c = project([](const glm::dvec3&) { return 1.0; });
  EXPECT_NEAR(c[0], 2.0 * std::sqrt(kPi), 1e-12);
  EXPECT_NEAR(c[0], 3.5449077, 1e-7);
  for (std::size_t k = 1; k < 9; ++k) EXPECT_NEAR(c[k], 0.0, 1e-12) << k;
}

TEST(SphericalHarmonics, ProjectClampedCosine) {
  const modrt::Sh9 c = project([](const glm::dvec3& d) { return std::max(0.0, d.z); });
  const std::array<double, 9> expect = {
      std::sqrt(kPi) / 2.0, 0, std::sqrt(kPi / 3.0), 0, 0, 0, std::sqrt(5.0 * kPi) / 8.0, 0, 0};
  for (std::size_t k = 0; k < 9; ++k) EXPECT_NEAR(c[k], expect[k], 1e-12) << k;
  // These are Â_l / sqrt(4π/(2l+1)), which ties the lobe to the convolution factors.
  for (int k : {0, 2, 6}) {
    const int l = modrt::sh9_band(k);
    EXPECT_NEAR(c[static_cast<std::size_t>(k)] * std::sqrt(4.0 * kPi / (2 * l + 1)),
                modrt::kClampedCosineBand[static_cast<std::size_t>(l)], 1e-12);
  }
}

TEST(SphericalHarmonics, SumReconstructsProjectedFunction) {
  std::mt19937_64 rng(7);
  const modrt::Sh9 c = random_sh9(rng);
  // A band-limited function round-trips through projection.
  const modrt::Sh9 back = project([&](const glm::dvec3& d) { return modrt::sh9_eval_sum(c.data(), d); });
  for (std::size_t k = 0; k < 9; ++k) EXPECT_NEAR(back[k], c[k], 1e-12) << k;
  std::array<float, 9> cf{};
  for (std::size_t k = 0; k < 9; ++k) cf[k] = static_cast<float>(c[k]);
  for (const glm::dvec3& d : test_directions())
    EXPECT_NEAR(static_cast<double>(modrt::sh9_eval_sum(cf.data(), glm::vec3(d))),
                modrt::sh9_eval_sum(c.data(), d), 1e-5);
}

TEST(Irradiance, ConstantRadianceGivesOne) {
  double L[9] = {2.0 * std::sqrt(kPi), 0, 0, 0, 0, 0, 0, 0, 0};  // L(ω) = 1
  double E[9];
  modrt::irradiance_from_radiance_sh9(L, E);
  for (const glm::dvec3& n : test_directions()) EXPECT_NEAR(modrt::sh9_eval_sum(E, n), 1.0, 1e-12);
}

TEST(Irradiance, MatchesBruteForceCosineIntegral) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 4; ++trial) {
    const modrt::Sh9 L = random_sh9(rng);
    modrt::Sh9 E{};
    modrt::irradiance_from_radiance_sh9(L.data(), E.data());
    for (const glm::dvec3& n : test_directions()) {
      // Hemisphere around n: the clamp's kink is the zone boundary, so this is exact.
      double brute = 0.0;
      for (const QuadNode& q : zone_quadrature(0.0, 1.0, n))
        brute += q.weight * modrt::sh9_eval_sum(L.data(), q.dir) * glm::dot(n, q.dir);
      EXPECT_NEAR(modrt::sh9_eval_sum(E.data(), n), brute / kPi, 1e-12) << "trial " << trial;
    }
  }
  // In-place use is allowed.
  modrt::Sh9 L = random_sh9(rng);
  modrt::Sh9 E{};
  modrt::irradiance_from_radiance_sh9(L.data(), E.data());
  modrt::irradiance_from_radiance_sh9(L.data(), L.data());
  for (std::size_t k = 0; k < 9; ++k) EXPECT_EQ(L[k], E[k]);
}

TEST(Ohlsh, ClosedFormMatchesNumericHemisphereIntegrals) {
  Eigen::Matrix4d H1 = Eigen::Matrix4d::Zero();
  Eigen::Matrix<double, 4, 9> H2 = Eigen::Matrix<double, 4, 9>::Zero();
  for (const QuadNode& q : hemisphere_quadrature()) {
    const modrt::Sh9 y = modrt::sh9_eval(q.dir);
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 9; ++j) {
        const double v = q.weight * y[static_cast<std::size_t>(i)] * y[static_cast<std::size_t>(j)];
        H2(i, j) += v;
        if (j < 4) H1(i, j) += v;
      }
  }
  const Eigen::Matrix<double, 4, 9> numeric = H1.partialPivLu().solve(H2);
  const modrt::OhlshMatrix closed = modrt::ohlsh_matrix();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 9; ++j)
      EXPECT_NEAR(closed[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)], numeric(i, j), 1e-9)
          << "M[" << i << "][" << j << "]";
}

TEST(Ohlsh, FunctionEqualsMatrix) {
  constexpr modrt::OhlshMatrix M = modrt::ohlsh_matrix();
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 8; ++trial) {
    const modrt::Sh9 b = random_sh9(rng);
    double a[4];
    modrt::ohlsh_from_sh9(b.data(), a);
    for (std::size_t i = 0; i < 4; ++i) {
      double expect = 0.0;
      for (std::size_t j = 0; j < 9; ++j) expect += M[i][j] * b[j];
      EXPECT_NEAR(a[i], expect, 1e-14);
    }
    // Aliased output gives the same result.
    modrt::Sh9 b2 = b;
    modrt::ohlsh_from_sh9(b2.data(), b2.data());
    for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(b2[i], a[i]);
  }
  // A purely linear expansion is reproduced exactly.
  const double lin[9] = {0.4, -0.2, 0.7, 0.1, 0, 0, 0, 0, 0};
  double a[4];
  modrt::ohlsh_from_sh9(lin, a);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(a[i], lin[i]);
}

TEST(Ohlsh, MinimizesHemisphereError) {
  std::mt19937_64 rng(5);
  const double delta = 1e-3;
  for (int trial = 0; trial < 6; ++trial) {
    const modrt::Sh9 b = random_sh9(rng);
    std::array<double, 4> a{};
    modrt::ohlsh_from_sh9(b.data(), a.data());
    const double e0 = hemisphere_error(b, a);
    // Perturbing the optimum by ±δ along any axis raises the error by δ²[H1]_ii (= δ²/2);
    // a wrong optimum would make one of the two signs decrease it.
    for (std::size_t i = 0; i < 4; ++i) {
      for (double sign : {-1.0, 1.0}) {
        std::array<double, 4> p = a;
        p[i] += sign * delta;
        const double e = hemisphere_error(b, p);
        EXPECT_GT(e, e0) << "trial " << trial << " axis " << i << " sign " << sign;
        EXPECT_NEAR(e - e0, 0.5 * delta * delta, 1e-9);
      }
    }
    // The OHLSH fit beats plain truncation to the first 4 coefficients on the hemisphere.
    const std::array<double, 4> truncated = {b[0], b[1], b[2], b[3]};
    EXPECT_LE(e0, hemisphere_error(b, truncated));
  }
}

TEST(Ohlsh, EvalIsLinearShSum) {
  const double a[4] = {0.3, -0.8, 0.5, 0.2};
  const float af[4] = {0.3f, -0.8f, 0.5f, 0.2f};
  const double b[9] = {0.3, -0.8, 0.5, 0.2, 0, 0, 0, 0, 0};
  for (const glm::dvec3& n : test_directions()) {
    const double expect = 0.3 * modrt::kShC0 + modrt::kShC1 * (-0.8 * n.y + 0.5 * n.z + 0.2 * n.x);
    EXPECT_NEAR(modrt::ohlsh_eval(a, n), expect, 1e-14);
    EXPECT_NEAR(modrt::ohlsh_eval(a, n), modrt::sh9_eval_sum(b, n), 1e-14);
    EXPECT_NEAR(static_cast<double>(modrt::ohlsh_eval(af, glm::vec3(n))), expect, 1e-6);
  }
}

}  // namespace
