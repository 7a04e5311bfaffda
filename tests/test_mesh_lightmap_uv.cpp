// SPDX-License-Identifier: MIT
// Core's proxy mapping of an app's own meshes (modrt/mesh_lightmap_uv.h) against brute-force
// references: every piece of a cut triangle lies in the block whose tile it samples (its
// corners, moved in front of the surface as the mapping classifies them, are in that block or
// in none, never in another), its lightmap coordinates are the projection onto that face
// inside the face's tile, the pieces of a triangle cover exactly its area (1e-5 relative), and
// a triangle inside one block is output unchanged and mapped as the demo's whole-triangle
// mapping did (its code is kept here as the reference). Levels: a 2 x 2 room (unwarped), the
// same room sheared (a warp that keeps faces planar: cut exactly too), the 11-block maze.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "modrt/cube.h"
#include "modrt/level_geometry.h"
#include "modrt/mesh_lightmap_uv.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/maze.h"
#include "test_support.h"

namespace modrt {
namespace {

using test::small_test_dictionary;

// Four connected blocks on the floor grid [0, 2] x [0, 1] x [0, 2]; `shear` moves every corner
// by shear * y along x (all faces stay planar).
LevelDescription room2x2(double shear = 0.0) {
  LevelDescription d;
  d.name = "room2x2";
  const glm::ivec3 cells[4] = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {1, 0, 1}};
  for (const glm::ivec3& c : cells) {
    BlockDescription b;
    b.cell = c;
    b.faces = kAllFaces;
    b.faces &= FaceMask(~(1u << (c.x == 0 ? kFacePosX : kFaceNegX)));
    b.faces &= FaceMask(~(1u << (c.z == 0 ? kFacePosZ : kFaceNegZ)));
    for (glm::dvec3& a : b.albedo) a = glm::dvec3(0.5);
    if (shear != 0.0) {
      b.warped = true;
      b.corners = grid_cell_corners(c, 1.0);
      for (glm::dvec3& p : b.corners) p.x += shear * p.y;
    }
    d.blocks.push_back(b);
  }
  LightDescription light;
  light.position = {1.0, 0.5, 1.0};
  d.lights.push_back(light);
  return d;
}

// Two closed blocks touching only at an edge: cells (0, 0, 0) and (1, 0, 1).
LevelDescription diagonal_pair() {
  LevelDescription d = room2x2();
  d.name = "diagonal";
  d.blocks = {d.blocks[0], d.blocks[3]};
  for (BlockDescription& b : d.blocks) b.faces = kAllFaces;
  return d;
}

const Level& built(const std::string& name) {
  static std::vector<std::pair<std::string, Level>> cache;
  for (const auto& [n, l] : cache)
    if (n == name) return l;
  LevelDescription d = name == "room"       ? room2x2()
                       : name == "sheared"  ? room2x2(0.3)
                       : name == "diagonal" ? diagonal_pair()
                                            : precompute::maze_level(11).value();
  Result<Level> level = precompute::build_level(d, small_test_dictionary());
  EXPECT_TRUE(level.ok()) << level.status().to_string();
  cache.emplace_back(name, std::move(level).value());
  return cache.back().second;
}

struct TestMesh {
  std::vector<glm::vec3> position, normal;
  std::vector<std::uint32_t> indices;
  MeshLightmapInput input() const {
    MeshLightmapInput in;
    in.positions = StridedVec3::tight(position);
    in.normals = StridedVec3::tight(normal);
    in.vertex_count = position.size();
    in.indices = indices;
    return in;
  }
  void add(glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 n) {
    const std::uint32_t base = std::uint32_t(position.size());
    for (const glm::vec3& p : {a, b, c}) position.push_back(p), normal.push_back(n);
    for (std::uint32_t k = 0; k < 3; ++k) indices.push_back(base + k);
  }
};

std::vector<MappedCorner> map_all(const Level& level, const TestMesh& mesh,
                                  MeshLightmapStats* stats = nullptr) {
  const Result<MeshLightmapStats> count = mesh_lightmap_corner_count(level, mesh.input());
  EXPECT_TRUE(count.ok()) << count.status().to_string();
  if (!count.ok()) return {};
  std::vector<MappedCorner> out(count->corners);
  const Result<MeshLightmapStats> r = map_mesh_lightmap(level, mesh.input(), out);
  EXPECT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->corners, count->corners);
  if (stats) *stats = r.value();
  return out;
}

