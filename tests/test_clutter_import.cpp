// SPDX-License-Identifier: MIT
// Furniture as DRT mesh clutter (precompute/clutter_import.h): artists' objects (intersecting
// closed boxes joined into one mesh, vertices split per face, any winding, no lightmap UVs)
// become closed, manifold, outward-wound meshes whose volume is the union's; generated UV
// charts lie in [0, 1]^2 without overlap (gutter included) at one texel density;
// make_mesh_clutter and ClutterMeshShape accept the result; bad input is refused by name; the
// flat's and the L hall's furniture (data/scenes/import, read with tinygltf) import in a few ms.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <numbers>
#include <random>
#include <set>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "clutter_meshes.h"
#include "modrt/precompute/clutter_import.h"
#include "modrt/precompute/clutter_mesh.h"

#if MODRT_TEST_HAVE_TINYGLTF
// Debian's libtinygltf is compiled: the header without TINYGLTF_IMPLEMENTATION.
#include <tiny_gltf.h>
#endif

namespace modrt::precompute {
namespace {

// A triangle soup, as an artist's joined mesh is: vertices split per face.
struct Soup {
  std::vector<glm::dvec3> positions;
  std::vector<std::uint32_t> indices;
  void add_polygon(const std::vector<glm::dvec3>& poly, bool reverse = false) {
    const std::uint32_t base = std::uint32_t(positions.size());
    for (std::size_t k = 0; k < poly.size(); ++k)
      positions.push_back(poly[reverse ? poly.size() - 1 - k : k]);
    for (std::uint32_t k = 1; k + 1 < poly.size(); ++k)
      indices.insert(indices.end(), {base, base + k, base + k + 1});
  }
  void append(const Soup& o) {
    const std::uint32_t base = std::uint32_t(positions.size());
    positions.insert(positions.end(), o.positions.begin(), o.positions.end());
    for (std::uint32_t i : o.indices) indices.push_back(base + i);
  }
  Soup transformed(const glm::dmat4& m) const {
    Soup s = *this;
    for (glm::dvec3& p : s.positions) p = glm::dvec3(m * glm::dvec4(p, 1.0));
    return s;
  }
};

// Box [lo, hi] as 6 quads (24 vertices); `inward` winds it inside out (a mirrored export).
Soup box_soup(const glm::dvec3& lo, const glm::dvec3& hi, bool inward = false) {
  Soup s;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int b = (axis + 1) % 3, c = (axis + 2) % 3;
      std::vector<glm::dvec3> q(4);
      for (int k = 0; k < 4; ++k) {
        glm::dvec3 p;
        p[axis] = side ? hi[axis] : lo[axis];
        const int u = (k == 1 || k == 2), v = (k >= 2);
        p[b] = u ? hi[b] : lo[b];
        p[c] = v ? hi[c] : lo[c];
        q[std::size_t(k)] = p;
      }
      s.add_polygon(q, (side == 0) != inward);
    }
  return s;
}

// A box with every edge chamfered by w (Blender's Bevel, one segment): 6 shrunk faces, 12
// edge quads and 8 corner triangles, each polygon its own vertices, wound outward.
Soup chamfered_box(const glm::dvec3& lo, const glm::dvec3& hi, double w) {
  const glm::dvec3 c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  auto point = [&](const glm::dvec3& s, int exact) {  // corner s's point on face `exact`
    glm::dvec3 p;
    for (int k = 0; k < 3; ++k) p[k] = c[k] + s[k] * (k == exact ? h[k] : h[k] - w);
    return p;
  };
  Soup soup;
  auto add = [&](std::vector<glm::dvec3> poly) {
    glm::dvec3 centre(0.0), n(0.0);
    for (const glm::dvec3& p : poly) centre += p / double(poly.size());
    for (std::size_t k = 0; k < poly.size(); ++k)
      n += glm::cross(poly[k] - centre, poly[(k + 1) % poly.size()] - centre);
    soup.add_polygon(poly, glm::dot(n, centre - c) < 0.0);
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side : {-1, 1}) {  // faces
      const int b = (axis + 1) % 3, d = (axis + 2) % 3;
      std::vector<glm::dvec3> q;
      for (auto [u, v] : {std::pair{-1, -1}, std::pair{1, -1}, std::pair{1, 1}, std::pair{-1, 1}}) {
        glm::dvec3 s;
        s[axis] = side, s[b] = u, s[d] = v;
        q.push_back(point(s, axis));
      }
      add(q);
    }
  for (int axis = 0; axis < 3; ++axis)  // edges along `axis`
    for (int sb : {-1, 1})
      for (int sd : {-1, 1}) {
        const int b = (axis + 1) % 3, d = (axis + 2) % 3;
        glm::dvec3 s0, s1;
        s0[axis] = -1, s1[axis] = 1;
        s0[b] = s1[b] = sb, s0[d] = s1[d] = sd;
        add({point(s0, b), point(s1, b), point(s1, d), point(s0, d)});
      }
  for (int k = 0; k < 8; ++k) {  // corners
    const glm::dvec3 s(k & 1 ? 1 : -1, k & 2 ? 1 : -1, k & 4 ? 1 : -1);
    add({point(s, 0), point(s, 1), point(s, 2)});
  }
  return soup;
}

struct MeshFacts {
  bool closed = true;  // every edge, welded by exact position: once each way
  std::string problem;
  double volume = 0.0, area = 0.0;
};

MeshFacts facts(const ClutterMesh& m) {
  MeshFacts f;
  std::map<std::array<double, 3>, std::uint32_t> weld;
  std::vector<std::uint32_t> id(m.positions.size());
  for (std::size_t v = 0; v < m.positions.size(); ++v)
    id[v] = weld.emplace(std::array<double, 3>{m.positions[v].x, m.positions[v].y, m.positions[v].z},
                         std::uint32_t(weld.size()))
                .first->second;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (std::size_t t = 0; t < m.indices.size(); t += 3) {
    const glm::dvec3 &a = m.positions[m.indices[t]], &b = m.positions[m.indices[t + 1]],
                     &c = m.positions[m.indices[t + 2]];
    f.volume += glm::dot(a, glm::cross(b, c)) / 6.0;
    f.area += 0.5 * glm::length(glm::cross(b - a, c - a));
    for (std::size_t k = 0; k < 3; ++k) ++directed[{id[m.indices[t + k]], id[m.indices[t + (k + 1) % 3]]}];
  }
  for (const auto& [e, n] : directed) {
    const auto back = directed.find({e.second, e.first});
    if (n != 1 || back == directed.end() || back->second != 1) {
      f.closed = false;
      f.problem = "edge " + std::to_string(e.first) + "-" + std::to_string(e.second) + " used " +
                  std::to_string(n) + " times forward, " +
                  std::to_string(back == directed.end() ? 0 : back->second) + " back";
      break;
    }
  }
  return f;
}

// UVs in [0, 1]; each chart's cells (every cell its UV triangles' bounds touch) grown by the
// gutter overlap no other chart's; world area per UV area is one number for all triangles.
void expect_good_atlas(const ClutterImport& r, int gutter) {
  const ClutterMesh& m = r.mesh;
  ASSERT_EQ(m.uvs.size(), m.positions.size());
  for (const glm::dvec2& uv : m.uvs) {
    EXPECT_GE(uv.x, 0.0);
    EXPECT_LE(uv.x, 1.0);
    EXPECT_GE(uv.y, 0.0);
    EXPECT_LE(uv.y, 1.0);
  }
  const std::vector<int> chart = clutter_mesh_charts(m);
  ASSERT_EQ(chart.size(), m.indices.size() / 3);
  ASSERT_EQ(*std::max_element(chart.begin(), chart.end()) + 1, r.chart_count) << "UV islands are the charts";
  const int res = r.res;
  std::vector<int> owner(std::size_t(res) * std::size_t(res), -1);
  std::vector<std::set<std::pair<int, int>>> cells(std::size_t(r.chart_count));
  double ratio_lo = INFINITY, ratio_hi = 0.0;
  for (std::size_t t = 0; t < m.indices.size() / 3; ++t) {
    glm::dvec2 lo(INFINITY), hi(-INFINITY);
    for (std::size_t k = 0; k < 3; ++k)
      lo = glm::min(lo, m.uvs[m.indices[3 * t + k]]), hi = glm::max(hi, m.uvs[m.indices[3 * t + k]]);
    const int i0 = int(std::floor(lo.x * res + 1e-7)), i1 = int(std::floor(hi.x * res - 1e-7));
    const int j0 = int(std::floor(lo.y * res + 1e-7)), j1 = int(std::floor(hi.y * res - 1e-7));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) cells[std::size_t(chart[t])].insert({i, j});
    const glm::dvec3 &a = m.positions[m.indices[3 * t]], &b = m.positions[m.indices[3 * t + 1]],
                     &c = m.positions[m.indices[3 * t + 2]];
    const glm::dvec2 &ua = m.uvs[m.indices[3 * t]], &ub = m.uvs[m.indices[3 * t + 1]],
                     &uc = m.uvs[m.indices[3 * t + 2]];
    const double uv_area = 0.5 * std::abs((ub - ua).x * (uc - ua).y - (ub - ua).y * (uc - ua).x);
    const double ratio = 0.5 * glm::length(glm::cross(b - a, c - a)) / uv_area;
    ratio_lo = std::min(ratio_lo, ratio), ratio_hi = std::max(ratio_hi, ratio);
  }
  // Texel density: exactly one scale (the only spread is rounding).
  EXPECT_LT(ratio_hi / ratio_lo, 1.0 + 1e-6);
  EXPECT_NEAR(std::sqrt(1.0 / ratio_lo) * res, r.texels_per_metre, 1e-6 * r.texels_per_metre);
  for (std::size_t ch = 0; ch < cells.size(); ++ch)
    for (const auto& [i, j] : cells[ch]) {
      ASSERT_TRUE(i >= 0 && j >= 0 && i < res && j < res) << "chart " << ch << " cell " << i << ", " << j;
      for (int dj = -gutter; dj <= gutter; ++dj)
        for (int di = -gutter; di <= gutter; ++di) {
          const int x = i + di, y = j + dj;
          if (x < 0 || y < 0 || x >= res || y >= res) continue;
          int& o = owner[std::size_t(y) * std::size_t(res) + std::size_t(x)];
          EXPECT_TRUE(o < 0 || o == int(ch))
              << "charts " << o << " and " << ch << " meet at cell " << x << ", " << y;
          o = int(ch);
        }
    }
}

