// SPDX-License-Identifier: MIT
// The C API's lightmap coordinates for an app's own meshes (modrt_level_map_mesh,
// runtime/src/c_api_mesh.cpp) against core's map_mesh_lightmap (bit-identical: the same
// function), with the bound respected and exact, interleaved (strided) vertex buffers equal
// to tight arrays, and bad input refused naming the argument and index with nothing written.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "c_api_test_support.h"
#include "modrt/level_io.h"
#include "modrt/mesh_lightmap_uv.h"
#include "modrt/modrt.h"
#include "modrt/modrt.hpp"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/maze.h"
#include "test_support.h"

namespace modrt {
namespace {

using test::expect_error;

const Level& maze11() {
  static const Level level = [] {
    Result<Level> l =
        precompute::build_level(precompute::maze_level(11).value(), test::small_test_dictionary());
    EXPECT_TRUE(l.ok()) << l.status().to_string();
    return std::move(l).value();
  }();
  return level;
}

// The maze through the C API: serialised and loaded from memory, as an app loads its level.
modrt_level* maze11_handle() {
  static const std::vector<std::byte> bytes = serialize_level(maze11()).value();
  modrt_level* l = nullptr;
  EXPECT_EQ(modrt_level_load_memory(bytes.data(), bytes.size(), "maze11", nullptr, &l), MODRT_OK)
      << modrt_last_error();
  return l;
}

// A floor and a wall-ish slab over the maze, big enough to cross many blocks.
struct Mesh {
  std::vector<float> position, normal;  // 3 floats per vertex
  std::vector<std::uint32_t> indices;
};
Mesh crossing_mesh(const Level& level) {
  glm::dvec3 lo(1e300), hi(-1e300);
  for (const LevelBlock& b : level.blocks)
    for (const glm::dvec3& c : b.corners) lo = glm::min(lo, c), hi = glm::max(hi, c);
  Mesh m;
  auto vertex = [&](glm::dvec3 p, glm::vec3 n) {
    for (int a = 0; a < 3; ++a) m.position.push_back(float(p[a])), m.normal.push_back(n[a]);
  };
  // Floor quad over the whole level, then a tilted quad through the middle.
  vertex({lo.x, 0.0, lo.z}, {0, 1, 0});
  vertex({hi.x, 0.0, lo.z}, {0, 1, 0});
  vertex({hi.x, 0.0, hi.z}, {0, 1, 0});
  vertex({lo.x, 0.0, hi.z}, {0, 1, 0});
  const glm::vec3 tilt = glm::normalize(glm::vec3(0.3f, 0.2f, 1.0f));
  const double zc = 0.5 * (lo.z + hi.z);
  vertex({lo.x, 0.1, zc}, tilt);
  vertex({hi.x, 0.1, zc - 0.6}, tilt);
  vertex({hi.x, 0.9, zc - 0.8}, tilt);
  vertex({lo.x, 0.9, zc - 0.2}, tilt);
  m.indices = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7};
  return m;
}

modrt_mesh_input c_input(const Mesh& m) {
  modrt_mesh_input in;
  modrt_mesh_input_init(&in);
  in.positions = m.position.data();
  in.normals = m.normal.data();
  in.vertex_count = m.position.size() / 3;
  in.indices = m.indices.data();
  in.index_count = m.indices.size();
  return in;
}

std::vector<modrt_mapped_corner> sentinel(std::size_t n) {
  std::vector<modrt_mapped_corner> out(n);
  std::memset(out.data(), 0xAB, n * sizeof(modrt_mapped_corner));
  return out;
}
bool untouched(const std::vector<modrt_mapped_corner>& out) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(out.data());
  for (std::size_t i = 0; i < out.size() * sizeof(modrt_mapped_corner); ++i)
    if (bytes[i] != 0xAB) return false;
  return true;
}