double area(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) { return 0.5 * glm::length(glm::cross(b - a, c - a)); }

double outside_unit(const glm::dvec3& p) {
  double d = 0.0;
  for (int a = 0; a < 3; ++a) d = std::max({d, -p[a], p[a] - 1.0});
  return d;
}

// How deep canonical point p lies inside [0,1]^3 (negative outside).
double depth_inside(const glm::dvec3& p) {
  double d = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) d = std::min({d, p[a], 1.0 - p[a]});
  return d;
}

double block_size(const Level& level) {
  return glm::length(level.blocks[0].corners[7] - level.blocks[0].corners[0]) / std::sqrt(3.0);
}

// The brute-force checks of the header's promises, for every output triangle of `mesh`.
void check_against_brute_force(const Level& level, const TestMesh& mesh,
                               const std::vector<MappedCorner>& out) {
  ASSERT_EQ(out.size() % 3, 0u);
  const double res = level.res, bs = block_size(level);
  std::vector<double> covered(mesh.indices.size() / 3, 0.0);
  for (std::size_t t = 0; t < out.size(); t += 3) {
    const MappedCorner* c = &out[t];
    const std::uint32_t src = c[0].triangle, block = c[0].block;
    const int face = c[0].face;
    for (int k = 1; k < 3; ++k) {
      ASSERT_EQ(c[k].triangle, src);
      ASSERT_EQ(c[k].block, block) << "an output triangle straddles two blocks";
      ASSERT_EQ(c[k].face, face) << "an output triangle straddles two tiles";
    }
    const std::uint32_t* idx = &mesh.indices[3 * std::size_t(src)];
    const glm::dvec3 a(mesh.position[idx[0]]), b(mesh.position[idx[1]]), cc(mesh.position[idx[2]]);
    const glm::dvec3 n = glm::normalize(glm::dvec3(mesh.normal[idx[0]]) + glm::dvec3(mesh.normal[idx[1]]) +
                                        glm::dvec3(mesh.normal[idx[2]]));
    const double ox = level.atlas.tile_origin_x[block][std::size_t(face)] + 1;
    const double oy = level.atlas.tile_origin_y[block][std::size_t(face)] + 1;
    ASSERT_GE(ox, 1.0) << "a missing face's tile";
    const FaceFrame& fr = face_frame(face);
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < 3; ++j) {
        ASSERT_TRUE(std::isfinite(c[k].position[j]) && std::isfinite(c[k].normal[j]));
        ASSERT_GE(c[k].barycentric[j], -1e-6f);
      }
      EXPECT_NEAR(c[k].barycentric.x + c[k].barycentric.y + c[k].barycentric.z, 1.0f, 1e-5f);
      // The corner is the barycentric point of its source triangle.
      const glm::dvec3 bary(c[k].barycentric);
      const glm::dvec3 p = bary.x * a + bary.y * b + bary.z * cc;
      EXPECT_LT(glm::length(p - glm::dvec3(c[k].position)), 1e-5 * bs);
      // Inside the face's tile, at the projection of the corner onto the face.
      const double u = c[k].lightmap.x - ox, v = c[k].lightmap.y - oy;
      ASSERT_TRUE(u >= -1e-4 && u <= res + 1e-4 && v >= -1e-4 && v <= res + 1e-4)
          << "lightmap (" << c[k].lightmap.x << ", " << c[k].lightmap.y << ") outside tile (" << block << ", "
          << face << ")";
      const glm::dvec3 q = world_to_block(level.blocks[block], glm::dvec3(c[k].position));
      EXPECT_NEAR(u, std::clamp(glm::dot(q - fr.origin, fr.u_axis), 0.0, 1.0) * res, 1e-3);
      EXPECT_NEAR(v, std::clamp(glm::dot(q - fr.origin, fr.v_axis), 0.0, 1.0) * res, 1e-3);
    }
    // The piece, moved in front of the surface as the mapping classifies it, lies in its
    // block or in no block (beyond an outer face), never inside another block: checked at its
    // corners, edge midpoints and centroid (depth inside another block at most 1e-6).
    const glm::dvec3 shift = 0.02 * bs * n;
    const glm::dvec3 p0 = glm::dvec3(c[0].position) + shift, p1 = glm::dvec3(c[1].position) + shift,
                     p2 = glm::dvec3(c[2].position) + shift;
    for (const glm::dvec3& q :
         {p0, p1, p2, (p0 + p1) / 2.0, (p1 + p2) / 2.0, (p2 + p0) / 2.0, (p0 + p1 + p2) / 3.0}) {
      if (outside_unit(world_to_block(level.blocks[block], q)) <= 1e-6) continue;
      for (std::size_t other = 0; other < level.blocks.size(); ++other) {
        if (other == block) continue;
        ASSERT_LE(depth_inside(world_to_block(level.blocks[other], q)), 1e-6)
            << "a piece of triangle " << src << " mapped to block " << block << " reaches into block "
            << other;
      }
    }
    covered[src] += area(glm::dvec3(c[0].position), glm::dvec3(c[1].position), glm::dvec3(c[2].position));
  }
  for (std::size_t t = 0; t < covered.size(); ++t) {
    const std::uint32_t* idx = &mesh.indices[3 * t];
    const double whole = area(glm::dvec3(mesh.position[idx[0]]), glm::dvec3(mesh.position[idx[1]]),
                              glm::dvec3(mesh.position[idx[2]]));
    EXPECT_NEAR(covered[t], whole, 1e-5 * whole) << "triangle " << t << ": the pieces do not cover it";
  }
}