double union_volume(const glm::dvec3& alo, const glm::dvec3& ahi, const glm::dvec3& blo,
                    const glm::dvec3& bhi) {
  auto vol = [](const glm::dvec3& lo, const glm::dvec3& hi) {
    const glm::dvec3 e = glm::max(hi - lo, glm::dvec3(0.0));
    return e.x * e.y * e.z;
  };
  return vol(alo, ahi) + vol(blo, bhi) - vol(glm::max(alo, blo), glm::min(ahi, bhi));
}

Result<ClutterImport> run(const Soup& s, const ClutterImportSettings& settings = {}) {
  return make_clutter_mesh_from_object(s.positions, s.indices, settings, "test object");
}

TEST(ClutterImport, TwoIntersectingBoxesGiveTheirUnionClosedAndOutward) {
  const glm::dvec3 alo(0.0, 0.0, 0.0), ahi(1.0, 0.5, 0.6), blo(0.3, 0.2, 0.1), bhi(0.8, 0.9, 0.5);
  const double want = union_volume(alo, ahi, blo, bhi);
  // Any winding (B inside out), anywhere, turned any way: the same union.
  const glm::dmat4 turn = glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(3.0, -1.0, 2.0)), 0.7,
                                      glm::normalize(glm::dvec3(1.0, 2.0, 0.5)));
  for (const glm::dmat4& m : {glm::dmat4(1.0), turn}) {
    Soup s = box_soup(alo, ahi);
    s.append(box_soup(blo, bhi, /*inward=*/true));
    Result<ClutterImport> r = run(s.transformed(m));
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    const MeshFacts f = facts(r->mesh);
    EXPECT_TRUE(f.closed) << f.problem;
    EXPECT_EQ(r->components, 2);
    EXPECT_EQ(r->open_components, 0);
    // Both boxes' planes are grid lines: the union is exact.
    EXPECT_NEAR(f.volume, want, 1e-9) << "signed volume (positive: outward)";
    EXPECT_NEAR(r->volume, want, 1e-9);
    // Normals: unit, along the frame, pointing out (a step along it leaves the union).
    Result<ClutterMeshShape> shape = ClutterMeshShape::create(r->mesh, clutter_mesh_charts(r->mesh), "union");
    ASSERT_TRUE(shape.ok()) << shape.status().to_string();
    const glm::dmat4 inv = glm::inverse(m);
    auto inside = [&](const glm::dvec3& p) {
      const glm::dvec3 q = glm::dvec3(inv * glm::dvec4(p, 1.0));
      return (glm::all(glm::greaterThan(q, alo)) && glm::all(glm::lessThan(q, ahi))) ||
             (glm::all(glm::greaterThan(q, blo)) && glm::all(glm::lessThan(q, bhi)));
    };
    for (std::size_t t = 0; t < r->mesh.indices.size(); t += 3) {
      const std::uint32_t v = r->mesh.indices[t];
      const glm::dvec3 centre = (r->mesh.positions[v] + r->mesh.positions[r->mesh.indices[t + 1]] +
                                 r->mesh.positions[r->mesh.indices[t + 2]]) /
                                3.0;
      EXPECT_NEAR(glm::length(r->normals[v]), 1.0, 1e-12);
      EXPECT_FALSE(inside(centre + 1e-4 * r->normals[v])) << "triangle " << t / 3;
      EXPECT_TRUE(inside(centre - 1e-4 * r->normals[v])) << "triangle " << t / 3;
    }
    EXPECT_TRUE(inside(r->centroid));
    // The DRT's inside test agrees with the union away from its surface.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.1, 1.0);
    int checked = 0;
    for (int k = 0; k < 2000; ++k) {
      const glm::dvec3 q(u(rng), u(rng), u(rng));
      bool near_face = false;
      for (int a = 0; a < 3; ++a)
        for (double x : {alo[a], ahi[a], blo[a], bhi[a]}) near_face |= std::abs(q[a] - x) < 1e-6;
      if (near_face) continue;
      const glm::dvec3 p = glm::dvec3(m * glm::dvec4(q, 1.0));
      EXPECT_EQ(shape->contains(p), inside(p)) << k;
      ++checked;
    }
    EXPECT_GT(checked, 1900);
  }
}

