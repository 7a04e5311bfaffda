// SPDX-License-Identifier: MIT
#include "gl_objects.h"

#include <algorithm>

namespace modrt::gles {

int linear_rows(std::size_t texels) {
  const std::size_t rows = (texels + kLinearWidth - 1) / kLinearWidth;
  return rows == 0 ? 1 : int(rows);
}

void upload_linear(const platform::GlFunctions& gl, GLuint texture, GLenum format, GLenum type,
                   int components, const void* data, std::size_t texels, std::size_t bytes_per_component,
                   std::size_t first) {
  if (texels == 0) return;
  gl.glBindTexture(GL_TEXTURE_2D, texture);
  gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  const std::size_t texel_bytes = std::size_t(components) * bytes_per_component;
  const auto* bytes = static_cast<const unsigned char*>(data);
  std::size_t at = first, end = first + texels;
  auto put = [&](std::size_t x, std::size_t y, std::size_t w, std::size_t h) {
    gl.glTexSubImage2D(GL_TEXTURE_2D, 0, GLint(x), GLint(y), GLsizei(w), GLsizei(h), format, type,
                       bytes + (at - first) * texel_bytes);
    at += w * h;
  };
  if (at % kLinearWidth != 0)
    put(at % kLinearWidth, at / kLinearWidth, std::min(end - at, kLinearWidth - at % kLinearWidth), 1);
  if (end - at >= std::size_t(kLinearWidth))
    put(0, at / kLinearWidth, kLinearWidth, (end - at) / kLinearWidth);
  if (at < end) put(0, at / kLinearWidth, end - at, 1);
}

}  // namespace modrt::gles
