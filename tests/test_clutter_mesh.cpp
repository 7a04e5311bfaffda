// SPDX-License-Identifier: MIT
// Mesh clutter lightmaps (precompute/clutter_mesh.h): a box given as a triangle mesh with a
// grid-aligned UV layout must give exactly the box clutter's texels; texel areas conserve the
// mesh's area; thin triangles still get texels; padding rings every chart; bad meshes are
// refused with named errors.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "clutter_meshes.h"
#include "modrt/precompute/clutter_mesh.h"

namespace modrt::precompute {
namespace {

using test::box_mesh;

double mesh_area(const ClutterMesh& m) {
  double a = 0;
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    const glm::dvec3 &p0 = m.positions[m.indices[t]], &p1 = m.positions[m.indices[t + 1]],
                     &p2 = m.positions[m.indices[t + 2]];
    a += 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
  }
  return a;
}

ClutterBox rotated_box() {
  ClutterBox box;
  box.center = {0.4, 0.3, 0.6};
  box.half_extent = {0.1, 0.25, 0.05};
  box.rotation = glm::dmat3(glm::rotate(glm::dmat4(1.0), 0.7, glm::normalize(glm::dvec3(1, 2, 0.5))));
  return box;
}

TEST(ClutterMesh, GridAlignedBoxMeshGivesTheBoxTexels) {
  const int n = 8, res = 32;
  const ClutterBox box = rotated_box();
  Result<ClutterMeshAtlas> atlas = rasterize_clutter_mesh(box_mesh(box, n, res), res, "box mesh");
  ASSERT_TRUE(atlas.ok()) << atlas.status().to_string();
  EXPECT_EQ(atlas->chart_count, kFaceCount);

  ClutterObject object;
  object.box = box;
  object.res = n;
  const ClutterTexelGeometry want = clutter_texel_geometry(object);
  ASSERT_EQ(atlas->texels.position.size(), want.position.size());
  std::set<std::size_t> matched;
  std::set<int> texels_per_chart[kFaceCount];
  for (std::size_t t = 0; t < atlas->texels.position.size(); ++t) {
    std::size_t best = 0;
    double best_d = INFINITY;
    for (std::size_t k = 0; k < want.position.size(); ++k) {
      const double d = glm::length(atlas->texels.position[t] - want.position[k]);
      if (d < best_d) best_d = d, best = k;
    }
    EXPECT_LT(best_d, 1e-12) << "texel " << t;
    EXPECT_LT(glm::length(atlas->texels.normal[t] - want.normal[best]), 1e-12) << "texel " << t;
    matched.insert(best);
    // One chart per box face: a chart's texels all lie on one face.
    texels_per_chart[atlas->texels.face[t]].insert(want.face[best]);
  }
  EXPECT_EQ(matched.size(), want.position.size());  // a bijection
  for (const std::set<int>& faces : texels_per_chart) EXPECT_EQ(faces.size(), 1u);
  // Each texel stands for exactly its share of the face.
  const double face_area[3] = {4 * box.half_extent.y * box.half_extent.z,
                               4 * box.half_extent.x * box.half_extent.z,
                               4 * box.half_extent.x * box.half_extent.y};
  double total = 0;
  for (double a : atlas->area) total += a;
  EXPECT_NEAR(total, 2 * (face_area[0] + face_area[1] + face_area[2]), 1e-12);
}

// A UV sphere with a longitude seam and pole fans: texel areas add up to the mesh's area, each
// texel's point lies on its triangle, and at a fine enough grid every triangle is
// represented.
TEST(ClutterMesh, SphereAreasAreConservedAndTexelsLieOnTheirTriangles) {
  const double r = 0.2;
  const ClutterMesh m = test::uv_sphere_mesh(glm::dvec3(0.5), r, 12, 24);
  for (int res : {8, 16, 64}) {
    SCOPED_TRACE(res);
    Result<ClutterMeshAtlas> atlas = rasterize_clutter_mesh(m, res, "sphere");
    ASSERT_TRUE(atlas.ok()) << atlas.status().to_string();
    double total = 0;
    for (double a : atlas->area) total += a;
    EXPECT_NEAR(total / mesh_area(m), 1.0, 1e-12);
    EXPECT_NEAR(mesh_area(m) / (4 * std::numbers::pi * r * r), 1.0, 0.03);  // the mesh itself
    // (Conservation also means no covered cell was left without a texel: only used texels
    // carry area.) With cells smaller than every triangle, every triangle has a texel.
    std::set<std::uint32_t> triangles(atlas->triangle.begin(), atlas->triangle.end());
    if (res == 64) {
      EXPECT_EQ(triangles.size(), m.indices.size() / 3);
    }
    for (std::size_t t = 0; t < atlas->triangle.size(); ++t) {
      const std::uint32_t tri = atlas->triangle[t];
      const glm::dvec3 &p0 = m.positions[m.indices[3 * tri]], &p1 = m.positions[m.indices[3 * tri + 1]],
                       &p2 = m.positions[m.indices[3 * tri + 2]];
      const glm::dvec3 q = atlas->texels.position[t];
      EXPECT_NEAR(glm::dot(q - p0, atlas->texels.normal[t]), 0.0, 1e-12);
      // Inside: the three edge normals agree.
      const glm::dvec3 nrm = atlas->texels.normal[t];
      EXPECT_GE(glm::dot(glm::cross(p1 - p0, q - p0), nrm), -1e-12);
      EXPECT_GE(glm::dot(glm::cross(p2 - p1, q - p1), nrm), -1e-12);
      EXPECT_GE(glm::dot(glm::cross(p0 - p2, q - p2), nrm), -1e-12);
      // Outward normals on a sphere around (0.5, 0.5, 0.5).
      EXPECT_GT(glm::dot(nrm, q - glm::dvec3(0.5)), 0.0);
    }
    EXPECT_EQ(atlas->chart_count, 1);
  }
}

TEST(ClutterMesh, ThinTriangleGetsATexelAndPaddingRingsTheCharts) {
  const int res = 16;
  ClutterMesh m;
  // A sliver a tenth of a texel wide, far from any texel centre.
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0.01, 0}};
  m.uvs = {{0.26, 0.5}, {0.74, 0.5}, {0.26, 0.5 + 0.1 / res}};
  m.indices = {0, 1, 2};
  Result<ClutterMeshAtlas> atlas = rasterize_clutter_mesh(m, res, "sliver");
  ASSERT_TRUE(atlas.ok()) << atlas.status().to_string();
  EXPECT_GE(atlas->triangle.size(), 1u);
  double total = 0;
  for (double a : atlas->area) total += a;
  EXPECT_NEAR(total, 0.005, 1e-15);

  std::set<std::uint32_t> padded;
  for (const auto& [dst, src] : atlas->padding) {
    EXPECT_LT(atlas->cell_texel[dst], 0);
    EXPECT_GE(atlas->cell_texel[src], 0);
    const int dx = int(dst % res) - int(src % res), dy = int(dst / res) - int(src / res);
    EXPECT_LE(std::max(std::abs(dx), std::abs(dy)), 1);
    padded.insert(dst);
  }
  // Every empty cell touching a used one is padded.
  for (int j = 0; j < res; ++j)
    for (int i = 0; i < res; ++i) {
      const std::uint32_t c = std::uint32_t(j * res + i);
      if (atlas->cell_texel[c] >= 0) continue;
      bool touches = false;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
          const int ni = i + di, nj = j + dj;
          if (ni >= 0 && nj >= 0 && ni < res && nj < res &&
              atlas->cell_texel[std::size_t(nj * res + ni)] >= 0)
            touches = true;
        }
      EXPECT_EQ(touches, padded.count(c) == 1) << i << ", " << j;
    }
}

