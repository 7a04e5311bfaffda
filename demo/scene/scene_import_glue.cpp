// SPDX-License-Identifier: MIT
#include "scene_import_glue.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <glm/geometric.hpp>

#include "modrt/precompute/clutter_import.h"
#include "modrt/precompute/clutter_mesh.h"

namespace modrt::demo {

namespace {

double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

// Barycentric coordinates of p's projection onto triangle (a, b, c)'s plane (extrapolated
// outside it).
glm::dvec3 plane_barycentric(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                             const glm::dvec3& c) {
  const glm::dvec3 e0 = b - a, e1 = c - a, d = p - a;
  const double d00 = glm::dot(e0, e0), d01 = glm::dot(e0, e1), d11 = glm::dot(e1, e1);
  const double d20 = glm::dot(d, e0), d21 = glm::dot(d, e1), den = d00 * d11 - d01 * d01;
  if (!(std::abs(den) > 0.0)) return glm::dvec3(1.0, 0.0, 0.0);
  const double v = (d11 * d20 - d01 * d21) / den, w = (d00 * d21 - d01 * d20) / den;
  return glm::dvec3(1.0 - v - w, v, w);
}

// Furniture (the importer's clutter objects) becomes DRT mesh clutter: a closed, welded
// mesh with generated lightmap charts (precompute/clutter_import.h) owned by the block that
// holds its centroid. The object's meshes are replaced by that mesh, piece by piece under
// their own materials (texture coordinates carried over from the nearest input triangle), and
// drawn with the clutter lightmap. An object that cannot be made clutter stays static
// geometry, with a warning.
void add_imported_clutter(DemoScene& scene, const std::vector<precompute::ImportObject>& objects,
                          const std::vector<std::vector<std::size_t>>& object_meshes,
                          precompute::SceneImport& imported) {
  std::vector<std::size_t> marked;  // meshes of extras.modrt_clutter nodes: their objects come later
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi)
    if (scene.meshes[mi].clutter >= 0) marked.push_back(mi);
  int added = 0;
  for (std::size_t o = 0; o < objects.size(); ++o) {
    if (imported.object_role[o] != precompute::ObjectRole::clutter) continue;
    const precompute::ImportObject& obj = objects[o];
    Result<precompute::ClutterImport> ci =
        precompute::make_clutter_mesh_from_object(obj.positions, obj.indices, {}, obj.name);
    // A curved object's rebuild is a staircase of grid cells (an icosphere of 80 triangles
    // becomes 2950), and the rebuild is what is drawn: such an object stays static geometry,
    // lit through the proxies, until its own triangles can carry the clutter charts.
    const std::size_t in_triangles = obj.indices.size() / 3;
    if (ci.ok() && ci->mesh.indices.size() / 3 > 4 * std::max<std::size_t>(in_triangles, 12)) {
      imported.warnings.push_back(
          obj.name + ": stays static geometry, not clutter: its rebuild on the clutter grid has " +
          std::to_string(ci->mesh.indices.size() / 3) + " triangles for its " + std::to_string(in_triangles) +
          " (a curved shape)");
      continue;
    }
    // DRT has one albedo per object: the area-weighted mean of its triangles'.
    glm::dvec3 albedo(0.0);
    double area = 0.0;
    for (std::size_t t = 0; 3 * t < obj.indices.size(); ++t) {
      const double a = 0.5 * glm::length(glm::cross(
                                 obj.positions[obj.indices[3 * t + 1]] - obj.positions[obj.indices[3 * t]],
                                 obj.positions[obj.indices[3 * t + 2]] - obj.positions[obj.indices[3 * t]]));
      albedo += a * obj.triangle_albedo[obj.triangle_albedo.size() == 1 ? 0 : t];
      area += a;
    }
    albedo = area > 0.0 ? albedo / area : glm::dvec3(0.5);
    Result<ClutterObject> object =
        ci.ok() ? precompute::make_mesh_clutter(ci->mesh,
                                                precompute::clutter_owner_block(scene.level, ci->centroid),
                                                albedo, ci->res, obj.name)
                : Result<ClutterObject>(ci.status());
    if (!object.ok()) {
      imported.warnings.push_back(obj.name +
                                  ": stays static geometry, not clutter: " + object.status().message());
      continue;
    }
    const int index = int(scene.clutter.size());
    std::size_t first = 0;  // the first triangle of this mesh within the object
    for (std::size_t mi : object_meshes[o]) {
      const Mesh& m = scene.meshes[mi];
      const std::size_t count = m.indices.size() / 3;
      Mesh out;
      out.name = m.name;
      out.material = m.material;
      out.clutter = index;
      out.source_node = m.source_node;
      out.source_primitive = m.source_primitive;
      out.import_object = m.import_object;
      for (std::size_t t = 0; t < ci->source_triangle.size(); ++t) {
        const std::size_t src = ci->source_triangle[t];
        if (src < first || src >= first + count) continue;
        const std::uint32_t* s = &m.indices[3 * (src - first)];
        for (int k = 0; k < 3; ++k) {
          const std::uint32_t v = ci->mesh.indices[3 * t + std::size_t(k)];
          const glm::dvec3 p = ci->mesh.positions[v];
          out.indices.push_back(std::uint32_t(out.position.size()));
          out.position.emplace_back(p);
          out.normal.emplace_back(ci->normals[v]);
          out.lightmap_uv.emplace_back(ci->mesh.uvs[v]);
          const glm::dvec3 w = plane_barycentric(p, glm::dvec3(m.position[s[0]]),
                                                 glm::dvec3(m.position[s[1]]), glm::dvec3(m.position[s[2]]));
          if (!m.uv.empty())
            out.uv.push_back(glm::vec2(w.x * glm::dvec2(m.uv[s[0]]) + w.y * glm::dvec2(m.uv[s[1]]) +
                                       w.z * glm::dvec2(m.uv[s[2]])));
          if (!m.tangent.empty()) out.tangent.push_back(m.tangent[s[0]]);
        }
      }
      first += count;
      scene.meshes[mi] = std::move(out);
    }
    scene.clutter.push_back(std::move(object).value());
    ++added;
  }
  for (std::size_t mi : marked) scene.meshes[mi].clutter += added;
}

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
    scene.meshes[mi].import_object = int(it->second);
    const std::uint32_t base = std::uint32_t(o.positions.size());
    for (const glm::vec3& p : m.position) o.positions.push_back(glm::dvec3(p));
    for (std::uint32_t i : m.indices) o.indices.push_back(base + i);
    const glm::dvec3 albedo = material_albedo(scene, m.material);
    o.triangle_albedo.insert(o.triangle_albedo.end(), m.indices.size() / 3, albedo);
  }
  std::vector<LightDescription> lights;
  for (const DemoLight& l : scene.lights) {
    if (l.path.empty() || l.directional) continue;  // the level's lights are point lights
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
  scene.proxy_depth = float(imported->plan.proxy_depth);
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
  add_imported_clutter(scene, objects, object_meshes, imported.value());
  return imported;
}

}  // namespace modrt::demo
