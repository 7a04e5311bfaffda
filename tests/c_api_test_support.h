// SPDX-License-Identifier: MIT
// modrt tests — what the C API test files (test_c_api*.cpp) share: the named-error check and a
// relative L2 that cannot pass on NaN.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <limits>
#include <span>
#include <string>

#include "modrt/modrt.h"

namespace modrt::test {

// Expects `status` to be `code` and the message to contain every one of `words`.
inline void expect_error(modrt_status status, modrt_status code, std::initializer_list<std::string> words) {
  EXPECT_EQ(status, code) << modrt_status_name(status) << ": " << modrt_last_error();
  const std::string message = modrt_last_error();
  for (const std::string& w : words)
    EXPECT_NE(message.find(w), std::string::npos) << "'" << w << "' not in: " << message;
}

// ||got - ref|| / ||ref|| (absolute when ref is 0); Inf when anything is not finite.
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

}  // namespace modrt::test