// Reference: entry into the box from outside by the slab test, in the box's frame.
ClutterMeshShape::Entry slab_entry(const ClutterBox& box, const glm::dvec3& origin, const glm::dvec3& dir) {
  const glm::dmat3 Rt = glm::transpose(box.rotation);
  const glm::dvec3 o = Rt * (origin - box.center), d = Rt * dir;
  double t_min = -INFINITY, t_max = INFINITY;
  int face = -1;
  for (int a = 0; a < 3; ++a) {
    double t1 = (-box.half_extent[a] - o[a]) / d[a], t2 = (box.half_extent[a] - o[a]) / d[a];
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > t_min) t_min = t1, face = 2 * a + (d[a] > 0.0 ? 0 : 1);
    t_max = std::min(t_max, t2);
  }
  if (t_min > t_max || t_min <= 0.0) return {};
  return {true, t_min, face};
}

TEST(ClutterMesh, ShapeRayEntryAndInsideAgreeWithTheAnalyticBox) {
  const ClutterBox box = rotated_box();
  const ClutterMesh mesh = box_mesh(box, 8, 32);
  const std::vector<int> charts = clutter_mesh_charts(mesh);
  Result<ClutterMeshShape> shape = ClutterMeshShape::create(mesh, charts, "box mesh");
  ASSERT_TRUE(shape.ok()) << shape.status().to_string();
  // Face f's two triangles form chart f (faces are listed in order).
  for (std::size_t t = 0; t < charts.size(); ++t) EXPECT_EQ(charts[t], int(t / 2));
  EXPECT_LE(glm::length(shape->bounding_center() - box.center), 1e-12);
  EXPECT_NEAR(shape->bounding_radius(), glm::length(box.half_extent), 1e-12);

  std::uint64_t state = 12345;
  auto uniform = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return double(state >> 11) * 0x1.0p-53;
  };
  int hits = 0, inside = 0, compared = 0;
  for (int k = 0; k < 20000; ++k) {
    const glm::dvec3 origin{uniform(), uniform(), uniform()};
    const glm::dvec3 dir = glm::normalize(glm::dvec3(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5));
    const glm::dvec3 local = glm::transpose(box.rotation) * (origin - box.center);
    const glm::dvec3 margin = glm::abs(local) - box.half_extent;
    // Points within 1e-4 of the surface are left out: float geometry inside Embree.
    if (std::abs(std::max({margin.x, margin.y, margin.z})) < 1e-4) continue;
    ++compared;
    const bool in = clutter_contains(box, origin, 0.0);
    EXPECT_EQ(shape->contains(origin), in) << k;
    inside += in;
    const ClutterMeshShape::Entry want = slab_entry(box, origin, dir), got = shape->enter(origin, dir);
    // Rays grazing an edge within float precision may go either way.
    if (want.hit != got.hit) {
      const glm::dvec3 p = origin + want.t * dir;
      const glm::dvec3 m = glm::abs(glm::transpose(box.rotation) * (p - box.center)) - box.half_extent;
      const double sorted[3] = {m.x, m.y, m.z};
      int near_edges = 0;
      for (double v : sorted) near_edges += std::abs(v) < 1e-5;
      EXPECT_GE(near_edges, 2) << "ray " << k;
      continue;
    }
    if (!want.hit) continue;
    ++hits;
    EXPECT_NEAR(got.t, want.t, 1e-5) << k;
    EXPECT_EQ(got.chart, want.chart) << k;
  }
  EXPECT_GT(compared, 19000);
  EXPECT_GT(hits, 500);
  EXPECT_GT(inside, 100);
}

