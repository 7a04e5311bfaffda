// SPDX-License-Identifier: MIT
// modrt — real spherical harmonics of order 3 (SH9), clamped-cosine convolution and the
// optimal hemispherical linear SH (OHLSH) projection (architecture.md §3 step 6, MRT §6.4, appendix B).
//
// Conventions
// -----------
// * Real SH, bands l = 0..2, WITHOUT the Condon-Shortley phase, orthonormal over the
//   full sphere. 0-based index k = l*(l+1) + m, for a unit direction (x, y, z):
//     k=0 (l0)        y0 = 1/(2√π)                     = 0.282095
//     k=1 (l1, m=-1)  y1 = √3/(2√π)  * y               = 0.488603 * y
//     k=2 (l1, m= 0)  y2 = √3/(2√π)  * z               = 0.488603 * z
//     k=3 (l1, m=+1)  y3 = √3/(2√π)  * x               = 0.488603 * x
//     k=4 (l2, m=-2)  y4 = √15/(2√π) * x*y             = 1.092548 * xy
//     k=5 (l2, m=-1)  y5 = √15/(2√π) * y*z             = 1.092548 * yz
//     k=6 (l2, m= 0)  y6 = √5/(4√π)  * (3z² - 1)       = 0.315392 * (3z² - 1)
//     k=7 (l2, m=+1)  y7 = √15/(2√π) * x*z             = 1.092548 * xz
//     k=8 (l2, m=+2)  y8 = √15/(4√π) * (x² - y²)       = 0.546274 * (x² - y²)
//   The MRT paper (appendix B) single-indexes the same functions 1-based: its b1..b9 are
//   our indices 0..8 (paper index = our index + 1).
// * Directions are in whatever frame the caller uses; for per-face work that is the face
//   frame (u_axis, v_axis, normal) = (x, y, z), so the lit hemisphere is z >= 0.
//   Evaluation functions expect unit-length directions and do not normalize.
// * Lightmaps store E/π (irradiance over π, i.e. the outgoing radiance of a white Lambertian
//   surface), so irradiance_from_radiance_sh9 returns coefficients of E(n)/π.
// * OHLSH: 4 coefficients a over the linear SH functions y0..y3, chosen to minimize
//   ∫_H (Σ_j b_j y_j − Σ_i a_i y_i)² dω over the upper hemisphere H = {z >= 0}, i.e.
//   a = H1⁻¹ H2 b with [H1]_ik = ∫_H y_i y_k dω (4×4) and [H2]_ij = ∫_H y_i y_j dω (4×9).
//   Reconstruct with ohlsh_eval (plain linear SH sum); only meaningful for n.z >= 0.
#pragma once

#include <array>
#include <cstddef>
#include <numbers>

#include <glm/vec3.hpp>

