// SPDX-License-Identifier: MIT
// modrt tests — what the C API test files (test_c_api*.cpp) share: the named-error check (and
// compare_support.h's relative L2, which cannot pass on NaN).
#pragma once

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>

#include "compare_support.h"
#include "modrt/modrt.h"

namespace modrt::test {

// Expects `status` to be `code` and the message to contain every one of `words`.
inline void expect_error(modrt_status status, modrt_status code, std::initializer_list<std::string> words) {
  EXPECT_EQ(status, code) << modrt_status_name(status) << ": " << modrt_last_error();
  const std::string message = modrt_last_error();
  for (const std::string& w : words)
    EXPECT_NE(message.find(w), std::string::npos) << "'" << w << "' not in: " << message;
}

}  // namespace modrt::test