// Volume of a union of axis-aligned boxes, exactly (coordinate compression).
double boxes_union_volume(const std::vector<std::pair<glm::dvec3, glm::dvec3>>& boxes) {
  std::array<std::vector<double>, 3> x;
  for (const auto& [lo, hi] : boxes)
    for (int k = 0; k < 3; ++k) x[std::size_t(k)].insert(x[std::size_t(k)].end(), {lo[k], hi[k]});
  for (auto& v : x) std::sort(v.begin(), v.end()), v.erase(std::unique(v.begin(), v.end()), v.end());
  double volume = 0.0;
  for (std::size_t i = 0; i + 1 < x[0].size(); ++i)
    for (std::size_t j = 0; j + 1 < x[1].size(); ++j)
      for (std::size_t k = 0; k + 1 < x[2].size(); ++k) {
        const glm::dvec3 c(0.5 * (x[0][i] + x[0][i + 1]), 0.5 * (x[1][j] + x[1][j + 1]),
                           0.5 * (x[2][k] + x[2][k + 1]));
        for (const auto& [lo, hi] : boxes)
          if (glm::all(glm::greaterThan(c, lo)) && glm::all(glm::lessThan(c, hi))) {
            volume += (x[0][i + 1] - x[0][i]) * (x[1][j + 1] - x[1][j]) * (x[2][k + 1] - x[2][k]);
            break;
          }
      }
  return volume;
}

