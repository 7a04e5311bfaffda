// SPDX-License-Identifier: MIT
// modrt tests — readable names for GL tests parameterised by context kind.
#pragma once

#include <gtest/gtest.h>

#include <ostream>
#include <string>

#include "modrt/platform/gl_context.h"

namespace modrt::test {

// "egl_surfaceless", "osmesa", "egl_device": the suffix of a TEST_P's name, so that ctest and
// --gtest_filter show the context instead of gtest's "4-byte object <04-00 00-00>".
inline std::string gl_context_test_name(const ::testing::TestParamInfo<platform::ContextRequest>& info) {
  std::string name = platform::context_request_name(info.param);
  for (char& ch : name)
    if (ch == '-') ch = '_';  // gtest names are identifiers
  return name;
}

}  // namespace modrt::test

namespace modrt::platform {

// gtest prints a parameter with this (found by ADL): ctest's test names carry
// "# GetParam() = osmesa", not the bytes of the enum.
inline void PrintTo(ContextRequest request, std::ostream* os) { *os << context_request_name(request); }

}  // namespace modrt::platform
