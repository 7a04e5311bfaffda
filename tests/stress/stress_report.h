// SPDX-License-Identifier: MIT
// The robustness table's rows (issue 9): every stress test prints, for each thing it checks,
//   ROBUSTNESS|case|stage|value|bound|result
// and scripts/robustness.sh collects those lines from `ctest -L stress` into a markdown table
// (docs/robustness.md). `value` is what was measured, `bound` what the test asserts it against
// (or "report" for a logged quantity with no assertion), result pass or FAIL.
#pragma once

#include <cstdarg>
#include <cstdio>
#include <string>

namespace modrt::stress {

inline std::string fmt(const char* format, ...) __attribute__((format(printf, 1, 2)));
inline std::string fmt(const char* format, ...) {
  char text[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(text, sizeof text, format, args);
  va_end(args);
  return text;
}

// One row; returns `pass` so a test can both report and assert: EXPECT_TRUE(row(...)).
// '|' separates the fields: one inside a field becomes '/'.
inline std::string field(std::string s) {
  for (char& c : s)
    if (c == '|' || c == '\n') c = c == '|' ? '/' : ' ';
  return s;
}

inline bool row(const std::string& case_name, const std::string& stage, const std::string& value,
                const std::string& bound, bool pass) {
  std::printf("ROBUSTNESS|%s|%s|%s|%s|%s\n", field(case_name).c_str(), field(stage).c_str(),
              field(value).c_str(), field(bound).c_str(), pass ? "pass" : "FAIL");
  std::fflush(stdout);
  return pass;
}

// A logged quantity (conditioning, a spectral radius): no assertion.
inline void report(const std::string& case_name, const std::string& stage, const std::string& value) {
  std::printf("ROBUSTNESS|%s|%s|%s|report|logged\n", field(case_name).c_str(), field(stage).c_str(),
              field(value).c_str());
  std::fflush(stdout);
}

}  // namespace modrt::stress
