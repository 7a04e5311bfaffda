// SPDX-License-Identifier: MIT
// modrt::platform — timing GL work: GPU timer queries where the context has them
// (EXT_disjoint_timer_query on GLES, GL_TIME_ELAPSED on desktop GL 3.3+), else CPU time
// around glFinish. A small class of its own, apart from the passes it times.
#pragma once

#include <cstdint>
#include <vector>

#include "modrt/platform/gl_functions.h"

namespace modrt::platform {

class GpuTimer {
 public:
  // `gl` must outlive the timer and its context must be current whenever a method is called.
  // `max_scopes`: how many begin()/end() pairs one frame may hold.
  GpuTimer(const GlFunctions& gl, bool gles, int max_scopes = 16);
  ~GpuTimer();
  GpuTimer(const GpuTimer&) = delete;
  GpuTimer& operator=(const GpuTimer&) = delete;

  // True when GPU timer queries are used; false when CPU time around glFinish is.
  bool uses_gpu_queries() const { return gpu_; }
  const char* method() const;  // "GL_TIME_ELAPSED query" or "CPU clock around glFinish"

  // Starts a frame: forgets the previous frame's scopes.
  void reset();
  // Times the GL commands issued between begin(i) and end(i); one scope open at a time.
  void begin(int scope);
  void end(int scope);
  // Waits for the results and returns scope i's time in nanoseconds (0 if never timed). With
  // EXT_disjoint_timer_query, a GPU_DISJOINT event makes every scope of the frame invalid:
  // then `valid` is false and the caller should discard the frame. A query result longer than
  // the wall time since begin(i) (llvmpipe's first query on a context) is also reported as
  // invalid, and 0 is returned for it.
  std::uint64_t elapsed_ns(int scope, bool* valid = nullptr);

 private:
  const GlFunctions& gl_;
  bool gpu_ = false;
  bool gles_ = true;
  bool disjoint_ = false;  // GPU_DISJOINT seen since reset(): reading it clears it in GL
  std::vector<GLuint> queries_;
  std::vector<std::uint64_t> cpu_ns_;  // CPU path: scope times; GPU path: begin() timestamps
  std::vector<bool> used_;
  std::int64_t cpu_start_ = 0;
};

}  // namespace modrt::platform
