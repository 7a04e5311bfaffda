#include "gl_objects.h"

#include <algorithm>
#include <cstdio>
#include <vector>

namespace modrt::gles {

int linear_rows(std::size_t texels) {
  const std::size_t rows = (texels + kLinearWidth - 1) / kLinearWidth;
  return rows == 0 ? 1 : int(rows);
}

namespace {

std::string info_log(const platform::GlFunctions& gl, GLuint object, bool program) {
  GLint length = 0;
  if (program)
    gl.glGetProgramiv(object, GL_INFO_LOG_LENGTH, &length);
  else
    gl.glGetShaderiv(object, GL_INFO_LOG_LENGTH, &length);
  std::string log(std::size_t(length > 1 ? length : 1), '\0');
  GLsizei written = 0;
  if (program)
    gl.glGetProgramInfoLog(object, GLsizei(log.size()), &written, log.data());
  else
    gl.glGetShaderInfoLog(object, GLsizei(log.size()), &written, log.data());
  log.resize(std::size_t(written));
  return log.empty() ? "(no log)" : log;
}

Result<GLuint> compile(const platform::GlFunctions& gl, GLenum stage, const char* name,
                       std::initializer_list<const char*> pieces) {
  const GLuint shader = gl.glCreateShader(stage);
  if (shader == 0)
    return Status::error(ErrorCode::internal_error, std::string("gles: glCreateShader failed for ") + name);
  std::vector<const char*> sources(pieces.begin(), pieces.end());
  gl.glShaderSource(shader, GLsizei(sources.size()), sources.data(), nullptr);
  gl.glCompileShader(shader);
  GLint ok = GL_FALSE;
  gl.glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    const std::string log = info_log(gl, shader, false);
    gl.glDeleteShader(shader);
    return Status::error(ErrorCode::internal_error,
                         std::string("gles: shader ") + name +
                             (stage == GL_VERTEX_SHADER ? " (vertex)" : " (fragment)") +
                             " failed to compile:\n" + log);
  }
  return shader;
}

}  // namespace

Result<GLuint> build_program(const platform::GlFunctions& gl, const char* name,
                             std::initializer_list<const char*> vertex,
                             std::initializer_list<const char*> fragment) {
  Result<GLuint> vs = compile(gl, GL_VERTEX_SHADER, name, vertex);
  if (!vs.ok()) return vs.status();
  Result<GLuint> fs = compile(gl, GL_FRAGMENT_SHADER, name, fragment);
  if (!fs.ok()) {
    gl.glDeleteShader(vs.value());
    return fs.status();
  }
  const GLuint program = gl.glCreateProgram();
  gl.glAttachShader(program, vs.value());
  gl.glAttachShader(program, fs.value());
  gl.glLinkProgram(program);
  gl.glDeleteShader(vs.value());  // flagged; freed with the program
  gl.glDeleteShader(fs.value());
  GLint ok = GL_FALSE;
  gl.glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    const std::string log = info_log(gl, program, true);
    gl.glDeleteProgram(program);
    return Status::error(ErrorCode::internal_error,
                         std::string("gles: program ") + name + " failed to link:\n" + log);
  }
  return program;
}

void assign_sampler_units(const platform::GlFunctions& gl, GLuint program,
                          std::initializer_list<const char*> samplers) {
  int unit = 0;
  for (const char* s : samplers) set_int(gl, program, s, unit++);
}

void set_int(const platform::GlFunctions& gl, GLuint program, const char* name, int value) {
  const GLint location = gl.glGetUniformLocation(program, name);
  if (location >= 0) gl.glUniform1i(location, value);
}

GLuint create_texture(const platform::GlFunctions& gl, GLenum internal_format, int width, int height) {
  GLuint texture = 0;
  gl.glGenTextures(1, &texture);
  gl.glBindTexture(GL_TEXTURE_2D, texture);
  gl.glTexStorage2D(GL_TEXTURE_2D, 1, internal_format, width, height);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
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

Result<GLuint> create_framebuffer(const platform::GlFunctions& gl, const char* name,
                                  std::initializer_list<GLuint> textures, const char* format_name) {
  GLuint framebuffer = 0;
  gl.glGenFramebuffers(1, &framebuffer);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  GLenum buffers[8];
  GLsizei count = 0;
  for (GLuint t : textures) {
    buffers[count] = GLenum(GL_COLOR_ATTACHMENT0 + count);
    gl.glFramebufferTexture2D(GL_FRAMEBUFFER, buffers[count], GL_TEXTURE_2D, t, 0);
    ++count;
  }
  gl.glDrawBuffers(count, buffers);
  const GLenum status = gl.glCheckFramebufferStatus(GL_FRAMEBUFFER);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    gl.glDeleteFramebuffers(1, &framebuffer);
    char code[16];
    std::snprintf(code, sizeof code, "0x%04x", unsigned(status));
    return Status::error(ErrorCode::internal_error, std::string("gles: render target ") + name + " (" +
                                                        format_name + ") is incomplete (status " + code +
                                                        "): the context cannot render to this format");
  }
  return framebuffer;
}

}  // namespace modrt::gles