// A floor quad over the four blocks of the room: each of its two triangles crosses both
// shared faces and is cut into pieces, one block each, with its area kept.
TEST(MeshLightmap, FloorAcrossFourBlocksIsCutIntoOnePiecePerBlock) {
  for (const char* name : {"room", "sheared"}) {
    SCOPED_TRACE(name);
    const Level& level = built(name);
    TestMesh floor;
    const glm::vec3 up(0, 1, 0);
    floor.add({0.1f, 0, 0.1f}, {1.9f, 0, 1.9f}, {1.9f, 0, 0.1f}, up);
    floor.add({0.1f, 0, 0.1f}, {0.1f, 0, 1.9f}, {1.9f, 0, 1.9f}, up);
    MeshLightmapStats stats;
    const std::vector<MappedCorner> out = map_all(level, floor, &stats);
    EXPECT_EQ(stats.triangles, 2u);
    EXPECT_EQ(stats.split_triangles, 2u);
    EXPECT_EQ(stats.triangles_outside, 0u);
    check_against_brute_force(level, floor, out);
    // Each triangle covers three of the four cells: pieces in 3 blocks, all on the floor.
    for (std::uint32_t t = 0; t < 2; ++t) {
      std::vector<std::uint32_t> blocks;
      for (const MappedCorner& c : out)
        if (c.triangle == t) {
          EXPECT_EQ(c.face, kFaceNegY) << "floor";
          blocks.push_back(c.block);
        }
      std::sort(blocks.begin(), blocks.end());
      blocks.erase(std::unique(blocks.begin(), blocks.end()), blocks.end());
      // (Sheared, the floor is classified 2 % of a block up, where the shared faces have
      // moved: a sliver of the fourth cell joins.)
      if (std::string(name) == "room") {
        EXPECT_EQ(blocks.size(), 3u) << "triangle " << t;
      }
    }
  }
}

// The demo's whole-triangle mapping (demo/scene/proxy_mapping.cpp before the mapping moved
// into core): the reference for triangles inside one block.
struct OldCorner {
  std::size_t block;
  int face;
  glm::vec2 lightmap;
};
std::array<OldCorner, 3> old_centroid_mapping(const Level& level, const std::array<glm::vec3, 3>& pos,
                                              const std::array<glm::vec3, 3>& nrm) {
  const double res = level.res, bsz = block_size(level);
  const glm::dvec3 a(pos[0]), b(pos[1]), c(pos[2]);
  const glm::dvec3 centroid = (a + b + c) / 3.0;
  glm::dvec3 normal = glm::dvec3(nrm[0]) + glm::dvec3(nrm[1]) + glm::dvec3(nrm[2]);
  if (glm::dot(normal, normal) < 1e-20) normal = glm::cross(b - a, c - a);
  normal = glm::normalize(normal);
  const glm::dvec3 probe = centroid + 0.02 * bsz * normal;
  std::size_t best_block = 0;
  double best_out = std::numeric_limits<double>::infinity();
  glm::dvec3 best_p(0.5);
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const glm::dvec3 p = world_to_block(level.blocks[bi], probe);
    const double o = outside_unit(p);
    if (o < best_out) best_out = o, best_block = bi, best_p = p;
    if (o == 0.0) break;
  }
  const LevelBlock& blk = level.blocks[best_block];
  const glm::dvec3 n_canonical = rotate_direction(normal, -blk.quarter_turns);
  const FaceMask mask = dictionary_shape_mask(blk.shape);
  int face = -1;
  double best_score = -std::numeric_limits<double>::infinity();
  for (int f = 0; f < kFaceCount; ++f) {
    if (!face_present(mask, f)) continue;
    const FaceFrame& fr = face_frame(f);
    const double score =
        glm::dot(n_canonical, fr.normal) - 0.25 * std::abs(glm::dot(best_p - fr.origin, fr.normal));
    if (score > best_score) best_score = score, face = f;
  }
  const FaceFrame& fr = face_frame(face);
  const double ox = level.atlas.tile_origin_x[best_block][std::size_t(face)] + 1;
  const double oy = level.atlas.tile_origin_y[best_block][std::size_t(face)] + 1;
  std::array<OldCorner, 3> out;
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 p = world_to_block(blk, glm::dvec3(pos[std::size_t(k)]));
    const double u = std::clamp(glm::dot(p - fr.origin, fr.u_axis), 0.0, 1.0);
    const double v = std::clamp(glm::dot(p - fr.origin, fr.v_axis), 0.0, 1.0);
    out[std::size_t(k)] = {best_block, face, glm::vec2(float(ox + u * res), float(oy + v * res))};
  }
  return out;
}

