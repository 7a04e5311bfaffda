// SPDX-License-Identifier: MIT
// modrt-embed-host's scene mode: the app's own glTF 2.0 loader (tinygltf), reading what a small
// renderer needs and nothing of modrt's: world-space meshes with their materials, the first
// camera, the first point light, and the nodes an app marks for the runtime (extras.modrt_dynamic:
// lit by the probe volume; extras.modrt_clutter: a DRT clutter object lit by its clutter
// lightmap at TEXCOORD_1; extras.modrt_block nodes are proxies and are not drawn). The same
// conventions as modrt-demo's loader (docs/demo.md, "Scenes from glTF") where both read a
// field, so that both draw the same scene; the subset is smaller, and what is outside it is an
// error naming the file and the field, never silently dropped.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace modrt::host {

// RGBA8, rows in the file's order (top first, as glTF's UV origin expects).
struct HostImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;
};

struct HostMaterial {
  std::string name;
  glm::vec3 base_color{0.7f};  // linear; glTF's default white would reflect everything between bounces
  int base_color_image = -1;   // HostScene::images, sRGB
  int normal_image = -1;       // tangent-space normal map, linear
  float normal_scale = 1.0f;
};

// One glTF primitive in world space (node transforms applied), indexed, counter-clockwise.
struct HostMesh {
  std::string name;  // the node's
  std::vector<glm::vec3> position, normal;
  std::vector<glm::vec4> tangent;  // empty unless the material has a normal map
  std::vector<glm::vec2> uv;       // TEXCOORD_0 (may be empty)
  std::vector<glm::vec2> uv1;      // TEXCOORD_1: a clutter mesh's lightmap UVs
  std::vector<std::uint32_t> indices;
  int material = 0;
  bool dynamic = false;  // positions relative to HostScene::dynamic_origin
  int clutter = -1;      // HostScene::clutter index
};

// A DRT clutter object (extras.modrt_clutter): its meshes are drawn with its clutter lightmap.
struct HostClutter {
  std::string name;
  int res = 48;  // the lightmap atlas's edge (extras.modrt_clutter.res, as the operator build used)
  glm::vec3 albedo{0.7f};
};

struct HostCamera {
  glm::vec3 position{0.0f}, forward{0.0f, 0.0f, -1.0f}, up{0.0f, 1.0f, 0.0f};
  float yfov = 1.0f, znear = 0.01f, zfar = 0.0f;  // zfar 0: not given (the renderer picks one)
};

struct HostLight {
  glm::vec3 position{0.0f}, color{1.0f};
  float intensity = 1.0f;  // W/sr: the glTF candela / 683 lm/W, as modrt-demo
};

struct HostScene {
  std::vector<HostMesh> meshes;
  std::vector<HostMaterial> materials;
  std::vector<HostImage> images;
  std::vector<HostClutter> clutter;
  HostCamera camera;
  HostLight light;
  glm::vec3 dynamic_origin{0.0f};  // the first dynamic node's world translation
  bool proxy_walls = true;         // extras.modrt_level.proxy_walls: the level's faces are the walls
  std::vector<std::string> warnings;
};

// Loads `path` (.gltf or .glb, told apart by the magic). Returns false with `error` naming the
// file and the problem.
bool load_host_scene(const std::string& path, HostScene& scene, std::string& error);

}  // namespace modrt::host