Soup boxes_soup(const std::vector<std::pair<glm::dvec3, glm::dvec3>>& boxes) {
  Soup s;
  for (const auto& [lo, hi] : boxes) s.append(box_soup(lo, hi));
  return s;
}

// The flat's sofa (flat.py), in its own frame.
const std::vector<std::pair<glm::dvec3, glm::dvec3>> kSofa{
    {{-1.0, 0.0, -0.45}, {1.0, 0.42, 0.45}},
    {{-1.0, 0.3, 0.2}, {1.0, 0.85, 0.45}},
    {{-1.0, 0.0, -0.45}, {-0.82, 0.62, 0.45}},
    {{0.82, 0.0, -0.45}, {1.0, 0.62, 0.45}},
};
const std::vector<std::pair<glm::dvec3, glm::dvec3>> kTable{
    {{-0.7, 0.71, -0.4}, {0.7, 0.75, 0.4}},    {{-0.65, 0.0, -0.35}, {-0.59, 0.71, -0.29}},
    {{0.59, 0.0, -0.35}, {0.65, 0.71, -0.29}}, {{-0.65, 0.0, 0.29}, {-0.59, 0.71, 0.35}},
    {{0.59, 0.0, 0.29}, {0.65, 0.71, 0.35}},
};

TEST(ClutterImport, PartsTouchingAlongAnEdgeBecomeManifold) {
  // Two boxes sharing only an edge (and the edge's vertices): the surface would not be a
  // manifold there; the cells beside the edge are filled, at the voxel size, not box-sized.
  Soup s = box_soup({0.0, 0.0, 0.0}, {1.0, 1.0, 0.5});
  s.append(box_soup({1.0, 1.0, 0.0}, {2.0, 2.0, 0.5}));
  Result<ClutterImport> r = run(s);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const MeshFacts f = facts(r->mesh);
  EXPECT_TRUE(f.closed) << f.problem;
  EXPECT_EQ(r->components, 2);
  EXPECT_LE(r->cell_size, 0.03 + 1e-12);
  EXPECT_GE(f.volume, 1.0 - 1e-9);
  EXPECT_LE(f.volume, 1.0 + 2.0 * 0.03 * 0.03 * 0.5 + 1e-9);
  expect_good_atlas(r.value(), 1);
}

TEST(ClutterImport, PartsOutOfTheFrameAreWithinTheCellTolerance) {
  // B turned 30 degrees about +Y against A: A's frame wins, B's slanted faces become stairs.
  const glm::dvec3 alo(0.0), ahi(1.2, 0.4, 0.8);
  Soup s = box_soup(alo, ahi);
  const glm::dmat4 turn = glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(0.6, 0.0, 0.4)),
                                      std::numbers::pi / 6.0, glm::dvec3(0.0, 1.0, 0.0));
  const glm::dvec3 blo(-0.3, 0.2, -0.3), bhi(0.3, 0.9, 0.3);
  s.append(box_soup(blo, bhi).transformed(turn));
  Result<ClutterImport> r = run(s);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const MeshFacts f = facts(r->mesh);
  EXPECT_TRUE(f.closed) << f.problem;
  EXPECT_NEAR(glm::length(r->frame[0] - glm::dvec3(1, 0, 0)), 0.0, 1e-12) << "A's frame (the larger area)";
  // The union's volume by midpoint sampling (~1e-4 accurate).
  const glm::dmat4 inv = glm::inverse(turn);
  const int n = 120;
  const glm::dvec3 lo(-0.1, 0.0, -0.1), hi(1.3, 0.9, 0.9);
  double want = 0.0;
  const glm::dvec3 step = (hi - lo) / double(n);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const glm::dvec3 p = lo + step * (glm::dvec3(i, j, k) + 0.5);
        const glm::dvec3 q = glm::dvec3(inv * glm::dvec4(p, 1.0));
        const bool in = (glm::all(glm::greaterThan(p, alo)) && glm::all(glm::lessThan(p, ahi))) ||
                        (glm::all(glm::greaterThan(q, blo)) && glm::all(glm::lessThan(q, bhi)));
        want += in ? step.x * step.y * step.z : 0.0;
      }
  // Tolerance: B's four slanted sides (0.6 x 0.7 each) times half a cell.
  EXPECT_NEAR(f.volume, want, 4 * 0.6 * 0.7 * 0.5 * r->cell_size);
  EXPECT_LE(r->cell_size, 0.03 + 1e-12);
  expect_good_atlas(r.value(), 1);
}

