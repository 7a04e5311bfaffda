// SPDX-License-Identifier: MIT
// modrt::platform — GL objects every modrt renderer needs, with errors that name what
// failed: shader programs (compile and link logs), textures, render targets. Used by the
// GLES backend (gles/) and the demo renderer.
#pragma once

#include <initializer_list>
#include <string>

#include "modrt/platform/gl_functions.h"
#include "modrt/status.h"

namespace modrt::platform {

// Compiles `vertex` + `fragment` (each given as source pieces, concatenated) and links them.
// Fails with internal_error naming `name` and carrying the compiler or linker log.
Result<GLuint> build_program(const GlFunctions& gl, const char* name,
                             std::initializer_list<const char*> vertex,
                             std::initializer_list<const char*> fragment);

// Assigns texture units 0, 1, ... to the named sampler uniforms, in order (program in use).
void assign_sampler_units(const GlFunctions& gl, GLuint program, std::initializer_list<const char*> samplers);
// Sets an int uniform by name (program in use); silently ignores names the compiler removed.
void set_int(const GlFunctions& gl, GLuint program, const char* name, int value);

// A 2D texture with immutable storage, nearest filtering and clamped addressing.
GLuint create_texture(const GlFunctions& gl, GLenum internal_format, int width, int height);
// A framebuffer with `textures` as colour attachments 0..n-1 and draw buffers set. Fails when
// the framebuffer is incomplete, naming `name` and the texture format.
Result<GLuint> create_framebuffer(const GlFunctions& gl, const char* name,
                                  std::initializer_list<GLuint> textures, const char* format_name);

}  // namespace modrt::platform
