// SPDX-License-Identifier: MIT
// Shared by the CPU backend tests (kernels, level runtime): tolerance-aware comparison with
// per-ISA worst-error reporting, and random inputs.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "modrt/cpu/isa.h"
#include "modrt/dictionary.h"

namespace modrt::cpu::cpu_test {

constexpr double kRelTolerance = 1e-5;
// Per-element floor as a fraction of the reference's RMS: an element that cancels to below
// it is judged against it (float accumulation cannot resolve deeper cancellation).
constexpr double kFloor = 0.1;

struct Error {
  double rel_l2 = 0.0;       // ||got - ref|| / ||ref||
  double max_element = 0.0;  // max |got - ref| / max(|ref|, floor)
};

// Per-element errors are relative to max(|ref_i|, kFloor x RMS(ref)).
// `scale` (optional, per element) raises the floor to kScaleFloor x scale_i; see the b check.
constexpr double kScaleFloor = 0.01;
inline Error compare(std::span<const float> got, std::span<const float> ref,
                     std::span<const double> scale = {}) {
  EXPECT_EQ(got.size(), ref.size());
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    num += (double(got[i]) - ref[i]) * (double(got[i]) - ref[i]);
    den += double(ref[i]) * ref[i];
  }
  Error e;
  if (ref.empty()) return e;
  e.rel_l2 = den > 0.0 ? std::sqrt(num / den) : std::sqrt(num);
  const double floor = std::max(kFloor * std::sqrt(den / double(ref.size())), 1e-30);
  for (std::size_t i = 0; i < ref.size(); ++i)
    e.max_element = std::max(e.max_element, std::abs(double(got[i]) - ref[i]) /
                                                std::max({std::abs(double(ref[i])), floor,
                                                          scale.empty() ? 0.0 : kScaleFloor * scale[i]}));
  return e;
}

// Worst errors seen per ISA, printed at the end of each test for the record.
struct Worst {
  double rel_l2 = 0.0, max_element = 0.0;
  void add(const Error& e) {
    rel_l2 = std::max(rel_l2, e.rel_l2);
    max_element = std::max(max_element, e.max_element);
  }
  void print(const char* what, Isa isa) const {
    std::printf("  %-28s %-6s rel L2 %.3g, max element %.3g\n", what, isa_name(isa), rel_l2, max_element);
  }
};

inline void expect_close(std::span<const float> got, std::span<const float> ref, const std::string& what,
                         Worst* worst, std::span<const double> scale = {}) {
  const Error e = compare(got, ref, scale);
  if (worst) worst->add(e);
  EXPECT_LE(e.rel_l2, kRelTolerance) << what;
  EXPECT_LE(e.max_element, kRelTolerance) << what;
}

inline std::vector<float> random_vector(std::mt19937& rng, std::size_t n, float lo, float hi) {
  std::uniform_real_distribution<float> d(lo, hi);
  std::vector<float> v(n);
  for (float& x : v) x = d(rng);
  return v;
}

inline Matrix random_matrix(std::mt19937& rng, std::uint32_t rows, std::uint32_t cols) {
  Matrix m(rows, cols);
  m.data = random_vector(rng, m.data.size(), -1.0f, 1.0f);
  return m;
}

}  // namespace modrt::cpu::cpu_test