// Random small triangles well inside blocks of the maze, facing anywhere: none is cut, each
// comes out as it went in, on the block and face (and at the lightmap coordinates) of the
// demo's old whole-triangle mapping.
TEST(MeshLightmap, TriangleInsideOneBlockMatchesTheCentroidMapping) {
  const Level& level = built("maze11");
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), sym(-1.0f, 1.0f);
  TestMesh mesh;
  for (int i = 0; i < 400; ++i) {
    const LevelBlock& b = level.blocks[std::size_t(rng() % level.blocks.size())];
    const glm::vec3 lo(b.corners[0]);
    // Coordinates drawn in a fixed order (unsequenced in one glm::vec3(...) call).
    const auto draw = [&rng](std::uniform_real_distribution<float>& d) {
      const float x = d(rng), y = d(rng), z = d(rng);
      return glm::vec3(x, y, z);
    };
    const glm::vec3 centre = lo + glm::vec3(0.2f) + 0.6f * draw(unit);
    std::array<glm::vec3, 3> p;
    for (glm::vec3& q : p) q = centre + 0.12f * draw(sym);
    glm::vec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
    if (glm::length(n) < 1e-4f) continue;
    mesh.add(p[0], p[1], p[2], glm::normalize(n));
  }
  ASSERT_GT(mesh.indices.size(), 900u);
  MeshLightmapStats stats;
  const std::vector<MappedCorner> out = map_all(level, mesh, &stats);
  EXPECT_EQ(stats.split_triangles, 0u);
  EXPECT_EQ(stats.triangles_outside, 0u);
  ASSERT_EQ(out.size(), mesh.indices.size()) << "a triangle inside one block was cut";
  double worst = 0.0;
  for (std::size_t t = 0; t < out.size(); t += 3) {
    const std::array<glm::vec3, 3> pos = {mesh.position[t], mesh.position[t + 1], mesh.position[t + 2]};
    const std::array<glm::vec3, 3> nrm = {mesh.normal[t], mesh.normal[t + 1], mesh.normal[t + 2]};
    const std::array<OldCorner, 3> ref = old_centroid_mapping(level, pos, nrm);
    for (std::size_t k = 0; k < 3; ++k) {
      const MappedCorner& c = out[t + k];
      EXPECT_EQ(c.triangle, t / 3);
      EXPECT_EQ(input_vertex(c), int(k));
      EXPECT_EQ(c.position, pos[k]) << "an input vertex keeps its position bit for bit";
      EXPECT_EQ(c.normal, nrm[k]);
      EXPECT_EQ(c.block, ref[k].block);
      EXPECT_EQ(c.face, ref[k].face);
      worst = std::max(worst, double(glm::length(c.lightmap - ref[k].lightmap)));
    }
  }
  EXPECT_LT(worst, 1e-4) << "texels";
}

