// SPDX-License-Identifier: MIT
// modrt — arithmetic on user-given counts that must not wrap. Estimates of sizes and costs
// multiply counts the user chose (res^2, grid^3, rays x samples); a wrapped product turns a
// refusal into an allocation or an empty loop, so every such product goes through here.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <limits>

namespace modrt {

// a * b into `out`; false (and `out` unspecified) when the product does not fit 64 bits.
inline bool checked_mul(std::uint64_t a, std::uint64_t b, std::uint64_t& out) {
  return !__builtin_mul_overflow(a, b, &out);
}

// a + b and the product of `factors`, saturating at UINT64_MAX: for estimates that are
// compared with a budget, where "more than can be counted" is the right answer.
inline std::uint64_t saturating_add(std::uint64_t a, std::uint64_t b) {
  std::uint64_t out;
  return __builtin_add_overflow(a, b, &out) ? std::numeric_limits<std::uint64_t>::max() : out;
}

inline std::uint64_t saturating_product(std::initializer_list<std::uint64_t> factors) {
  std::uint64_t out = 1;
  for (std::uint64_t f : factors) {
    if (f == 0) return 0;
    if (!checked_mul(out, f, out)) out = std::numeric_limits<std::uint64_t>::max();
  }
  return out;
}

}  // namespace modrt
