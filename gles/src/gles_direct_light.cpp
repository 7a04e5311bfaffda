// SPDX-License-Identifier: MIT
#include "modrt/gles/gles_direct_light.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "gl_objects.h"
#include "modrt/level_geometry.h"
#include "modrt/light_policy.h"
#include "modrt/operator_limits.h"
#include "modrt/reference_runtime.h"

namespace modrt::gles {

// Shader sources, generated from gles/shaders/*.glsl by cmake/EmbedShaders.cmake.
extern const char* const kCommon;
extern const char* const kFullscreenVert;
extern const char* const kLight;
extern const char* const kDirectLightFrag;

const char* light_glsl() { return kLight; }

LightUniforms LightUniforms::find(const platform::GlFunctions& gl, GLuint program) {
  const auto loc = [&](const char* name) { return gl.glGetUniformLocation(program, name); };
  return {loc("u_light_position"), loc("u_light_rgb"),     loc("u_light_radius"),     loc("u_spot_direction"),
          loc("u_spot_cos"),       loc("u_shadow_params"), loc("u_falloff_floor_d2"), loc("u_shadow_matrix")};
}

void LightUniforms::set(const platform::GlFunctions& gl, const GpuLight& l,
                        const GpuShadowCube& shadow) const {
  gl.glUniform3f(position, l.position.x, l.position.y, l.position.z);
  gl.glUniform3f(rgb, l.rgb.x, l.rgb.y, l.rgb.z);
  gl.glUniform1f(radius, l.radius);
  const glm::vec3 d =
      glm::length(l.spot_direction) > 1e-6f ? glm::normalize(l.spot_direction) : glm::vec3(0, -1, 0);
  gl.glUniform3f(spot_direction, d.x, d.y, d.z);
  // cos of the cones; a point light (outer cone >= pi) gets -2, below every cosine. The inner
  // cone at least 1e-4 inside the outer one (CpuDirectLight's max(cos inner - cos outer, 1e-4)).
  const float cos_outer = l.spot_outer >= 3.14159f ? -2.0f : std::cos(l.spot_outer);
  const float cos_inner =
      std::max(l.spot_inner >= 3.14159f ? -1.0f : std::cos(l.spot_inner), cos_outer + 1e-4f);
  gl.glUniform3f(spot_cos, cos_outer, cos_inner, l.directional ? 1.0f : 0.0f);
  gl.glUniformMatrix4fv(shadow_matrix, 1, GL_FALSE, &shadow.directional_view_proj[0][0]);
  gl.glUniform4f(shadow_params, shadow.near_plane, shadow.far_plane, shadow.texture != 0 ? 1.0f : 0.0f,
                 std::isfinite(shadow.normal_offset) ? std::clamp(shadow.normal_offset, 0.0f, 1.0f) : 0.0f);
}

namespace {

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

Result<std::unique_ptr<GlesDirectLight>> GlesDirectLight::create(const platform::GlFunctions& gl,
                                                                 const Level& level,
                                                                 std::span<const float> albedo) {
  if (albedo.size() != 3 * std::size_t(level.sample_count))
    return Status::error(ErrorCode::invalid_argument,
                         "gles direct light: albedo has " + std::to_string(albedo.size()) +
                             " floats, expected " + std::to_string(3 * std::size_t(level.sample_count)));
  if (Status s = validate_light_signal(albedo, level.sample_count, "albedo"); !s.ok()) return s;
  std::unique_ptr<GlesDirectLight> d(new GlesDirectLight(gl));
  d->samples_ = level.sample_count;
  d->width_ = kLinearWidth;
  d->rows_ = linear_rows(d->samples_);
  GLint max_size = 0;
  gl.glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  if (d->rows_ > max_size)
    return Status::error(ErrorCode::resource_limit, "gles direct light: " + std::to_string(d->rows_) +
                                                        " rows of samples exceed GL_MAX_TEXTURE_SIZE " +
                                                        std::to_string(max_size));
  // The defines common.glsl reads (as the level runtime's passes set them).
  const std::string head =
      "#version 300 es\n#define LINEAR_SHIFT " + std::to_string(kLinearShift) + "\n#define MAX_LIGHT " +
      glsl_float(kMaxLightValue) +
      "\n#define OUTPUT_BITS 0\n#define OUTPUT_MAX 3.4028234e38\nprecision highp samplerCubeShadow;\n";
  Result<GLuint> program = build_program(gl, "direct_light.frag", {"#version 300 es\n", kFullscreenVert},
                                         {head.c_str(), kCommon, kLight, kDirectLightFrag});
  if (!program.ok()) return program.status();
  d->program_ = program.value();
  gl.glUseProgram(d->program_);
  assign_sampler_units(gl, d->program_,
                       {"u_shadow", "u_sample_position", "u_sample_normal", "u_sample_albedo"});
  set_int(gl, d->program_, "u_count", GLint(d->samples_));
  // The footprint floor (light_policy.h) from the smallest block texels: a lower bound on every
  // block's own floor, equal to it in an unwarped level.
  double floor_d2 = 0.0;
  for (std::size_t b = 0; b < level.blocks.size(); ++b) {
    const double f = texel_footprint_d2(block_texel_area(level.blocks[b].corners, level.res));
    floor_d2 = b == 0 ? f : std::min(floor_d2, f);
  }
  d->uniforms_ = LightUniforms::find(gl, d->program_);
  gl.glUniform1f(d->uniforms_.falloff_floor, float(floor_d2));
  gl.glUseProgram(0);

  const LevelSampleGeometry geometry = level_sample_geometry(level);
  std::vector<float> pos(4 * d->samples_, 0.0f), nrm(pos.size(), 0.0f), alb(pos.size(), 0.0f);
  for (std::size_t s = 0; s < d->samples_; ++s)
    for (std::size_t c = 0; c < 3; ++c) {
      pos[4 * s + c] = float(geometry.position[s][int(c)]);
      nrm[4 * s + c] = float(geometry.normal[s][int(c)]);
      alb[4 * s + c] = albedo[3 * s + c];
    }
  for (auto [tex, data] : {std::pair{&d->position_, &pos}, {&d->normal_, &nrm}, {&d->albedo_, &alb}}) {
    *tex = create_texture(gl, GL_RGBA32F, d->width_, d->rows_);
    upload_linear(gl, *tex, GL_RGBA, GL_FLOAT, 4, data->data(), d->samples_, sizeof(float));
  }
  d->target_ = create_texture(gl, GL_RGBA32F, d->width_, d->rows_);
  Result<GLuint> fb = create_framebuffer(gl, "direct light", {d->target_}, "RGBA32F");
  if (!fb.ok()) return fb.status();
  d->framebuffer_ = fb.value();
  gl.glGenVertexArrays(1, &d->vao_);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  d->readback_.reset(new float[4 * std::size_t(d->width_) * std::size_t(d->rows_)]);
  if (const GLenum e = gl.glGetError(); e != GL_NO_ERROR)
    return Status::error(ErrorCode::internal_error,
                         "gles direct light: GL error " + std::to_string(e) + " creating the sample images");
  return d;
}

GlesDirectLight::~GlesDirectLight() {
  if (framebuffer_) gl_.glDeleteFramebuffers(1, &framebuffer_);
  for (GLuint t : {position_, normal_, albedo_, target_})
    if (t) gl_.glDeleteTextures(1, &t);
  if (vao_) gl_.glDeleteVertexArrays(1, &vao_);
  if (program_) gl_.glDeleteProgram(program_);
}

Status GlesDirectLight::render(const GpuLight& light, const GpuShadowCube& shadow) {
  if (!finite(light.position) || !finite(light.rgb) || !finite(light.spot_direction) ||
      !std::isfinite(light.radius) || !std::isfinite(light.spot_inner) || !std::isfinite(light.spot_outer))
    return Status::error(ErrorCode::non_finite, "gles direct light: the light has a NaN or Inf field");
  if (light.rgb.x < 0.0f || light.rgb.y < 0.0f || light.rgb.z < 0.0f || light.radius < 0.0f)
    return Status::error(ErrorCode::invalid_argument, "gles direct light: negative intensity or radius");
  if (light.directional && !(glm::length(light.spot_direction) > 1e-6f))
    return Status::error(ErrorCode::invalid_argument,
                         "gles direct light: a directional light needs a direction (spot_direction is zero)");
  gl_.glDisable(GL_BLEND);
  gl_.glDisable(GL_DEPTH_TEST);
  gl_.glDisable(GL_SCISSOR_TEST);
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  gl_.glViewport(0, 0, width_, rows_);
  gl_.glUseProgram(program_);
  uniforms_.set(gl_, light, shadow);
  gl_.glActiveTexture(GL_TEXTURE0);
  gl_.glBindTexture(GL_TEXTURE_CUBE_MAP, shadow.texture);
  const GLuint images[3] = {position_, normal_, albedo_};
  for (int i = 0; i < 3; ++i) {
    gl_.glActiveTexture(GLenum(GL_TEXTURE1 + i));
    gl_.glBindTexture(GL_TEXTURE_2D, images[i]);
  }
  gl_.glBindVertexArray(vao_);
  gl_.glDrawArrays(GL_TRIANGLES, 0, 3);
  gl_.glBindVertexArray(0);
  gl_.glUseProgram(0);
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl_.glActiveTexture(GL_TEXTURE0);
  if (const GLenum e = gl_.glGetError(); e != GL_NO_ERROR)
    return Status::error(ErrorCode::internal_error, "gles direct light: GL error " + std::to_string(e));
  return Status::success();
}

Status GlesDirectLight::read_ld(std::span<float> ld) {
  if (ld.size() != 3 * samples_)
    return Status::error(ErrorCode::invalid_argument, "gles direct light: ld has " +
                                                          std::to_string(ld.size()) + " floats, expected " +
                                                          std::to_string(3 * samples_));
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  gl_.glReadBuffer(GL_COLOR_ATTACHMENT0);
  gl_.glPixelStorei(GL_PACK_ALIGNMENT, 4);
  gl_.glReadPixels(0, 0, width_, rows_, GL_RGBA, GL_FLOAT, readback_.get());
  gl_.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (const GLenum e = gl_.glGetError(); e != GL_NO_ERROR)
    return Status::error(ErrorCode::internal_error,
                         "gles direct light: GL error " + std::to_string(e) + " reading ld");
  // The CPU runtime rejects NaN and negative ld: sanitised as the GPU passes read it.
  for (std::size_t s = 0; s < samples_; ++s)
    for (std::size_t c = 0; c < 3; ++c) {
      const float v = readback_[4 * s + c];
      ld[3 * s + c] = v > 0.0f ? std::min(v, kMaxLightValue) : 0.0f;  // NaN and negatives -> 0
    }
  return Status::success();
}

}  // namespace modrt::gles
