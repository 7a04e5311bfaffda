// SPDX-License-Identifier: MIT
#include "clutter_shapes.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <glm/geometric.hpp>

#include "modrt/precompute/clutter_mesh.h"

namespace modrt::demo {

Status add_clutter_prism(DemoScene& scene, const ClutterPrism& prism) {
  const std::size_t n = prism.polygon.size();
  double area2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const glm::dvec2 &a = prism.polygon[i], &b = prism.polygon[(i + 1) % n];
    area2 += a.x * b.y - b.x * a.y;
  }
  if (n < 3 || !(area2 > 0.0) || prism.cap_triangles.size() % 3 != 0 || prism.cap_triangles.empty() ||
      !(prism.y1 > prism.y0) || prism.material < 0 || std::size_t(prism.material) >= scene.materials.size())
    return Status::error(ErrorCode::invalid_argument,
                         "clutter prism '" + prism.name +
                             "': needs a counter-clockwise polygon, cap triangles, y1 > y0 and a material");
  for (int i : prism.cap_triangles)
    if (i < 0 || std::size_t(i) >= n)
      return Status::error(ErrorCode::invalid_argument, "clutter prism '" + prism.name + "': cap index " +
                                                            std::to_string(i) + " out of range");
  const int charts = int(n) + 2;
  const int grid = int(std::ceil(std::sqrt(double(charts))));
  constexpr double kInset = 0.08;  // of a tile, so neighbouring charts never share a cell
  ClutterMesh cm;
  int chart = 0;
  auto tile = [&](double u, double v) {
    const double s = (1.0 - 2.0 * kInset) / grid;
    return glm::dvec2((chart % grid + kInset) / grid + u * s, (chart / grid + kInset) / grid + v * s);
  };
  // Winds (a, b, c) so that its geometric normal points along `outward`.
  auto triangle = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, const glm::dvec3& outward) {
    const glm::dvec3 nrm = glm::cross(cm.positions[b] - cm.positions[a], cm.positions[c] - cm.positions[a]);
    if (glm::dot(nrm, outward) < 0.0) std::swap(b, c);
    cm.indices.insert(cm.indices.end(), {a, b, c});
  };
  for (std::size_t i = 0; i < n; ++i, ++chart) {
    const glm::dvec2 p = prism.polygon[i], q = prism.polygon[(i + 1) % n];
    const glm::dvec3 outward(q.y - p.y, 0.0, -(q.x - p.x));  // right of a counter-clockwise edge
    const std::uint32_t base = std::uint32_t(cm.positions.size());
    const glm::dvec3 corners[4] = {
        {p.x, prism.y0, p.y}, {q.x, prism.y0, q.y}, {q.x, prism.y1, q.y}, {p.x, prism.y1, p.y}};
    const glm::dvec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int k = 0; k < 4; ++k) cm.positions.push_back(corners[k]), cm.uvs.push_back(tile(uv[k].x, uv[k].y));
    triangle(base, base + 1, base + 2, outward);
    triangle(base, base + 2, base + 3, outward);
  }
  glm::dvec2 lo(1e300), hi(-1e300);
  for (const glm::dvec2& p : prism.polygon) lo = glm::min(lo, p), hi = glm::max(hi, p);
  const double size = std::max(hi.x - lo.x, hi.y - lo.y);
  for (const double y : {prism.y0, prism.y1}) {
    const glm::dvec3 outward(0.0, y == prism.y0 ? -1.0 : 1.0, 0.0);
    const std::uint32_t base = std::uint32_t(cm.positions.size());
    for (const glm::dvec2& p : prism.polygon)
      cm.positions.push_back({p.x, y, p.y}), cm.uvs.push_back(tile((p.x - lo.x) / size, (p.y - lo.y) / size));
    for (std::size_t t = 0; t < prism.cap_triangles.size(); t += 3)
      triangle(base + std::uint32_t(prism.cap_triangles[t]), base + std::uint32_t(prism.cap_triangles[t + 1]),
               base + std::uint32_t(prism.cap_triangles[t + 2]), outward);
    ++chart;
  }
  // The drawn mesh: a vertex per corner (flat normals), the lightmap UVs with it.
  Mesh mesh;
  mesh.name = prism.name;
  mesh.material = prism.material;
  for (std::size_t t = 0; t < cm.indices.size(); t += 3) {
    const glm::dvec3 &a = cm.positions[cm.indices[t]], &b = cm.positions[cm.indices[t + 1]],
                     &c = cm.positions[cm.indices[t + 2]];
    const glm::vec3 nrm(glm::normalize(glm::cross(b - a, c - a)));
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = cm.indices[t + std::size_t(k)];
      mesh.indices.push_back(std::uint32_t(mesh.position.size()));
      mesh.position.emplace_back(cm.positions[v]);
      mesh.normal.push_back(nrm);
      mesh.lightmap_uv.emplace_back(cm.uvs[v]);
    }
  }
  const glm::dvec3 albedo(scene.materials[std::size_t(prism.material)].base_color);
  Result<ClutterObject> object = precompute::make_mesh_clutter(std::move(cm), prism.block, albedo, prism.res,
                                                               "clutter prism '" + prism.name + "'");
  if (!object.ok()) return object.status();
  mesh.clutter = int(scene.clutter.size());
  scene.clutter.push_back(std::move(object).value());
  scene.meshes.push_back(std::move(mesh));
  return Status::success();
}

}  // namespace modrt::demo
