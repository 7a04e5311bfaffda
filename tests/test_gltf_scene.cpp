// SPDX-License-Identifier: MIT
// glTF scenes for the demo (demo/scene/gltf_scene.h): the committed sample
// data/scenes/two_rooms.gltf (scripts/make_sample_gltf.py) loads with the counts, transforms,
// materials, camera and light the script wrote, maps onto its proxies inside the atlas and
// survives a .glb round trip through tinygltf's writer; small synthetic files check the
// extras schema, the light conversion and that every kind of broken input is an error that
// names the file and the problem.
#include <gtest/gtest.h>

#include <tiny_gltf.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include <glm/geometric.hpp>

#include "demo_run.h"
#include "modrt/precompute/clutter_mesh.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "scene/gltf_scene.h"
#include "scene/proxy_mapping.h"
#include "test_support.h"

namespace modrt::demo {
namespace {

namespace fs = std::filesystem;

constexpr float kDegree = 3.14159265358979f / 180.0f;
const std::string kSample = std::string(MODRT_SCENES_DIR) + "/two_rooms.gltf";

fs::path temp_dir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("modrt_test_gltf_" + std::to_string(::getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

// The written files go when the program ends.
class TempDirCleanup : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(temp_dir(), ec);
  }
};
[[maybe_unused]] ::testing::Environment* const kCleanup =
    ::testing::AddGlobalTestEnvironment(new TempDirCleanup);

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

const DemoScene& sample(std::vector<std::string>* warnings = nullptr) {
  static std::vector<std::string> sample_warnings;
  static const DemoScene s = [] {
    GltfSceneOptions options;
    options.warnings = &sample_warnings;
    Result<DemoScene> r = load_gltf_scene(kSample, options);
    if (!r.ok()) {
      std::fprintf(stderr, "sample: %s\n", r.status().to_string().c_str());
      std::abort();
    }
    return std::move(r).value();
  }();
  if (warnings) *warnings = sample_warnings;
  return s;
}

// Bounding box of a mesh's positions.
std::pair<glm::vec3, glm::vec3> bounds(const Mesh& m) {
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const glm::vec3& p : m.position) lo = glm::min(lo, p), hi = glm::max(hi, p);
  return {lo, hi};
}

void expect_near(const glm::vec3& a, const glm::vec3& b, float tol, const std::string& what) {
  EXPECT_LE(glm::length(a - b), tol) << what << ": (" << a.x << ", " << a.y << ", " << a.z << ") vs (" << b.x
                                     << ", " << b.y << ", " << b.z << ")";
}

TEST(GltfScene, SampleMeshesAndTransforms) {
  std::vector<std::string> warnings;
  const DemoScene& s = sample(&warnings);
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  ASSERT_EQ(s.level.blocks.size(), 3u);
  EXPECT_EQ(s.level.blocks[1].name, "corner");
  // The four glTF meshes first, in node order, then the proxy walls (proxy_walls: true).
  ASSERT_GT(s.meshes.size(), 4u);
  const char* names[4] = {"crate", "bench", "pillar", "rolling cube"};
  const std::size_t vertices[4] = {24, 24, 36, 24};  // the pillar has no NORMAL: flat, split per corner
  for (int i = 0; i < 4; ++i) {
    const Mesh& m = s.meshes[std::size_t(i)];
    EXPECT_EQ(m.name, names[i]);
    EXPECT_EQ(m.position.size(), vertices[i]) << m.name;
    EXPECT_EQ(m.normal.size(), vertices[i]) << m.name;
    EXPECT_EQ(m.uv.size(), vertices[i]) << m.name;
    EXPECT_EQ(m.indices.size(), 36u) << m.name;
    EXPECT_EQ(m.dynamic, i == 3) << m.name;
    for (std::uint32_t idx : m.indices) ASSERT_LT(idx, m.position.size()) << m.name;
  }
  for (std::size_t i = 4; i < s.meshes.size(); ++i) {
    EXPECT_FALSE(s.meshes[i].dynamic);
    EXPECT_EQ(s.materials[std::size_t(s.meshes[i].material)].name.rfind("wall", 0), 0u);
  }

  // crate: translation (0.7, 0.1, 0.3), scale 0.2 of the unit cube.
  auto [clo, chi] = bounds(s.meshes[0]);
  expect_near(clo, {0.6f, 0.0f, 0.2f}, 1e-6f, "crate min");
  expect_near(chi, {0.8f, 0.2f, 0.4f}, 1e-6f, "crate max");

  // bench: parent translation (0.5, 0, 1.5); child translation (0, 0.1, 0), 30 degrees about
  // +Y, scale (0.4, 0.2, 0.15). The local corner (0.5, 0.5, 0.5):
  const float c = std::cos(30.0f * kDegree), sn = std::sin(30.0f * kDegree);
  const glm::vec3 scaled(0.2f, 0.1f, 0.075f);
  const glm::vec3 corner(0.5f + c * scaled.x + sn * scaled.z, 0.1f + scaled.y,
                         1.5f - sn * scaled.x + c * scaled.z);
  const Mesh& bench = s.meshes[1];
  float best = 1e30f;
  for (const glm::vec3& p : bench.position) best = std::min(best, glm::length(p - corner));
  EXPECT_LT(best, 1e-5f) << "no bench vertex at the transformed corner";
  // Its +X face normal turns with the rotation (the non-uniform scale leaves it axial).
  const glm::vec3 turned_x(c, 0.0f, -sn);
  int facing = 0;
  for (const glm::vec3& n : bench.normal) {
    EXPECT_NEAR(glm::length(n), 1.0f, 1e-5f);
    facing += glm::length(n - turned_x) < 1e-5f;
  }
  EXPECT_EQ(facing, 4);

  // pillar: column-major matrix, scale (0.1, 0.9, 0.1) at (1.8, 0.45, 1.8); computed flat
  // normals perpendicular to their triangles and pointing out of the box.
  const Mesh& pillar = s.meshes[2];
  auto [plo, phi] = bounds(pillar);
  expect_near(plo, {1.75f, 0.0f, 1.75f}, 1e-6f, "pillar min");
  expect_near(phi, {1.85f, 0.9f, 1.85f}, 1e-6f, "pillar max");
  const glm::vec3 pillar_centre(1.8f, 0.45f, 1.8f);
  for (std::size_t t = 0; t < pillar.indices.size(); t += 3) {
    const glm::vec3 a = pillar.position[pillar.indices[t]], b = pillar.position[pillar.indices[t + 1]],
                    d = pillar.position[pillar.indices[t + 2]];
    const glm::vec3 n = pillar.normal[pillar.indices[t]];
    EXPECT_NEAR(glm::dot(n, b - a), 0.0f, 1e-6f);
    EXPECT_NEAR(glm::dot(n, d - a), 0.0f, 1e-6f);
    EXPECT_GT(glm::dot(n, (a + b + d) / 3.0f - pillar_centre), 0.0f) << "normal points into the box";
    EXPECT_GT(glm::dot(glm::cross(b - a, d - a), n), 0.0f) << "counter-clockwise winding";
  }
  // Tangents from the UVs: unit, perpendicular to the normal; on the +Z face u runs along +X
  // and the image's up (-v) along +Y, so the tangent is (1, 0, 0) with w = +1.
  ASSERT_EQ(pillar.tangent.size(), pillar.position.size());
  int plus_z = 0;
  for (std::size_t v = 0; v < pillar.tangent.size(); ++v) {
    const glm::vec3 t(pillar.tangent[v]);
    EXPECT_NEAR(glm::length(t), 1.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(t, pillar.normal[v]), 0.0f, 1e-5f);
    EXPECT_EQ(std::abs(pillar.tangent[v].w), 1.0f);
    if (glm::length(pillar.normal[v] - glm::vec3(0, 0, 1)) < 1e-6f) {
      ++plus_z;
      expect_near(t, {1, 0, 0}, 1e-5f, "+Z face tangent");
      EXPECT_EQ(pillar.tangent[v].w, 1.0f);
    }
  }
  EXPECT_EQ(plus_z, 6);
  EXPECT_TRUE(s.meshes[0].tangent.empty()) << "no normal map, no tangents";

  // The dynamic cube sits at its path's only key; its vertices are relative to it.
  ASSERT_EQ(s.dynamic_path.size(), 1u);
  expect_near(s.dynamic_path[0], {1.4f, 0.08f, 1.5f}, 1e-6f, "dynamic key");
  auto [dlo, dhi] = bounds(s.meshes[3]);
  expect_near(dlo, glm::vec3(-0.08f), 1e-6f, "dynamic min");
  expect_near(dhi, glm::vec3(0.08f), 1e-6f, "dynamic max");
}

TEST(GltfScene, SampleMaterialsCameraLight) {
  const DemoScene& s = sample();
  const Material& crate = s.materials[std::size_t(s.meshes[0].material)];
  EXPECT_EQ(crate.name, "painted crate");
  expect_near(crate.base_color, {0.75f, 0.62f, 0.15f}, 1e-6f, "crate colour");
  EXPECT_EQ(crate.normal_texture, -1);
  EXPECT_EQ(crate.base_color_texture, -1);
  const Material& stone = s.materials[std::size_t(s.meshes[2].material)];
  EXPECT_EQ(stone.name, "stone");
  expect_near(stone.base_color, {0.62f, 0.6f, 0.56f}, 1e-6f, "stone colour");
  EXPECT_FLOAT_EQ(stone.normal_scale, 0.8f);
  ASSERT_GE(stone.normal_texture, 0);
  ASSERT_GE(stone.base_color_texture, 0);
  ASSERT_EQ(s.images.size(), 2u);
  const Image& tiles = s.images[std::size_t(stone.normal_texture)];
  EXPECT_EQ(tiles.name, "tiles");
  ASSERT_EQ(tiles.width, 16);
  ASSERT_EQ(tiles.height, 16);
  ASSERT_EQ(tiles.rgba.size(), 16u * 16u * 4u);
  // The middle of a tile is flat: (0, 0, 1) encoded.
  const std::uint8_t* flat = &tiles.rgba[4 * (4 * 16 + 4)];
  EXPECT_EQ(int(flat[0]), 128);
  EXPECT_EQ(int(flat[1]), 128);
  EXPECT_EQ(int(flat[2]), 255);
  const Image& checker = s.images[std::size_t(stone.base_color_texture)];
  ASSERT_EQ(checker.width, 8);
  EXPECT_EQ(int(checker.rgba[0]), 200);
  EXPECT_EQ(int(checker.rgba[2]), 190);
  EXPECT_EQ(int(checker.rgba[4]), 150);  // the next pixel is the other square
  EXPECT_EQ(int(checker.rgba[3]), 255);

  // The script turns the camera (local -Z) towards (1.5, 0.35, 1.75), its up in the vertical
  // plane through that direction.
  const glm::vec3 eye(0.15f, 0.55f, 1.15f), view = glm::normalize(glm::vec3(1.5f, 0.35f, 1.75f) - eye);
  expect_near(s.camera.position, eye, 1e-6f, "camera position");
  expect_near(s.camera.target, eye + view, 1e-6f, "camera target");
  EXPECT_NEAR(glm::length(s.camera.up), 1.0f, 1e-6f);
  EXPECT_NEAR(glm::dot(s.camera.up, view), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::dot(s.camera.up, glm::cross(view, glm::vec3(0, 1, 0))), 0.0f, 1e-6f);
  EXPECT_GT(s.camera.up.y, 0.9f);
  EXPECT_FLOAT_EQ(s.camera.yfov, 1.1f);
  EXPECT_FLOAT_EQ(s.camera.znear, 0.02f);
  EXPECT_FLOAT_EQ(s.camera.zfar, 50.0f);

  ASSERT_EQ(s.lights.size(), 1u);
  ASSERT_EQ(s.lights[0].path.size(), 1u);
  expect_near(s.lights[0].path[0], {0.9f, 0.8f, 1.3f}, 1e-6f, "light position");
  expect_near(s.lights[0].color, {1.0f, 0.9f, 0.8f}, 1e-6f, "light colour");
  EXPECT_NEAR(s.lights[0].intensity, 410.0f / 683.0f, 1e-6f);
}

TEST(GltfScene, SampleMapsOntoItsProxies) {
  const DemoScene& s = sample();
  Result<Level> level = precompute::build_level(s.level, test::small_test_dictionary());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  Result<std::vector<MappedMesh>> mapped = map_to_proxies(s, level.value());
  ASSERT_TRUE(mapped.ok()) << mapped.status().to_string();
  const std::size_t static_meshes =
      std::size_t(std::count_if(s.meshes.begin(), s.meshes.end(), [](const Mesh& m) { return !m.dynamic; }));
  ASSERT_EQ(mapped->size(), static_meshes);
  const float w = float(level->atlas.width), h = float(level->atlas.height);
  ASSERT_GT(w, 0.0f);
  for (const MappedMesh& mm : mapped.value()) {
    const Mesh& m = s.meshes[std::size_t(mm.mesh)];
    EXPECT_EQ(mm.vertices.size(), m.indices.size()) << m.name;
    // Only the bottoms of boxes resting on the floor face away from every block.
    int on_floor_facing_down = 0;
    for (std::size_t t = 0; t < m.indices.size(); t += 3) {
      bool down = true;
      for (std::size_t k = 0; k < 3; ++k)
        down = down && m.position[m.indices[t + k]].y < 1e-6f && m.normal[m.indices[t + k]].y < -0.99f;
      on_floor_facing_down += down;
    }
    EXPECT_EQ(mm.triangles_outside, on_floor_facing_down) << m.name;
    for (const MappedVertex& v : mm.vertices) {
      ASSERT_GE(v.lightmap.x, 0.0f) << m.name;
      ASSERT_GE(v.lightmap.y, 0.0f) << m.name;
      ASSERT_LE(v.lightmap.x, w) << m.name;
      ASSERT_LE(v.lightmap.y, h) << m.name;
    }
  }
}

// Regression (fuzz_gltf, CI): an embedded PNG whose IHDR was damaged, so that stb_image read
// a 2 GB IDAT length from an 85-byte image and reallocated to it before reading. The PNG
// chunk walk refuses it first, naming the image and the chunk.
TEST(GltfScene, DamagedPngChunkIsRefusedBeforeDecoding) {
  GltfSceneOptions options;
  options.level_path = std::string(MODRT_SCENES_DIR) + "/two_rooms.level.json";
  Result<DemoScene> scene = load_gltf_scene(
      std::string(MODRT_TEST_DATA_DIR) + "/fuzz_regressions/gltf_png_huge_idat.gltf", options);
  ASSERT_FALSE(scene.ok());
  EXPECT_NE(scene.status().message().find("image 1"), std::string::npos) << scene.status().message();
  EXPECT_NE(scene.status().message().find("PNG chunk"), std::string::npos) << scene.status().message();
}

// fuzz_gltf found a clutter node whose mesh centre lies ~1e30 away: its cell was converted
// to int (undefined behaviour) before the search for its block. Now it is no block's, with the
// message saying so. (GCC's -fsanitize=undefined leaves out float-cast-overflow, so this test
// alone cannot see the conversion; the input is also in the fuzz corpus, which every CI fuzz
// run replays under clang's UBSan, where it aborts.)
TEST(GltfScene, ClutterFarOutsideTheLevelIsRefusedWithoutOverflow) {
  GltfSceneOptions options;
  options.level_path = std::string(MODRT_SCENES_DIR) + "/two_rooms.level.json";
  Result<DemoScene> scene = load_gltf_scene(
      std::string(MODRT_TEST_DATA_DIR) + "/fuzz_regressions/gltf_clutter_far_centre.gltf", options);
  ASSERT_FALSE(scene.ok());
  EXPECT_NE(scene.status().message().find("modrt_clutter"), std::string::npos) << scene.status().message();
  EXPECT_NE(scene.status().message().find("no block's cell contains the mesh's centre"), std::string::npos)
      << scene.status().message();
}

TEST(GltfScene, GlbRoundTrip) {
  tinygltf::TinyGLTF io;
  tinygltf::Model model;
  std::string err, warn;
  ASSERT_TRUE(io.LoadASCIIFromFile(&model, &err, &warn, kSample)) << err;
  const fs::path glb = temp_dir() / "two_rooms_copy.glb";
  ASSERT_TRUE(io.WriteGltfSceneToFile(&model, glb.string(), true, true, false, true));
  std::ifstream head(glb, std::ios::binary);
  char magic[4] = {};
  head.read(magic, 4);
  ASSERT_EQ(std::string(magic, 4), "glTF");
  // The sidecar travels with it under the .glb's name.
  fs::copy_file(std::string(MODRT_SCENES_DIR) + "/two_rooms.level.json",
                gltf_sidecar_level_path(glb.string()), fs::copy_options::overwrite_existing);
  Result<DemoScene> r = load_gltf_scene(glb.string());
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const DemoScene& a = sample();
  const DemoScene& b = r.value();
  ASSERT_EQ(b.meshes.size(), a.meshes.size());
  for (std::size_t i = 0; i < a.meshes.size(); ++i) {
    EXPECT_EQ(b.meshes[i].name, a.meshes[i].name);
    ASSERT_EQ(b.meshes[i].position.size(), a.meshes[i].position.size());
    EXPECT_EQ(b.meshes[i].indices, a.meshes[i].indices);
    EXPECT_EQ(b.meshes[i].dynamic, a.meshes[i].dynamic);
    for (std::size_t v = 0; v < a.meshes[i].position.size(); ++v)
      ASSERT_EQ(b.meshes[i].position[v], a.meshes[i].position[v]);
  }
  ASSERT_EQ(b.images.size(), a.images.size());
  for (std::size_t i = 0; i < a.images.size(); ++i)
    EXPECT_EQ(b.images[i].rgba, a.images[i].rgba);  // PNG is lossless
  EXPECT_EQ(b.level.blocks.size(), a.level.blocks.size());
  ASSERT_EQ(b.lights.size(), 1u);
  EXPECT_EQ(b.lights[0].intensity, a.lights[0].intensity);
  EXPECT_EQ(b.camera.position, a.camera.position);
  EXPECT_EQ(b.dynamic_path, a.dynamic_path);
}

// ---- synthetic files ----

std::string base64(const std::vector<std::uint8_t>& bytes) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::uint32_t n = (std::uint32_t(bytes[i]) << 16) | (i + 1 < bytes.size() ? bytes[i + 1] << 8 : 0) |
                            (i + 2 < bytes.size() ? bytes[i + 2] : 0);
    out += table[(n >> 18) & 63];
    out += table[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? table[(n >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? table[n & 63] : '=';
  }
  return out;
}

// A triangle (optionally a unit cube's 8 corners for block nodes) in one embedded buffer.
struct Synthetic {
  std::vector<float> positions = {0.2f, 0.1f, 0.2f, 0.5f, 0.1f, 0.8f, 0.8f, 0.1f, 0.2f};
  std::vector<std::uint16_t> indices = {0, 1, 2};
  std::string nodes =
      R"([{"name":"tri","mesh":0},{"name":"room","extras":{"modrt_block":{"cell":[0,0,0]}}}])";
  std::string scene_nodes = "[0,1]";
  std::string primitive_extra;  // appended inside the primitive object
  std::string accessor0_extra;  // appended inside accessor 0
  std::string top_extra;        // appended at the top level (",\"materials\":...")

  std::string text() const {
    std::vector<std::uint8_t> bytes(positions.size() * 4 + indices.size() * 2);
    std::memcpy(bytes.data(), positions.data(), positions.size() * 4);
    std::memcpy(bytes.data() + positions.size() * 4, indices.data(), indices.size() * 2);
    const std::string pos_len = std::to_string(positions.size() * 4),
                      idx_len = std::to_string(indices.size() * 2);
    return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":)" + scene_nodes + R"(}],"nodes":)" +
           nodes + R"(,"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1)" + primitive_extra +
           R"(}]}],"buffers":[{"byteLength":)" + std::to_string(bytes.size()) +
           R"(,"uri":"data:application/octet-stream;base64,)" + base64(bytes) +
           R"("}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":)" + pos_len +
           R"(},{"buffer":0,"byteOffset":)" + pos_len + R"(,"byteLength":)" + idx_len +
           R"(}],"accessors":[{"bufferView":0,"componentType":5126,"count":)" +
           std::to_string(positions.size() / 3) + R"(,"type":"VEC3")" + accessor0_extra +
           R"(},{"bufferView":1,"componentType":5123,"count":)" + std::to_string(indices.size()) +
           R"(,"type":"SCALAR"}])" + top_extra + "}";
  }
};

