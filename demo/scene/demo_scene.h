// SPDX-License-Identifier: MIT
// modrt demo — what the demo renders: a level of proxy blocks (the MRT level) plus the real
// geometry drawn on top of it, its materials and textures, lights, a camera and the dynamic
// objects lit by the probe volume. Filled by the built-in default scene (default_scene.h) or
// a glTF file; proxy_mapping.h then gives every static mesh its lightmap coordinates.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "modrt/drt.h"
#include "modrt/level_description.h"

namespace modrt::demo {

// RGBA8 image, rows top to bottom. base colour textures are sRGB, normal maps linear.
struct Image {
  std::string name;
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;
};

struct Material {
  std::string name;
  glm::vec3 base_color{0.7f};   // linear RGB, multiplies the base colour texture
  int base_color_texture = -1;  // index into DemoScene::images, -1: none
  int normal_texture = -1;      // tangent-space normal map (glTF convention), -1: none
  float normal_scale = 1.0f;
  // glTF doubleSided: both sides are drawn, the back side shaded with the normal (and tangent
  // frame) reversed; false: back faces are culled (docs/demo.md, "Scenes from glTF").
  bool double_sided = false;
};

// Triangle mesh in world space (node transforms applied), indexed.
struct Mesh {
  std::string name;
  std::vector<glm::vec3> position, normal;
  std::vector<glm::vec4> tangent;  // xyz + handedness w; empty when the material has no normal map
  std::vector<glm::vec2> uv;       // material texture coordinates; may be empty
  std::vector<std::uint32_t> indices;
  int material = 0;
  // Dynamic meshes move and are lit by the probe volume; static ones get lightmap
  // coordinates (proxy_mapping.h). A dynamic mesh's positions are in its local frame and
  // `animation` moves it.
  bool dynamic = false;
  // DRT clutter (docs/drt.md): index into DemoScene::clutter, -1 for none. A clutter mesh is
  // drawn with that object's clutter lightmap at `lightmap_uv` (its glTF TEXCOORD_1, one per
  // vertex, in [0, 1]^2) instead of being mapped onto the proxies.
  int clutter = -1;
  std::vector<glm::vec2> lightmap_uv;
  // Where it came from in a glTF file (node and primitive), -1 for meshes made by the demo.
  int source_node = -1, source_primitive = -1;
  // The scene importer's object this mesh belongs to (index into SceneImport::object_role);
  // -1 when the scene was not imported or the mesh is dynamic.
  int import_object = -1;
};

// Sampled keyframes of a position (a glTF animation's translation channel, in world space):
// `times` in demo frames, strictly increasing; `values` one per key, or for cubic three per key
// (in-tangent, value, out-tangent; tangents per frame) as glTF's CUBICSPLINE. The track loops
// every `period` frames (its animation's duration); before the first key and after the last it
// holds that key's value. Sampled by track_point (demo_run.h).
struct KeyTrack {
  enum class Interpolation { linear, step, cubic };
  std::vector<float> times;
  std::vector<glm::vec3> values;
  Interpolation interpolation = Interpolation::linear;
  float period = 0.0f;
};

// The renderer's light limit: one shadow cube map and one copy of the light model per light in
// the camera image (docs/demo.md, "Lights"); load_gltf_scene keeps the first ones and names
// the rest in a warning, DemoRun refuses a scene with more.
inline constexpr std::size_t kMaxDemoLights = 4;

// A point or spot light moves along a closed path of key positions (Catmull-Rom, one loop
// per `period` frames); a single key holds it still. A spot light (outer_cone < pi) shines
// along `direction`, full inside inner_cone, fading smoothly to zero at outer_cone (half
// angles, radians, as glTF's KHR_lights_punctual); both backends see it through ld.
struct DemoLight {
  std::vector<glm::vec3> path;
  // Spot: the cone's axis; directional: the direction the light travels.
  glm::vec3 direction{0.0f, -1.0f, 0.0f};
  // A directional light (the sun): `intensity` is the irradiance on a surface facing it, and
  // `path`, `radius` and the cones are unused (its shadow map is orthographic).
  bool directional = false;
  float inner_cone = 3.14159265f, outer_cone = 3.14159265f;
  int period = 120;
  glm::vec3 color{1.0f};
  float intensity = 1.0f;  // radiant intensity (W/sr) at colour (1, 1, 1)
  float radius = 0.05f;    // size of the emitter drawn in the image; shading treats it as a point
  KeyTrack track;          // when it has keys: the light's position, instead of `path`
};

struct DemoCamera {
  glm::vec3 position{0.5f}, target{0.5f, 0.5f, 1.5f}, up{0.0f, 1.0f, 0.0f};
  float yfov = 1.1f;  // vertical field of view, radians
  float znear = 0.02f, zfar = 100.0f;
};

struct DemoScene {
  std::string name;
  LevelDescription level;  // the proxy blocks (MRT level)
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Image> images;
  std::vector<DemoLight> lights;
  DemoCamera camera;
  // Path of the dynamic meshes (all move together), as DemoLight::path.
  std::vector<glm::vec3> dynamic_path;
  int dynamic_period = 120;
  KeyTrack dynamic_track;  // when it has keys: the dynamic meshes' offset, instead of dynamic_path
  // DRT clutter objects inside the level's blocks (kind mesh from glTF, drawn by the meshes
  // whose Mesh::clutter names them).
  std::vector<ClutterObject> clutter;
  // How far the proxy walls lie behind the surfaces they stand for (m): 0 for hand-placed
  // proxies; an imported level's rooms meet at their walls' mid-planes (ImportPlan::proxy_depth).
  // The direct-light pass at the proxy samples tests shadows this much further along the normal.
  float proxy_depth = 0.0f;
};

}  // namespace modrt::demo
