// SPDX-License-Identifier: MIT
// modrt demo — scenes from glTF 2.0 files (.gltf with external or embedded buffers and
// images, or .glb), read with tinygltf: triangle meshes with their node transforms baked
// in, pbrMetallicRoughness base colours, normal maps and doubleSided, the first camera, the
// KHR_lights_punctual point and spot lights (up to kMaxDemoLights), dynamic meshes, the
// translation animations of lights and dynamic meshes, and the proxy blocks (the MRT level),
// either from nodes marked in `extras` or from a sidecar level JSON file. The schema, units
// and limits are documented in docs/demo.md, "Scenes from glTF".
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "demo_scene.h"
#include "modrt/precompute/scene_import.h"
#include "modrt/status.h"
#include "proxy_mapping.h"

namespace modrt::demo {

// glTF point lights are photometric (candela); DemoLight::intensity is radiometric (W/sr).
// The default divides by the luminous efficacy of 555 nm light, 683 lm/W, i.e. treats the
// light as if all its power were at the eye's peak sensitivity.
inline constexpr float kCandelaToWattsPerSr = 1.0f / 683.0f;

struct GltfSceneOptions {
  // The proxy blocks: this level JSON file when set; otherwise `<scene>.level.json` next to
  // the glTF file when it exists (`scene.gltf` -> `scene.level.json`); otherwise the nodes
  // marked with `extras.modrt_block`.
  std::string level_path;
  int scene = -1;  // glTF scene to load; -1: the file's default scene (or scene 0)
  // Draw the proxy blocks' walls as meshes (add_wall_meshes). Unset: the glTF scene's
  // `extras.modrt_level.proxy_walls`, true when that is absent too, false when the blocks
  // were imported from the scene's own geometry (its walls are drawn).
  std::optional<bool> proxy_walls;
  int wall_subdivisions = 4;
  // Primitives without NORMAL: flat normals (the glTF rule; vertices are split per
  // triangle) or, when true, area-weighted smooth normals over the shared vertices.
  bool smooth_missing_normals = false;
  float light_intensity_scale = kCandelaToWattsPerSr;  // multiplies KHR_lights_punctual intensity
  float light_radius = 0.05f;                          // DemoLight::radius of the glTF lights
  // glTF animations are timed in seconds, the demo in frames: key time t becomes frame
  // t x animation_fps (Blender's default scene rate is 24). In (0, 1e6].
  float animation_fps = 24.0f;
  // Size limits, checked before anything of that size is allocated.
  std::size_t max_vertices = 50'000'000;              // all meshes together, after normal splitting
  std::size_t max_file_bytes = std::size_t(1) << 30;  // the glTF/glb file and each external file
  int max_image_side = 16384;                         // texture side (llvmpipe GL_MAX_TEXTURE_SIZE)
  // The renderer's vertex buffer (a MappedVertex per drawn triangle corner, every instance of
  // a mesh counted): estimated from the accessor counts before any mesh is expanded. The
  // renderer refuses more than kMaxVertexBufferBytes whatever this says.
  std::size_t max_vertex_buffer_bytes = kMaxVertexBufferBytes;
  // Non-fatal problems (directional lights dropped, lights beyond kMaxDemoLights dropped,
  // animation channels the demo does not play, no light and so the default light, no camera,
  // orthographic camera, skins, ignored extensions, tinygltf's own warnings) are appended here
  // when set.
  std::vector<std::string>* warnings = nullptr;
  // A file without proxy blocks (no level file, no sidecar, no marked nodes) gets them from its
  // own geometry (scene_import_glue.h, docs/import.md); false: such a file is refused.
  bool import_unmarked = true;
  precompute::ImportSettings import_settings;
  // When set and the blocks were imported, what the importer decided (rooms, openings, roles).
  precompute::SceneImport* import_result = nullptr;
};

// Reads a glTF 2.0 scene. Errors name the file and the problem: missing or unreadable file,
// malformed JSON or glb, accessor or buffer view out of range, non-triangle primitive mode,
// missing POSITION, index out of range, unsupported or undecodable image, missing image
// file, size limit exceeded (the vertex buffer estimate among them), a malformed URI escape,
// a light far outside the level or too bright, no proxy blocks, level JSON errors (from
// load_level_json or from the extras turned into level JSON). A scene without a light gets
// the default light (docs/demo.md, "Default light"), with a warning. Never throws.
Result<DemoScene> load_gltf_scene(const std::string& path, const GltfSceneOptions& options = {});

// The sidecar level file checked for `gltf_path`: the same path with its extension replaced
// by `.level.json`.
std::string gltf_sidecar_level_path(const std::string& gltf_path);

}  // namespace modrt::demo