Result<DemoScene> load_text(const std::string& name, const std::string& text, GltfSceneOptions options = {}) {
  const fs::path path = temp_dir() / name;
  write_text(path, text);
  return load_gltf_scene(path.string(), options);
}

// The error names the file and contains every one of `words`.
void expect_error(const Result<DemoScene>& r, const std::string& file,
                  std::initializer_list<const char*> words) {
  ASSERT_FALSE(r.ok()) << file << " loaded";
  const std::string& m = r.status().message();
  EXPECT_NE(m.find(file), std::string::npos) << m;
  for (const char* w : words) EXPECT_NE(m.find(w), std::string::npos) << "'" << w << "' not in: " << m;
}

TEST(GltfScene, SyntheticTriangleLoads) {
  // The base file of the error tests is valid: each test below breaks one thing.
  std::vector<std::string> warnings;
  GltfSceneOptions options;
  options.warnings = &warnings;
  Result<DemoScene> r = load_text("ok.gltf", Synthetic().text(), options);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_GE(r->meshes.size(), 1u);
  EXPECT_EQ(r->meshes[0].name, "tri");
  EXPECT_EQ(r->meshes[0].position.size(), 3u);  // flat normals: one vertex per corner already
  expect_near(r->meshes[0].normal[0], {0, 1, 0}, 1e-6f, "computed normal");
  ASSERT_EQ(r->level.blocks.size(), 1u);
  EXPECT_EQ(r->level.blocks[0].name, "room");
  // No light in the file or its level: the default light (docs/demo.md, "Default light"), a
  // white point light of cell_size^2 W/sr high in the block nearest the level's middle, said
  // in a warning. (It used to stay empty, and modrt-demo refused: "the scene has no light".)
  ASSERT_EQ(r->lights.size(), 1u);
  expect_near(r->lights[0].path.at(0), {0.5f, 0.85f, 0.5f}, 1e-6f, "default light");
  EXPECT_FLOAT_EQ(r->lights[0].intensity, 1.0f);
  expect_near(r->lights[0].color, glm::vec3(1.0f), 0.0f, "default light colour");
  EXPECT_GE(r->lights[0].outer_cone, 3.14159f);
  bool warned_light = false, warned_camera = false;
  for (const std::string& w : warnings) {
    warned_light = warned_light || (w.find("no point or spot light") != std::string::npos &&
                                    w.find("default white point light") != std::string::npos &&
                                    w.find("(0.5, 0.85, 0.5)") != std::string::npos);
    warned_camera = warned_camera || w.find("no camera") != std::string::npos;
  }
  EXPECT_TRUE(warned_light);
  EXPECT_TRUE(warned_camera);
  // The default camera stands in the block's middle.
  expect_near(r->camera.position, glm::vec3(0.5f), 1e-6f, "default camera");
}

