// SPDX-License-Identifier: MIT
// modrt demo — the OpenGL ES 3.0 scene renderer: a shadow cube map per point or spot light (up
// to kMaxDemoLights), the sum of the lights' direct light at the proxy samples (the ld the MRT
// runtime takes), and the camera image shaded with every light's direct light plus indirect
// light from the lightmap atlas, the vector irradiance atlases (normal-mapped materials) or the
// probe volume (dynamic meshes), tone-mapped to sRGB. Double-sided materials are drawn from both
// sides (map_back_sides), single-sided ones with their back faces culled.
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
  // The point and spot lights this frame (gles::GpuLight: position, W/sr per channel, radius,
  // spot cone; cones of pi: a point light), at most the renderer's light_slots(), each with its
  // shadow cube map (render_shadows) and drawn as a small emissive sphere.
  std::vector<gles::GpuLight> lights;
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

// The back sides of the static meshes whose material is double-sided, each a copy of its mesh
// with the triangles' order reversed, the normals turned and the tangent frame mirrored (xyz
// and w negated, so that the bumped normal turns with the normal, as glTF's double-sided
// lighting), mapped onto the proxies like any static mesh: each side gets the lightmap of the
// proxy face it faces. MappedMesh::mesh names the original mesh. Empty when no static mesh is
// double-sided.
Result<std::vector<MappedMesh>> map_back_sides(const DemoScene& scene, const Level& level);

class SceneRenderer {
 public:
  // `mapped` from map_to_proxies(scene, level); the back sides of double-sided static meshes are
  // mapped here (map_back_sides). Dynamic and clutter meshes of a double-sided material are drawn
  // without culling, their back faces shaded with the normal turned. `albedo` is the level's
  // per-sample albedo (3 per sample). One shadow cube map per light of the scene (at least one;
  // more than kMaxDemoLights is an error). The context must be current for every call.
  static Result<std::unique_ptr<SceneRenderer>> create(const platform::GlFunctions& gl, bool gles_context,
                                                       const DemoScene& scene,
                                                       std::span<const MappedMesh> mapped, const Level& level,
                                                       std::span<const float> albedo,
                                                       const RendererOptions& options);
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // Each light's cube shadow map over every mesh (dynamic ones at dynamic_offset).
  Status render_shadows(const FrameState& frame);
  // Light `light`'s shadow map, for the direct-light pass at the level's samples
  // (gles::GlesDirectLight: the same light.glsl as the camera image).
  gles::GpuShadowCube shadow_cube(std::size_t light = 0) const;
  // The number of lights the renderer was made for (its shadow maps and light model copies).
  std::size_t light_slots() const;
  // Several lights' ld at the proxy samples, summed on the GPU one light at a time:
  // gles::GlesDirectLight renders one light into its texture, add_ld() adds that texture (of
  // `layout`, GlesDirectLight::layout()) to the sum (`first`: the sum restarts with it), and
  // summed_ld() is the texture of the sum so far, in the same layout (what
  // FramePipeline::run_from_texture reads). read_summed_ld() copies it to the CPU as
  // GlesDirectLight::read_ld does (3 floats per sample, NaN and negatives as 0).
  Status add_ld(GLuint ld_texture, TextureSize layout, bool first);
  GLuint summed_ld() const;
  Status read_summed_ld(std::span<float> ld);
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
