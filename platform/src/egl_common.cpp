// SPDX-License-Identifier: MIT
#include "egl_common.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string_view>

#include "context_kinds.h"

namespace modrt::platform::detail {
namespace {

// EGLDisplays are per-process singletons (eglGetPlatformDisplay returns the same handle each
// time, and eglInitialize on an initialised display only reports its version), so contexts of
// one kind share one. modrt never calls eglTerminate: it would pull the display out from under
// every other context on it, the host app's included, and with Mesa it also unloads the
// driver, orphaning state the driver allocated once (a leak per terminate). A display stays
// initialised until the process ends, as in most GL applications.
Status initialise_display(EGLDisplay display, const char* kind, EGLint* major, EGLint* minor) {
  eglGetError();
  if (!eglInitialize(display, major, minor))
    return Status::error(ErrorCode::internal_error, std::string(kind) + ": " + egl_failure("eglInitialize"));
  return Status::success();
}

void* egl_gl_loader(const char* name, void*) { return reinterpret_cast<void*>(eglGetProcAddress(name)); }

class EglContext final : public GlContext {
 public:
  explicit EglContext(const EglSetup& setup) : display_(setup.display), name_(context_kind_name(setup.kind)) {
    info_.kind = setup.kind;
    info_.gles = true;
  }
  ~EglContext() override { release(); }

  Status make_current() override {
    if (!eglBindAPI(EGL_OPENGL_ES_API)) return fail("eglBindAPI(EGL_OPENGL_ES_API)");
    // Release first: OSMesa and Mesa's EGL share one glapi current-context slot, so after an
    // OSMesa context was made current EGL may still believe this context is current and skip
    // the rebind, leaving GL calls going to the OSMesa context.
    if (eglGetCurrentContext() == context_)
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (!eglMakeCurrent(display_, surface_, surface_, context_)) return fail("eglMakeCurrent");
    return Status::success();
  }

  Status init(const EglSetup& setup, const ContextOptions& options);

 private:
  Status fail(const char* what) const {
    return Status::error(ErrorCode::internal_error, name_ + ": " + egl_failure(what));
  }
  Status fail_message(const std::string& message) const {
    return Status::error(ErrorCode::internal_error, name_ + ": " + message);
  }
  void release();

  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  EGLSurface surface_ = EGL_NO_SURFACE;
  std::string name_;
};

Status EglContext::init(const EglSetup& setup, const ContextOptions& options) {
  EGLint major = 0, minor = 0;
  if (Status s = initialise_display(display_, name_.c_str(), &major, &minor); !s) return s;
  const char* extensions = eglQueryString(display_, EGL_EXTENSIONS);
  const bool egl15 = major > 1 || (major == 1 && minor >= 5);
  const bool surfaceless = setup.surface == EglSurfaceMode::surfaceless_if_possible &&
                           extension_listed(extensions, "EGL_KHR_surfaceless_context");

  if (!eglBindAPI(EGL_OPENGL_ES_API)) return fail("eglBindAPI(EGL_OPENGL_ES_API)");

  // Colour bits do not matter: modrt renders only into its own framebuffer objects.
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE,
                                   surfaceless ? 0 : EGL_PBUFFER_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint config_count = 0;
  if (!eglChooseConfig(display_, config_attribs, &config, 1, &config_count)) return fail("eglChooseConfig");
  if (config_count < 1)
    return fail_message(surfaceless ? "no EGL config supports OpenGL ES 3 (EGL_OPENGL_ES3_BIT)"
                                    : "no EGL config supports OpenGL ES 3 with pbuffer surfaces");

  // A debug context is a nicety: ask for it where EGL can express it, retry without on refusal.
  const bool can_debug = egl15 || extension_listed(extensions, "EGL_KHR_create_context");
  for (int attempt = (options.debug && can_debug) ? 0 : 1; attempt < 2 && context_ == EGL_NO_CONTEXT;
       ++attempt) {
    EGLint attribs[8];
    int n = 0;
    attribs[n++] = EGL_CONTEXT_MAJOR_VERSION;
    attribs[n++] = 3;
    if (attempt == 0) {
      attribs[n++] = egl15 ? EGL_CONTEXT_OPENGL_DEBUG : EGL_CONTEXT_FLAGS_KHR;
      attribs[n++] = egl15 ? EGL_TRUE : EGL_CONTEXT_OPENGL_DEBUG_BIT_KHR;
    }
    attribs[n] = EGL_NONE;
    context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, attribs);
    if (context_ == EGL_NO_CONTEXT && attempt == 1) return fail("eglCreateContext(OpenGL ES 3)");
  }

