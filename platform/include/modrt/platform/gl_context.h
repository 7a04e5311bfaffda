// SPDX-License-Identifier: MIT
// modrt::platform — creating an OpenGL ES 3 capable context without a window.
//
// One small interface, one implementation file per context kind (Filament's
// PlatformEGLHeadless / PlatformOSMesa split):
//   egl_device      EGL_EXT_platform_device: a GPU without a display (NVIDIA headless);
//   egl_surfaceless EGL_MESA_platform_surfaceless: Mesa (llvmpipe or a DRM driver);
//   egl_pbuffer     the default EGL display with a 1x1 pbuffer surface;
//   osmesa          Mesa's OSMesa (libOSMesa.so.8, loaded at run time): desktop GL 4.5 core,
//                   which runs modrt's "#version 300 es" shaders through ARB_ES3_compatibility.
//                   The environment variable MODRT_OSMESA_LIBRARY, when set, names the library
//                   to dlopen instead (a path or a soname; no fallback to the default names).
// modrt renders only into its own framebuffer objects, so no context needs a real surface.
//
// auto_select tries, in order, egl_device on a hardware device, egl_surfaceless,
// egl_pbuffer and osmesa, and records why each earlier kind was passed over
// (ContextInfo::selection_report), so a user can see what was chosen and why.
#pragma once

#include <memory>
#include <string>

#include "modrt/platform/gl_functions.h"
#include "modrt/status.h"

namespace modrt::platform {

enum class ContextKind { egl_device, egl_surfaceless, egl_pbuffer, osmesa };
enum class ContextRequest { auto_select, egl_device, egl_surfaceless, egl_pbuffer, osmesa };

// "egl-device", "egl-surfaceless", "egl-pbuffer", "osmesa" (and "auto" for the request).
const char* context_kind_name(ContextKind kind);
const char* context_request_name(ContextRequest request);
// Parses the names above (also "egl" = egl_surfaceless); false on an unknown name.
bool parse_context_request(const std::string& name, ContextRequest* out);

struct ContextOptions {
  bool debug = false;  // ask for a debug context where the platform can (KHR_debug)
};

struct ContextInfo {
  ContextKind kind = ContextKind::egl_surfaceless;
  bool gles = true;          // an OpenGL ES context (false: desktop GL core profile, OSMesa)
  std::string version;       // GL_VERSION
  std::string glsl_version;  // GL_SHADING_LANGUAGE_VERSION
  std::string renderer;      // GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string vendor;        // GL_VENDOR
  std::string device;        // EGL device / driver detail where known, else empty
  // One line per kind tried: "egl-device: no hardware EGL device (only a Mesa software device)"
  // ... "egl-surfaceless: chosen". For an explicit request, just that kind's line.
  std::string selection_report;
};

// A current-able GL context with its entry points loaded. Not thread-safe: use it from one
// thread at a time, and make_current() on that thread first.
class GlContext {
 public:
  virtual ~GlContext() = default;
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  // Binds the context to the calling thread.
  virtual Status make_current() = 0;

  const ContextInfo& info() const { return info_; }
  const GlFunctions& gl() const { return gl_; }

 protected:
  GlContext() = default;
  ContextInfo info_;
  GlFunctions gl_;
};

// Creates a context of the requested kind (or the first that works for auto_select), makes
// it current on the calling thread and loads its entry points. Never crashes when a driver
// or library is missing: the error says which kind failed and why (every kind for auto).
Result<std::unique_ptr<GlContext>> create_context(ContextRequest request, const ContextOptions& options = {});

}  // namespace modrt::platform