TEST(GltfScene, MatrixIsColumnMajorAndFlatNormalsFollowTheGeometry) {
  Synthetic syn;
  // x += 1.0 * y: a shear that tilts the triangle (y = 0.1 plane stays a plane) and moves it.
  syn.positions = {0.2f, 0.1f, 0.2f, 0.3f, 0.6f, 0.2f, 0.2f, 0.1f, 0.7f};
  syn.nodes = R"([{"name":"tri","mesh":0,"matrix":[1,0,0,0, 0.5,1,0,0, 0,0,1,0, 0,0,0,1]},)"
              R"({"name":"room","extras":{"modrt_block":{"cell":[0,0,0]}}}])";
  syn.primitive_extra = R"(,"material":0)";
  syn.top_extra = R"(,"materials":[{"name":"m"}])";
  // Without NORMAL the flat normal comes from the transformed triangle.
  Result<DemoScene> r = load_text("shear.gltf", syn.text());
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const Mesh& m = r->meshes[0];
  const glm::vec3 a = m.position[m.indices[0]], b = m.position[m.indices[1]], c = m.position[m.indices[2]];
  expect_near(b, {0.3f + 0.5f * 0.6f, 0.6f, 0.2f}, 1e-6f, "sheared vertex");
  EXPECT_NEAR(glm::dot(m.normal[0], b - a), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::dot(m.normal[0], c - a), 0.0f, 1e-6f);
  expect_near(r->materials[std::size_t(m.material)].base_color, glm::vec3(1.0f), 1e-6f,
              "glTF default factor");
}

TEST(GltfScene, ExplicitNormalsTurnWithTheInverseTranspose) {
  // Positions, then normals: accessor 2 reads the normals from bytes appended after the
  // indices (the index view is 6 bytes; 2 bytes of padding keep the floats aligned).
  Synthetic syn;
  syn.positions = {0, 0, 0, 1, 0, 0, 0, 0, 1};
  const std::vector<float> normals = {0, 1, 0, 0, 1, 0, 0, 1, 0};
  std::vector<std::uint8_t> bytes(36 + 6 + 2 + 36);
  std::memcpy(bytes.data(), syn.positions.data(), 36);
  std::memcpy(bytes.data() + 36, syn.indices.data(), 6);
  std::memcpy(bytes.data() + 44, normals.data(), 36);
  // A shear mixing y into z (column 1 = (0, 1, 0.5)): the normal (0, 1, 0) of the plane
  // y = 0 stays (0, 1, 0) under the inverse transpose, while M * n would tilt it.
  const std::string text =
      R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],)"
      R"("nodes":[{"name":"tri","mesh":0,"matrix":[1,0,0,0, 0,1,0.5,0, 0,0,1,0, 0,0,0,1]},)"
      R"({"name":"room","extras":{"modrt_block":{"cell":[0,0,0]}}}],)"
      R"("meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":2},"indices":1}]}],)"
      R"("buffers":[{"byteLength":80,"uri":"data:application/octet-stream;base64,)" +
      base64(bytes) +
      R"("}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6},)"
      R"({"buffer":0,"byteOffset":44,"byteLength":36}],)"
      R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},)"
      R"({"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"},)"
      R"({"bufferView":2,"componentType":5126,"count":3,"type":"VEC3"}]})";
  Result<DemoScene> r = load_text("normals.gltf", text);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const Mesh& m = r->meshes[0];
  const glm::vec3 a = m.position[m.indices[0]], b = m.position[m.indices[1]], c = m.position[m.indices[2]];
  EXPECT_NEAR(glm::dot(m.normal[0], b - a), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::dot(m.normal[0], c - a), 0.0f, 1e-6f);
  expect_near(m.normal[0], {0, 1, 0}, 1e-6f, "normal");
}

TEST(GltfScene, BlocksFromExtras) {
  // Two blocks from the bounding boxes of a unit cube mesh (8 corners, no indices needed
  // for a bounding box but the mesh is a valid triangle list), a third with an explicit cell.
  Synthetic syn;
  syn.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
  syn.indices = {0, 1, 2, 1, 3, 2};
  syn.nodes =
      R"([{"name":"south","mesh":0,"extras":{"modrt_block":{"missing":["+Z"],"albedo":[0.5,0.4,0.3]}}},)"
      R"({"name":"north","mesh":0,"translation":[0,0,1],"extras":{"modrt_block":{"missing":["-Z","+X"]}}},)"
      R"({"name":"east","extras":{"modrt_block":{"cell":[1,0,1],"missing":["-X"]}}},)"
      R"({"name":"detail","mesh":0,"translation":[0.25,0,0.25],"scale":[0.1,0.1,0.1]}])";
  syn.scene_nodes = "[0,1,2,3]";
  syn.top_extra = "";
  const std::string text = syn.text();
  // proxy_walls false: only the detail mesh is drawn; the block meshes are not.
  std::string no_walls = text;
  no_walls.replace(
      no_walls.find(R"("scenes":[{"nodes":[0,1,2,3]})"),
      std::string(R"("scenes":[{"nodes":[0,1,2,3]})").size(),
      R"("scenes":[{"nodes":[0,1,2,3],"extras":{"modrt_level":{"proxy_walls":false,"cell_size":1.0}}})");
  Result<DemoScene> r = load_text("blocks.gltf", no_walls);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->level.blocks.size(), 3u);
  EXPECT_EQ(r->level.blocks[0].name, "south");
  EXPECT_EQ(r->level.blocks[1].cell, glm::ivec3(0, 0, 1));
  EXPECT_EQ(r->level.blocks[2].cell, glm::ivec3(1, 0, 1));
  for (const BlockDescription& b : r->level.blocks) EXPECT_FALSE(b.warped) << b.name;
  EXPECT_EQ(r->level.blocks[0].albedo[0], glm::dvec3(0.5, 0.4, 0.3));
  ASSERT_EQ(r->meshes.size(), 1u);
  EXPECT_EQ(r->meshes[0].name, "detail");
  // With the default proxy_walls the walls are added.
  Result<DemoScene> walls = load_text("blocks_walls.gltf", text);
  ASSERT_TRUE(walls.ok()) << walls.status().to_string();
  EXPECT_GT(walls->meshes.size(), 1u);
  // draw: true keeps the block's mesh as geometry too.
  std::string drawn = text;
  drawn.replace(drawn.find(R"("albedo":[0.5,0.4,0.3])"), std::string(R"("albedo":[0.5,0.4,0.3])").size(),
                R"("albedo":[0.5,0.4,0.3],"draw":true)");
  GltfSceneOptions no_wall_option;
  no_wall_option.proxy_walls = false;
  Result<DemoScene> d = load_text("blocks_drawn.gltf", drawn, no_wall_option);
  ASSERT_TRUE(d.ok()) << d.status().to_string();
  ASSERT_EQ(d->meshes.size(), 2u);
  EXPECT_EQ(d->meshes[0].name, "south");

  // A stretched box is a warped block with the box's corners.
  Synthetic warped = syn;
  warped.nodes = R"([{"name":"wide","mesh":0,"scale":[1.2,1,1],"extras":{"modrt_block":true}}])";
  warped.scene_nodes = "[0]";
  Result<DemoScene> w = load_text("warped.gltf", warped.text());
  ASSERT_TRUE(w.ok()) << w.status().to_string();
  ASSERT_EQ(w->level.blocks.size(), 1u);
  EXPECT_TRUE(w->level.blocks[0].warped);
  EXPECT_EQ(w->level.blocks[0].corners[7], glm::dvec3(1.2, 1.0, 1.0));
  // tinygltf drops empty objects from extras; an empty modrt_block is reported, not ignored.
  Synthetic empty = warped;
  empty.nodes = R"([{"name":"wide","mesh":0,"extras":{"modrt_block":{}}}])";
  expect_error(load_text("empty_block.gltf", empty.text()), "empty_block.gltf",
               {"modrt_block is empty", "'wide'"});
}

TEST(GltfScene, SmoothMissingNormalsShareVertices) {
  // Two triangles folded along their shared edge (vertices 1 and 2).
  Synthetic syn;
  syn.positions = {0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0.5f, 1};
  syn.indices = {0, 2, 1, 1, 2, 3};
  GltfSceneOptions options;
  options.smooth_missing_normals = true;
  Result<DemoScene> smooth = load_text("smooth.gltf", syn.text(), options);
  ASSERT_TRUE(smooth.ok()) << smooth.status().to_string();
  const Mesh& m = smooth->meshes[0];
  ASSERT_EQ(m.position.size(), 4u);
  const glm::vec3 p0(0, 0, 0), p1(1, 0, 0), p2(0, 0, 1), p3(1, 0.5f, 1);
  const glm::vec3 n0 = glm::cross(p2 - p0, p1 - p0), n1 = glm::cross(p2 - p1, p3 - p1);  // area-weighted
  expect_near(m.normal[0], glm::normalize(n0), 1e-6f, "vertex 0 (one triangle)");
  expect_near(m.normal[1], glm::normalize(n0 + n1), 1e-6f, "vertex 1 (shared)");
  expect_near(m.normal[3], glm::normalize(n1), 1e-6f, "vertex 3 (one triangle)");
  // The default (the glTF rule): flat, a vertex per corner.
  Result<DemoScene> flat = load_text("flat.gltf", syn.text());
  ASSERT_TRUE(flat.ok()) << flat.status().to_string();
  EXPECT_EQ(flat->meshes[0].position.size(), 6u);
  expect_near(flat->meshes[0].normal[3], glm::normalize(n1), 1e-6f, "second triangle, flat");
}

TEST(GltfScene, LightConversion) {
  Synthetic syn;
  // The spot turned 90 degrees about +X: its local -Z shines down (-Y).
  const double h = std::sqrt(0.5);
  syn.nodes = R"([{"name":"tri","mesh":0},{"name":"room","extras":{"modrt_block":{"cell":[0,0,0]}}},)"
              R"({"name":"sun","extensions":{"KHR_lights_punctual":{"light":0}}},)"
              R"({"name":"spot","translation":[0.5,0.9,0.5],"rotation":[)" +
              std::to_string(-h) + ",0,0," + std::to_string(h) +
              R"(],"extensions":{"KHR_lights_punctual":{"light":1}}}])";
  syn.scene_nodes = "[0,1,2,3]";
  syn.top_extra =
      R"(,"extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[)"
      R"({"type":"directional","name":"sun","intensity":3},)"
      R"({"type":"spot","name":"torch","intensity":68.3,"color":[1,0.5,0.25],)"
      R"("spot":{"innerConeAngle":0.25,"outerConeAngle":0.5}}]}})";
  std::vector<std::string> warnings;
  GltfSceneOptions options;
  options.warnings = &warnings;
  Result<DemoScene> r = load_text("lights.gltf", syn.text(), options);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->lights.size(), 2u);
  // The sun: along its node's -Z, 3 lux as irradiance (the candela scale), no cone.
  const DemoLight& sun = r->lights[0];
  EXPECT_TRUE(sun.directional);
  EXPECT_NEAR(sun.intensity, 3.0f / 683.0f, 1e-7f);
  expect_near(sun.direction, {0.0f, 0.0f, -1.0f}, 1e-6f, "sun direction");
  const DemoLight& spot = r->lights[1];
  EXPECT_FALSE(spot.directional);
  EXPECT_NEAR(spot.intensity, 0.1f, 1e-6f);  // 68.3 cd / 683 lm/W
  expect_near(spot.color, {1.0f, 0.5f, 0.25f}, 1e-6f, "spot colour");
  expect_near(spot.path[0], {0.5f, 0.9f, 0.5f}, 1e-6f, "spot position");
  expect_near(spot.direction, {0.0f, -1.0f, 0.0f}, 1e-5f, "spot direction");
  EXPECT_FLOAT_EQ(spot.inner_cone, 0.25f);
  EXPECT_FLOAT_EQ(spot.outer_cone, 0.5f);
  for (const std::string& w : warnings) EXPECT_EQ(w.find("'sun'"), std::string::npos) << w;
  // A point light keeps the DemoLight defaults: no cone.
  EXPECT_GE(sample().lights[0].outer_cone, 3.14159f);

  // Cone angles outside the extension's rules are errors.
  std::string bad = syn.text();
  bad.replace(bad.find(R"("innerConeAngle":0.25)"), std::string(R"("innerConeAngle":0.25)").size(),
              R"("innerConeAngle":0.75)");
  expect_error(load_text("badspot.gltf", bad), "badspot.gltf", {"'torch'", "cone"});
}

