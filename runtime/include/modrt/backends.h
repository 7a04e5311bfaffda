// SPDX-License-Identifier: MIT
// modrt — creating a backend by kind (architecture.md §5): one creator table, indexed by
// BackendKind and checked against it at compile time, so a caller switches between the CPU and
// GLES backends by a value, and a kind this build left out is a clear error, not a link error.
// C++ only: in libmodrt_runtime.a (modrt::runtime_static); the shared library exports the C API.
#pragma once

#include <memory>

#include "modrt/backend.h"
#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/status.h"

namespace modrt {

namespace platform {
struct GlFunctions;
}

struct BackendCreateInfo {
  // Borrowed: both must outlive the backend.
  const Level* level = nullptr;
  const Dictionary* dict = nullptr;
  int threads = 1;                 // cpu: threads working on a frame, the caller's included
  bool skip_unchanged = true;      // exact skipping of unchanged blocks, slots and tiles
  bool probes = true;              // evaluate the volume probes (when the dictionary has them)
  bool vector_irradiance = false;  // gles: the four OHLSH atlases (cpu: computed on read)
  bool timing = false;             // per-stage times (Backend::stage_times)
  // gles: the current GL context's entry points (platform::GlContext::gl() or
  // platform::load_gl_functions on the app's context) and whether it is an ES context.
  const platform::GlFunctions* gl = nullptr;
  bool gles_context = true;
};

// The backend of `kind` for info.level and info.dict. Fails (invalid_argument) for a null level
// or dictionary, a kind out of range, a GLES backend without info.gl, or a kind this build was
// configured without (MODRT_BUILD_GLES=OFF); otherwise as the backend's own create().
Result<std::unique_ptr<Backend>> create_backend(BackendKind kind, const BackendCreateInfo& info);

}  // namespace modrt
