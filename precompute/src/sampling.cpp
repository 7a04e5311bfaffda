// SPDX-License-Identifier: MIT
#include "modrt/precompute/sampling.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace modrt::precompute {

Rng::Rng(std::uint64_t seed, std::uint64_t stream) : state_(seed ^ (stream * 0xD1B54A32D192ED03ull)) {
  next_u64();  // decorrelate neighbouring streams
}

std::uint64_t Rng::next_u64() {
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double Rng::next_double() { return double(next_u64() >> 11) * 0x1.0p-53; }

void stratified_square(int count, Rng& rng, std::vector<glm::dvec2>& out) {
  out.clear();
  if (count <= 0) return;
  int nx = int(std::sqrt(double(count)));
  while (nx > 1 && count % nx != 0) --nx;
  const int ny = count / nx;
  out.reserve(std::size_t(count));
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) out.push_back({(x + rng.next_double()) / nx, (y + rng.next_double()) / ny});
}

glm::dvec2 concentric_square_to_disk(const glm::dvec2& s) {
  const double a = 2.0 * s.x - 1.0;
  const double b = 2.0 * s.y - 1.0;
  if (a == 0.0 && b == 0.0) return {0.0, 0.0};
  constexpr double kQuarterPi = std::numbers::pi / 4.0;
  double r, phi;
  if (std::abs(a) > std::abs(b)) {
    r = a;
    phi = kQuarterPi * (b / a);
  } else {
    r = b;
    phi = 2.0 * kQuarterPi - kQuarterPi * (a / b);
  }
  return {r * std::cos(phi), r * std::sin(phi)};
}

glm::dvec2 concentric_disk_to_square(const glm::dvec2& d) {
  const double r = std::sqrt(d.x * d.x + d.y * d.y);
  double phi = std::atan2(d.y, d.x);
  constexpr double kPi = std::numbers::pi;
  if (phi < -kPi / 4.0) phi += 2.0 * kPi;  // phi in [-pi/4, 7pi/4)
  double a, b;
  if (phi < kPi / 4.0) {
    a = r;
    b = phi * a / (kPi / 4.0);
  } else if (phi < 3.0 * kPi / 4.0) {
    b = r;
    a = -(phi - kPi / 2.0) * b / (kPi / 4.0);
  } else if (phi < 5.0 * kPi / 4.0) {
    a = -r;
    b = (phi - kPi) * a / (kPi / 4.0);
  } else {
    b = -r;
    a = -(phi - 3.0 * kPi / 2.0) * b / (kPi / 4.0);
  }
  return {(a + 1.0) * 0.5, (b + 1.0) * 0.5};
}

glm::dvec3 cosine_hemisphere(const glm::dvec2& s) {
  const glm::dvec2 d = concentric_square_to_disk(s);
  const double z = std::sqrt(std::max(0.0, 1.0 - d.x * d.x - d.y * d.y));
  return {d.x, d.y, z};
}

glm::dvec3 uniform_hemisphere(const glm::dvec2& s) {
  const double z = s.x;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * std::numbers::pi * s.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

glm::dvec3 uniform_sphere(const glm::dvec2& s) {
  const double z = 1.0 - 2.0 * s.x;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * std::numbers::pi * s.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

void sphere_surface_points(const glm::dvec3& c, double r, int count, std::vector<glm::dvec3>& out) {
  // Latitude rings about +Y with a multiple of 4 longitudes starting at +X: the set is
  // invariant under quarter turns about Y and under the X and Z mirrors, so light
  // patterns keep the symmetries of the block (see symmetry.h).
  out.clear();
  const int rings = std::max(1, int(std::lround(std::sqrt(count / 4.0))));
  const int longitudes = 4 * std::max(1, int(std::lround(count / (4.0 * rings))));
  for (int i = 0; i < rings; ++i) {
    const double y = 1.0 - 2.0 * (i + 0.5) / rings;
    const double ring = std::sqrt(std::max(0.0, 1.0 - y * y));
    for (int k = 0; k < longitudes; ++k) {
      const double phi = 2.0 * std::numbers::pi * k / longitudes;
      out.push_back(c + r * glm::dvec3(ring * std::cos(phi), y, ring * std::sin(phi)));
    }
  }
}

}  // namespace modrt::precompute