TEST(GltfScene, ErrorsNameTheFileAndTheProblem) {
  const std::string valid = Synthetic().text();

  Result<DemoScene> missing = load_gltf_scene((temp_dir() / "absent.gltf").string());
  expect_error(missing, "absent.gltf", {"not found"});
  EXPECT_EQ(missing.status().code(), ErrorCode::io_error);

  expect_error(load_text("truncated.gltf", valid.substr(0, valid.size() / 2)), "truncated.gltf",
               {"tinygltf"});
  expect_error(load_text("garbage.gltf", "this is not JSON"), "garbage.gltf", {"tinygltf"});

  Synthetic beyond;
  beyond.accessor0_extra = "";
  std::string beyond_text = beyond.text();
  beyond_text.replace(beyond_text.find(R"("count":3,"type":"VEC3")"),
                      std::string(R"("count":3,"type":"VEC3")").size(), R"("count":300,"type":"VEC3")");
  expect_error(load_text("beyond.gltf", beyond_text), "beyond.gltf", {"accessor 0", "out of range"});

  Synthetic bad_index;
  bad_index.indices = {0, 1, 7};
  expect_error(load_text("index.gltf", bad_index.text()), "index.gltf", {"index out of range", "7"});

  Synthetic points;
  points.primitive_extra = R"(,"mode":0)";
  expect_error(load_text("points.gltf", points.text()), "points.gltf", {"POINTS", "not supported"});

  std::string no_position = valid;
  no_position.replace(no_position.find(R"({"POSITION":0})"), std::string(R"({"POSITION":0})").size(),
                      R"({"NORMAL":0})");
  expect_error(load_text("noposition.gltf", no_position), "noposition.gltf", {"missing POSITION"});

  Synthetic missing_image;
  missing_image.primitive_extra = R"(,"material":0)";
  missing_image.top_extra =
      R"(,"materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],"textures":[{"source":0}],)"
      R"("images":[{"uri":"nowhere.png"}])";
  expect_error(load_text("noimage.gltf", missing_image.text()), "noimage.gltf",
               {"nowhere.png", "could not be loaded"});

  Synthetic gif = missing_image;
  gif.top_extra = R"(,"materials":[{"normalTexture":{"index":0}}],"textures":[{"source":0}],)"
                  R"("images":[{"uri":"data:image/png;base64,)" +
                  base64({'G', 'I', 'F', '8', '9', 'a', 1, 0, 1, 0, 0, 0, 0}) + R"("}])";
  expect_error(load_text("gif.gltf", gif.text()), "gif.gltf", {"unsupported image format"});

  Synthetic no_blocks;
  no_blocks.scene_nodes = "[0]";
  GltfSceneOptions no_import;  // by default a file without blocks gets them from its geometry
  no_import.import_unmarked = false;
  expect_error(load_text("noblocks.gltf", no_blocks.text(), no_import), "noblocks.gltf",
               {"no proxy blocks found"});
  expect_error(load_text("noblocks.gltf", no_blocks.text()), "noblocks.gltf",
               {"no proxy blocks in the file, and importing them from its geometry failed"});

  // A sidecar level file with an error: the level loader's message comes through.
  write_text(temp_dir() / "sidecar.level.json",
             R"({"format":"modrt-level","version":1,"blocks":[{"cel":[0,0,0]}]})");
  expect_error(load_text("sidecar.gltf", valid), "sidecar.gltf", {"level JSON error", "cel"});
  GltfSceneOptions explicit_level;
  explicit_level.level_path = (temp_dir() / "absent.level.json").string();
  expect_error(load_text("explicit.gltf", valid, explicit_level), "explicit.gltf",
               {"level JSON error", "absent.level.json"});

  // An extras block with a bad face name: the message names the node.
  Synthetic bad_block;
  bad_block.nodes =
      R"([{"name":"tri","mesh":0},{"name":"hall","extras":{"modrt_block":{"cell":[0,0,0],"missing":["+W"]}}}])";
  expect_error(load_text("badblock.gltf", bad_block.text()), "badblock.gltf",
               {"level JSON error", "+W", "'hall'"});

  // Node cycle: never loops.
  Synthetic cycle;
  cycle.nodes = R"([{"name":"a","mesh":0,"children":[1]},{"name":"b","children":[0]}])";
  cycle.scene_nodes = "[0]";
  expect_error(load_text("cycle.gltf", cycle.text()), "cycle.gltf", {"reached twice"});

  // Size limits are checked before allocating.
  GltfSceneOptions tiny;
  tiny.max_vertices = 2;
  const Result<DemoScene> limited = load_text("limit.gltf", valid, tiny);
  expect_error(limited, "limit.gltf", {"limit"});
  EXPECT_EQ(limited.status().code(), ErrorCode::resource_limit);
  GltfSceneOptions small_images;
  small_images.max_image_side = 8;  // the sample's normal map is 16 x 16, read from its PNG header
  expect_error(load_gltf_scene(kSample, small_images), "two_rooms.gltf", {"16 x 16", "texture limit"});
  // A JPEG claiming 20000 x 20000 pixels is refused from its start-of-frame header, before
  // anything decodes it (the rest of the file is missing).
  Synthetic huge_jpeg = gif;
  huge_jpeg.top_extra = R"(,"materials":[{"normalTexture":{"index":0}}],"textures":[{"source":0}],)"
                        R"("images":[{"uri":"data:image/jpeg;base64,)" +
                        base64({0xff, 0xd8, 0xff, 0xe0, 0x00, 0x10, 'J', 'F',  'I',  'F',  0,    1,    1,
                                0,    0,    1,    0,    1,    0,    0,   0xff, 0xc0, 0x00, 0x11, 0x08, 0x4e,
                                0x20, 0x4e, 0x20, 0x03, 1,    0x22, 0,   2,    0x11, 1,    3,    0x11, 1}) +
                        R"("}])";
  expect_error(load_text("huge.gltf", huge_jpeg.text()), "huge.gltf", {"20000 x 20000", "texture limit"});
  GltfSceneOptions small_files;
  small_files.max_file_bytes = 100;
  expect_error(load_text("bigfile.gltf", valid, small_files), "bigfile.gltf", {"bytes"});

  // JSON nested deep enough to overflow a recursive parser's stack is refused up front.
  std::string deep = valid;
  deep.insert(deep.size() - 1, R"(,"extras":)" + std::string(100000, '[') + std::string(100000, ']'));
  expect_error(load_text("deep.gltf", deep), "deep.gltf", {"nested deeper"});

  // An accessor without a buffer view would be all zeros: refused rather than allocated.
  std::string zeros = valid;
  zeros.replace(zeros.find(R"({"bufferView":0,"componentType":5126,"count":3)"),
                std::string(R"({"bufferView":0,"componentType":5126,"count":3)").size(),
                R"({"componentType":5126,"count":40000000)");
  expect_error(load_text("zeros.gltf", zeros), "zeros.gltf", {"accessor 0", "no bufferView"});

  // A required extension the loader does not implement.
  Synthetic draco;
  draco.top_extra =
      R"(,"extensionsRequired":["KHR_draco_mesh_compression"],"extensionsUsed":["KHR_draco_mesh_compression"])";
  expect_error(load_text("draco.gltf", draco.text()), "draco.gltf", {"KHR_draco_mesh_compression"});
}

// ---- DRT clutter meshes (extras.modrt_clutter) ----

// A box of local half extents h around the node's origin, 4 vertices per face (faces +X, -X,
// +Y, -Y, +Z, -Z, counter-clockwise from outside), flat, with TEXCOORD_1 laying the faces out
// as 6 of the 4 x 2 tiles of a 32 x 32 atlas, each 6 x 14 cells inset by one cell (multiples
// of 1/32, exact in float, so every face covers exactly 84 cells).
struct ClutterBoxGltf {
  glm::vec3 h{0.1f, 0.3f, 0.15f};
  std::string node_fields = R"("translation":[0.5,0.3,0.5],"rotation":[0,0.70710678,0,0.70710678])";
  std::string clutter = R"({"res":32})";
  bool texcoord1 = true;
  int drop_faces = 0;         // leave out the last faces' triangles (an open mesh)
  bool flat_uv_face = false;  // face 0's lightmap UVs all at one point (zero UV area)
  std::string extra_nodes = R"({"name":"room","extras":{"modrt_block":{"cell":[0,0,0]}}},)"
                            R"({"name":"annex","extras":{"modrt_block":{"cell":[1,0,0]}}})";

  std::string text() const {
    std::vector<float> pos, uv;
    std::vector<std::uint16_t> idx;
    for (int f = 0; f < 6; ++f) {
      const int a = f / 2;
      const float sign = f % 2 == 0 ? 1.0f : -1.0f;
      const int ua = sign > 0 ? (a + 1) % 3 : (a + 2) % 3, va = sign > 0 ? (a + 2) % 3 : (a + 1) % 3;
      const int col = f % 4, row = f / 4;
      const std::uint16_t base = std::uint16_t(pos.size() / 3);
      for (auto [x, y] : {std::pair{0, 0}, {1, 0}, {1, 1}, {0, 1}}) {
        glm::vec3 p(0.0f);
        p[a] = sign * h[a];
        p[ua] = (x ? 1.0f : -1.0f) * h[ua];
        p[va] = (y ? 1.0f : -1.0f) * h[va];
        pos.insert(pos.end(), {p.x, p.y, p.z});
        if (flat_uv_face && f == 0)
          uv.insert(uv.end(), {1.0f / 32.0f, 1.0f / 32.0f});
        else
          uv.insert(uv.end(), {float(8 * col + 1 + 6 * x) / 32.0f, float(16 * row + 1 + 14 * y) / 32.0f});
      }
      if (f < 6 - drop_faces)
        idx.insert(idx.end(), {base, std::uint16_t(base + 1), std::uint16_t(base + 2), base,
                               std::uint16_t(base + 2), std::uint16_t(base + 3)});
    }
    std::vector<std::uint8_t> bytes(pos.size() * 4 + uv.size() * 4 + idx.size() * 2);
    std::memcpy(bytes.data(), pos.data(), pos.size() * 4);
    std::memcpy(bytes.data() + pos.size() * 4, uv.data(), uv.size() * 4);
    std::memcpy(bytes.data() + pos.size() * 4 + uv.size() * 4, idx.data(), idx.size() * 2);
    const std::string n = std::to_string(pos.size() / 3), pl = std::to_string(pos.size() * 4),
                      ul = std::to_string(uv.size() * 4), il = std::to_string(idx.size() * 2);
    const std::string attributes =
        std::string(R"({"POSITION":0)") + (texcoord1 ? R"(,"TEXCOORD_1":1)" : "") + "}";
    return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2]}],"nodes":[{"name":"box","mesh":0,)" +
           node_fields + (clutter.empty() ? "" : R"(,"extras":{"modrt_clutter":)" + clutter + "}") + "}," +
           extra_nodes + R"(],"materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.6,0.5,0.4,1]}}],)" +
           R"("meshes":[{"primitives":[{"attributes":)" + attributes + R"(,"indices":2,"material":0}]}],)" +
           R"("buffers":[{"byteLength":)" + std::to_string(bytes.size()) +
           R"(,"uri":"data:application/octet-stream;base64,)" + base64(bytes) + R"("}],"bufferViews":[)" +
           R"({"buffer":0,"byteOffset":0,"byteLength":)" + pl + R"(},{"buffer":0,"byteOffset":)" + pl +
           R"(,"byteLength":)" + ul + R"(},{"buffer":0,"byteOffset":)" +
           std::to_string(pos.size() * 4 + uv.size() * 4) + R"(,"byteLength":)" + il +
           R"(}],"accessors":[{"bufferView":0,"componentType":5126,"count":)" + n +
           R"(,"type":"VEC3"},{"bufferView":1,"componentType":5126,"count":)" + n +
           R"(,"type":"VEC2"},{"bufferView":2,"componentType":5123,"count":)" + std::to_string(idx.size()) +
           R"(,"type":"SCALAR"}]})";
  }
};

