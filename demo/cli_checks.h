// SPDX-License-Identifier: MIT
// modrt demo — the one definition of how the programs in demo/ check their floating-point
// options (issue 18): a value must be a whole number token (strtod consumes it all), finite
// and inside the option's stated range. CLI::Range is not enough: every comparison with NaN
// is false, so CLI::Range(0.0, 1.0) lets "nan" through.
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <CLI/CLI.hpp>

namespace modrt::demo {

// Parses `text` as a finite number in [lo, hi]: "" and *value set when it is one, else why not
// (without the option's name, which the caller adds).
inline std::string parse_finite_in_range(const std::string& text, double lo, double hi,
                                         double* value = nullptr) {
  auto bounds = [&] {
    char buf[96];
    std::snprintf(buf, sizeof buf, "[%g, %g]", lo, hi);
    return std::string(buf);
  };
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end == text.c_str() || *end != '\0')
    return "'" + text + "' is not a number; expected a finite number in " + bounds();
  // ERANGE with a huge result: overflow (1e400); with a tiny one: underflow, a usable ~0.
  if (!std::isfinite(v) || (errno == ERANGE && std::abs(v) > 1.0))
    return "'" + text + "' is not finite (NaN, Inf or beyond double range); expected a finite number in " +
           bounds();
  if (v < lo || v > hi) return "'" + text + "' is outside " + bounds();
  if (value) *value = v;
  return {};
}

// CLI11 check for a float or double option (each element of a vector option): CLI11 prefixes
// the message with the flag, e.g. "--exposure: 'nan' is not finite ...".
inline CLI::Validator FiniteRange(double lo, double hi) {
  char desc[96];
  std::snprintf(desc, sizeof desc, "FINITE in [%g, %g]", lo, hi);
  return CLI::Validator([lo, hi](std::string& text) { return parse_finite_in_range(text, lo, hi); }, desc);
}

}  // namespace modrt::demo
