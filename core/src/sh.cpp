// SPDX-License-Identifier: MIT
#include "modrt/sh.h"

#include <cmath>
#include <utility>

#include <glm/geometric.hpp>

#include "modrt/cube.h"

namespace modrt {

namespace {

// One template for double and float so the two overloads cannot drift apart; the
// constants are rounded once to T.
template <typename T, typename V>
void eval_basis(const V& d, T out[9]) {
  const T c0 = static_cast<T>(kShC0);
  const T c1 = static_cast<T>(kShC1);
  const T c2 = static_cast<T>(kShC2);
  const T c6 = static_cast<T>(kShC6);
  const T c8 = static_cast<T>(kShC8);
  const T x = d.x;
  const T y = d.y;
  const T z = d.z;
  out[0] = c0;
  out[1] = c1 * y;
  out[2] = c1 * z;
  out[3] = c1 * x;
  out[4] = c2 * x * y;
  out[5] = c2 * y * z;
  out[6] = c6 * (T(3) * z * z - T(1));
  out[7] = c2 * x * z;
  out[8] = c8 * (x * x - y * y);
}

template <typename T, typename V>
T eval_sum(const T* c, int count, const V& d) {
  T y[9];
  eval_basis<T>(d, y);
  T s = T(0);
  for (int k = 0; k < count; ++k) s += c[k] * y[k];
  return s;
}

}  // namespace

void sh9_eval(const glm::dvec3& unit_dir, double out[9]) { eval_basis<double>(unit_dir, out); }

void sh9_eval(const glm::vec3& unit_dir, float out[9]) { eval_basis<float>(unit_dir, out); }

Sh9 sh9_eval(const glm::dvec3& unit_dir) {
  Sh9 out{};
  eval_basis<double>(unit_dir, out.data());
  return out;
}

double sh9_eval_sum(const double c[9], const glm::dvec3& unit_dir) {
  return eval_sum<double>(c, 9, unit_dir);
}

float sh9_eval_sum(const float c[9], const glm::vec3& unit_dir) { return eval_sum<float>(c, 9, unit_dir); }

void irradiance_from_radiance_sh9(const double radiance[9], double irradiance_over_pi[9]) {
  // Funk-Hecke: convolving with max(0, cos) scales band l by Â_l; the extra 1/π is the
  // project's lightmap convention (E/π). Elementwise, so in-place use is fine.
  for (int k = 0; k < kSh9Count; ++k) {
    const double scale = kClampedCosineBand[static_cast<std::size_t>(sh9_band(k))] / std::numbers::pi;
    irradiance_over_pi[k] = radiance[k] * scale;
  }
}

void ohlsh_from_sh9(const double b[9], double a[4]) {
  // Sparse form of ohlsh_matrix(): only the zonal y6 and the z-odd y5, y7 overlap the
  // linear band on the hemisphere (y4, y8 integrate to zero against y0..y3 there).
  // Computed into locals first so that a may alias b.
  const double a0 = b[0] - kOhlshC1 * b[6];
  const double a1 = b[1] + kOhlshC2 * b[5];
  const double a2 = b[2] + kOhlshC3 * b[6];
  const double a3 = b[3] + kOhlshC2 * b[7];
  a[0] = a0;
  a[1] = a1;
  a[2] = a2;
  a[3] = a3;
}

double ohlsh_eval(const double a[4], const glm::dvec3& unit_normal) {
  return eval_sum<double>(a, 4, unit_normal);
}

float ohlsh_eval(const float a[4], const glm::vec3& unit_normal) {
  return eval_sum<float>(a, 4, unit_normal);
}

// M with sum_k (M c)_k Y_k(d) = sum_k c_k Y_k(R^-1 d) for every d, R = rotate_direction(., turns):
// least squares over 26 directions (exact: SH9 is closed under rotation), normal equations
// solved by Gauss-Jordan in double.
std::array<double, 81> sh9_quarter_turn_rotation(int turns) {
  std::array<double, 81> ata{}, atb{};
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
      for (int k = -1; k <= 1; ++k) {
        if (i == 0 && j == 0 && k == 0) continue;
        const glm::dvec3 d = glm::normalize(glm::dvec3(i, j + 0.25 * i, k - 0.5 * j));
        double y[9], yr[9];
        sh9_eval(d, y);
        sh9_eval(glm::normalize(rotate_direction(d, -turns)), yr);
        for (int r = 0; r < 9; ++r)
          for (int c = 0; c < 9; ++c) {
            ata[std::size_t(9 * r + c)] += y[r] * y[c];
            atb[std::size_t(9 * r + c)] += y[r] * yr[c];
          }
      }
  for (int col = 0; col < 9; ++col) {
    int pivot = col;
    for (int r = col + 1; r < 9; ++r)
      if (std::abs(ata[std::size_t(9 * r + col)]) > std::abs(ata[std::size_t(9 * pivot + col)])) pivot = r;
    for (int c = 0; c < 9; ++c) {
      std::swap(ata[std::size_t(9 * col + c)], ata[std::size_t(9 * pivot + c)]);
      std::swap(atb[std::size_t(9 * col + c)], atb[std::size_t(9 * pivot + c)]);
    }
    const double inv = 1.0 / ata[std::size_t(9 * col + col)];
    for (int c = 0; c < 9; ++c) ata[std::size_t(9 * col + c)] *= inv, atb[std::size_t(9 * col + c)] *= inv;
    for (int r = 0; r < 9; ++r) {
      if (r == col) continue;
      const double f = ata[std::size_t(9 * r + col)];
      for (int c = 0; c < 9; ++c) {
        ata[std::size_t(9 * r + c)] -= f * ata[std::size_t(9 * col + c)];
        atb[std::size_t(9 * r + c)] -= f * atb[std::size_t(9 * col + c)];
      }
    }
  }
  return atb;
}

}  // namespace modrt