TEST(GltfScene, ClutterMeshFromExtras) {
  // The node turns the box a quarter about +Y: local half extents (0.1, 0.3, 0.15) become
  // world (0.15, 0.3, 0.1) around (0.5, 0.3, 0.5), standing on the floor of block 0.
  Result<DemoScene> r = load_text("clutter.gltf", ClutterBoxGltf().text());
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->clutter.size(), 1u);
  const ClutterObject& object = r->clutter[0];
  EXPECT_EQ(object.kind, ClutterKind::mesh);
  EXPECT_EQ(object.block, 0);  // the block whose cell holds the mesh's centre
  EXPECT_EQ(object.res, 32);
  EXPECT_EQ(object.albedo, glm::dvec3(glm::vec3(0.6f, 0.5f, 0.4f)));  // the material's base colour
  ASSERT_TRUE(object.mesh);
  const ClutterMeshData& data = *object.mesh;
  EXPECT_EQ(data.mesh.positions.size(), 24u);
  EXPECT_EQ(data.mesh.indices.size(), 36u);
  // Exactly the 6 x 84 cells inside the faces' UV rectangles are texels.
  EXPECT_EQ(clutter_texel_count(object), 6 * 6 * 14);
  EXPECT_EQ(data.atlas.chart_count, 6);
  const glm::dvec3 lo(0.35, 0.0, 0.4), hi(0.65, 0.6, 0.6);
  glm::dvec3 mlo(1e30), mhi(-1e30);
  for (const glm::dvec3& p : data.mesh.positions) mlo = glm::min(mlo, p), mhi = glm::max(mhi, p);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(mlo[a], lo[a], 1e-6) << a;
    EXPECT_NEAR(mhi[a], hi[a], 1e-6) << a;
  }
  // Every texel lies on the world box's surface with the outward normal of its side, and
  // the texels' areas add up to the box's (2 (0.3 0.6 + 0.6 0.2 + 0.3 0.2) = 0.72).
  double area = 0.0;
  for (double x : data.atlas.area) area += x;
  EXPECT_NEAR(area, 0.72, 1e-6);
  const ClutterTexelGeometry& g = data.atlas.texels;
  ASSERT_EQ(g.position.size(), std::size_t(clutter_texel_count(object)));
  for (std::size_t t = 0; t < g.position.size(); ++t) {
    int on_side = 0;
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(g.position[t][a], lo[a] - 1e-6);
      EXPECT_LE(g.position[t][a], hi[a] + 1e-6);
      for (double sign : {-1.0, 1.0}) {
        const double bound = sign > 0 ? hi[a] : lo[a];
        if (std::abs(g.position[t][a] - bound) > 1e-6) continue;
        glm::dvec3 n(0.0);
        n[a] = sign;
        if (glm::length(g.normal[t] - n) < 1e-6) ++on_side;
      }
    }
    ASSERT_EQ(on_side, 1) << "texel " << t;
  }
  // The drawn mesh carries the object's index and its lightmap UVs; proxy mapping skips it.
  const Mesh* drawn = nullptr;
  for (const Mesh& m : r->meshes)
    if (m.name == "box") drawn = &m;
  ASSERT_NE(drawn, nullptr);
  EXPECT_EQ(drawn->clutter, 0);
  ASSERT_EQ(drawn->lightmap_uv.size(), drawn->position.size());
  for (const glm::vec2& uv : drawn->lightmap_uv) {
    EXPECT_GT(uv.x, 0.0f);
    EXPECT_LT(uv.y, 1.0f);
  }
  const std::size_t box_index = std::size_t(drawn - r->meshes.data());
  Result<Level> level = precompute::build_level(r->level, test::small_test_dictionary());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  Result<std::vector<MappedMesh>> mapped = map_to_proxies(r.value(), level.value());
  ASSERT_TRUE(mapped.ok()) << mapped.status().to_string();
  EXPECT_FALSE(mapped->empty());  // the proxy walls
  for (const MappedMesh& m : mapped.value()) EXPECT_NE(std::size_t(m.mesh), box_index);
  EXPECT_TRUE(validate_clutter(level.value(), r->clutter).ok());

  // Default block from the centre's cell; explicit block, res and albedo.
  ClutterBoxGltf moved;
  moved.node_fields = R"("translation":[1.5,0.3,0.5])";
  moved.clutter = "true";
  Result<DemoScene> m = load_text("clutter_moved.gltf", moved.text());
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  ASSERT_EQ(m->clutter.size(), 1u);
  EXPECT_EQ(m->clutter[0].block, 1);
  EXPECT_EQ(m->clutter[0].res, precompute::kClutterMeshDefaultRes);
  ClutterBoxGltf fields;
  fields.clutter = R"({"block":1,"res":16,"albedo":[0.2,0.3,0.9]})";
  Result<DemoScene> f = load_text("clutter_fields.gltf", fields.text());
  ASSERT_TRUE(f.ok()) << f.status().to_string();
  EXPECT_EQ(f->clutter[0].block, 1);
  EXPECT_EQ(f->clutter[0].res, 16);
  EXPECT_EQ(f->clutter[0].albedo, glm::dvec3(0.2, 0.3, 0.9));
  // Half the res: the faces' edges cut cells in half, and every cell a face touches is a
  // texel (conservative rasterization): 4 x 8 cells per face.
  EXPECT_EQ(clutter_texel_count(f->clutter[0]), 6 * 4 * 8);
  ClutterBoxGltf off;
  off.clutter = "false";
  Result<DemoScene> o = load_text("clutter_off.gltf", off.text());
  ASSERT_TRUE(o.ok()) << o.status().to_string();
  EXPECT_TRUE(o->clutter.empty());
}

TEST(GltfScene, ClutterSampleBuildsDrtOperators) {
  // data/scenes/clutter_room.gltf (scripts/make_clutter_gltf.py): a concave L pillar in block
  // 0 (its default block) and a box given block 1, both closed prisms.
  const std::string path = std::string(MODRT_SCENES_DIR) + "/clutter_room.gltf";
  Result<DemoScene> r = load_gltf_scene(path);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->clutter.size(), 2u);
  const ClutterObject &pillar = r->clutter[0], &box = r->clutter[1];
  EXPECT_EQ(pillar.block, 0);
  EXPECT_EQ(box.block, 1);
  EXPECT_EQ(pillar.res, 48);
  EXPECT_EQ(box.res, precompute::kClutterMeshDefaultRes);
  EXPECT_EQ(pillar.albedo, glm::dvec3(glm::vec3(0.8f, 0.45f, 0.3f)));
  EXPECT_EQ(box.albedo, glm::dvec3(0.25, 0.4, 0.8));
  EXPECT_EQ(pillar.mesh->atlas.chart_count, 8);  // 6 sides + 2 caps
  EXPECT_EQ(box.mesh->atlas.chart_count, 6);
  // Surface areas: 2 cap areas + perimeter x height (L: caps 0.0896, perimeter 1.44, height
  // 0.748; box: 0.3 x 0.25, perimeter 1.1, height 0.298).
  auto area = [](const ClutterObject& o) {
    double a = 0.0;
    for (double x : o.mesh->atlas.area) a += x;
    return a;
  };
  EXPECT_NEAR(area(pillar), 2 * 0.0896 + 1.44 * 0.748, 1e-5);
  EXPECT_NEAR(area(box), 2 * 0.075 + 1.1 * 0.298, 1e-5);
  int drawn = 0;
  for (const Mesh& m : r->meshes) drawn += m.clutter >= 0;
  EXPECT_EQ(drawn, 2);
  // The DRT build accepts the objects and its operators pass the runtime's checks; the box
  // and the pillar see each other across the open side (the gather's Gt).
  Result<Level> level = precompute::build_level(r->level, test::small_test_dictionary());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  precompute::DrtBuildSettings settings;
  settings.rays = 64;
  Result<DrtOperators> drt =
      precompute::DrtBuilder(level.value(), test::small_test_dictionary(), settings).build(r->clutter);
  ASSERT_TRUE(drt.ok()) << drt.status().to_string();
  EXPECT_TRUE(check_drt_operators(level.value(), drt.value()).ok());
  ASSERT_EQ(drt->objects.size(), 2u);
  EXPECT_FALSE(drt->objects[0].Gt.index.empty());
}

TEST(GltfScene, ClutterErrorsNameTheNode) {
  ClutterBoxGltf no_uv;
  no_uv.texcoord1 = false;
  expect_error(load_text("clutter_nouv.gltf", no_uv.text()), "clutter_nouv.gltf",
               {"node 0 ('box')", "TEXCOORD_1"});
  ClutterBoxGltf block;
  block.clutter = R"({"block":5})";
  expect_error(load_text("clutter_block.gltf", block.text()), "clutter_block.gltf",
               {"node 0 ('box')", "block 5", "does not exist"});
  ClutterBoxGltf outside;
  outside.node_fields = R"("translation":[4.5,0.3,0.5])";
  expect_error(load_text("clutter_outside.gltf", outside.text()), "clutter_outside.gltf",
               {"node 0 ('box')", "no block"});
  for (const char* res : {"0", "2000", "1.5"}) {
    ClutterBoxGltf bad_res;
    bad_res.clutter = std::string(R"({"res":)") + res + "}";
    expect_error(load_text("clutter_res.gltf", bad_res.text()), "clutter_res.gltf",
                 {"node 0 ('box')", ".res"});
  }
  ClutterBoxGltf albedo;
  albedo.clutter = R"({"albedo":[0.5,1.5,0.5]})";
  expect_error(load_text("clutter_albedo.gltf", albedo.text()), "clutter_albedo.gltf",
               {"node 0 ('box')", "albedo[1]", "[0, 1]"});
  ClutterBoxGltf unknown;
  unknown.clutter = R"({"rez":32})";
  expect_error(load_text("clutter_field.gltf", unknown.text()), "clutter_field.gltf",
               {"node 0 ('box')", "'rez'"});
  ClutterBoxGltf open;
  open.drop_faces = 1;
  expect_error(load_text("clutter_open.gltf", open.text()), "clutter_open.gltf",
               {"node 0 ('box')", "not closed"});
  ClutterBoxGltf flat;
  flat.flat_uv_face = true;
  expect_error(load_text("clutter_flat.gltf", flat.text()), "clutter_flat.gltf",
               {"node 0 ('box')", "clutter mesh"});
  ClutterBoxGltf huge;  // a finite shear (determinant 1) carrying a finite position past double's range
  huge.node_fields = R"("matrix":[1,0,0,0, 1e300,1,0,0, 0,0,1,0, 0,0,0,1])";
  huge.h = glm::vec3(0.1f, 1e10f, 0.15f);
  expect_error(load_text("clutter_inf.gltf", huge.text()), "clutter_inf.gltf",
               {"node 0 ('box')", "not finite"});
  ClutterBoxGltf empty;
  empty.clutter = "{}";
  expect_error(load_text("clutter_empty.gltf", empty.text()), "clutter_empty.gltf",
               {"node 0 ('box')", "empty"});
  ClutterBoxGltf both;
  both.clutter = R"({"res":32},"modrt_dynamic":true)";
  expect_error(load_text("clutter_dynamic.gltf", both.text()), "clutter_dynamic.gltf",
               {"node 0 ('box')", "dynamic"});
}

// ---- issue 18: hostile scenes ----

// Synthetic's triangle instanced by `count` nodes (one mesh, many nodes: the glTF way of
// instancing), a row along +X inside the one block.
Synthetic instanced_triangles(int count) {
  Synthetic syn;
  std::string nodes = R"([{"name":"room","extras":{"modrt_block":{"cell":[0,0,0]}}})", scene = "[0";
  for (int i = 0; i < count; ++i) {
    nodes += R"(,{"mesh":0,"translation":[)" + std::to_string(0.5 * double(i) / double(count)) + ",0,0]}";
    scene += "," + std::to_string(i + 1);
  }
  syn.nodes = nodes + "]";
  syn.scene_nodes = scene + "]";
  return syn;
}

