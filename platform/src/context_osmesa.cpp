// SPDX-License-Identifier: MIT
// osmesa: Mesa's off-screen library, loaded with dlopen so that libmodrt_platform links only
// EGL and runs where OSMesa is absent. It gives desktop GL (4.5, else 3.3) core profile, and
// modrt's "#version 300 es" shaders run there through GL_ARB_ES3_compatibility.
#include <dlfcn.h>

// osmesa.h is used for its constants and types only; every function comes from dlsym.
#include <GL/osmesa.h>

#include <cstdlib>
#include <string>

#include "context_kinds.h"

namespace modrt::platform::detail {
namespace {

using CreateContextAttribsFn = OSMesaContext (*)(const int*, OSMesaContext);
using MakeCurrentFn = GLboolean (*)(OSMesaContext, void*, GLenum, GLsizei, GLsizei);
using DestroyContextFn = void (*)(OSMesaContext);
using GetCurrentContextFn = OSMesaContext (*)();
using GetProcAddressFn = OSMESAproc (*)(const char*);

struct OsmesaApi {
  std::string library;
  CreateContextAttribsFn create_context_attribs = nullptr;
  MakeCurrentFn make_current = nullptr;
  DestroyContextFn destroy_context = nullptr;
  GetCurrentContextFn get_current_context = nullptr;  // optional
  GetProcAddressFn get_proc_address = nullptr;
};

const std::string kName = context_kind_name(ContextKind::osmesa);

Status osmesa_error(const std::string& message) {
  return Status::error(ErrorCode::internal_error, kName + ": " + message);
}

// A successfully loaded libOSMesa is never dlclosed: Mesa keeps a process-wide screen and
// llvmpipe's rasterizer threads alive after the last context, and unmapping their code would
// crash them. dlopen of an already loaded library only bumps its count, so each context may
// call this.
Status load_osmesa(OsmesaApi* api) {
  const char* override_name = std::getenv("MODRT_OSMESA_LIBRARY");
  const char* candidates[] = {override_name, override_name ? nullptr : "libOSMesa.so.8",
                              override_name ? nullptr : "libOSMesa.so"};
  void* handle = nullptr;
  std::string errors;
  for (const char* candidate : candidates) {
    if (!candidate || !*candidate) continue;
    handle = dlopen(candidate, RTLD_NOW | RTLD_LOCAL);
    if (handle) {
      api->library = candidate;
      break;
    }
    const char* why = dlerror();
    errors += (errors.empty() ? "" : "; ") + std::string(why ? why : candidate);
  }
  if (!handle)
    return osmesa_error("cannot load the OSMesa library (" + errors +
                        "); install libosmesa6 or set MODRT_OSMESA_LIBRARY");

  auto symbol = [&](const char* name) { return dlsym(handle, name); };
  api->create_context_attribs =
      reinterpret_cast<CreateContextAttribsFn>(symbol("OSMesaCreateContextAttribs"));
  api->make_current = reinterpret_cast<MakeCurrentFn>(symbol("OSMesaMakeCurrent"));
  api->destroy_context = reinterpret_cast<DestroyContextFn>(symbol("OSMesaDestroyContext"));
  api->get_current_context = reinterpret_cast<GetCurrentContextFn>(symbol("OSMesaGetCurrentContext"));
  api->get_proc_address = reinterpret_cast<GetProcAddressFn>(symbol("OSMesaGetProcAddress"));
  if (!api->create_context_attribs || !api->make_current || !api->destroy_context || !api->get_proc_address) {
    dlclose(handle);  // nothing was created with it yet
    return osmesa_error(api->library +
                        " lacks OSMesaCreateContextAttribs/OSMesaMakeCurrent/OSMesaDestroyContext/"
                        "OSMesaGetProcAddress (Mesa older than 12?)");
  }
  return Status::success();
}

void* osmesa_gl_loader(const char* name, void* user) {
  return reinterpret_cast<void*>(static_cast<const OsmesaApi*>(user)->get_proc_address(name));
}

class OsmesaContext final : public GlContext {
 public:
  OsmesaContext() {
    info_.kind = ContextKind::osmesa;
    info_.gles = false;
  }
  ~OsmesaContext() override {
    if (!context_) return;
    if (api_.get_current_context && api_.get_current_context() == context_)
      api_.make_current(nullptr, nullptr, 0, 0, 0);  // Mesa accepts this as "release current"
    api_.destroy_context(context_);
  }

  Status make_current() override {
    // OSMesa needs a colour buffer to bind; modrt never draws to it (it renders into FBOs).
    if (!api_.make_current(context_, buffer_, GL_UNSIGNED_BYTE, kSize, kSize))
      return osmesa_error("OSMesaMakeCurrent failed");
    return Status::success();
  }

  Status init() {
    if (Status s = load_osmesa(&api_); !s) return s;
    for (int minor_version : {5, 3}) {
      const int major_version = minor_version == 5 ? 4 : 3;
      const int attribs[] = {OSMESA_FORMAT,
                             OSMESA_RGBA,
                             OSMESA_DEPTH_BITS,
                             0,
                             OSMESA_STENCIL_BITS,
                             0,
                             OSMESA_PROFILE,
                             OSMESA_CORE_PROFILE,
                             OSMESA_CONTEXT_MAJOR_VERSION,
                             major_version,
                             OSMESA_CONTEXT_MINOR_VERSION,
                             minor_version,
                             0};
      context_ = api_.create_context_attribs(attribs, nullptr);
      if (context_) break;
    }
    if (!context_)
      return osmesa_error("OSMesaCreateContextAttribs failed for GL 4.5 and 3.3 core profile (" +
                          api_.library + ")");
    if (Status s = make_current(); !s) return s;
    if (Status s = load_gl_functions(osmesa_gl_loader, &api_, &gl_); !s) return osmesa_error(s.message());
    read_gl_strings(gl_, &info_);
    if (!has_gl_extension(gl_, "GL_ARB_ES3_compatibility"))
      return osmesa_error("GL " + info_.version +
                          " lacks GL_ARB_ES3_compatibility, needed to run OpenGL ES 3.0 shaders");
    info_.device = "OSMesa (" + api_.library + "), desktop GL core profile";
    return Status::success();
  }

 private:
  static constexpr int kSize = 4;
  OsmesaApi api_;
  OSMesaContext context_ = nullptr;
  unsigned char buffer_[kSize * kSize * 4] = {};
};

}  // namespace

Result<std::unique_ptr<GlContext>> create_osmesa_context(const ContextOptions&) {
  auto context = std::make_unique<OsmesaContext>();
  if (Status s = context->init(); !s) return s;  // ~OsmesaContext releases what init made
  return std::unique_ptr<GlContext>(std::move(context));
}

}  // namespace modrt::platform::detail