// Random triangles up to 2.5 blocks across over the maze and the sheared room (some reach
// outside the level): the brute-force checks hold for every piece.
TEST(MeshLightmap, RandomTrianglesAgainstBruteForce) {
  for (const char* name : {"maze11", "sheared", "room"}) {
    SCOPED_TRACE(name);
    const Level& level = built(name);
    glm::dvec3 lo(1e300), hi(-1e300);
    for (const LevelBlock& b : level.blocks)
      for (const glm::dvec3& c : b.corners) lo = glm::min(lo, c), hi = glm::max(hi, c);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0), sym(-1.0, 1.0);
    // Coordinates drawn in a fixed order (x, y, z): the three draws inside one glm::dvec3(...)
    // call are unsequenced, and GCC and clang would test different triangles.
    const auto draw = [&rng](std::uniform_real_distribution<double>& d) {
      const double x = d(rng), y = d(rng), z = d(rng);
      return glm::dvec3(x, y, z);
    };
    TestMesh mesh;
    for (int i = 0; i < 300; ++i) {
      const glm::dvec3 centre = lo + draw(unit) * (hi - lo);
      std::array<glm::vec3, 3> p;
      for (glm::vec3& q : p) q = glm::vec3(centre + 1.25 * draw(sym));
      const glm::vec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
      if (glm::length(n) < 1e-3f) continue;
      mesh.add(p[0], p[1], p[2], glm::normalize(n));
    }
    MeshLightmapStats stats;
    const std::vector<MappedCorner> out = map_all(level, mesh, &stats);
    EXPECT_GT(stats.split_triangles, stats.triangles / 4) << "most of these triangles cross a shared face";
    check_against_brute_force(level, mesh, out);
    std::printf("  %s: %zu triangles, %zu cut, %zu partly outside, %zu output triangles\n", name,
                stats.triangles, stats.split_triangles, stats.triangles_outside, stats.corners / 3);
  }
}

// A block's reach past its outer faces (where uncut triangles stay whole) stops at a block
// diagonally across its edge: a floor triangle from one block into the other is cut so that
// no piece of the first reaches into the second.
TEST(MeshLightmap, ReachStopsAtADiagonalBlock) {
  const Level& level = built("diagonal");
  ASSERT_EQ(level.blocks.size(), 2u);
  TestMesh floor;
  floor.add({0.5f, 0, 0.5f}, {1.6f, 0, 1.6f}, {1.6f, 0, 0.9f}, {0, 1, 0});
  MeshLightmapStats stats;
  const std::vector<MappedCorner> out = map_all(level, floor, &stats);
  EXPECT_EQ(stats.split_triangles, 1u);
  check_against_brute_force(level, floor, out);
}

// An interleaved vertex buffer (position, normal, uv: 32 bytes) maps as the tight arrays do.
TEST(MeshLightmap, StridedInputMatchesTightArrays) {
  const Level& level = built("room");
  TestMesh mesh;
  mesh.add({0.3f, 0.2f, 0.5f}, {1.7f, 0.3f, 0.4f}, {1.2f, 0.9f, 1.6f},
           glm::normalize(glm::vec3(0.2f, 0.4f, -0.9f)));
  mesh.add({0.2f, 0.0f, 0.2f}, {1.8f, 0.0f, 1.8f}, {1.8f, 0.0f, 0.2f}, {0, 1, 0});
  struct Interleaved {
    float position[3], normal[3], uv[2];
  };
  std::vector<Interleaved> vb(mesh.position.size());
  for (std::size_t i = 0; i < vb.size(); ++i)
    for (int a = 0; a < 3; ++a) vb[i].position[a] = mesh.position[i][a], vb[i].normal[a] = mesh.normal[i][a];
  MeshLightmapInput in = mesh.input();
  in.positions = {&vb[0].position[0], sizeof(Interleaved)};
  in.normals = {&vb[0].normal[0], sizeof(Interleaved)};
  const std::vector<MappedCorner> tight = map_all(level, mesh);
  std::vector<MappedCorner> strided(tight.size());
  ASSERT_TRUE(map_mesh_lightmap(level, in, strided).ok());
  ASSERT_GT(tight.size(), 6u);
  for (std::size_t i = 0; i < tight.size(); ++i) {
    EXPECT_EQ(strided[i].position, tight[i].position);
    EXPECT_EQ(strided[i].lightmap, tight[i].lightmap);
    EXPECT_EQ(strided[i].block, tight[i].block);
  }
}

