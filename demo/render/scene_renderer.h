// SPDX-License-Identifier: MIT
// modrt demo — the OpenGL ES 3.0 scene renderer: shadow cube map of the point light, direct
// light at the proxy samples (the ld the MRT runtime takes), and the camera image shaded with
// direct light plus indirect light from the lightmap atlas, the vector irradiance atlases
// (normal-mapped materials) or the probe volume (dynamic meshes), tone-mapped to sRGB.
//
// Works with either backend: the GLES backend's atlas textures are sampled directly (same
// context); the CPU backend's atlas is uploaded with upload_atlas(). Needs float render
// targets (EXT_color_buffer_float, or desktop GL); every Mesa context here has them.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "../scene/demo_scene.h"
#include "../scene/proxy_mapping.h"
#include "modrt/gles/gles_direct_light.h"
#include "modrt/level.h"
#include "modrt/platform/gl_functions.h"
#include "modrt/probe_sampler.h"
#include "modrt/status.h"

namespace modrt::demo {

enum class OutputMode { combined, direct, indirect };

struct RendererOptions {
  int width = 960, height = 540;
  int shadow_size = 1024;  // texels per cube face
};

// What one frame shows and is lit by.
struct FrameState {
  DemoCamera camera;
  glm::vec3 light_position{0.5f};
  glm::vec3 light_rgb{1.0f};  // radiant intensity per channel (W/sr)
  float light_radius = 0.05f;
  glm::vec3 spot_direction{0.0f, -1.0f, 0.0f};  // spot lights (DemoLight); cones of pi: a point light
  float spot_inner = 3.14159265f, spot_outer = 3.14159265f;
  glm::vec3 dynamic_offset{0.0f};
  // Indirect light: the scalar atlas (RGBA, .rgb = E/pi) and, when all four are set, the
  // OHLSH vector atlases used by normal-mapped materials.
  GLuint atlas = 0;
  std::array<GLuint, 4> vector_atlas{};
  // Dynamic meshes: the probe volume as a texture of world-frame radiance SH9
  // (Backend::world_probe_texture's layout; upload_probes() for a CPU backend's), its grid g,
  // and the dynamic object's cell in it (ProbeSampler::locate at dynamic_offset). probes = 0:
  // no probe volume, dynamic meshes get no indirect light.
  GLuint probes = 0;
  int probe_grid = 0;
  ProbeCell probe_cell;
  OutputMode output = OutputMode::combined;
  float exposure = 1.0f;
};

// The first pending GL error as a Status ("renderer: <what>: GL_OUT_OF_MEMORY ..."; out of
// memory is resource_limit, anything else internal_error), clearing the rest; success when none.
Status gl_error_status(const platform::GlFunctions& gl, const std::string& what);
// glBufferData(target, bytes, data, GL_STATIC_DRAW) on the bound buffer with its failure
// checked: a driver that cannot allocate the buffer reports GL_OUT_OF_MEMORY, and drawing from
// that buffer would crash (llvmpipe), so it becomes an error naming `what` and the size.
Status buffer_data_checked(const platform::GlFunctions& gl, GLenum target, std::size_t bytes,
                           const void* data, const std::string& what);

class SceneRenderer {
 public:
  // `mapped` from map_to_proxies(scene, level); `albedo` is the level's per-sample albedo
  // (3 per sample). The context must be current for every call.
  static Result<std::unique_ptr<SceneRenderer>> create(const platform::GlFunctions& gl, bool gles_context,
                                                       const DemoScene& scene,
                                                       std::span<const MappedMesh> mapped, const Level& level,
                                                       std::span<const float> albedo,
                                                       const RendererOptions& options);
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // The light's cube shadow map over every mesh (dynamic ones at dynamic_offset).
  Status render_shadows(const FrameState& frame);
  // That shadow map, and the frame's light, for the direct-light pass at the level's samples
  // (gles::GlesDirectLight: the same light.glsl as the camera image).
  gles::GpuShadowCube shadow_cube() const;
  static gles::GpuLight gpu_light(const FrameState& frame);
  // Uploads an atlas computed on the CPU (3 floats per texel) into one of the renderer's own
  // atlas textures and returns it: slot 0 for FrameState::atlas, 1..4 for vector_atlas[0..3].
  Result<GLuint> upload_atlas(std::span<const float> atlas_rgb, int slot = 0);
  // Uploads a probe volume computed on the CPU (ProbeSampler::world_probes, radiance, 27
  // floats per probe) into the renderer's own probe texture, laid out as
  // Backend::world_probe_texture's, and returns it (for FrameState::probes).
  Result<GLuint> upload_probes(std::span<const float> world_probes);
  // DRT: the clutter lightmap (Backend::read_clutter_lightmap, 3 floats per clutter texel,
  // the scene's clutter objects in order), scattered into each mesh object's res x res
  // texture through its atlas's cells and padding. This or gather_clutter_lightmap() is
  // required before render_image when the scene has clutter.
  Status upload_clutter_lightmap(std::span<const float> clutter_lightmap);
  // The same on the GPU from a backend's clutter atlas texture (Backend::output_texture(
  // BackendOutput::clutter_atlas)): set_clutter_atlas_layout() once with where texel t of
  // object k lies in it (Backend::clutter_atlas_texel), then gather_clutter_lightmap() each
  // frame, one pass per mesh object; nothing is read back.
  using ClutterAtlasTexel = std::function<std::array<int, 2>(std::size_t object, std::uint32_t texel)>;
  Status set_clutter_atlas_layout(const ClutterAtlasTexel& atlas_texel);
  Status gather_clutter_lightmap(GLuint clutter_atlas);
  // The camera image: linear RGB (3 floats per pixel, rows bottom to top) and sRGB8 (3 bytes
  // per pixel, rows top to bottom, ready for an image file).
  Status render_image(const FrameState& frame, std::span<float> linear_rgb, std::span<std::uint8_t> srgb8);

  int width() const { return options_.width; }
  int height() const { return options_.height; }
  // The camera's clip transform as render_image draws with it (OpenGL clip space).
  glm::mat4 view_projection(const DemoCamera& camera) const;

 private:
  struct Impl;
  explicit SceneRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  RendererOptions options_;
};

}  // namespace modrt::demo
