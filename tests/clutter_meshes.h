// SPDX-License-Identifier: MIT
// Procedural clutter meshes with lightmap UV layouts, shared by the mesh-clutter tests
// (test_clutter_mesh, test_drt): a box as 12 triangles whose faces land on grid-aligned UV
// squares (the same texels as a box clutter object), a UV sphere (one chart with a seam),
// and an extruded L (concave: it shadows itself), each chart packed into the atlas with a
// gutter so that no two charts share a texel.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include <glm/geometric.hpp>

#include "modrt/clutter_mesh.h"
#include "modrt/drt.h"

namespace modrt::test {

// A box as 12 triangles; face f's n x n texels occupy a grid-aligned UV square with a
// one-texel gutter, faces in a 3 x 2 arrangement of a res x res atlas (res >= 3 (n + 2)).
inline ClutterMesh box_mesh(const ClutterBox& box, int n, int res) {
  ClutterMesh m;
  for (int f = 0; f < kFaceCount; ++f) {
    const glm::dvec2 origin{double(1 + (f % 3) * (n + 2)) / res, double(1 + (f / 3) * (n + 2)) / res};
    const std::uint32_t base = std::uint32_t(m.positions.size());
    for (int k = 0; k < 4; ++k) {
      const double u = k & 1, v = k >> 1;
      m.positions.push_back(clutter_face_point(box, f, u, v));
      m.uvs.push_back(origin + glm::dvec2(u, v) * (double(n) / res));
    }
    for (std::uint32_t i : {0u, 1u, 3u, 0u, 3u, 2u}) m.indices.push_back(base + i);
  }
  return m;
}

// A UV sphere (rings x segments) around `center`: one chart, longitude seam, pole fans.
inline ClutterMesh uv_sphere_mesh(const glm::dvec3& center, double r, int rings, int segments) {
  ClutterMesh m;
  for (int j = 0; j <= rings; ++j)
    for (int i = 0; i <= segments; ++i) {
      const double theta = std::numbers::pi * j / rings, phi = 2 * std::numbers::pi * i / segments;
      // Pole rows: one vertex per segment, in the middle of its UV span, so no UV triangle is
      // degenerate.
      const double u = (j == 0 || j == rings) ? (i + 0.5) / segments : double(i) / segments;
      m.positions.push_back(center + r * glm::dvec3(std::sin(theta) * std::cos(phi), std::cos(theta),
                                                    std::sin(theta) * std::sin(phi)));
      m.uvs.push_back({0.02 + 0.96 * std::min(u, 1.0), 0.02 + 0.96 * j / rings});
    }
  auto vertex = [&](int i, int j) { return std::uint32_t(j * (segments + 1) + i); };
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < segments; ++i) {
      if (j > 0) m.indices.insert(m.indices.end(), {vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1)});
      if (j + 1 < rings)
        m.indices.insert(m.indices.end(), {vertex(i, j), vertex(i + 1, j + 1), vertex(i, j + 1)});
    }
  return m;
}

// A prism: the polygon `outline` (x, z; star-shaped from outline[0]) extruded from y0 to
// y1, its two caps and every side a chart. Charts are packed on shelves with a two-texel
// gutter of a res x res atlas; triangles wind outward.
inline ClutterMesh prism_mesh(const std::vector<glm::dvec2>& outline, double y0, double y1, int res) {
  struct Chart {
    std::vector<glm::dvec3> p;   // quad or polygon corners
    std::vector<glm::dvec2> uv;  // in world units, from 0
    glm::dvec2 size;
    glm::dvec3 outward;
  };
  std::vector<Chart> charts;
  const std::size_t n = outline.size();
  double signed_area = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const glm::dvec2 &a = outline[i], &b = outline[(i + 1) % n];
    signed_area += a.x * b.y - a.y * b.x;
  }
  glm::dvec2 lo(INFINITY), hi(-INFINITY);
  for (const glm::dvec2& q : outline) lo = glm::min(lo, q), hi = glm::max(hi, q);
  for (double y : {y0, y1}) {
    Chart c;
    for (const glm::dvec2& q : outline) {
      c.p.push_back({q.x, y, q.y});
      c.uv.push_back(q - lo);
    }
    c.size = hi - lo;
    c.outward = {0, y == y1 ? 1.0 : -1.0, 0};
    charts.push_back(c);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const glm::dvec2 &a = outline[i], &b = outline[(i + 1) % n];
    const double w = glm::length(b - a), h = y1 - y0;
    Chart c;
    c.p = {{a.x, y0, a.y}, {b.x, y0, b.y}, {b.x, y1, b.y}, {a.x, y1, a.y}};
    c.uv = {{0, 0}, {w, 0}, {w, h}, {0, h}};
    c.size = {w, h};
    const glm::dvec2 e = b - a;
    const glm::dvec2 out = signed_area > 0 ? glm::dvec2(e.y, -e.x) : glm::dvec2(-e.y, e.x);
    c.outward = {out.x, 0, out.y};
    charts.push_back(c);
  }
  // Shelf packing at the largest scale that fits, two texels of gutter round every chart.
  const double gutter = 2.0 / res;
  std::vector<glm::dvec2> offset(charts.size());
  double scale = 4.0;
  for (;; scale *= 0.95) {
    double x = gutter, y = gutter, shelf = 0;
    bool fits = true;
    for (std::size_t k = 0; k < charts.size() && fits; ++k) {
      const glm::dvec2 s = charts[k].size * scale;
      if (x + s.x + gutter > 1.0) x = gutter, y += shelf + gutter, shelf = 0;
      offset[k] = {x, y};
      x += s.x + gutter;
      shelf = std::max(shelf, s.y);
      fits = s.x + 2 * gutter <= 1.0 && y + shelf + gutter <= 1.0;
    }
    if (fits) break;
  }
  ClutterMesh m;
  for (std::size_t k = 0; k < charts.size(); ++k) {
    const Chart& c = charts[k];
    const std::uint32_t base = std::uint32_t(m.positions.size());
    for (std::size_t v = 0; v < c.p.size(); ++v) {
      m.positions.push_back(c.p[v]);
      m.uvs.push_back(offset[k] + c.uv[v] * scale);
    }
    for (std::uint32_t v = 1; v + 1 < c.p.size(); ++v) {  // a fan from the first corner
      std::uint32_t t[3] = {base, base + v, base + v + 1};
      const glm::dvec3 nrm =
          glm::cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]);
      if (glm::dot(nrm, c.outward) < 0) std::swap(t[1], t[2]);
      m.indices.insert(m.indices.end(), {t[0], t[1], t[2]});
    }
  }
  return m;
}

// An L (concave) standing on y0: two arms of `arm` x `width` meeting at (x0, z0); the fan
// starts at the inner corner, from which the L is star-shaped.
inline ClutterMesh l_prism_mesh(double x0, double z0, double arm, double width, double y0, double y1,
                                int res) {
  const std::vector<glm::dvec2> outline = {{x0 + width, z0 + width}, {x0 + width, z0 + arm},
                                           {x0, z0 + arm},           {x0, z0},
                                           {x0 + arm, z0},           {x0 + arm, z0 + width}};
  return prism_mesh(outline, y0, y1, res);
}

}  // namespace modrt::test
