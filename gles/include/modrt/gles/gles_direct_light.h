// SPDX-License-Identifier: MIT
// modrt::gles — the direct light at the level's proxy samples on the GPU (architecture.md §5
// step 1): ld = albedo x E/pi of one point or spot light, optionally shadowed by a cube shadow
// map the caller rendered, into an RGBA32F texture in the layout
// GlesLevelRuntime::update_from_texture reads, so that ld never leaves the GPU (no readback,
// no upload). The light model is gles/shaders/light.glsl (light_glsl()); a renderer that
// includes it and sets its uniforms with LightUniforms shades its camera image with the same
// light as the lightmaps. Light units and falloff as core's light_policy.h and modrt::cpu's
// CpuDirectLight (point and spot models; the inverse-square floor is the level's smallest
// block texel footprint, A / (2 pi), where the CPU evaluator uses each block's own).
#pragma once

#include <cstdint>
#include <memory>
#include <span>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "modrt/backend.h"
#include "modrt/level.h"
#include "modrt/platform/gl_functions.h"
#include "modrt/status.h"

namespace modrt::gles {

// One point, spot or directional light (light.glsl), in CpuLight's units.
struct GpuLight {
  glm::vec3 position{0.5f};
  // Point and spot: radiant intensity, W/sr per channel (colour x intensity); directional: the
  // irradiance on a surface facing the light, per channel (CpuLight::intensity's meaning).
  glm::vec3 rgb{1.0f};
  float radius = 0.0f;  // the 1/d^2 clamp, as CpuLight::radius
  // Spot: the cone's axis; directional: the direction the light travels.
  glm::vec3 spot_direction{0.0f, -1.0f, 0.0f};
  float spot_inner = 3.14159265f, spot_outer = 3.14159265f;  // half-angles; outer >= pi: a point light
  bool directional = false;                                  // position, radius and cones unused
};

// A cube shadow map of the light: a GL_TEXTURE_CUBE_MAP depth texture with
// GL_TEXTURE_COMPARE_MODE set, each face a 90° perspective projection from the light with
// these planes. texture 0: no shadows.
struct GpuShadowCube {
  std::uint32_t texture = 0;
  float near_plane = 0.01f, far_plane = 30.0f;
  // How far (m) the shadow test moves a point along its normal, beyond the shader's own offset
  // against acne: 0 for points on the surfaces they shade; for proxy samples that lie inside
  // walls (an imported level's proxies run through the walls' mid-planes), how deep they lie,
  // so that the wall's own faces do not shadow them (DemoScene::proxy_depth).
  float normal_offset = 0.0f;
  // Directional lights: the shadow map is orthographic, in the cube's +X face; this takes world
  // positions to its clip space (x, y in [-1, 1] across the face, z its depth from near_plane
  // to far_plane).
  glm::mat4 directional_view_proj{1.0f};
};

// light_glsl()'s uniforms in one program: found once, set per frame. floor_d2 is
// u_falloff_floor_d2 (the proxy samples' texel floor; 0 for a camera image of points).
struct LightUniforms {
  GLint position = -1, rgb = -1, radius = -1, spot_direction = -1, spot_cos = -1, shadow_params = -1,
        falloff_floor = -1, shadow_matrix = -1;
  static LightUniforms find(const platform::GlFunctions& gl, GLuint program);
  // With the program in use. The shadow map goes to the texture unit of u_shadow (the caller's).
  void set(const platform::GlFunctions& gl, const GpuLight& light, const GpuShadowCube& shadow) const;
};

// light.glsl's source, for a renderer's own shaders (after "precision highp samplerCubeShadow;").
const char* light_glsl();

class GlesDirectLight {
 public:
  // The sample images (position, normal, albedo: 3 x samples floats in [0, 1]) uploaded once,
  // the pass compiled and its target allocated, on the current GL context.
  static Result<std::unique_ptr<GlesDirectLight>> create(const platform::GlFunctions& gl, const Level& level,
                                                         std::span<const float> albedo);
  ~GlesDirectLight();
  GlesDirectLight(const GlesDirectLight&) = delete;
  GlesDirectLight& operator=(const GlesDirectLight&) = delete;

  // Renders ld for `light` into ld_texture(). Leaves framebuffer 0, program 0 and VAO 0 bound.
  // Fails for a light with a non-finite field or a negative intensity or radius.
  Status render(const GpuLight& light, const GpuShadowCube& shadow = {});
  std::uint32_t ld_texture() const { return target_; }
  TextureSize layout() const { return {width_, rows_}; }
  // Copies ld (3 x samples floats) to the CPU, for a CPU backend: one glReadPixels.
  Status read_ld(std::span<float> ld);

 private:
  explicit GlesDirectLight(const platform::GlFunctions& gl) : gl_(gl) {}
  const platform::GlFunctions& gl_;
  std::size_t samples_ = 0;
  int width_ = 0, rows_ = 0;
  GLuint program_ = 0, vao_ = 0, position_ = 0, normal_ = 0, albedo_ = 0, target_ = 0, framebuffer_ = 0;
  LightUniforms uniforms_;
  std::unique_ptr<float[]> readback_;
};

}  // namespace modrt::gles