TEST(GltfScene, InstancedVertexBufferIsEstimatedAndRefusedBeforeExpanding) {
  // 10^6 nodes sharing a cube (24 M vertices, under the 50 M vertex limit) made a 2.9 GB
  // non-indexed vertex buffer, and llvmpipe crashed on the failed glBufferData. The loader now
  // counts every instance's corners from the accessors first. Here 10 000 instances of a
  // triangle: 30 000 + 768 (the light marker) corners x 80 bytes = 2.46 MB, over a 1 MB limit.
  // (The measured reproduction, 10^6 instances of a cube at the default 1 GiB limit, is in
  // docs/robustness.md.)
  GltfSceneOptions options;
  options.max_vertex_buffer_bytes = 1'000'000;
  const Result<DemoScene> many = load_text("instances.gltf", instanced_triangles(10000).text(), options);
  expect_error(many, "instances.gltf",
               {"10000 drawn node instances of 1 meshes", "30768 triangle corners", "30768 x 80 bytes",
                "limit of 1000000 bytes", "before expanding"});
  EXPECT_EQ(many.status().code(), ErrorCode::resource_limit);
  // Under the limit the same file loads, with a mesh per instance.
  options.max_vertex_buffer_bytes = 3'000'000;
  const Result<DemoScene> fits = load_text("instances_ok.gltf", instanced_triangles(10000).text(), options);
  ASSERT_TRUE(fits.ok()) << fits.status().to_string();
  EXPECT_EQ(check_vertex_buffer_size(fits.value(), 3'000'000).code(), ErrorCode::ok);
  // The renderer's own check (proxy mapping, SceneRenderer) counts the finished scene.
  const Status over = check_vertex_buffer_size(fits.value(), 1'000'000);
  EXPECT_EQ(over.code(), ErrorCode::resource_limit);
  EXPECT_NE(over.message().find("limit of 1000000 bytes"), std::string::npos) << over.message();
}

TEST(GltfScene, ProxyMappingRefusesAnOversizedSceneBeforeExpanding) {
  // 13.5 M corners (one mesh's index list, 54 MB) would map to a 1.08 GB vertex list.
  DemoScene scene = sample();
  Mesh big;
  big.name = "big";
  big.position = {glm::vec3(0.2f), glm::vec3(0.3f), glm::vec3(0.4f)};
  big.normal.assign(3, glm::vec3(0, 1, 0));
  big.indices.assign(13'500'000, 0u);
  scene.meshes.push_back(std::move(big));
  Result<Level> level = precompute::build_level(scene.level, test::small_test_dictionary());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  const Result<std::vector<MappedMesh>> mapped = map_to_proxies(scene, level.value());
  ASSERT_FALSE(mapped.ok());
  EXPECT_EQ(mapped.status().code(), ErrorCode::resource_limit);
  EXPECT_NE(mapped.status().message().find("proxy mapping: "), std::string::npos)
      << mapped.status().message();
  EXPECT_NE(mapped.status().message().find("limit of 1073741824 bytes"), std::string::npos)
      << mapped.status().message();
}

// Synthetic with a point light on a node `lamp_fields` places (and, optionally, the light's own fields).
Synthetic with_lamp(const std::string& lamp_fields, const std::string& light = R"("intensity":10)") {
  Synthetic syn;
  syn.nodes = R"([{"name":"tri","mesh":0},{"name":"room","extras":{"modrt_block":{"cell":[0,0,0]}}},)"
              R"({"name":"lamp",)" +
              lamp_fields + R"("extensions":{"KHR_lights_punctual":{"light":0}}}])";
  syn.scene_nodes = "[0,1,2]";
  syn.top_extra =
      R"(,"extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[)"
      R"({"type":"point","name":"bulb",)" +
      light + "}]}}";
  return syn;
}

TEST(GltfScene, LightsFarOutsideTheLevelOrTooBrightAreRefused) {
  // A lamp at x = 1e19 in a clutter scene aborted Embree in the DRT clutter direct light. The
  // contract (light_position_in_level, light_policy.h): a light lies in the level's bounding box
  // (here the unit cell) grown by its largest extent (1) on every side.
  expect_error(load_text("far_lamp.gltf", with_lamp(R"("translation":[1e19,0.5,0.5],)").text()),
               "far_lamp.gltf",
               {"node 2 ('lamp')", "light 0 ('bulb')", "(1e+19, 0.5, 0.5)", "outside the level's box",
                "grown by its largest extent 1"});
  expect_error(load_text("out_lamp.gltf", with_lamp(R"("translation":[2.1,0.5,0.5],)").text()),
               "out_lamp.gltf", {"(2.1, 0.5, 0.5)", "outside the level's box"});
  // Just inside the bound it loads.
  const Result<DemoScene> near =
      load_text("near_lamp.gltf", with_lamp(R"("translation":[1.9,0.5,0.5],)").text());
  ASSERT_TRUE(near.ok()) << near.status().to_string();
  EXPECT_EQ(near->lights.size(), 1u);
  // A world position that overflows double through the node hierarchy (finite numbers each).
  Synthetic inf = with_lamp(R"("scale":[1e300,1,1],"children":[3],)");
  inf.nodes.pop_back();
  inf.nodes +=
      R"(,{"name":"cap","translation":[1e300,0,0],"extensions":{"KHR_lights_punctual":{"light":0}}}])";
  expect_error(load_text("inf_lamp.gltf", inf.text()), "inf_lamp.gltf", {"node 3 ('cap')", "not finite"});
  // 1e300 cd is finite in double, Inf in float: refused by the intensity bound of every
  // authored light (kMaxLightIntensity, 1e18 W/sr), not turned into an Inf image.
  expect_error(
      load_text("bright_lamp.gltf", with_lamp("", R"("intensity":1e300)").text()), "bright_lamp.gltf",
      {"node 2 ('lamp')", "light 0 ('bulb')", "intensity 1e+300 cd", "more than the limit of 1e+18 W/sr"});
  expect_error(load_text("bright_colour.gltf", with_lamp("", R"("intensity":1,"color":[1e300,1,1])").text()),
               "bright_colour.gltf", {"colour 1e+300", "limit"});
  // 1e20 cd (1.5e17 W/sr) is a legal if blinding light: it loads (the frame then needs float32
  // EXR, image_output.h).
  EXPECT_TRUE(load_text("1e20.gltf", with_lamp("", R"("intensity":1e20)").text()).ok());
}

// The bytes of Synthetic's embedded buffer, and its text with the buffer moved to `uri`.
std::string with_external_buffer(const Synthetic& syn, const std::string& uri, const fs::path& file) {
  std::vector<std::uint8_t> bytes(syn.positions.size() * 4 + syn.indices.size() * 2);
  std::memcpy(bytes.data(), syn.positions.data(), syn.positions.size() * 4);
  std::memcpy(bytes.data() + syn.positions.size() * 4, syn.indices.data(), syn.indices.size() * 2);
  std::ofstream out(file, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  std::string text = syn.text();
  const std::string data = "data:application/octet-stream;base64," + base64(bytes);
  text.replace(text.find(data), data.size(), uri);
  return text;
}

// A .glb holding `json` and no BIN chunk.
std::string glb_of(std::string json) {
  while (json.size() % 4 != 0) json += ' ';
  auto le32 = [](std::uint32_t v) {
    std::string b(4, '\0');
    for (int i = 0; i < 4; ++i) b[std::size_t(i)] = char((v >> (8 * i)) & 0xff);
    return b;
  };
  return "glTF" + le32(2) + le32(std::uint32_t(20 + json.size())) + le32(std::uint32_t(json.size())) +
         "JSON" + json;
}

TEST(GltfScene, RelativeUrisArePercentDecodedOnly) {
  // tinygltf 2.7 decoded '+' as a space: "a_1e+30.bin" -> "File not found : a_1e 30.bin".
  // RFC 3986 decodes %XX only: '+' is itself, %20 a space, %2B a '+'.
  const Synthetic syn;
  for (const auto& [uri, file] : std::vector<std::pair<std::string, std::string>>{
           {"a_1e+30.bin", "a_1e+30.bin"},
           {"my%20buffer.bin", "my buffer.bin"},
           {"b+c%2B%25d.bin", "b+c+%d.bin"},
       }) {
    const std::string text = with_external_buffer(syn, uri, temp_dir() / file);
    const Result<DemoScene> r = load_text("uri_" + file + ".gltf", text);
    ASSERT_TRUE(r.ok()) << uri << ": " << r.status().to_string();
    ASSERT_GE(r->meshes.size(), 1u);
    expect_near(r->meshes[0].position[1], {0.5f, 0.1f, 0.8f}, 0.0f, uri);
    // The same as a .glb (the loader rewrites its JSON chunk).
    const fs::path glb = temp_dir() / ("uri_" + file + ".glb");
    write_text(glb, glb_of(text));
    const Result<DemoScene> b = load_gltf_scene(glb.string());
    ASSERT_TRUE(b.ok()) << uri << " (glb): " << b.status().to_string();
    expect_near(b->meshes[0].position[1], {0.5f, 0.1f, 0.8f}, 0.0f, uri + " (glb)");
  }
  // A '%' that is not an escape is an error naming the field, not a file of garbage bytes.
  const std::string bad = with_external_buffer(syn, "a%zz.bin", temp_dir() / "unused.bin");
  expect_error(load_text("uri_bad.gltf", bad), "uri_bad.gltf",
               {"buffers[0].uri 'a%zz.bin'", "two hex digits", "RFC 3986"});
  const std::string nul = with_external_buffer(syn, "a%00.bin", temp_dir() / "unused.bin");
  expect_error(load_text("uri_nul.gltf", nul), "uri_nul.gltf", {"buffers[0].uri", "NUL"});
  // A missing file still says so, with the decoded name.
  const std::string missing = with_external_buffer(syn, "no+such.bin", temp_dir() / "unused.bin");
  expect_error(load_text("uri_missing.gltf", missing), "uri_missing.gltf", {"no+such.bin"});
}

// ---- glTF as artists export it (Blender 3.4) ----

// Blender writes boolean custom properties as 1 and 0: every extras boolean takes them (only
// exactly 0 and 1), and still refuses anything else naming the field.
TEST(GltfScene, ExtrasBooleansMayBeOneAndZero) {
  // A unit cube mesh, so that "modrt_block": 1 takes the block from the mesh's bounds.
  Synthetic syn;
  syn.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
  syn.indices = {0, 1, 2, 1, 3, 2};
  syn.nodes = R"([{"name":"hall","mesh":0,"extras":{"modrt_block":1}},)"
              R"({"name":"annex","extras":{"modrt_block":{"cell":[1,0,0],"draw":0}}},)"
              R"({"name":"not a block","mesh":0,"scale":[0.1,0.1,0.1],"translation":[0.2,0.2,0.2],)"
              R"("extras":{"modrt_block":0,"modrt_clutter":0}},)"
              R"({"name":"ball","mesh":0,"scale":[0.1,0.1,0.1],"translation":[0.5,0.5,0.5],)"
              R"("extras":{"modrt_dynamic":1}},)"
              R"({"name":"drawn","mesh":0,"translation":[0,0,1],"extras":{"modrt_block":{"draw":1}}}])";
  syn.scene_nodes = R"([0,1,2,3,4],"extras":{"modrt_level":{"proxy_walls":0}})";
  std::vector<std::string> warnings;
  GltfSceneOptions options;
  options.warnings = &warnings;
  const Result<DemoScene> r = load_text("blender_bools.gltf", syn.text(), options);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->level.blocks.size(), 3u);
  EXPECT_EQ(r->level.blocks[0].name, "hall");
  EXPECT_EQ(r->level.blocks[0].cell, glm::ivec3(0, 0, 0));
  EXPECT_EQ(r->level.blocks[1].name, "annex");
  EXPECT_EQ(r->level.blocks[2].name, "drawn");
  // proxy_walls 0: no walls; drawn: the block "drawn" (draw 1), "not a block" and the ball.
  std::vector<std::string> names;
  for (const Mesh& m : r->meshes) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"not a block", "ball", "drawn"}));
  EXPECT_FALSE(r->meshes[0].dynamic);
  EXPECT_EQ(r->meshes[0].clutter, -1);
  EXPECT_TRUE(r->meshes[1].dynamic);
  // The same file with true and false loads the same scene.
  std::string text = syn.text();
  for (const auto& [from, to] :
       std::vector<std::pair<std::string, std::string>>{{R"("modrt_block":1)", R"("modrt_block":true)"},
                                                        {R"("draw":0)", R"("draw":false)"},
                                                        {R"("modrt_block":0)", R"("modrt_block":false)"},
                                                        {R"("modrt_clutter":0)", R"("modrt_clutter":false)"},
                                                        {R"("modrt_dynamic":1)", R"("modrt_dynamic":true)"},
                                                        {R"("draw":1)", R"("draw":true)"},
                                                        {R"("proxy_walls":0)", R"("proxy_walls":false)"}}) {
    ASSERT_NE(text.find(from), std::string::npos) << from;
    text.replace(text.find(from), from.size(), to);
  }
  const Result<DemoScene> b = load_text("json_bools.gltf", text);
  ASSERT_TRUE(b.ok()) << b.status().to_string();
  ASSERT_EQ(b->meshes.size(), r->meshes.size());
  for (std::size_t i = 0; i < b->meshes.size(); ++i) {
    EXPECT_EQ(b->meshes[i].name, r->meshes[i].name);
    EXPECT_EQ(b->meshes[i].position, r->meshes[i].position);
  }
  // modrt_clutter 1 is a clutter object with every field at its default.
  ClutterBoxGltf one;
  one.clutter = "1";
  const Result<DemoScene> c = load_text("clutter_one.gltf", one.text());
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  ASSERT_EQ(c->clutter.size(), 1u);
  EXPECT_EQ(c->clutter[0].mesh->atlas.res, precompute::kClutterMeshDefaultRes);
  // Only exactly 0 and 1: 2, -1, 0.5 and strings are no booleans; each error names the node and field.
  for (const auto& [from, to, words] :
       std::vector<std::tuple<std::string, std::string, std::vector<const char*>>>{
           {R"("modrt_dynamic":1)",
            R"("modrt_dynamic":2)",
            {"'ball'", "modrt_dynamic must be true or false (or 1 or 0)"}},
           {R"("modrt_dynamic":1)", R"("modrt_dynamic":"1")", {"'ball'", "modrt_dynamic"}},
           {R"("draw":0)",
            R"("draw":0.5)",
            {"'annex'", "modrt_block.draw must be true or false (or 1 or 0)"}},
           {R"("draw":0)", R"("draw":-1)", {"'annex'", "modrt_block.draw"}},
           {R"("modrt_block":1)",
            R"("modrt_block":2)",
            {"'hall'", "modrt_block must be an object (or true or 1)"}},
           {R"("proxy_walls":0)", R"("proxy_walls":3)", {"proxy_walls must be true or false (or 1 or 0)"}}}) {
    std::string bad = syn.text();
    bad.replace(bad.find(from), from.size(), to);
    const Result<DemoScene> e = load_text("bad_bool.gltf", bad);
    ASSERT_FALSE(e.ok()) << to;
    EXPECT_EQ(e.status().code(), ErrorCode::format_error) << to;
    EXPECT_NE(e.status().message().find("bad_bool.gltf"), std::string::npos) << e.status().message();
    for (const char* w : words)
      EXPECT_NE(e.status().message().find(w), std::string::npos) << w << " not in: " << e.status().message();
  }
  ClutterBoxGltf two;
  two.clutter = "2";
  expect_error(load_text("clutter_two.gltf", two.text()), "clutter_two.gltf",
               {"node 0 ('box')", "modrt_clutter must be an object (or true or 1)"});
}