TEST(ClutterImport, AtlasChartsAreInsideDisjointAndUniform) {
  std::vector<std::pair<std::string, Soup>> objects;
  objects.emplace_back("sofa", boxes_soup(kSofa));
  const ClutterMesh sphere = test::uv_sphere_mesh({0.2, 1.0, -0.3}, 0.25, 10, 20);
  objects.emplace_back("sphere", Soup{sphere.positions, sphere.indices});
  objects.emplace_back("slant", box_soup({0.0, 0.0, 0.0}, {1.2, 0.4, 0.8}));
  objects.back().second.append(
      box_soup({-0.3, 0.2, -0.3}, {0.3, 0.9, 0.3})
          .transformed(glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(0.6, 0.0, 0.4)), 0.5,
                                   glm::dvec3(0.0, 1.0, 0.0))));
  for (const auto& [name, soup] : objects)
    for (int res : {16, 48, 128})
      for (int gutter : {1, 2}) {
        SCOPED_TRACE(name + " res " + std::to_string(res) + " gutter " + std::to_string(gutter));
        ClutterImportSettings settings;
        settings.res = res;
        settings.gutter = gutter;
        Result<ClutterImport> r = run(soup, settings);
        if (res == 16 && gutter == 2 && !r.ok()) {  // 12 charts of 1 + 2 x 2 texels a side: 300 > 256
          EXPECT_EQ(r.status().code(), ErrorCode::resource_limit);
          EXPECT_NE(r.status().message().find("raise res"), std::string::npos);
          continue;
        }
        ASSERT_TRUE(r.ok()) << r.status().to_string();
        EXPECT_EQ(r->res, res);
        EXPECT_TRUE(facts(r->mesh).closed);
        expect_good_atlas(r.value(), gutter);
        // The packing uses the atlas: from 48 texels on, at least a fifth of the cells are
        // chart texels (the gutters take the rest).
        const MeshFacts f = facts(r->mesh);
        const double used = f.area * r->texels_per_metre * r->texels_per_metre / (res * res);
        if (res >= 48) {
          EXPECT_GT(used, 0.2) << r->chart_count << " charts";
        }
        std::printf("%-6s res %3d gutter %d: %3d charts, %.0f %% of the atlas in charts, %.1f texels/m\n",
                    name.c_str(), res, gutter, r->chart_count, 100.0 * used, r->texels_per_metre);
      }
}

TEST(ClutterImport, MakeMeshClutterAcceptsTheResult) {
  Result<ClutterImport> r = run(boxes_soup(kSofa));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const MeshFacts f = facts(r->mesh);
  EXPECT_NEAR(f.volume, boxes_union_volume(kSofa), 1e-9);
  const double chart_texels = f.area * r->texels_per_metre * r->texels_per_metre;
  Result<ClutterObject> object = make_mesh_clutter(r->mesh, 0, glm::dvec3(0.5), r->res, "sofa");
  ASSERT_TRUE(object.ok()) << object.status().to_string();
  const int texels = clutter_texel_count(object.value());
  // Every chart's cells, partly covered border cells included: its area in texels, plus up to
  // a ring of border cells.
  EXPECT_GE(texels, int(chart_texels * 0.99));
  EXPECT_LE(texels, int(chart_texels * 1.6) + 4 * r->chart_count);
  EXPECT_EQ(clutter_face_count(object.value()), r->chart_count);
  EXPECT_EQ(object->res, r->res);
  // The texels' world areas add up to the mesh's area.
  double area = 0.0;
  for (double a : clutter_texel_area(object.value())) area += a;
  EXPECT_NEAR(area, f.area, 1e-9 * f.area);
  std::printf("sofa: %zu triangles, %d charts, %d texels of %d^2 (%.1f texels/m)\n",
              r->mesh.indices.size() / 3, r->chart_count, texels, r->res, r->texels_per_metre);
}

TEST(ClutterImport, TexelsPerMetreChoosesTheAtlasSize) {
  const Soup sofa = boxes_soup(kSofa);
  int last = 0;
  for (double density : {8.0, 16.0, 32.0}) {
    ClutterImportSettings settings;
    settings.texels_per_metre = density;
    Result<ClutterImport> r = run(sofa, settings);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_EQ(r->texels_per_metre, density);
    EXPECT_GT(r->res, last);
    last = r->res;
    expect_good_atlas(r.value(), settings.gutter);
    ClutterImportSettings smaller = settings;
    smaller.max_res = r->res - 1;
    Result<ClutterImport> refused = run(sofa, smaller);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.status().code(), ErrorCode::resource_limit);
  }
}

TEST(ClutterImport, BadInputIsRefusedByName) {
  const Soup box = box_soup(glm::dvec3(0.0), glm::dvec3(1.0));
  auto refused = [](const std::vector<glm::dvec3>& p, const std::vector<std::uint32_t>& i,
                    const ClutterImportSettings& s = {}) {
    Result<ClutterImport> r = make_clutter_mesh_from_object(p, i, s, "Chair");
    EXPECT_FALSE(r.ok());
    EXPECT_NE(r.status().message().find("Chair"), std::string::npos) << r.status().message();
    return r.ok() ? std::string() : r.status().to_string();
  };
  EXPECT_NE(refused({}, {}).find("no triangles"), std::string::npos);
  EXPECT_NE(refused(box.positions, {0, 1}).find("multiple of 3"), std::string::npos);
  EXPECT_NE(refused(box.positions, {0, 1, 99}).find("vertex 99"), std::string::npos);
  std::vector<glm::dvec3> nan = box.positions;
  nan[5].y = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(refused(nan, box.indices).find("vertex 5 has a NaN"), std::string::npos);
  std::vector<glm::dvec3> inf = box.positions;
  inf[2].x = std::numeric_limits<double>::infinity();
  EXPECT_NE(refused(inf, box.indices).find("vertex 2"), std::string::npos);
  std::vector<glm::dvec3> far = box.positions;
  far[3].z = 1e31;
  EXPECT_NE(refused(far, box.indices).find("float range"), std::string::npos);
  // Collinear and repeated vertices only.
  EXPECT_NE(refused({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}}, {0, 1, 2, 3, 3, 0}).find("degenerate"),
            std::string::npos);
  EXPECT_NE(refused({{1, 1, 1}, {1, 1, 1}, {1, 1, 1}}, {0, 1, 2}).find("one point"), std::string::npos);
  ClutterImportSettings s;
  s.res = 0;
  EXPECT_NE(refused(box.positions, box.indices, s).find("res 0"), std::string::npos);
  s = {};
  s.voxel_size = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(refused(box.positions, box.indices, s).find("voxel_size"), std::string::npos);
  s = {};
  s.max_triangles = 11;
  EXPECT_NE(refused(box.positions, box.indices, s).find("resource_limit"), std::string::npos);
  // Sizes far from furniture's still work: a 2 km union and a 1 mm one, each within its cells.
  for (double size : {2000.0, 0.001}) {
    Soup s2 = box_soup(glm::dvec3(0.0), glm::dvec3(size, 0.5 * size, 0.3 * size));
    s2.append(box_soup(glm::dvec3(0.2 * size), glm::dvec3(0.7 * size, size, 0.25 * size)));
    Result<ClutterImport> r = run(s2);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_TRUE(facts(r->mesh).closed);
    const double want = union_volume(glm::dvec3(0.0), glm::dvec3(size, 0.5 * size, 0.3 * size),
                                     glm::dvec3(0.2 * size), glm::dvec3(0.7 * size, size, 0.25 * size));
    EXPECT_NEAR(r->volume, want, 1e-9 * want);
    EXPECT_LE(std::max({r->cells.x, r->cells.y, r->cells.z}), ClutterImportSettings{}.max_cells);
  }
  // Too many charts for the atlas: the sphere's stairs in a 4 x 4 atlas.
  const ClutterMesh sphere = test::uv_sphere_mesh(glm::dvec3(0.0), 0.5, 10, 20);
  s = {};
  s.res = 4;
  EXPECT_NE(refused(sphere.positions, sphere.indices, s).find("raise res"), std::string::npos);
}

