// SPDX-License-Identifier: MIT
// modrt tests — comparing a result with core's reference, stated once for every test file: the
// relative L2 over all values (architecture.md §8's error metric) that cannot pass on NaN, the
// per-element error with a floor for values that cancel, a difference of two results, and
// random inputs.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <vector>

namespace modrt::test {

// ||got - ref|| / ||ref|| over all values (absolute when ref is 0); Inf when anything is not
// finite, so that a NaN never passes a tolerance.
inline double rel_l2(std::span<const float> got, std::span<const float> ref) {
  EXPECT_EQ(got.size(), ref.size());
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < ref.size() && i < got.size(); ++i) {
    const double d = double(got[i]) - double(ref[i]);
    num += d * d;
    den += double(ref[i]) * ref[i];
  }
  if (!std::isfinite(num)) return std::numeric_limits<double>::infinity();
  return den > 0.0 ? std::sqrt(num / den) : std::sqrt(num);
}

// Per-element floor as a fraction of the reference's RMS: an element that cancels to below
// it is judged against it (float accumulation cannot resolve deeper cancellation).
constexpr double kElementFloor = 0.1;
// `scale` (optional, per element) raises the floor to kScaleFloor x scale_i (the b check of
// test_cpu_backend.cpp).
constexpr double kScaleFloor = 0.01;

struct Error {
  double rel_l2 = 0.0;       // ||got - ref|| / ||ref||
  double max_element = 0.0;  // max |got - ref| / max(|ref|, kElementFloor x RMS(ref), kScaleFloor x scale)
};

inline Error compare(std::span<const float> got, std::span<const float> ref, std::span<const double> scale = {}) {
  Error e;
  e.rel_l2 = rel_l2(got, ref);
  if (ref.empty() || got.size() != ref.size()) return e;
  double den = 0.0;
  for (float v : ref) den += double(v) * v;
  const double floor = std::max(kElementFloor * std::sqrt(den / double(ref.size())), 1e-30);
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const double d = std::abs(double(got[i]) - ref[i]);
    e.max_element = std::max(e.max_element, std::isfinite(d) ? d / std::max({std::abs(double(ref[i])), floor,
                                                                             scale.empty() ? 0.0 : kScaleFloor * scale[i]})
                                                             : std::numeric_limits<double>::infinity());
  }
  return e;
}

// a - b, element by element (the DRT delta: a lightmap with clutter minus the one without).
inline std::vector<float> minus(std::span<const float> a, std::span<const float> b) {
  EXPECT_EQ(a.size(), b.size());
  std::vector<float> d(std::min(a.size(), b.size()));
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = a[i] - b[i];
  return d;
}

inline std::vector<float> random_vector(std::mt19937& rng, std::size_t n, float lo, float hi) {
  std::uniform_real_distribution<float> u(lo, hi);
  std::vector<float> v(n);
  for (float& x : v) x = u(rng);
  return v;
}

}  // namespace modrt::test