// The bound is exact, the call writes that many corners, and they are core's, bit for bit.
TEST(CApiMesh, MatchesCoreAndTheBoundIsExact) {
  modrt_level* level = maze11_handle();
  ASSERT_NE(level, nullptr);
  const Mesh mesh = crossing_mesh(maze11());
  const modrt_mesh_input in = c_input(mesh);
  std::size_t bound = 0;
  ASSERT_EQ(modrt_level_map_mesh_bound(level, &in, &bound), MODRT_OK) << modrt_last_error();
  std::vector<modrt_mapped_corner> out = sentinel(bound + 5);
  std::size_t written = 0;
  modrt_mesh_map_stats stats = modrt::rt::sized<modrt_mesh_map_stats>();
  ASSERT_EQ(modrt_level_map_mesh(level, &in, out.data(), out.size(), &written, &stats), MODRT_OK)
      << modrt_last_error();
  EXPECT_EQ(written, bound);
  EXPECT_EQ(stats.corners, bound);
  EXPECT_EQ(stats.triangles, 4u);
  EXPECT_EQ(stats.split_triangles, 4u) << "every triangle crosses block boundaries";
  EXPECT_GT(bound, 40u * 3u);
  // Past the bound nothing was touched.
  const auto* tail = reinterpret_cast<const unsigned char*>(out.data() + written);
  for (std::size_t i = 0; i < 5 * sizeof(modrt_mapped_corner); ++i) ASSERT_EQ(tail[i], 0xAB);

  MeshLightmapInput core_in;
  core_in.positions = {mesh.position.data(), 12};
  core_in.normals = {mesh.normal.data(), 12};
  core_in.vertex_count = mesh.position.size() / 3;
  core_in.indices = mesh.indices;
  std::vector<MappedCorner> ref(bound);
  const Result<MeshLightmapStats> r = map_mesh_lightmap(maze11(), core_in, ref);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->corners, written);
  EXPECT_EQ(r->split_triangles, stats.split_triangles);
  EXPECT_EQ(r->triangles_outside, stats.triangles_outside);
  for (std::size_t i = 0; i < written; ++i) {
    const modrt_mapped_corner& c = out[i];
    const MappedCorner& e = ref[i];
    for (int a = 0; a < 3; ++a) {
      ASSERT_EQ(c.position[a], e.position[a]) << i;
      ASSERT_EQ(c.normal[a], e.normal[a]) << i;
      ASSERT_EQ(c.face_u[a], e.face_u[a]) << i;
      ASSERT_EQ(c.face_v[a], e.face_v[a]) << i;
      ASSERT_EQ(c.barycentric[a], e.barycentric[a]) << i;
    }
    ASSERT_EQ(c.lightmap[0], e.lightmap.x) << i;
    ASSERT_EQ(c.lightmap[1], e.lightmap.y) << i;
    ASSERT_EQ(c.triangle, e.triangle);
    ASSERT_EQ(c.block, e.block);
    ASSERT_EQ(c.face, std::uint32_t(e.face));
    ASSERT_EQ(c.outside, e.outside ? 1u : 0u);
  }
  modrt_level_destroy(level);
}

// An app's interleaved vertex buffer (position, normal, uv, colour: 48 bytes) gives the
// result of tight arrays.
TEST(CApiMesh, InterleavedVertexBufferMatchesTightArrays) {
  modrt_level* level = maze11_handle();
  const Mesh mesh = crossing_mesh(maze11());
  struct Vertex {
    float uv[2];
    float position[3];
    float colour[4];
    float normal[3];
  };
  std::vector<Vertex> vb(mesh.position.size() / 3);
  for (std::size_t i = 0; i < vb.size(); ++i)
    for (int a = 0; a < 3; ++a)
      vb[i].position[a] = mesh.position[3 * i + a], vb[i].normal[a] = mesh.normal[3 * i + a];
  modrt_mesh_input tight = c_input(mesh);
  modrt_mesh_input strided = tight;
  strided.positions = vb[0].position;
  strided.position_stride = sizeof(Vertex);
  strided.normals = vb[0].normal;
  strided.normal_stride = sizeof(Vertex);
  std::size_t n_tight = 0, n_strided = 0;
  ASSERT_EQ(modrt_level_map_mesh_bound(level, &tight, &n_tight), MODRT_OK);
  ASSERT_EQ(modrt_level_map_mesh_bound(level, &strided, &n_strided), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(n_tight, n_strided);
  std::vector<modrt_mapped_corner> a(n_tight), b(n_strided);
  std::size_t wa = 0, wb = 0;
  ASSERT_EQ(modrt_level_map_mesh(level, &tight, a.data(), a.size(), &wa, nullptr), MODRT_OK);
  ASSERT_EQ(modrt_level_map_mesh(level, &strided, b.data(), b.size(), &wb, nullptr), MODRT_OK);
  ASSERT_EQ(wa, wb);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), wa * sizeof(modrt_mapped_corner)), 0);
  // A stride of 0 means tight.
  modrt_mesh_input zero = tight;
  zero.position_stride = zero.normal_stride = 0;
  std::size_t wz = 0;
  std::vector<modrt_mapped_corner> z(n_tight);
  ASSERT_EQ(modrt_level_map_mesh(level, &zero, z.data(), z.size(), &wz, nullptr), MODRT_OK);
  EXPECT_EQ(std::memcmp(a.data(), z.data(), wa * sizeof(modrt_mapped_corner)), 0);
  modrt_level_destroy(level);
}