  if (!surfaceless) {
    const EGLint pbuffer_attribs[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
    surface_ = eglCreatePbufferSurface(display_, config, pbuffer_attribs);
    if (surface_ == EGL_NO_SURFACE) return fail("eglCreatePbufferSurface(1x1)");
  }
  if (Status s = make_current(); !s) return s;

  if (Status s = load_gl_functions(egl_gl_loader, nullptr, &gl_); !s) return fail_message(s.message());
  read_gl_strings(gl_, &info_);
  if (info_.version.rfind("OpenGL ES 3", 0) != 0)
    return fail_message("the context is not OpenGL ES 3 (GL_VERSION \"" + info_.version + "\")");

  std::string device = setup.device;
  if (!device.empty()) device += "; ";
  const char* vendor = eglQueryString(display_, EGL_VENDOR);
  device +=
      "EGL " + std::to_string(major) + "." + std::to_string(minor) + " (" + (vendor ? vendor : "?") + ")";
  if (extension_listed(extensions, "EGL_MESA_query_driver")) {
    auto driver_name =
        reinterpret_cast<PFNEGLGETDISPLAYDRIVERNAMEPROC>(eglGetProcAddress("eglGetDisplayDriverName"));
    const char* driver = driver_name ? driver_name(display_) : nullptr;
    if (driver) device += std::string(", driver ") + driver;
  }
  device += surfaceless ? ", no surface" : ", 1x1 pbuffer";
  info_.device = device;
  return Status::success();
}

void EglContext::release() {
  if (context_ != EGL_NO_CONTEXT) {
    // eglGetCurrentContext answers for the bound API: look with ours bound, then restore the
    // thread's API so a host app using another one is not disturbed.
    const EGLenum api = eglQueryAPI();
    eglBindAPI(EGL_OPENGL_ES_API);
    if (eglGetCurrentContext() == context_)
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
    if (api != EGL_NONE) eglBindAPI(api);
    context_ = EGL_NO_CONTEXT;
  }
  if (surface_ != EGL_NO_SURFACE) {
    eglDestroySurface(display_, surface_);
    surface_ = EGL_NO_SURFACE;
  }
}

}  // namespace

std::string egl_error_name(EGLint code) {
  switch (code) {
    case EGL_SUCCESS: return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_CURRENT_SURFACE: return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_NATIVE_PIXMAP: return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
    case EGL_CONTEXT_LOST: return "EGL_CONTEXT_LOST";
    case EGL_BAD_DEVICE_EXT: return "EGL_BAD_DEVICE_EXT";
    default: {
      char buf[32];
      std::snprintf(buf, sizeof buf, "EGL error 0x%04x", unsigned(code));
      return buf;
    }
  }
}

std::string egl_failure(const char* what) {
  return std::string(what) + " failed (" + egl_error_name(eglGetError()) + ")";
}

bool extension_listed(const char* list, const char* name) {
  if (!list) return false;
  const std::string_view all(list), wanted(name);
  for (std::size_t pos = 0; pos < all.size();) {
    const std::size_t end = std::min(all.find(' ', pos), all.size());
    if (all.substr(pos, end - pos) == wanted) return true;
    pos = end + 1;
  }
  return false;
}

std::string egl_client_extensions() {
  const char* list = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!list) eglGetError();  // EGL_BAD_DISPLAY without EGL_EXT_client_extensions: not an error for us
  return list ? list : "";
}

EGLDisplay egl_platform_display(EGLenum platform, void* native_display, std::string* error) {
  EGLDisplay display = EGL_NO_DISPLAY;
  if (extension_listed(egl_client_extensions().c_str(), "EGL_EXT_platform_base")) {
    auto get =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get) display = get(platform, native_display, nullptr);
  } else {
    auto get = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYPROC>(eglGetProcAddress("eglGetPlatformDisplay"));
    if (get)
      display = get(platform, native_display, nullptr);
    else if (error)
      *error = "neither eglGetPlatformDisplayEXT nor eglGetPlatformDisplay is available";
  }
  if (display == EGL_NO_DISPLAY && error && error->empty()) *error = egl_failure("eglGetPlatformDisplay");
  return display;
}

Result<std::unique_ptr<GlContext>> create_egl_context(const EglSetup& setup, const ContextOptions& options) {
  auto context = std::make_unique<EglContext>(setup);
  if (Status s = context->init(setup, options); !s) return s;  // ~EglContext releases what init made
  return std::unique_ptr<GlContext>(std::move(context));
}

}  // namespace modrt::platform::detail
