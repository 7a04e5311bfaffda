// SPDX-License-Identifier: MIT
// modrt::platform — shader programs and render targets with named errors (gl_program.h).
#include "modrt/platform/gl_program.h"

#include <cstdio>
#include <vector>

namespace modrt::platform {

namespace {

std::string info_log(const GlFunctions& gl, GLuint object, bool program) {
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

Result<GLuint> compile(const GlFunctions& gl, GLenum stage, const char* name,
                       std::initializer_list<const char*> pieces) {
  const GLuint shader = gl.glCreateShader(stage);
  if (shader == 0)
    return Status::error(ErrorCode::internal_error, std::string("glCreateShader failed for ") + name);
  std::vector<const char*> sources(pieces.begin(), pieces.end());
  gl.glShaderSource(shader, GLsizei(sources.size()), sources.data(), nullptr);
  gl.glCompileShader(shader);
  GLint ok = GL_FALSE;
  gl.glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    const std::string log = info_log(gl, shader, false);
    gl.glDeleteShader(shader);
    return Status::error(ErrorCode::internal_error,
                         std::string("shader ") + name +
                             (stage == GL_VERTEX_SHADER ? " (vertex)" : " (fragment)") +
                             " failed to compile:\n" + log);
  }
  return shader;
}

}  // namespace

Result<GLuint> build_program(const GlFunctions& gl, const char* name,
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
                         std::string("program ") + name + " failed to link:\n" + log);
  }
  return program;
}

void assign_sampler_units(const GlFunctions& gl, GLuint program,
                          std::initializer_list<const char*> samplers) {
  int unit = 0;
  for (const char* s : samplers) set_int(gl, program, s, unit++);
}

void set_int(const GlFunctions& gl, GLuint program, const char* name, int value) {
  const GLint location = gl.glGetUniformLocation(program, name);
  if (location >= 0) gl.glUniform1i(location, value);
}

GLuint create_texture(const GlFunctions& gl, GLenum internal_format, int width, int height) {
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

Result<GLuint> create_framebuffer(const GlFunctions& gl, const char* name,
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
    return Status::error(ErrorCode::internal_error, std::string("render target ") + name + " (" +
                                                        format_name + ") is incomplete (status " + code +
                                                        "): the context cannot render to this format");
  }
  return framebuffer;
}

}  // namespace modrt::platform