TEST(GltfScene, DoubleSidedMaterialsAreMarked) {
  Synthetic syn;
  syn.primitive_extra = R"(,"material":1)";
  syn.top_extra = R"(,"materials":[{"name":"one side"},{"name":"leaf","doubleSided":true}])";
  const Result<DemoScene> r = load_text("double_sided.gltf", syn.text());
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_GE(r->materials.size(), 2u);
  EXPECT_FALSE(r->materials[0].double_sided);
  EXPECT_TRUE(r->materials[1].double_sided);
  EXPECT_EQ(r->meshes[0].material, 1);
  // The walls and primitives without a material stay single-sided.
  for (const Mesh& m : r->meshes)
    if (m.name != "tri") {
      EXPECT_FALSE(r->materials[std::size_t(m.material)].double_sided) << m.name;
    }
  // Its back side is drawn too: the vertex buffer estimate counts a double-sided primitive twice.
  GltfSceneOptions tight;
  tight.proxy_walls = false;
  tight.max_vertex_buffer_bytes = (kLightMarkerCorners + 3) * sizeof(MappedVertex);
  Synthetic single = syn;
  single.top_extra = R"(,"materials":[{"name":"one side"},{"name":"leaf"}])";
  EXPECT_TRUE(load_text("one_sided_tight.gltf", single.text(), tight).ok());
  expect_error(load_text("double_sided_tight.gltf", syn.text(), tight), "double_sided_tight.gltf",
               {"vertex buffer"});
}

// Every light, point, spot or directional, is kept up to kMaxDemoLights in node order; the
// others are named in one warning.
TEST(GltfScene, LightsUpToTheLimitAndOneWarningForTheDropped) {
  Synthetic syn;
  std::string nodes = R"([{"name":"tri","mesh":0},{"name":"room","extras":{"modrt_block":{"cell":[0,0,0]}}})";
  std::string lights;
  std::string scene_nodes = "[0,1";
  for (int i = 0; i < 8; ++i) {
    const bool directional = i == 2 || i == 5;
    nodes += R"(,{"name":"n)" + std::to_string(i) + R"(","translation":[0.)" + std::to_string(i + 1) +
             R"(,0.5,0.5],"extensions":{"KHR_lights_punctual":{"light":)" + std::to_string(i) + "}}}";
    lights += std::string(i ? "," : "") + R"({"type":")" + (directional ? "directional" : "point") +
              R"(","name":"l)" + std::to_string(i) + R"(","intensity":)" + std::to_string(10 + i) + "}";
    scene_nodes += "," + std::to_string(i + 2);
  }
  syn.nodes = nodes + "]";
  syn.scene_nodes = scene_nodes + "]";
  syn.top_extra =
      R"(,"extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[)" +
      lights + "]}}";
  std::vector<std::string> warnings;
  GltfSceneOptions options;
  options.warnings = &warnings;
  options.light_intensity_scale = 1.0f;
  const Result<DemoScene> r = load_text("many_lights.gltf", syn.text(), options);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->lights.size(), kMaxDemoLights);
  const float kept[4] = {10, 11, 12, 13};  // lights 0 to 3 in node order, light 2 directional
  for (std::size_t i = 0; i < kMaxDemoLights; ++i) {
    EXPECT_EQ(r->lights[i].intensity, kept[i]);
    EXPECT_EQ(r->lights[i].directional, i == 2);
  }
  int dropped = 0;
  for (const std::string& w : warnings) {
    if (w.find("dropped") != std::string::npos) {
      ++dropped;
      EXPECT_NE(w.find("8 lights"), std::string::npos) << w;
      EXPECT_NE(w.find("first 4"), std::string::npos) << w;
      for (const char* l : {"light 4 ('l4')", "light 5 ('l5')", "light 6 ('l6')", "light 7 ('l7')"})
        EXPECT_NE(w.find(l), std::string::npos) << w;
      EXPECT_EQ(w.find("light 3 ('l3')"), std::string::npos) << w;
    }
    EXPECT_EQ(w.find("renders the first one"), std::string::npos) << w;
  }
  EXPECT_EQ(dropped, 1);
}

// A small embedded buffer of float accessors for hand-written glTF files.
struct GltfBuffer {
  std::vector<std::uint8_t> bytes;
  std::string views, accessors;
  int count = 0;
  int add(const std::vector<float>& values, const char* type, int components) {
    const std::size_t offset = bytes.size();
    bytes.resize(offset + 4 * values.size());
    std::memcpy(bytes.data() + offset, values.data(), 4 * values.size());
    views += std::string(count ? "," : "") + R"({"buffer":0,"byteOffset":)" + std::to_string(offset) +
             R"(,"byteLength":)" + std::to_string(4 * values.size()) + "}";
    accessors += std::string(count ? "," : "") + R"({"bufferView":)" + std::to_string(count) +
                 R"(,"componentType":5126,"count":)" +
                 std::to_string(values.size() / std::size_t(components)) + R"(,"type":")" + type + R"("})";
    return count++;
  }
  std::string json() const {
    return R"("buffers":[{"byteLength":)" + std::to_string(bytes.size()) +
           R"(,"uri":"data:application/octet-stream;base64,)" + base64(bytes) + R"("}],"bufferViews":[)" +
           views + R"(],"accessors":[)" + accessors + "]";
  }
};

// Two blocks; a point light 'lamp' under a translated parent 'rig' with a LINEAR translation, a
// dynamic 'ball' with a STEP translation and a rotation, a spot 'torch' with a CUBICSPLINE
// translation, a static 'crate' with a translation, a point light 'lamp2' with a scale.
std::string animated_gltf(const std::string& extra_channel = "",
                          const std::string& torch_interpolation = "CUBICSPLINE") {
  GltfBuffer b;
  const int tri = b.add({0.2f, 0.1f, 0.2f, 0.5f, 0.1f, 0.8f, 0.8f, 0.1f, 0.2f}, "VEC3", 3);
  const int times_a = b.add({0.0f, 1.0f, 2.0f}, "SCALAR", 1);
  const int keys_a = b.add({0.3f, 0.5f, 0.5f, 0.6f, 0.5f, 0.5f, 0.6f, 0.7f, 0.5f}, "VEC3", 3);
  const int times_b = b.add({0.5f, 1.0f}, "SCALAR", 1);
  const int keys_b = b.add({0.2f, 0.3f, 0.2f, 0.7f, 0.3f, 0.7f}, "VEC3", 3);
  const int times_r = b.add({0.0f, 1.5f}, "SCALAR", 1);
  const int rot_r = b.add({0, 0, 0, 1, 0, 0.70710678f, 0, 0.70710678f}, "VEC4", 4);
  const int times_c = b.add({0.0f, 2.0f}, "SCALAR", 1);
  const int keys_c =
      b.add({0, 0, 0, 0.5f, 0.8f, 0.2f, 0.3f, 0, 0, 0, 0, 0.3f, 0.5f, 0.8f, 0.8f, 0, 0, 0}, "VEC3", 3);
  const auto sampler = [](int input, int output, const std::string& interpolation) {
    return R"({"input":)" + std::to_string(input) + R"(,"output":)" + std::to_string(output) +
           R"(,"interpolation":")" + interpolation + R"("})";
  };
  const auto channel = [](int sampler_index, int node, const char* path) {
    return R"({"sampler":)" + std::to_string(sampler_index) + R"(,"target":{"node":)" + std::to_string(node) +
           R"(,"path":")" + path + R"("}})";
  };
  return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2,4,5,6,7,8]}],"nodes":[)"
         R"({"name":"tri","mesh":0},{"name":"room","extras":{"modrt_block":{"cell":[0,0,0],"missing":["+X"]}}},)"
         R"({"name":"rig","translation":[0.1,0.2,0],"children":[3]},)"
         R"({"name":"lamp","translation":[0.3,0.5,0.5],"extensions":{"KHR_lights_punctual":{"light":0}}},)"
         R"({"name":"ball","mesh":0,"translation":[0.5,0.3,0.5],"extras":{"modrt_dynamic":1}},)"
         R"({"name":"torch","translation":[0.5,0.8,0.2],"extensions":{"KHR_lights_punctual":{"light":1}}},)"
         R"({"name":"crate","mesh":0},)"
         R"({"name":"lamp2","translation":[1.5,0.5,0.5],"extensions":{"KHR_lights_punctual":{"light":0}}},)"
         R"({"name":"annex","extras":{"modrt_block":{"cell":[1,0,0],"missing":["-X"]}}}],)"
         R"("meshes":[{"primitives":[{"attributes":{"POSITION":)" +
         std::to_string(tri) + R"(}}]}],"animations":[)" + R"({"name":"LampAction","samplers":[)" +
         sampler(times_a, keys_a, "LINEAR") + R"(],"channels":[)" + channel(0, 3, "translation") +
         extra_channel + "]}," + R"({"name":"BallAction","samplers":[)" + sampler(times_b, keys_b, "STEP") +
         "," + sampler(times_r, rot_r, "LINEAR") + R"(],"channels":[)" + channel(0, 4, "translation") + "," +
         channel(1, 4, "rotation") + "]}," + R"({"name":"TorchAction","samplers":[)" +
         sampler(times_c, keys_c, torch_interpolation) + "," + sampler(times_a, keys_a, "LINEAR") +
         R"(],"channels":[)" + channel(0, 5, "translation") + "," + channel(1, 6, "translation") + "," +
         channel(1, 7, "scale") + "]}]," +
         R"("extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[)"
         R"({"type":"point","name":"bulb","intensity":10},)"
         R"({"type":"spot","name":"beam","intensity":10,"spot":{"outerConeAngle":0.6}}]}},)" +
         b.json() + "}";
}