// Zero-area triangles are output whole (not cut, no NaN); geometry away from the level maps
// to the nearest block and is counted as outside.
TEST(MeshLightmap, ZeroAreaAndOutsideTriangles) {
  const Level& level = built("room");
  TestMesh mesh;
  mesh.add({0.5f, 0.5f, 0.5f}, {1.5f, 0.5f, 0.5f}, {1.0f, 0.5f, 0.5f}, {0, 1, 0});   // collinear
  mesh.add({0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}, {0, 0, 1});   // a point
  mesh.add({5.0f, 0.2f, 0.4f}, {5.0f, 0.8f, 0.4f}, {5.0f, 0.5f, 0.9f}, {-1, 0, 0});  // 3 blocks past +X
  MeshLightmapStats stats;
  const std::vector<MappedCorner> out = map_all(level, mesh, &stats);
  ASSERT_EQ(out.size(), 9u);
  EXPECT_EQ(stats.split_triangles, 0u);
  EXPECT_EQ(stats.triangles_outside, 1u);
  for (const MappedCorner& c : out) {
    EXPECT_TRUE(std::isfinite(c.lightmap.x) && std::isfinite(c.lightmap.y));
    EXPECT_EQ(c.outside, c.triangle == 2);
  }
  // Past +X of the room: one of the two blocks at x = 1..2, on its +X wall (which faces -X).
  EXPECT_EQ(level.blocks[out[6].block].cell.x, 1);
  EXPECT_EQ(rotate_face(out[6].face, level.blocks[out[6].block].quarter_turns), kFacePosX);
}

// Bad input is refused, naming the argument and the index, before anything is written.
TEST(MeshLightmap, BadInputIsNamed) {
  const Level& level = built("room");
  TestMesh good;
  good.add({0.2f, 0.1f, 0.2f}, {1.8f, 0.1f, 0.3f}, {0.9f, 0.1f, 1.7f}, {0, 1, 0});
  auto expect = [&](const TestMesh& m, MeshLightmapInput in, ErrorCode code, const std::string& words) {
    std::vector<MappedCorner> out(64);
    out[0].triangle = 12345;
    const Result<MeshLightmapStats> r = map_mesh_lightmap(level, in, out);
    ASSERT_FALSE(r.ok()) << words;
    EXPECT_EQ(r.status().code(), code) << r.status().to_string();
    EXPECT_NE(r.status().message().find(words), std::string::npos) << r.status().message();
    EXPECT_EQ(out[0].triangle, 12345u) << "written on failure";
    (void)m;
  };
  {
    TestMesh m = good;
    m.position[2].y = std::numeric_limits<float>::quiet_NaN();
    expect(m, m.input(), ErrorCode::non_finite, "positions[2] = (0.9, nan, 1.7) is not finite");
  }
  {
    TestMesh m = good;
    m.position[1].x = std::numeric_limits<float>::infinity();
    expect(m, m.input(), ErrorCode::non_finite, "positions[1]");
  }
  {
    TestMesh m = good;
    m.normal[1] = glm::vec3(0.0f);
    expect(m, m.input(), ErrorCode::invalid_argument, "normals[1] = (0, 0, 0) has (almost) zero length");
  }
  {
    TestMesh m = good;
    m.indices[2] = 99;
    expect(m, m.input(), ErrorCode::invalid_argument, "indices[2] = 99 is out of range (3 vertices)");
  }
  {
    TestMesh m = good;
    m.indices.push_back(0);
    expect(m, m.input(), ErrorCode::invalid_argument, "index count 4 is not a multiple of 3");
  }
  {
    MeshLightmapInput in = good.input();
    in.positions.stride = 8;
    expect(good, in, ErrorCode::invalid_argument, "positions: stride of 8 bytes");
  }
  {
    MeshLightmapInput in = good.input();
    in.normals.data = nullptr;
    expect(good, in, ErrorCode::invalid_argument, "normals is null");
  }
  {
    MeshLightmapInput in = good.input();
    in.positions.stride = std::size_t(1) << 62;
    expect(good, in, ErrorCode::invalid_argument, "do not fit in memory");
  }
  // Too small an output: refused, nothing written.
  std::vector<MappedCorner> small(2);
  small[0].triangle = 777;
  const Result<MeshLightmapStats> r = map_mesh_lightmap(level, good.input(), small);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("the output holds 2 corners"), std::string::npos)
      << r.status().message();
  EXPECT_EQ(small[0].triangle, 777u);
  // A level without an atlas.
  Level bare = level;
  bare.atlas = {};
  const Result<MeshLightmapStats> nb = mesh_lightmap_corner_count(bare, good.input());
  ASSERT_FALSE(nb.ok());
  EXPECT_NE(nb.status().message().find("the level has no lightmap atlas"), std::string::npos);
}

}  // namespace
}  // namespace modrt
