// SPDX-License-Identifier: MIT
#include "scene_import_glue.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace modrt::demo {

namespace {

double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

}  // namespace

glm::dvec3 material_albedo(const DemoScene& scene, int material) {
  if (material < 0 || std::size_t(material) >= scene.materials.size()) return glm::dvec3(0.7);
  const Material& m = scene.materials[std::size_t(material)];
  glm::dvec3 albedo(m.base_color);
  if (m.base_color_texture >= 0 && std::size_t(m.base_color_texture) < scene.images.size()) {
    const Image& image = scene.images[std::size_t(m.base_color_texture)];
    glm::dvec3 sum(0.0);
    const std::size_t texels = std::size_t(image.width) * std::size_t(image.height);
    for (std::size_t t = 0; t < texels && 4 * t + 2 < image.rgba.size(); ++t)
      for (int c = 0; c < 3; ++c) sum[c] += srgb_to_linear(image.rgba[4 * t + std::size_t(c)] / 255.0);
    if (texels > 0) albedo *= sum / double(texels);
  }
  return glm::clamp(albedo, 0.0, 1.0);
}

Result<precompute::SceneImport> import_scene_level(DemoScene& scene,
                                                   const precompute::ImportSettings& settings) {
  // One importer object per glTF node (its primitives together): closedness and facing are
  // decided per object.
  std::vector<precompute::ImportObject> objects;
  std::vector<std::vector<std::size_t>> object_meshes;
  std::map<int, std::size_t> object_of_node;
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& m = scene.meshes[mi];
    if (m.dynamic || m.clutter >= 0) continue;
    const int key = m.source_node >= 0 ? m.source_node : -1 - int(mi);
    auto [it, inserted] = object_of_node.try_emplace(key, objects.size());
    if (inserted) {
      objects.emplace_back();
      objects.back().name = m.name;
      object_meshes.emplace_back();
    }
    precompute::ImportObject& o = objects[it->second];
    object_meshes[it->second].push_back(mi);
    const std::uint32_t base = std::uint32_t(o.positions.size());
    for (const glm::vec3& p : m.position) o.positions.push_back(glm::dvec3(p));
    for (std::uint32_t i : m.indices) o.indices.push_back(base + i);
    const glm::dvec3 albedo = material_albedo(scene, m.material);
    o.triangle_albedo.insert(o.triangle_albedo.end(), m.indices.size() / 3, albedo);
  }
  std::vector<LightDescription> lights;
  for (const DemoLight& l : scene.lights) {
    if (l.path.empty()) continue;
    LightDescription d;
    d.position = glm::dvec3(l.path.front());
    d.radius = l.radius;
    d.color = glm::dvec3(l.color);
    d.intensity = l.intensity;
    lights.push_back(d);
  }
  Result<precompute::SceneImport> imported = precompute::import_scene(objects, lights, settings);
  if (!imported.ok()) return imported.status();
  scene.level = imported->level;
  scene.level.name = scene.name.empty() ? "imported" : scene.name;
  // Turn round what faces solid: indices swapped, and the normals (and tangents' handedness)
  // of a mesh all of whose triangles turn (shared vertices keep theirs otherwise).
  for (std::size_t o = 0; o < objects.size(); ++o) {
    std::size_t first = 0;
    for (std::size_t mi : object_meshes[o]) {
      Mesh& m = scene.meshes[mi];
      const std::size_t tris = m.indices.size() / 3;
      std::size_t turned = 0;
      for (std::size_t t = 0; t < tris; ++t)
        if (imported->flipped[o][first + t]) {
          std::swap(m.indices[3 * t + 1], m.indices[3 * t + 2]);
          ++turned;
        }
      // A vertex turns when every triangle using it turned.
      std::vector<int> uses(m.position.size(), 0), turns(m.position.size(), 0);
      for (std::size_t t = 0; t < tris; ++t)
        for (int k = 0; k < 3; ++k) {
          ++uses[m.indices[3 * t + std::size_t(k)]];
          turns[m.indices[3 * t + std::size_t(k)]] += imported->flipped[o][first + t];
        }
      if (turned > 0)
        for (std::size_t v = 0; v < m.position.size(); ++v) {
          if (uses[v] == 0 || turns[v] != uses[v]) continue;
          if (v < m.normal.size()) m.normal[v] = -m.normal[v];
          if (v < m.tangent.size()) m.tangent[v].w = -m.tangent[v].w;
        }
      first += tris;
    }
  }
  return imported;
}

}  // namespace modrt::demo