TEST(ClutterMesh, BadMeshesAreRefusedWithNamedErrors) {
  const ClutterMesh good = box_mesh(rotated_box(), 8, 32);
  auto expect_refused = [](const ClutterMesh& m, int res, const std::string& part) {
    Result<ClutterMeshAtlas> r = rasterize_clutter_mesh(m, res, "crate.glb mesh 2");
    ASSERT_FALSE(r.ok()) << "accepted a mesh that should fail with " << part;
    EXPECT_EQ(r.status().code(), ErrorCode::invalid_argument);
    EXPECT_NE(r.status().message().find("crate.glb mesh 2"), std::string::npos) << r.status().message();
    EXPECT_NE(r.status().message().find(part), std::string::npos) << r.status().message();
  };
  expect_refused(good, 0, "res 0");
  ClutterMesh m = good;
  m.indices.clear();
  expect_refused(m, 32, "indices");
  m = good;
  m.indices[4] = 999;
  expect_refused(m, 32, "triangle 1 uses vertex 999");
  m = good;
  m.uvs.pop_back();
  expect_refused(m, 32, "lightmap UVs");
  m = good;
  m.positions[3].y = std::nan("");
  expect_refused(m, 32, "vertex 3");
  m = good;
  m.positions[5].x = 1e38;  // finite in double, not as float (Embree's)
  expect_refused(m, 32, "vertex 5 lies beyond float range");
  m = good;
  m.uvs[2].x = 1.5;
  expect_refused(m, 32, "outside [0, 1]");
  m = good;
  m.positions[1] = m.positions[0];  // triangle 0 collapses
  expect_refused(m, 32, "triangle 0 has zero");
  // Face 1's UV square moved onto face 0's.
  m = good;
  for (int k = 4; k < 8; ++k) m.uvs[std::size_t(k)] = m.uvs[std::size_t(k - 4)];
  expect_refused(m, 32, "overlap in UV space");
}

}  // namespace
}  // namespace modrt::precompute
