// SPDX-License-Identifier: MIT
#include "modrt/platform/gpu_timer.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

namespace modrt::platform {
namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

bool timer_queries_available(const GlFunctions& gl, bool gles) {
  if (!gl.glGetQueryObjectui64vEXT) return false;
  // Loaders hand out stubs for names the driver does not implement, so the pointer alone
  // proves nothing: the extension (GLES) or the core version (desktop) does.
  if (gles) return has_gl_extension(gl, "GL_EXT_disjoint_timer_query");
  const auto* version = reinterpret_cast<const char*>(gl.glGetString(GL_VERSION));
  int major = 0, minor = 0;
  if (!version || std::sscanf(version, "%d.%d", &major, &minor) != 2) return false;
  return major > 3 || (major == 3 && minor >= 3);
}

}  // namespace

GpuTimer::GpuTimer(const GlFunctions& gl, bool gles, int max_scopes) : gl_(gl), gles_(gles) {
  const auto count = static_cast<std::size_t>(std::max(max_scopes, 1));
  gpu_ = timer_queries_available(gl_, gles_);
  if (gpu_) {
    queries_.resize(count);
    gl_.glGenQueries(static_cast<GLsizei>(count), queries_.data());
  }
  cpu_ns_.assign(count, 0);
  used_.assign(count, false);
  reset();
}

GpuTimer::~GpuTimer() {
  if (!queries_.empty()) gl_.glDeleteQueries(static_cast<GLsizei>(queries_.size()), queries_.data());
}

const char* GpuTimer::method() const { return gpu_ ? "GL_TIME_ELAPSED query" : "CPU clock around glFinish"; }

void GpuTimer::reset() {
  std::fill(used_.begin(), used_.end(), false);
  std::fill(cpu_ns_.begin(), cpu_ns_.end(), 0);
  disjoint_ = false;
  if (gpu_ && gles_) {
    GLint disjoint = 0;  // reading clears the flag, so this frame starts clean
    gl_.glGetIntegerv(GL_GPU_DISJOINT_EXT, &disjoint);
  }
}

void GpuTimer::begin(int scope) {
  if (scope < 0 || static_cast<std::size_t>(scope) >= used_.size()) return;
  if (gpu_) {
    // The begin time bounds the result: see elapsed_ns.
    cpu_ns_[static_cast<std::size_t>(scope)] = static_cast<std::uint64_t>(now_ns());
    gl_.glBeginQuery(GL_TIME_ELAPSED_EXT, queries_[static_cast<std::size_t>(scope)]);
  } else {
    gl_.glFinish();  // earlier work must not be billed to this scope
    cpu_start_ = now_ns();
  }
}

void GpuTimer::end(int scope) {
  if (scope < 0 || static_cast<std::size_t>(scope) >= used_.size()) return;
  const auto i = static_cast<std::size_t>(scope);
  if (gpu_) {
    gl_.glEndQuery(GL_TIME_ELAPSED_EXT);
  } else {
    gl_.glFinish();
    cpu_ns_[i] = static_cast<std::uint64_t>(std::max<std::int64_t>(now_ns() - cpu_start_, 0));
  }
  used_[i] = true;
}

std::uint64_t GpuTimer::elapsed_ns(int scope, bool* valid) {
  if (valid) *valid = true;
  if (scope < 0 || static_cast<std::size_t>(scope) >= used_.size()) return 0;
  const auto i = static_cast<std::size_t>(scope);
  if (!used_[i]) return 0;
  if (!gpu_) return cpu_ns_[i];
  GLuint64 result = 0;
  gl_.glGetQueryObjectui64vEXT(queries_[i], GL_QUERY_RESULT, &result);  // blocks until available
  if (gles_) {
    GLint disjoint = 0;
    gl_.glGetIntegerv(GL_GPU_DISJOINT_EXT, &disjoint);
    if (disjoint) disjoint_ = true;
  }
  // GPU time spent on commands issued after begin() cannot exceed the wall time since then.
  // llvmpipe breaks this on a context's first TIME_ELAPSED query (it reports an absolute
  // timestamp, ~uptime); such a result is flagged invalid rather than passed on.
  const auto wall = static_cast<std::uint64_t>(now_ns()) - cpu_ns_[i];
  const bool plausible = static_cast<std::uint64_t>(result) <= wall;
  if (valid) *valid = !disjoint_ && plausible;
  return plausible ? static_cast<std::uint64_t>(result) : 0;
}

}  // namespace modrt::platform