namespace modrt {

inline constexpr int kSh9Count = 9;
inline constexpr int kOhlshCount = 4;

using Sh9 = std::array<double, kSh9Count>;
using Ohlsh4 = std::array<double, kOhlshCount>;
using OhlshMatrix = std::array<std::array<double, kSh9Count>, kOhlshCount>;

namespace sh_detail {
// constexpr square root (std::sqrt is not constexpr in C++20). Newton from above; the
// iteration cap guards against a last-ulp oscillation. Only used for the constants below.
constexpr double sqrt_newton(double x) {
  double r = x > 1.0 ? x : 1.0;
  for (int i = 0; i < 100; ++i) {
    const double next = 0.5 * (r + x / r);
    if (next == r) break;
    r = next;
  }
  return r;
}
}  // namespace sh_detail

// Normalization constants of the basis functions (see the table above).
inline constexpr double kShC0 = 0.5 * std::numbers::inv_sqrtpi;                        // 1/(2√π)
inline constexpr double kShC1 = 0.5 * std::numbers::sqrt3 * std::numbers::inv_sqrtpi;  // √3/(2√π)
inline constexpr double kShC2 = 0.5 * sh_detail::sqrt_newton(15.0) * std::numbers::inv_sqrtpi;  // √15/(2√π)
inline constexpr double kShC6 = 0.25 * sh_detail::sqrt_newton(5.0) * std::numbers::inv_sqrtpi;  // √5/(4√π)
inline constexpr double kShC8 = 0.25 * sh_detail::sqrt_newton(15.0) * std::numbers::inv_sqrtpi;  // √15/(4√π)

// Band l of 0-based SH index k (0..8).
constexpr int sh9_band(int k) { return k < 1 ? 0 : (k < 4 ? 1 : 2); }

// Clamped-cosine convolution factors Â_l (Ramamoorthi & Hanrahan 2001): the irradiance
// coefficients are E_lm = Â_l L_lm. Â0 = π, Â1 = 2π/3, Â2 = π/4.
inline constexpr std::array<double, 3> kClampedCosineBand = {std::numbers::pi, 2.0 * std::numbers::pi / 3.0,
                                                             std::numbers::pi / 4.0};

// OHLSH closed-form constants (MRT appendix B): c1 = 3√5/4, c2 = 3√5/8, c3 = √15/2.
inline constexpr double kOhlshC1 = 3.0 * sh_detail::sqrt_newton(5.0) / 4.0;
inline constexpr double kOhlshC2 = 3.0 * sh_detail::sqrt_newton(5.0) / 8.0;
inline constexpr double kOhlshC3 = sh_detail::sqrt_newton(15.0) / 2.0;

// The 4×9 matrix H1⁻¹H2 mapping SH9 coefficients b to OHLSH coefficients a = M b.
// In the paper's 1-based indices a = {b1 − c1 b7, b2 + c2 b6, b3 + c3 b7, b4 + c2 b8};
// 0-based: a0 = b0 − c1 b6, a1 = b1 + c2 b5, a2 = b2 + c3 b6, a3 = b3 + c2 b7.
// (Verified against numeric hemisphere integrals in tests/test_sh.cpp; the transcribed
// closed form holds as written for this SH convention.)
constexpr OhlshMatrix ohlsh_matrix() {
  OhlshMatrix m{};
  for (int i = 0; i < kOhlshCount; ++i) m[static_cast<std::size_t>(i)][static_cast<std::size_t>(i)] = 1.0;
  m[0][6] = -kOhlshC1;
  m[1][5] = kOhlshC2;
  m[2][6] = kOhlshC3;
  m[3][7] = kOhlshC2;
  return m;
}

// Evaluates the 9 basis functions at unit_dir (no normalization is done).
// The SH9 rotation of a block's quarter turns about +Y (cube.h rotate_direction, turns & 3):
// row-major 9 x 9 M with c_world = M c_canonical (MRT §6.5: a block's probes are stored in
// its canonical frame). Exact up to rounding: SH9 is closed under rotation.
std::array<double, 81> sh9_quarter_turn_rotation(int turns);

void sh9_eval(const glm::dvec3& unit_dir, double out[9]);
void sh9_eval(const glm::vec3& unit_dir, float out[9]);
Sh9 sh9_eval(const glm::dvec3& unit_dir);

// Σ_k c_k y_k(dir): reconstruction of an SH9 expansion.
double sh9_eval_sum(const double c[9], const glm::dvec3& unit_dir);
float sh9_eval_sum(const float c[9], const glm::vec3& unit_dir);

// Radiance SH coefficients L -> coefficients of E(n)/π, i.e. band l scaled by Â_l/π
// (1, 2/3, 1/4). `radiance` and `irradiance_over_pi` may be the same array.
void irradiance_from_radiance_sh9(const double radiance[9], double irradiance_over_pi[9]);

// SH9 coefficients b -> OHLSH coefficients a = ohlsh_matrix() * b (hemisphere z >= 0).
// `b` and `a` may alias (a == b reads all of b before writing).
void ohlsh_from_sh9(const double b[9], double a[4]);

// Σ_{i<4} a_i y_i(n): linear SH reconstruction of an OHLSH vector at unit normal n.
double ohlsh_eval(const double a[4], const glm::dvec3& unit_normal);
float ohlsh_eval(const float a[4], const glm::vec3& unit_normal);

}  // namespace modrt