TEST(ClutterImport, OpenSheetsAreThickenedOrRefused) {
  // A single quad (a tabletop without thickness) and a box without its bottom face.
  Soup sheet;
  sheet.add_polygon({{0.0, 0.7, 0.0}, {1.0, 0.7, 0.0}, {1.0, 0.7, 0.6}, {0.0, 0.7, 0.6}});
  Soup bottomless;
  {
    const Soup box = box_soup(glm::dvec3(0.0), glm::dvec3(0.5, 0.4, 0.3));
    bottomless.positions = box.positions;
    for (std::size_t t = 0; t < box.indices.size(); t += 3) {
      bool bottom = true;
      for (std::size_t k = 0; k < 3; ++k) bottom &= box.positions[box.indices[t + k]].y == 0.0;
      if (!bottom)
        bottomless.indices.insert(bottomless.indices.end(), box.indices.begin() + long(t),
                                  box.indices.begin() + long(t) + 3);
    }
  }
  ClutterImportSettings settings;
  Result<ClutterImport> r = run(sheet, settings);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->open_components, 1);
  EXPECT_TRUE(facts(r->mesh).closed);
  // One cell layer on each side of the sheet's plane... of voxel_size in all (a flat sheet's
  // bounds are widened to one voxel, split by its plane).
  EXPECT_NEAR(r->volume, 1.0 * 0.6 * settings.voxel_size, 1e-9);
  expect_good_atlas(r.value(), settings.gutter);
  Result<ClutterImport> b = run(bottomless, settings);
  ASSERT_TRUE(b.ok()) << b.status().to_string();
  EXPECT_TRUE(facts(b->mesh).closed);
  EXPECT_GT(b->volume, 0.0);
  settings.open_surfaces = ClutterImportSettings::OpenSurfaces::refuse;
  for (const Soup* s : {&sheet, &bottomless}) {
    Result<ClutterImport> refused = run(*s, settings);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.status().code(), ErrorCode::invalid_argument);
    EXPECT_NE(refused.status().message().find("not closed"), std::string::npos) << refused.status().message();
  }
}

TEST(ClutterImport, BevelledTableTurnedAndWeldedSphere) {
  // The flat's table: five chamfered boxes (8 mm), turned 15 degrees about +Y.
  Soup table;
  for (const auto& [lo, hi] : kTable) table.append(chamfered_box(lo, hi, 0.008));
  const glm::dmat4 place = glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(2.9, 0.0, 2.4)),
                                       15.0 * std::numbers::pi / 180.0, glm::dvec3(0.0, 1.0, 0.0));
  const auto t0 = std::chrono::steady_clock::now();
  Result<ClutterImport> r = run(table.transformed(place));
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_TRUE(facts(r->mesh).closed);
  EXPECT_EQ(r->components, 5);
  // The object's frame: its own x axis (turned 15 degrees) and +Y.
  EXPECT_NEAR(std::abs(glm::dot(r->frame[0], glm::dvec3(place[0]))), 1.0, 1e-9);
  EXPECT_NEAR(std::abs(glm::dot(r->frame[1], glm::dvec3(0.0, 1.0, 0.0))), 1.0, 1e-9);
  // The boxes' planes are grid lines; the chamfers are within a cell (and 2 % of the volume).
  EXPECT_NEAR(r->volume, boxes_union_volume(kTable), 0.02 * boxes_union_volume(kTable));
  expect_good_atlas(r.value(), 1);
  std::printf("table: %zu -> %zu triangles, %d charts, cells %dx%dx%d, %.2f ms\n", table.indices.size() / 3,
              r->mesh.indices.size() / 3, r->chart_count, r->cells.x, r->cells.y, r->cells.z, ms);

  // A UV sphere: seam and pole vertices welded; the stairs hold the sphere within a cell.
  const ClutterMesh sphere = test::uv_sphere_mesh({0.0, 1.0, 0.0}, 0.25, 12, 24);
  Result<ClutterImport> s = make_clutter_mesh_from_object(sphere.positions, sphere.indices, {}, "sphere");
  ASSERT_TRUE(s.ok()) << s.status().to_string();
  EXPECT_TRUE(facts(s->mesh).closed);
  EXPECT_EQ(s->components, 1);
  EXPECT_EQ(s->open_components, 0);
  const double v = 4.0 / 3.0 * std::numbers::pi * std::pow(0.25, 3);
  EXPECT_NEAR(s->volume, v, 4.0 * std::numbers::pi * 0.25 * 0.25 * 0.5 * s->cell_size);
  EXPECT_NEAR(glm::length(s->centroid - glm::dvec3(0.0, 1.0, 0.0)), 0.0, s->cell_size);
  expect_good_atlas(s.value(), 1);
}