void expect_track_point(const KeyTrack& track, double frame, const glm::vec3& expected,
                        const std::string& what) {
  expect_near(track_point(track, frame), expected, 1e-5f, what + " at frame " + std::to_string(frame));
}

// The translations of light nodes and of the first dynamic node become KeyTracks (world space,
// times in frames at animation_fps, looping over their animation's duration) that the demo
// samples per frame (track_point, light_position); every other channel is named in one warning.
TEST(GltfScene, LightAndDynamicTranslationAnimationsArePlayed) {
  std::vector<std::string> warnings;
  GltfSceneOptions options;
  options.warnings = &warnings;
  const Result<DemoScene> r = load_text("animated.gltf", animated_gltf(), options);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_EQ(r->lights.size(), 3u);  // lamp, torch, lamp2 (depth-first node order)
  // The lamp: LINEAR, keys carried by its parent 'rig' (+0.1, +0.2, 0), times 0, 1, 2 s at 24 fps.
  const KeyTrack& lamp = r->lights[0].track;
  EXPECT_EQ(lamp.interpolation, KeyTrack::Interpolation::linear);
  EXPECT_EQ(lamp.times, (std::vector<float>{0.0f, 24.0f, 48.0f}));
  EXPECT_FLOAT_EQ(lamp.period, 48.0f);
  ASSERT_EQ(lamp.values.size(), 3u);
  expect_near(lamp.values[0], {0.4f, 0.7f, 0.5f}, 1e-6f, "lamp key 0");
  expect_near(lamp.values[2], {0.7f, 0.9f, 0.5f}, 1e-6f, "lamp key 2");
  expect_near(r->lights[0].path.at(0), {0.4f, 0.7f, 0.5f}, 1e-6f, "lamp at rest");
  expect_track_point(lamp, 12.0, {0.55f, 0.7f, 0.5f}, "lamp");
  expect_track_point(lamp, 36.0, {0.7f, 0.8f, 0.5f}, "lamp");
  expect_track_point(lamp, 48.0 + 12.0, {0.55f, 0.7f, 0.5f}, "lamp (looped)");
  expect_near(light_position(r->lights[0], 12), {0.55f, 0.7f, 0.5f}, 1e-5f, "light_position");
  // The ball: STEP at 0.5 and 1 s; its animation lasts 1.5 s (the rotation sampler's last key).
  const KeyTrack& ball = r->dynamic_track;
  EXPECT_EQ(ball.interpolation, KeyTrack::Interpolation::step);
  EXPECT_FLOAT_EQ(ball.period, 36.0f);
  expect_track_point(ball, 5.0, {0.2f, 0.3f, 0.2f}, "ball before its first key");
  expect_track_point(ball, 18.0, {0.2f, 0.3f, 0.2f}, "ball");
  expect_track_point(ball, 23.9, {0.2f, 0.3f, 0.2f}, "ball");
  expect_track_point(ball, 30.0, {0.7f, 0.3f, 0.7f}, "ball after its last key");
  expect_track_point(ball, 36.0 + 18.0, {0.2f, 0.3f, 0.2f}, "ball (looped)");
  expect_near(dynamic_offset(r.value(), 30), {0.7f, 0.3f, 0.7f}, 1e-6f, "dynamic_offset");
  // The dynamic mesh is stored relative to its node's rest position (0.5, 0.3, 0.5), the key of
  // dynamic_path, so that the track's offsets place it: its vertices are the local ones.
  const Mesh& ball_mesh = r->meshes[1];
  ASSERT_TRUE(ball_mesh.dynamic);
  expect_near(ball_mesh.position[0], {0.2f, 0.1f, 0.2f}, 1e-6f, "ball mesh, relative");
  ASSERT_EQ(r->dynamic_path.size(), 1u);
  expect_near(r->dynamic_path[0], {0.5f, 0.3f, 0.5f}, 1e-6f, "ball at rest");
  // The torch: CUBICSPLINE (in-tangent, value, out-tangent per key; tangents per frame), glTF's
  // Hermite spline: at s = 0.5 of a 2 s key interval with out-tangent (0.3, 0, 0) per second
  // at the first key and in-tangent (0, 0, 0.3) at the second:
  // x = 0.5 + 2 x 0.125 x 0.3, z = 0.5 (0.2 + 0.8) - 2 x 0.125 x 0.3.
  const KeyTrack& torch = r->lights[1].track;
  EXPECT_EQ(torch.interpolation, KeyTrack::Interpolation::cubic);
  ASSERT_EQ(torch.values.size(), 6u);
  expect_track_point(torch, 24.0, {0.575f, 0.8f, 0.425f}, "torch");
  expect_track_point(torch, 0.0, {0.5f, 0.8f, 0.2f}, "torch");
  // lamp2's scale moves nothing; the crate's translation and the ball's rotation are ignored, in
  // exactly one warning that names them and nothing else.
  EXPECT_TRUE(r->lights[2].track.times.empty());
  int animation_warnings = 0;
  for (const std::string& w : warnings) {
    if (w.find("animation") == std::string::npos) continue;
    ++animation_warnings;
    EXPECT_NE(w.find("animation 1 ('BallAction') channel 1 (node 4 ('ball') rotation)"), std::string::npos)
        << w;
    EXPECT_NE(w.find("animation 2 ('TorchAction') channel 1 (node 6 ('crate') translation)"),
              std::string::npos)
        << w;
    EXPECT_EQ(w.find("lamp2"), std::string::npos) << w;
    EXPECT_EQ(w.find("'lamp'"), std::string::npos) << w;
    EXPECT_EQ(w.find("'torch'"), std::string::npos) << w;
  }
  EXPECT_EQ(animation_warnings, 1);

  // An animated parent: the lamp's own channel is not played (the demo would move it without its
  // parent's motion), and the warning says why.
  warnings.clear();
  const Result<DemoScene> p =
      load_text("animated_parent.gltf",
                animated_gltf(R"(,{"sampler":0,"target":{"node":2,"path":"translation"}})"), options);
  ASSERT_TRUE(p.ok()) << p.status().to_string();
  EXPECT_TRUE(p->lights[0].track.times.empty());
  std::erase_if(warnings, [](const std::string& w) { return w.find("animation") == std::string::npos; });
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("node 3 ('lamp') translation: a parent node is animated too"), std::string::npos)
      << warnings[0];
  EXPECT_NE(warnings[0].find("node 2 ('rig') translation"), std::string::npos) << warnings[0];

  // Another frame rate; a malformed sampler is an error naming the animation and channel.
  GltfSceneOptions fps30;
  fps30.animation_fps = 30.0f;
  const Result<DemoScene> f = load_text("animated_30.gltf", animated_gltf(), fps30);
  ASSERT_TRUE(f.ok()) << f.status().to_string();
  EXPECT_EQ(f->lights[0].track.times, (std::vector<float>{0.0f, 30.0f, 60.0f}));
  expect_error(load_text("animated_bezier.gltf", animated_gltf("", "BEZIER")), "animated_bezier.gltf",
               {"animation 2 ('TorchAction') channel 0", "unknown interpolation 'BEZIER'"});
  expect_error(load_text("animated_count.gltf", animated_gltf("", "LINEAR")), "animated_count.gltf",
               {"animation 2 ('TorchAction') channel 0", "6 values for 2 key times"});
}

// An animated light is checked against the level's bounds at every key, as at rest.
TEST(GltfScene, AnimatedLightKeysOutsideTheLevelAreRefused) {
  // The rig moves 4 along +X and the lamp's rest translation back, so that the lamp rests at
  // (0, 0.7, 0.5) while its keys (in the buffer, carried by the rig) lie at x = 4.3 to 4.6, past
  // the two-block level's box grown by its extent 2 (x <= 4).
  std::string text = animated_gltf();
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {R"("translation":[0.1,0.2,0])", R"("translation":[4.0,0.2,0])"},
           {R"("translation":[0.3,0.5,0.5])", R"("translation":[-4.0,0.5,0.5])"}})
    text.replace(text.find(from), from.size(), to);
  expect_error(
      load_text("animated_far.gltf", text), "animated_far.gltf",
      {"node 3 ('lamp'): light 0 ('bulb'): animation key 0", "(4.3, 0.7, 0.5)", "outside the level's box"});
  // At rest inside, with keys inside: it loads.
  EXPECT_TRUE(load_text("animated_near.gltf", animated_gltf()).ok());
}

// The sample scenes number their attribute sets from 0 (clutter_room.gltf had TEXCOORD_1
// without TEXCOORD_0, which the Khronos validator refuses); the loader warns about a gap.
TEST(GltfScene, AttributeSetsWithoutGapsInTheSamples) {
  for (const char* name : {"two_rooms.gltf", "clutter_room.gltf", "host_room.gltf"}) {
    tinygltf::TinyGLTF gltf;
    tinygltf::Model model;
    std::string err, warn;
    ASSERT_TRUE(gltf.LoadASCIIFromFile(&model, &err, &warn, std::string(MODRT_SCENES_DIR) + "/" + name))
        << name << ": " << err;
    for (const tinygltf::Mesh& mesh : model.meshes)
      for (const tinygltf::Primitive& prim : mesh.primitives)
        for (const auto& [attribute, accessor] : prim.attributes) {
          const std::size_t underscore = attribute.rfind('_');
          if (underscore == std::string::npos || attribute.rfind("TEXCOORD", 0) != 0) continue;
          const int set = std::stoi(attribute.substr(underscore + 1));
          if (set > 0) {
            EXPECT_TRUE(prim.attributes.count("TEXCOORD_" + std::to_string(set - 1)))
                << name << ": mesh '" << mesh.name << "' has " << attribute << " without the set before it";
          }
        }
    std::vector<std::string> warnings;
    GltfSceneOptions options;
    options.warnings = &warnings;
    ASSERT_TRUE(load_gltf_scene(std::string(MODRT_SCENES_DIR) + "/" + name, options).ok()) << name;
    for (const std::string& w : warnings) EXPECT_EQ(w.find("without TEXCOORD_0"), std::string::npos) << w;
  }
  std::vector<std::string> warnings;
  GltfSceneOptions options;
  options.warnings = &warnings;
  ClutterBoxGltf gap;  // TEXCOORD_1 alone
  ASSERT_TRUE(load_text("texcoord_gap.gltf", gap.text(), options).ok());
  int gaps = 0;
  for (const std::string& w : warnings) gaps += w.find("TEXCOORD_1 without TEXCOORD_0") != std::string::npos;
  EXPECT_EQ(gaps, 1);
}

}  // namespace
}  // namespace modrt::demo