// Every refusal names the argument (and index) and writes nothing: out, written and stats
// keep their values.
TEST(CApiMesh, BadInputIsNamedAndNothingIsWritten) {
  modrt_level* level = maze11_handle();
  const Mesh good = crossing_mesh(maze11());
  std::size_t bound = 0;
  {
    const modrt_mesh_input in = c_input(good);
    ASSERT_EQ(modrt_level_map_mesh_bound(level, &in, &bound), MODRT_OK);
  }
  auto refused = [&](const modrt_mesh_input& in, std::size_t capacity, modrt_status code,
                     std::initializer_list<std::string> words) {
    std::vector<modrt_mapped_corner> out = sentinel(bound + 3);
    std::size_t written = 4242;
    modrt_mesh_map_stats stats{sizeof(modrt_mesh_map_stats), 7, 7, 7, 7};
    expect_error(modrt_level_map_mesh(level, &in, out.data(), capacity, &written, &stats), code, words);
    EXPECT_TRUE(untouched(out)) << "out written on failure";
    EXPECT_EQ(written, 4242u);
    EXPECT_EQ(stats.corners, 7u);
  };
  {  // An out struct without its struct_size (modrt.h, "Structs").
    const modrt_mesh_input in = c_input(good);
    std::vector<modrt_mapped_corner> out = sentinel(bound);
    std::size_t written = 4242;
    modrt_mesh_map_stats stats{};
    expect_error(modrt_level_map_mesh(level, &in, out.data(), bound, &written, &stats),
                 MODRT_ERROR_INVALID_ARGUMENT, {"stats.struct_size is 0", "sizeof(modrt_mesh_map_stats)"});
    EXPECT_TRUE(untouched(out));
    EXPECT_EQ(written, 4242u);
  }
  // Capacity one corner short of the bound.
  refused(c_input(good), bound - 1, MODRT_ERROR_INVALID_ARGUMENT,
          {"modrt_level_map_mesh", "capacity", std::to_string(bound).c_str()});
  {
    Mesh m = good;
    m.position[3 * 2 + 1] = std::numeric_limits<float>::quiet_NaN();
    refused(c_input(m), bound, MODRT_ERROR_NON_FINITE, {"positions[2]", "not finite"});
  }
  {
    Mesh m = good;
    m.indices[7] = 8;
    refused(c_input(m), bound, MODRT_ERROR_INVALID_ARGUMENT, {"indices[7] = 8 is out of range (8 vertices)"});
  }
  {
    Mesh m = good;
    for (int a = 0; a < 3; ++a) m.normal[3 * 5 + a] = 0.0f;
    refused(c_input(m), bound, MODRT_ERROR_INVALID_ARGUMENT, {"normals[5]"});
  }
  {
    modrt_mesh_input in = c_input(good);
    in.struct_size = 12;
    refused(in, bound, MODRT_ERROR_INVALID_ARGUMENT, {"mesh.struct_size is 12", "modrt_mesh_input_init"});
  }
  {
    modrt_mesh_input in = c_input(good);
    in.index_count = 11;
    refused(in, bound, MODRT_ERROR_INVALID_ARGUMENT, {"index count 11 is not a multiple of 3"});
  }
  {
    modrt_mesh_input in = c_input(good);
    in.indices = nullptr;
    refused(in, bound, MODRT_ERROR_INVALID_ARGUMENT, {"mesh->indices is null"});
  }
  {
    modrt_mesh_input in = c_input(good);
    in.normal_stride = 4;
    refused(in, bound, MODRT_ERROR_INVALID_ARGUMENT, {"normals: stride of 4 bytes"});
  }
  {
    modrt_mesh_input in = c_input(good);
    in.vertex_count = std::numeric_limits<std::size_t>::max() / 2;
    refused(in, bound, MODRT_ERROR_INVALID_ARGUMENT, {"positions", "do not fit in memory"});
  }
  // Null handles and outputs.
  const modrt_mesh_input in = c_input(good);
  std::size_t corners = 99;
  expect_error(modrt_level_map_mesh_bound(nullptr, &in, &corners), MODRT_ERROR_INVALID_ARGUMENT,
               {"level is null"});
  expect_error(modrt_level_map_mesh_bound(level, nullptr, &corners), MODRT_ERROR_INVALID_ARGUMENT,
               {"mesh is null"});
  expect_error(modrt_level_map_mesh_bound(level, &in, nullptr), MODRT_ERROR_INVALID_ARGUMENT,
               {"corners is null"});
  EXPECT_EQ(corners, 99u);
  std::size_t written = 0;
  expect_error(modrt_level_map_mesh(level, &in, nullptr, bound, &written, nullptr),
               MODRT_ERROR_INVALID_ARGUMENT, {"out is null"});
  expect_error(modrt_level_map_mesh(level, &in, nullptr, 0, nullptr, nullptr), MODRT_ERROR_INVALID_ARGUMENT,
               {"written is null"});
  // An empty mesh maps to nothing.
  modrt_mesh_input empty;
  modrt_mesh_input_init(&empty);
  ASSERT_EQ(modrt_level_map_mesh_bound(level, &empty, &corners), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(corners, 0u);
  ASSERT_EQ(modrt_level_map_mesh(level, &empty, nullptr, 0, &written, nullptr), MODRT_OK)
      << modrt_last_error();
  EXPECT_EQ(written, 0u);
  modrt_mesh_input_init(nullptr);  // ignored
  modrt_level_destroy(level);
}

}  // namespace
}  // namespace modrt
