// SPDX-License-Identifier: MIT
// Small GL helpers of the GLES runtime: linear-layout textures (programs, textures and render
// targets come from modrt/platform/gl_program.h). Private to modrt::gles.
#pragma once

#include <initializer_list>
#include <span>
#include <string>

#include "modrt/platform/gl_functions.h"
#include "modrt/platform/gl_program.h"
#include "modrt/status.h"

namespace modrt::gles {

using platform::assign_sampler_units;
using platform::build_program;
using platform::create_framebuffer;
using platform::create_texture;
using platform::set_int;

// Width of every linear-layout texture: 2^11 = 2048, the smallest GL_MAX_TEXTURE_SIZE that
// OpenGL ES 3.0 allows, so a row always fits.
constexpr int kLinearShift = 11;
constexpr int kLinearWidth = 1 << kLinearShift;

// A float as a GLSL literal that reads back as the same float (9 significant digits).
std::string glsl_float(float v);

// Rows a linear-layout texture needs for `texels` texels (at least one).
int linear_rows(std::size_t texels);

// Uploads `texels` texels of `data` (`components` per texel, float or int32) into a linear
// texture starting at texel `first` (data points at texel `first`'s values): a partial first
// row, whole rows, a partial last row.
void upload_linear(const platform::GlFunctions& gl, GLuint texture, GLenum format, GLenum type,
                   int components, const void* data, std::size_t texels, std::size_t bytes_per_component,
                   std::size_t first = 0);

}  // namespace modrt::gles
