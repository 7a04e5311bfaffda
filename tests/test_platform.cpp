// SPDX-License-Identifier: MIT
// modrt::platform: every context kind renders, auto_select explains itself, timers time.
// A kind this machine cannot provide is skipped with the reason printed; set
// MODRT_REQUIRE_GL_CONTEXTS (e.g. "egl-surfaceless,osmesa") to make such a skip a failure.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "modrt/platform/gl_context.h"
#include "modrt/platform/gpu_timer.h"

namespace modrt::platform {
namespace {

bool required(ContextRequest request) {
  const char* list = std::getenv("MODRT_REQUIRE_GL_CONTEXTS");
  if (!list) return false;
  const std::string all = std::string(",") + list + ",";
  return all.find(std::string(",") + context_request_name(request) + ",") != std::string::npos;
}

// Creates `request`, or skips (fails when required) with the Status message.
#define MODRT_CREATE_OR_SKIP(var, request)                                                                \
  auto var##_result = create_context(request);                                                            \
  if (!var##_result) {                                                                                    \
    if (required(request)) FAIL() << var##_result.status().message();                                     \
    GTEST_SKIP() << context_request_name(request) << " unavailable: " << var##_result.status().message(); \
  }                                                                                                       \
  std::unique_ptr<GlContext> var = std::move(var##_result).value()

// An RGBA8 texture with a framebuffer, bound; deleted by the destructor.
struct TargetFbo {
  TargetFbo(const GlFunctions& g, int w, int h) : gl(g) {
    gl.glGenTextures(1, &texture);
    gl.glBindTexture(GL_TEXTURE_2D, texture);
    gl.glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, w, h);
    gl.glGenFramebuffers(1, &fbo);
    gl.glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
    gl.glViewport(0, 0, w, h);
  }
  ~TargetFbo() {
    gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
    gl.glDeleteFramebuffers(1, &fbo);
    gl.glDeleteTextures(1, &texture);
  }
  const GlFunctions& gl;
  GLuint texture = 0, fbo = 0;
};

// Clears an FBO to a colour, reads it back, checks every pixel and the GL error state.
void expect_clear_round_trip(const GlContext& context, float r, float g, float b) {
  const GlFunctions& gl = context.gl();
  constexpr int kW = 8, kH = 4;
  TargetFbo target(gl, kW, kH);
  ASSERT_EQ(gl.glCheckFramebufferStatus(GL_FRAMEBUFFER), GLenum(GL_FRAMEBUFFER_COMPLETE));
  gl.glClearColor(r, g, b, 1.0f);
  gl.glClear(GL_COLOR_BUFFER_BIT);
  std::vector<unsigned char> pixels(kW * kH * 4, 0);
  gl.glPixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.glReadPixels(0, 0, kW, kH, GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  const float want[4] = {r * 255.0f, g * 255.0f, b * 255.0f, 255.0f};
  for (int p = 0; p < kW * kH; ++p)
    for (int c = 0; c < 4; ++c)
      ASSERT_NEAR(pixels[p * 4 + c], want[c], 1.0) << "pixel " << p << " channel " << c;
  EXPECT_EQ(gl_error_name(gl.glGetError()), "GL_NO_ERROR");
}

void check_kind(ContextRequest request, ContextKind kind, bool gles) {
  MODRT_CREATE_OR_SKIP(context, request);
  const ContextInfo& info = context->info();
  std::printf("[ %s ] GL_VERSION \"%s\", GLSL \"%s\", renderer \"%s\", vendor \"%s\", device \"%s\"\n",
              context_kind_name(kind), info.version.c_str(), info.glsl_version.c_str(), info.renderer.c_str(),
              info.vendor.c_str(), info.device.c_str());
  EXPECT_EQ(info.kind, kind);
  EXPECT_EQ(info.gles, gles);
  if (gles)
    EXPECT_EQ(info.version.rfind("OpenGL ES 3", 0), 0u) << info.version;
  else
    EXPECT_FALSE(info.version.empty());
  EXPECT_FALSE(info.glsl_version.empty());
  EXPECT_FALSE(info.renderer.empty());
  EXPECT_EQ(info.selection_report, std::string(context_kind_name(kind)) + ": chosen");
  ASSERT_TRUE(context->make_current().ok());
  expect_clear_round_trip(*context, 0.25f, 0.5f, 0.75f);
}

TEST(PlatformContext, EglSurfaceless) {
  check_kind(ContextRequest::egl_surfaceless, ContextKind::egl_surfaceless, true);
}
TEST(PlatformContext, EglPbuffer) { check_kind(ContextRequest::egl_pbuffer, ContextKind::egl_pbuffer, true); }
TEST(PlatformContext, EglDevice) { check_kind(ContextRequest::egl_device, ContextKind::egl_device, true); }
TEST(PlatformContext, Osmesa) { check_kind(ContextRequest::osmesa, ContextKind::osmesa, false); }

TEST(PlatformContext, DebugOptionIsAccepted) {
  ContextOptions options;
  options.debug = true;
  auto context = create_context(ContextRequest::egl_surfaceless, options);
  if (!context) GTEST_SKIP() << context.status().message();
  expect_clear_round_trip(*context.value(), 1.0f, 0.0f, 0.0f);
}

TEST(PlatformContext, AutoSelectExplainsItsChoice) {
  auto result = create_context(ContextRequest::auto_select);
  ASSERT_TRUE(result.ok()) << result.status().message();
  const ContextInfo& info = result.value()->info();
  std::printf("[ auto ] selection report:\n%s\n", info.selection_report.c_str());
  const std::string chosen = std::string(context_kind_name(info.kind)) + ": chosen";
  ASSERT_GE(info.selection_report.size(), chosen.size());
  EXPECT_EQ(info.selection_report.substr(info.selection_report.size() - chosen.size()), chosen);
  // One line per kind tried, in auto order, ending at the chosen one.
  const ContextKind order[] = {ContextKind::egl_device, ContextKind::egl_surfaceless,
                               ContextKind::egl_pbuffer, ContextKind::osmesa};
  std::size_t line_start = 0;
  for (ContextKind kind : order) {
    const std::string prefix = std::string(context_kind_name(kind)) + ": ";
    EXPECT_EQ(info.selection_report.compare(line_start, prefix.size(), prefix), 0)
        << "expected a line for " << context_kind_name(kind) << " in:\n"
        << info.selection_report;
    if (kind == info.kind) break;
    line_start = info.selection_report.find('\n', line_start);
    ASSERT_NE(line_start, std::string::npos);
    ++line_start;
  }
  expect_clear_round_trip(*result.value(), 0.0f, 1.0f, 0.0f);
}

TEST(PlatformContext, TwoSurfacelessContextsAtOnce) {
  MODRT_CREATE_OR_SKIP(first, ContextRequest::egl_surfaceless);
  MODRT_CREATE_OR_SKIP(second, ContextRequest::egl_surfaceless);
  for (int round = 0; round < 2; ++round) {
    ASSERT_TRUE(first->make_current().ok());
    expect_clear_round_trip(*first, 1.0f, 0.0f, 0.0f);
    ASSERT_TRUE(second->make_current().ok());
    expect_clear_round_trip(*second, 0.0f, 0.0f, 1.0f);
  }
  // Destroying one must leave the shared display usable by the other.
  second.reset();
  ASSERT_TRUE(first->make_current().ok());
  expect_clear_round_trip(*first, 0.0f, 1.0f, 0.0f);
}

TEST(PlatformContext, ParseRequestRoundTrips) {
  for (ContextRequest request :
       {ContextRequest::auto_select, ContextRequest::egl_device, ContextRequest::egl_surfaceless,
        ContextRequest::egl_pbuffer, ContextRequest::osmesa}) {
    ContextRequest parsed = ContextRequest::auto_select;
    ASSERT_TRUE(parse_context_request(context_request_name(request), &parsed))
        << context_request_name(request);
    EXPECT_EQ(parsed, request);
  }
  ContextRequest parsed = ContextRequest::osmesa;
  ASSERT_TRUE(parse_context_request("egl", &parsed));
  EXPECT_EQ(parsed, ContextRequest::egl_surfaceless);
  parsed = ContextRequest::osmesa;
  EXPECT_FALSE(parse_context_request("foo", &parsed));
  EXPECT_FALSE(parse_context_request("", &parsed));
  EXPECT_EQ(parsed, ContextRequest::osmesa);  // untouched on failure
  EXPECT_STREQ(context_kind_name(ContextKind::egl_pbuffer), "egl-pbuffer");
}

TEST(PlatformContext, OsmesaMissingLibraryIsAnError) {
  ASSERT_EQ(setenv("MODRT_OSMESA_LIBRARY", "/nonexistent/libOSMesa.so", 1), 0);
  auto result = create_context(ContextRequest::osmesa);
  unsetenv("MODRT_OSMESA_LIBRARY");
  ASSERT_FALSE(result.ok());
  const std::string& message = result.status().message();
  EXPECT_NE(message.find("osmesa"), std::string::npos) << message;
  EXPECT_NE(message.find("/nonexistent/libOSMesa.so"), std::string::npos) << message;
  std::printf("[ osmesa, bad library ] %s\n", message.c_str());
}

void check_timer(ContextRequest request) {
  MODRT_CREATE_OR_SKIP(context, request);
  const GlFunctions& gl = context->gl();
  const bool expect_gpu = context->info().gles ? has_gl_extension(gl, "GL_EXT_disjoint_timer_query") : true;
  TargetFbo target(gl, 512, 512);
  GpuTimer timer(gl, context->info().gles, 4);
  std::printf("[ %s ] timer: %s\n", context_request_name(request), timer.method());
  EXPECT_EQ(timer.uses_gpu_queries(), expect_gpu);
  EXPECT_STREQ(timer.method(), expect_gpu ? "GL_TIME_ELAPSED query" : "CPU clock around glFinish");
  int valid_results = 0;
  for (int frame = 0; frame < 3; ++frame) {
    timer.reset();
    EXPECT_EQ(timer.elapsed_ns(0), 0u) << "reset must forget the previous frame";
    for (int scope = 0; scope < 2; ++scope) {
      timer.begin(scope);
      for (int i = 0; i < 4; ++i) {
        gl.glClearColor(0.1f * float(i), 0.2f, 0.3f, 1.0f);
        gl.glClear(GL_COLOR_BUFFER_BIT);
      }
      gl.glFinish();
      timer.end(scope);
    }
    for (int scope = 0; scope < 2; ++scope) {
      bool valid = false;
      const std::uint64_t ns = timer.elapsed_ns(scope, &valid);
      if (!valid) {  // a disjoint event or an implausible result (llvmpipe's first query)
        std::printf("[ %s ] frame %d scope %d: result flagged invalid\n", context_request_name(request),
                    frame, scope);
        continue;
      }
      ++valid_results;
      EXPECT_GT(ns, 0u) << "frame " << frame << " scope " << scope;
      EXPECT_LT(ns, 10'000'000'000ull) << "frame " << frame << " scope " << scope;
    }
    EXPECT_EQ(timer.elapsed_ns(3), 0u);  // never timed
  }
  EXPECT_GE(valid_results, 4) << "most scopes of 3 frames must time validly";
  EXPECT_EQ(gl_error_name(gl.glGetError()), "GL_NO_ERROR");
}

TEST(PlatformTimer, CpuFallbackWithoutQueryEntryPoint) {
  MODRT_CREATE_OR_SKIP(context, ContextRequest::egl_surfaceless);
  GlFunctions gl = context->gl();
  gl.glGetQueryObjectui64vEXT = nullptr;  // as on a GLES driver without EXT_disjoint_timer_query
  GpuTimer timer(gl, true, 2);
  EXPECT_FALSE(timer.uses_gpu_queries());
  EXPECT_STREQ(timer.method(), "CPU clock around glFinish");
  for (int frame = 0; frame < 2; ++frame) {
    timer.reset();
    EXPECT_EQ(timer.elapsed_ns(0), 0u);
    timer.begin(0);
    gl.glClear(GL_COLOR_BUFFER_BIT);
    timer.end(0);
    bool valid = false;
    EXPECT_GT(timer.elapsed_ns(0, &valid), 0u);
    EXPECT_TRUE(valid);
    EXPECT_EQ(timer.elapsed_ns(1), 0u);
  }
}

TEST(PlatformTimer, Surfaceless) { check_timer(ContextRequest::egl_surfaceless); }
TEST(PlatformTimer, Osmesa) { check_timer(ContextRequest::osmesa); }

}  // namespace
}  // namespace modrt::platform