TEST(ClutterImport, SourceTrianglesNameTheNearestInputFace) {
  // Two boxes of different "materials": every output triangle's source lies in its plane and
  // belongs to the box whose surface it is.
  const std::vector<std::pair<glm::dvec3, glm::dvec3>> bed{{{-0.8, 0.0, -1.0}, {0.8, 0.3, 1.0}},
                                                           {{-0.76, 0.3, -0.98}, {0.76, 0.5, 0.97}}};
  const Soup soup = boxes_soup(bed);
  Result<ClutterImport> r = run(soup);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->source_triangle.size(), r->mesh.indices.size() / 3);
  for (std::size_t t = 0; t < r->source_triangle.size(); ++t) {
    const std::uint32_t src = r->source_triangle[t];
    ASSERT_LT(src, soup.indices.size() / 3);
    const glm::dvec3 a = soup.positions[soup.indices[3 * src]], b = soup.positions[soup.indices[3 * src + 1]],
                     c = soup.positions[soup.indices[3 * src + 2]];
    const glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
    const glm::dvec3 p = r->mesh.positions[r->mesh.indices[3 * t]];
    EXPECT_NEAR(std::abs(glm::dot(n, r->normals[r->mesh.indices[3 * t]])), 1.0, 1e-12) << t;
    EXPECT_NEAR(glm::dot(p - a, n), 0.0, 1e-12) << t;
    // Mattress (box 1: source triangles 12..23) above the frame's top.
    const glm::dvec3 centre =
        (p + r->mesh.positions[r->mesh.indices[3 * t + 1]] + r->mesh.positions[r->mesh.indices[3 * t + 2]]) /
        3.0;
    EXPECT_EQ(src >= 12, centre.y > 0.3 + 1e-9) << t;
  }
}

TEST(ClutterImport, OwnerBlockContainsTheCentroid) {
  LevelDescription level;
  level.cell_size = 2.0;
  for (int i = 0; i < 3; ++i) {
    BlockDescription b;
    b.cell = {i, 0, 0};
    level.blocks.push_back(b);
  }
  level.blocks[2].corners = block_corners(level, level.blocks[2]);
  level.blocks[2].warped = true;
  level.blocks[2].corners[0].x -= 0.5;  // the shared face leans into block 1 at the bottom
  level.blocks[2].corners[4].x -= 0.5;
  level.blocks[1].corners = block_corners(level, level.blocks[1]);
  level.blocks[1].warped = true;
  level.blocks[1].corners[1].x -= 0.5;
  level.blocks[1].corners[5].x -= 0.5;
  EXPECT_EQ(clutter_owner_block(level, {1.0, 1.0, 1.0}), 0);
  EXPECT_EQ(clutter_owner_block(level, {3.0, 1.0, 1.0}), 1);
  EXPECT_EQ(clutter_owner_block(level, {5.0, 1.0, 1.0}), 2);
  EXPECT_EQ(clutter_owner_block(level, {3.8, 0.1, 1.0}), 2);  // in block 2's lean
  EXPECT_EQ(clutter_owner_block(level, {3.8, 1.9, 1.0}), 1);
  EXPECT_EQ(clutter_owner_block(level, {-3.0, 1.0, 1.0}), 0);  // outside: the nearest
  EXPECT_EQ(clutter_owner_block(level, {9.0, 1.0, 1.0}), 2);
  EXPECT_EQ(clutter_owner_block(LevelDescription{}, {0.0, 0.0, 0.0}), -1);
}

