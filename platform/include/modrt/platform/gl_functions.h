// SPDX-License-Identifier: MIT
// modrt::platform — the OpenGL ES 3.0 entry points modrt calls, loaded through the context's
// get-proc-address function into one table.
//
// Why a table and not libGLESv2's exported symbols: OSMesa exports its own gl* symbols, so a
// process that links both would call whichever library the dynamic linker found first, with
// the other's context current. Loading every entry point from the context that is current
// (eglGetProcAddress, OSMesaGetProcAddress, or the host app's loader for an app-owned
// context) makes each call go to the driver that owns the context.
//
// Members are named exactly like the GL functions (`gl.glDrawArrays(...)`) so call sites
// read like plain GL and grep finds them.
#pragma once

#ifndef GL_GLES_PROTOTYPES
#define GL_GLES_PROTOTYPES 0
#endif
#include <GLES3/gl3.h>
// After gl3.h, which defines the calling-convention macros gl2ext.h uses.
#include <GLES2/gl2ext.h>

#include <string>

#include "modrt/status.h"

namespace modrt::platform {

// Entry points of core OpenGL ES 3.0 that modrt uses: loading fails if one is missing.
#define MODRT_GL_CORE_FUNCTIONS(X)                               \
  X(PFNGLACTIVETEXTUREPROC, glActiveTexture)                     \
  X(PFNGLATTACHSHADERPROC, glAttachShader)                       \
  X(PFNGLBEGINQUERYPROC, glBeginQuery)                           \
  X(PFNGLBINDBUFFERPROC, glBindBuffer)                           \
  X(PFNGLBINDFRAMEBUFFERPROC, glBindFramebuffer)                 \
  X(PFNGLBINDSAMPLERPROC, glBindSampler)                         \
  X(PFNGLBINDTEXTUREPROC, glBindTexture)                         \
  X(PFNGLBINDVERTEXARRAYPROC, glBindVertexArray)                 \
  X(PFNGLBLENDFUNCPROC, glBlendFunc)                             \
  X(PFNGLBUFFERDATAPROC, glBufferData)                           \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, glCheckFramebufferStatus)   \
  X(PFNGLCLEARPROC, glClear)                                     \
  X(PFNGLCLEARBUFFERFVPROC, glClearBufferfv)                     \
  X(PFNGLCLEARBUFFERUIVPROC, glClearBufferuiv)                   \
  X(PFNGLCLEARCOLORPROC, glClearColor)                           \
  X(PFNGLCOMPILESHADERPROC, glCompileShader)                     \
  X(PFNGLCLEARDEPTHFPROC, glClearDepthf)                         \
  X(PFNGLCOLORMASKPROC, glColorMask)                             \
  X(PFNGLCREATEPROGRAMPROC, glCreateProgram)                     \
  X(PFNGLCREATESHADERPROC, glCreateShader)                       \
  X(PFNGLCULLFACEPROC, glCullFace)                               \
  X(PFNGLDELETEBUFFERSPROC, glDeleteBuffers)                     \
  X(PFNGLDELETEFRAMEBUFFERSPROC, glDeleteFramebuffers)           \
  X(PFNGLDELETEPROGRAMPROC, glDeleteProgram)                     \
  X(PFNGLDELETEQUERIESPROC, glDeleteQueries)                     \
  X(PFNGLDELETESAMPLERSPROC, glDeleteSamplers)                   \
  X(PFNGLDELETESHADERPROC, glDeleteShader)                       \
  X(PFNGLDELETETEXTURESPROC, glDeleteTextures)                   \
  X(PFNGLDELETEVERTEXARRAYSPROC, glDeleteVertexArrays)           \
  X(PFNGLDEPTHFUNCPROC, glDepthFunc)                             \
  X(PFNGLDEPTHMASKPROC, glDepthMask)                             \
  X(PFNGLDISABLEPROC, glDisable)                                 \
  X(PFNGLDRAWARRAYSPROC, glDrawArrays)                           \
  X(PFNGLDRAWBUFFERSPROC, glDrawBuffers)                         \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, glEnableVertexAttribArray) \
  X(PFNGLENABLEPROC, glEnable)                                   \
  X(PFNGLENDQUERYPROC, glEndQuery)                               \
  X(PFNGLFINISHPROC, glFinish)                                   \
  X(PFNGLFLUSHPROC, glFlush)                                     \
  X(PFNGLFRAMEBUFFERTEXTURE2DPROC, glFramebufferTexture2D)       \
  X(PFNGLGENBUFFERSPROC, glGenBuffers)                           \
  X(PFNGLGENFRAMEBUFFERSPROC, glGenFramebuffers)                 \
  X(PFNGLGENQUERIESPROC, glGenQueries)                           \
  X(PFNGLGENSAMPLERSPROC, glGenSamplers)                         \
  X(PFNGLGENTEXTURESPROC, glGenTextures)                         \
  X(PFNGLGENVERTEXARRAYSPROC, glGenVertexArrays)                 \
  X(PFNGLGENERATEMIPMAPPROC, glGenerateMipmap)                   \
  X(PFNGLGETERRORPROC, glGetError)                               \
  X(PFNGLGETINTEGERVPROC, glGetIntegerv)                         \
  X(PFNGLGETPROGRAMINFOLOGPROC, glGetProgramInfoLog)             \
  X(PFNGLGETPROGRAMIVPROC, glGetProgramiv)                       \
  X(PFNGLGETQUERYOBJECTUIVPROC, glGetQueryObjectuiv)             \
  X(PFNGLGETSHADERINFOLOGPROC, glGetShaderInfoLog)               \
  X(PFNGLGETSHADERIVPROC, glGetShaderiv)                         \
  X(PFNGLGETSTRINGPROC, glGetString)                             \
  X(PFNGLGETSTRINGIPROC, glGetStringi)                           \
  X(PFNGLGETUNIFORMLOCATIONPROC, glGetUniformLocation)           \
  X(PFNGLISTEXTUREPROC, glIsTexture)                             \
  X(PFNGLLINKPROGRAMPROC, glLinkProgram)                         \
  X(PFNGLPIXELSTOREIPROC, glPixelStorei)                         \
  X(PFNGLPOLYGONOFFSETPROC, glPolygonOffset)                     \
  X(PFNGLREADBUFFERPROC, glReadBuffer)                           \
  X(PFNGLREADPIXELSPROC, glReadPixels)                           \
  X(PFNGLSAMPLERPARAMETERIPROC, glSamplerParameteri)             \
  X(PFNGLSCISSORPROC, glScissor)                                 \
  X(PFNGLSHADERSOURCEPROC, glShaderSource)                       \
  X(PFNGLTEXPARAMETERIPROC, glTexParameteri)                     \
  X(PFNGLTEXSTORAGE2DPROC, glTexStorage2D)                       \
  X(PFNGLTEXSUBIMAGE2DPROC, glTexSubImage2D)                     \
  X(PFNGLUNIFORM1FPROC, glUniform1f)                             \
  X(PFNGLUNIFORM1IPROC, glUniform1i)                             \
  X(PFNGLUNIFORM2IPROC, glUniform2i)                             \
  X(PFNGLUNIFORM4IPROC, glUniform4i)                             \
  X(PFNGLUNIFORM3FPROC, glUniform3f)                             \
  X(PFNGLUNIFORM3FVPROC, glUniform3fv)                           \
  X(PFNGLUNIFORM4FPROC, glUniform4f)                             \
  X(PFNGLUNIFORMMATRIX3FVPROC, glUniformMatrix3fv)               \
  X(PFNGLUNIFORMMATRIX4FVPROC, glUniformMatrix4fv)               \
  X(PFNGLUSEPROGRAMPROC, glUseProgram)                           \
  X(PFNGLVERTEXATTRIBPOINTERPROC, glVertexAttribPointer)         \
  X(PFNGLVIEWPORTPROC, glViewport)

