// SPDX-License-Identifier: MIT
// modrt tests — the GL context fixture every GL test shares: one context per kind for the whole
// test program (creating contexts is the slow part), a TEST_P base that skips with the reason
// when a kind cannot be created here, and readable names for the parameterised tests.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <memory>
#include <ostream>
#include <string>

#include "modrt/platform/gl_context.h"
#include "modrt/status.h"

namespace modrt::test {

struct GlContextSlot {
  std::unique_ptr<platform::GlContext> context;
  Status status;  // why there is no context
};
inline std::map<platform::ContextRequest, GlContextSlot>& gl_context_slots() {
  static std::map<platform::ContextRequest, GlContextSlot> slots;
  return slots;
}
// Contexts are destroyed when the tests end, not by static destructors: those run after
// Mesa's own exit handlers, and OSMesa crashes if its context outlives them.
class GlContextEnvironment : public ::testing::Environment {
 public:
  void TearDown() override { gl_context_slots().clear(); }
};
[[maybe_unused]] inline ::testing::Environment* const kGlContextEnvironment =
    ::testing::AddGlobalTestEnvironment(new GlContextEnvironment);

// The program's context of this kind, created (and described on stdout) on first use and made
// current; .context is null (and .status says why) when this machine cannot create it.
inline GlContextSlot& gl_context_for(platform::ContextRequest request) {
  std::map<platform::ContextRequest, GlContextSlot>& slots = gl_context_slots();
  auto it = slots.find(request);
  if (it == slots.end()) {
    GlContextSlot slot;
    Result<std::unique_ptr<platform::GlContext>> c = platform::create_context(request);
    if (c.ok()) {
      slot.context = std::move(c).value();
      std::printf("  %s: %s | %s | GLSL %s\n", platform::context_request_name(request),
                  slot.context->info().renderer.c_str(), slot.context->info().version.c_str(),
                  slot.context->info().glsl_version.c_str());
    } else {
      slot.status = c.status();
    }
    it = slots.emplace(request, std::move(slot)).first;
  }
  if (it->second.context) {
    const Status s = it->second.context->make_current();
    EXPECT_TRUE(s.ok()) << s.to_string();
  }
  return it->second;
}

// In a test body (or SetUp): `var`, a platform::GlContext*, is the program's context of this
// kind made current (gl_context_for); without one the test is skipped naming the kind and why.
#define MODRT_GL_CONTEXT_OR_SKIP(var, request)                                       \
  ::modrt::test::GlContextSlot& var##_slot = ::modrt::test::gl_context_for(request); \
  if (!var##_slot.context)                                                           \
    GTEST_SKIP() << "no " << ::modrt::platform::context_request_name(request)        \
                 << " context here: " << var##_slot.status.to_string();              \
  [[maybe_unused]] ::modrt::platform::GlContext* const var = var##_slot.context.get()

// Base of the tests parameterised by context kind: SetUp makes the kind's context current or
// skips the test, naming the kind and the reason.
class GlContextTest : public ::testing::TestWithParam<platform::ContextRequest> {
 protected:
  void SetUp() override {
    MODRT_GL_CONTEXT_OR_SKIP(context, GetParam());
    context_ = context;
  }
  const platform::GlFunctions& gl() const { return context_->gl(); }
  bool gles() const { return context_->info().gles; }
  platform::GlContext* context_ = nullptr;
};

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
