// SPDX-License-Identifier: MIT
// Private: what the three EGL context kinds share. They differ only in how they obtain an
// EGLDisplay and whether they need a pbuffer surface; everything from eglInitialize on is here.
#pragma once

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <memory>
#include <string>

#include "modrt/platform/gl_context.h"

namespace modrt::platform::detail {

// "EGL_BAD_MATCH" etc.; "EGL error 0x...." for unknown codes.
std::string egl_error_name(EGLint code);
// "<what> failed (EGL_BAD_MATCH)", reading (and so clearing) eglGetError().
std::string egl_failure(const char* what);
// True when the space-separated extension list `list` (may be null) contains `name`.
bool extension_listed(const char* list, const char* name);
// Client extensions (EGL_EXT_client_extensions); empty when the EGL library has none.
std::string egl_client_extensions();

// eglGetPlatformDisplayEXT (EGL_EXT_platform_base) or the EGL 1.5 core eglGetPlatformDisplay.
// Returns EGL_NO_DISPLAY with `*error` set on failure.
EGLDisplay egl_platform_display(EGLenum platform, void* native_display, std::string* error);

enum class EglSurfaceMode {
  surfaceless_if_possible,  // EGL_NO_SURFACE with EGL_KHR_surfaceless_context, else a 1x1 pbuffer
  pbuffer,                  // always a 1x1 pbuffer
};

struct EglSetup {
  ContextKind kind = ContextKind::egl_surfaceless;
  EGLDisplay display = EGL_NO_DISPLAY;  // obtained, not yet initialised
  EglSurfaceMode surface = EglSurfaceMode::surfaceless_if_possible;
  std::string device;  // what the kind knows about the device, for ContextInfo::device
};

// Initialises the display, creates an OpenGL ES 3 context, makes it current and loads its
// entry points. On failure every EGL object it made is released again.
Result<std::unique_ptr<GlContext>> create_egl_context(const EglSetup& setup, const ContextOptions& options);

}  // namespace modrt::platform::detail