// Optional entry points (GPU timer queries): null when the context lacks them. The loader
// tries the EXT name first (EXT_disjoint_timer_query on GLES) and then the core desktop GL
// 3.3 name (ARB_timer_query, e.g. OSMesa's core profile).
#define MODRT_GL_OPTIONAL_FUNCTIONS(X)                                                  \
  X(PFNGLGETQUERYOBJECTUI64VEXTPROC, glGetQueryObjectui64vEXT, "glGetQueryObjectui64v") \
  X(PFNGLQUERYCOUNTEREXTPROC, glQueryCounterEXT, "glQueryCounter")

struct GlFunctions {
#define MODRT_GL_MEMBER(type, name) type name = nullptr;
  MODRT_GL_CORE_FUNCTIONS(MODRT_GL_MEMBER)
#undef MODRT_GL_MEMBER
#define MODRT_GL_OPTIONAL_MEMBER(type, name, fallback) type name = nullptr;
  MODRT_GL_OPTIONAL_FUNCTIONS(MODRT_GL_OPTIONAL_MEMBER)
#undef MODRT_GL_OPTIONAL_MEMBER
};

// Returns the address of a GL entry point, or null. `user` is passed through unchanged.
using GlProcLoader = void* (*)(const char* name, void* user);

// Fills `out` from `loader`. Fails with internal_error naming the first missing core entry
// point (which means the context is not OpenGL ES 3.0 capable).
Status load_gl_functions(GlProcLoader loader, void* user, GlFunctions* out);

// True when the current context lists `name` in GL_EXTENSIONS (glGetStringi).
bool has_gl_extension(const GlFunctions& gl, const char* name);

// "GL_INVALID_OPERATION" etc.; "GL error 0x...." for unknown codes.
std::string gl_error_name(GLenum error);

}  // namespace modrt::platform
