// SPDX-License-Identifier: MIT
// modrt tests — the relative L2 error of a result against its reference (architecture.md §8's
// error metric), stated once for every test file that compares whole buffers; the difference
// of two results; random inputs.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <vector>

namespace modrt::test {

// ||got - ref|| / ||ref|| over all values; Inf when anything is not finite, so that a NaN never
// passes a tolerance. Absolute when ref is 0: 0 for two empty buffers (a level without slots
// has no r), a test failure for a non-empty all-zero ref (a relative error against nothing).
inline double rel_l2(std::span<const float> got, std::span<const float> ref) {
  EXPECT_EQ(got.size(), ref.size());
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < ref.size() && i < got.size(); ++i) {
    const double d = double(got[i]) - double(ref[i]);
    num += d * d;
    den += double(ref[i]) * ref[i];
  }
  if (!std::isfinite(num)) return std::numeric_limits<double>::infinity();
  if (!ref.empty()) {
    EXPECT_GT(den, 0.0) << "rel_l2 against an all-zero reference (" << ref.size() << " values)";
  }
  return den > 0.0 ? std::sqrt(num / den) : std::sqrt(num);
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