#if MODRT_TEST_HAVE_TINYGLTF
// The named nodes of a glTF file (top-level, TRS), their primitives in world space.
std::map<std::string, Soup> read_nodes(const std::string& path, const std::set<std::string>& names) {
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  EXPECT_TRUE(loader.LoadASCIIFromFile(&model, &err, &warn, path)) << err;
  std::map<std::string, Soup> out;
  auto accessor_value = [&](int index, std::size_t i, int c) -> double {
    const tinygltf::Accessor& a = model.accessors[std::size_t(index)];
    const tinygltf::BufferView& view = model.bufferViews[std::size_t(a.bufferView)];
    const std::size_t size = std::size_t(tinygltf::GetComponentSizeInBytes(std::uint32_t(a.componentType)));
    const std::size_t comps = std::size_t(tinygltf::GetNumComponentsInType(std::uint32_t(a.type)));
    const std::size_t stride = view.byteStride ? view.byteStride : size * comps;
    const unsigned char* p = model.buffers[std::size_t(view.buffer)].data.data() + view.byteOffset +
                             a.byteOffset + i * stride + std::size_t(c) * size;
    switch (a.componentType) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p, 4);
        return f;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t v;
        std::memcpy(&v, p, 2);
        return v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        std::uint32_t v;
        std::memcpy(&v, p, 4);
        return v;
      }
      default: return double(*p);
    }
  };
  for (const tinygltf::Node& node : model.nodes) {
    if (!names.count(node.name) || node.mesh < 0) continue;
    glm::dmat4 m(1.0);
    if (node.translation.size() == 3)
      m = glm::translate(m, glm::dvec3(node.translation[0], node.translation[1], node.translation[2]));
    if (node.rotation.size() == 4)
      m *= glm::mat4_cast(glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]));
    if (node.scale.size() == 3) m = glm::scale(m, glm::dvec3(node.scale[0], node.scale[1], node.scale[2]));
    Soup& s = out[node.name];
    for (const tinygltf::Primitive& prim : model.meshes[std::size_t(node.mesh)].primitives) {
      const int pos = prim.attributes.at("POSITION");
      const std::uint32_t base = std::uint32_t(s.positions.size());
      for (std::size_t v = 0; v < model.accessors[std::size_t(pos)].count; ++v)
        s.positions.push_back(glm::dvec3(m * glm::dvec4(accessor_value(pos, v, 0), accessor_value(pos, v, 1),
                                                        accessor_value(pos, v, 2), 1.0)));
      for (std::size_t i = 0; i < model.accessors[std::size_t(prim.indices)].count; ++i)
        s.indices.push_back(base + std::uint32_t(accessor_value(prim.indices, i, 0)));
    }
  }
  return out;
}

TEST(ClutterImport, FlatAndHallFurniture) {
  const std::string dir = MODRT_SCENES_DIR "/import/";
  const std::map<std::string, Soup> flat = read_nodes(dir + "flat.gltf", {"Sofa", "Table", "Bed", "Cabinet"});
  const std::map<std::string, Soup> hall = read_nodes(dir + "l_hall.gltf", {"Bench", "Plinth", "Sculpture"});
  const std::vector<std::pair<glm::dvec3, glm::dvec3>> bed{{{-0.8, 0.0, -1.0}, {0.8, 0.3, 1.0}},
                                                           {{-0.8, 0.0, -1.05}, {0.8, 0.9, -0.98}},
                                                           {{-0.76, 0.3, -0.98}, {0.76, 0.5, 0.97}}};
  const std::vector<std::pair<glm::dvec3, glm::dvec3>> bench{{{-0.9, 0.40, -0.2}, {0.9, 0.45, 0.2}},
                                                             {{-0.8, 0.0, -0.18}, {-0.74, 0.40, 0.18}},
                                                             {{0.74, 0.0, -0.18}, {0.8, 0.40, 0.18}}};
  // Expected volumes and how close (the table's chamfers, the icosphere's facets, float data).
  const std::map<std::string, std::pair<double, double>> expect{
      {"Sofa", {boxes_union_volume(kSofa), 1e-5}},
      {"Table", {boxes_union_volume(kTable), 0.02}},
      {"Bed", {boxes_union_volume(bed), 1e-5}},
      {"Cabinet", {1.2 * 2.0 * 0.5, 1e-5}},
      {"Bench", {boxes_union_volume(bench), 1e-5}},
      {"Plinth", {0.5 * 0.5 * 1.1, 1e-5}},
      {"Sculpture", {0.0, 0.0}}};  // its own volume (an 80-face icosphere), below
  std::map<std::string, Soup> all = flat;
  all.insert(hall.begin(), hall.end());
  ASSERT_EQ(all.size(), expect.size());
  for (const auto& [name, soup] : all) {
    SCOPED_TRACE(name);
    Result<ClutterImport> r = ClutterImport{};
    double best_ms = INFINITY;
    for (int rep = 0; rep < 3; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      r = make_clutter_mesh_from_object(soup.positions, soup.indices, {}, name);
      best_ms = std::min(
          best_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    const MeshFacts f = facts(r->mesh);
    EXPECT_TRUE(f.closed) << f.problem;
    EXPECT_EQ(r->open_components, 0);
    auto [want, tolerance] = expect.at(name);
    if (want == 0.0) {  // within half a cell of its surface
      const MeshFacts input = facts(ClutterMesh{soup.positions, {}, soup.indices});
      want = std::abs(input.volume), tolerance = 0.5 * input.area * r->cell_size / want;
    }
    EXPECT_NEAR(f.volume, want, tolerance * want);
    expect_good_atlas(r.value(), 1);
    Result<ClutterObject> object = make_mesh_clutter(r->mesh, 0, glm::dvec3(0.5), r->res, name);
    ASSERT_TRUE(object.ok()) << object.status().to_string();
    std::printf(
        "%-9s %4zu -> %4zu triangles, %2d parts, %3d charts, cells %3dx%3dx%3d, %4d texels of %d^2, "
        "volume %.4f (want %.4f), %.2f ms\n",
        name.c_str(), soup.indices.size() / 3, r->mesh.indices.size() / 3, r->components, r->chart_count,
        r->cells.x, r->cells.y, r->cells.z, clutter_texel_count(object.value()), r->res, f.volume, want,
        best_ms);
    EXPECT_LT(best_ms, 500.0);  // ~ms in a release build; generous for sanitizers
  }
}
#endif

}  // namespace
}  // namespace modrt::precompute
