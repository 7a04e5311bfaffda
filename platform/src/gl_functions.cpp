// SPDX-License-Identifier: MIT
#include "modrt/platform/gl_functions.h"

#include <cstdio>
#include <cstring>

namespace modrt::platform {

Status load_gl_functions(GlProcLoader loader, void* user, GlFunctions* out) {
  if (!loader || !out)
    return Status::error(ErrorCode::invalid_argument, "load_gl_functions: null loader or table");
  GlFunctions gl;
#define MODRT_GL_LOAD(type, name)                                                      \
  gl.name = reinterpret_cast<type>(loader(#name, user));                               \
  if (!gl.name)                                                                        \
    return Status::error(ErrorCode::internal_error, "OpenGL ES 3.0 entry point " #name \
                                                    " not found: the context is not ES 3.0 capable");
  MODRT_GL_CORE_FUNCTIONS(MODRT_GL_LOAD)
#undef MODRT_GL_LOAD
#define MODRT_GL_LOAD_OPTIONAL(type, name, fallback)     \
  gl.name = reinterpret_cast<type>(loader(#name, user)); \
  if (!gl.name) gl.name = reinterpret_cast<type>(loader(fallback, user));
  MODRT_GL_OPTIONAL_FUNCTIONS(MODRT_GL_LOAD_OPTIONAL)
#undef MODRT_GL_LOAD_OPTIONAL
  *out = gl;
  return Status::success();
}

bool has_gl_extension(const GlFunctions& gl, const char* name) {
  GLint count = 0;
  gl.glGetIntegerv(GL_NUM_EXTENSIONS, &count);
  for (GLint i = 0; i < count; ++i) {
    const auto* ext = reinterpret_cast<const char*>(gl.glGetStringi(GL_EXTENSIONS, GLuint(i)));
    if (ext && std::strcmp(ext, name) == 0) return true;
  }
  return false;
}

std::string gl_error_name(GLenum error) {
  switch (error) {
    case GL_NO_ERROR: return "GL_NO_ERROR";
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    default: {
      char buf[32];
      std::snprintf(buf, sizeof buf, "GL error 0x%04x", unsigned(error));
      return buf;
    }
  }
}

}  // namespace modrt::platform
