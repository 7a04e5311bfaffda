// Small GL helpers of the GLES runtime: shader programs with named errors, linear-layout
// textures, render targets. Private to modrt::gles.
#pragma once

#include <initializer_list>
#include <span>
#include <string>

#include "modrt/platform/gl_functions.h"
#include "modrt/status.h"

namespace modrt::gles {

// Width of every linear-layout texture: 2^11 = 2048, the smallest GL_MAX_TEXTURE_SIZE that
// OpenGL ES 3.0 allows, so a row always fits.
constexpr int kLinearShift = 11;
constexpr int kLinearWidth = 1 << kLinearShift;

// Rows a linear-layout texture needs for `texels` texels (at least one).
int linear_rows(std::size_t texels);

// Compiles `vertex` + `fragment` (each given as source pieces, concatenated) and links them.
// Fails with internal_error naming `name` and carrying the compiler or linker log.
Result<GLuint> build_program(const platform::GlFunctions& gl, const char* name,
                             std::initializer_list<const char*> vertex,
                             std::initializer_list<const char*> fragment);

// Assigns texture units 0, 1, ... to the named sampler uniforms, in order (program in use).
void assign_sampler_units(const platform::GlFunctions& gl, GLuint program,
                          std::initializer_list<const char*> samplers);
// Sets an int uniform by name (program in use); silently ignores names the compiler removed.
void set_int(const platform::GlFunctions& gl, GLuint program, const char* name, int value);

// A 2D texture with immutable storage, nearest filtering and clamped addressing.
GLuint create_texture(const platform::GlFunctions& gl, GLenum internal_format, int width, int height);
// Uploads `texels` texels of `data` (`components` per texel, float or int32) into a linear
// texture starting at texel `first` (data points at texel `first`'s values): a partial first
// row, whole rows, a partial last row.
void upload_linear(const platform::GlFunctions& gl, GLuint texture, GLenum format, GLenum type,
                   int components, const void* data, std::size_t texels, std::size_t bytes_per_component,
                   std::size_t first = 0);

// A framebuffer with `textures` as colour attachments 0..n-1 and draw buffers set. Fails when
// the framebuffer is incomplete, naming `name` and the texture format.
Result<GLuint> create_framebuffer(const platform::GlFunctions& gl, const char* name,
                                  std::initializer_list<GLuint> textures, const char* format_name);

}  // namespace modrt::gles
