// SPDX-License-Identifier: MIT
#include "default_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>

#include <glm/geometric.hpp>

#include "clutter_shapes.h"
#include "modrt/cube.h"
#include "modrt/precompute/maze.h"

namespace modrt::demo {
namespace {

constexpr float kPi = 3.14159265358979f;

int add_material(DemoScene& scene, const std::string& name, glm::vec3 color, int normal_texture = -1) {
  Material m;
  m.name = name;
  m.base_color = color;
  m.normal_texture = normal_texture;
  scene.materials.push_back(m);
  return int(scene.materials.size()) - 1;
}

// A quad p0, p0 + du, p0 + du + dv, p0 + dv facing cross(du, dv); uv spans [0, tu] x [0, tv].
void add_quad(Mesh& m, glm::vec3 p0, glm::vec3 du, glm::vec3 dv, float tu = 1.0f, float tv = 1.0f) {
  const glm::vec3 n = glm::normalize(glm::cross(du, dv));
  const glm::vec4 tangent(glm::normalize(du), 1.0f);
  const std::uint32_t base = std::uint32_t(m.position.size());
  const glm::vec3 p[4] = {p0, p0 + du, p0 + du + dv, p0 + dv};
  const glm::vec2 uv[4] = {{0, 0}, {tu, 0}, {tu, tv}, {0, tv}};
  for (int i = 0; i < 4; ++i) {
    m.position.push_back(p[i]);
    m.normal.push_back(n);
    m.tangent.push_back(tangent);
    m.uv.push_back(uv[i]);
  }
  for (std::uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
}

// Axis-aligned box [lo, hi], outward faces.
void add_box(Mesh& m, glm::vec3 lo, glm::vec3 hi) {
  const glm::vec3 d = hi - lo;
  add_quad(m, {lo.x, lo.y, hi.z}, {d.x, 0, 0}, {0, d.y, 0});   // +Z
  add_quad(m, {hi.x, lo.y, lo.z}, {-d.x, 0, 0}, {0, d.y, 0});  // -Z
  add_quad(m, {hi.x, lo.y, hi.z}, {0, 0, -d.z}, {0, d.y, 0});  // +X
  add_quad(m, {lo.x, lo.y, lo.z}, {0, 0, d.z}, {0, d.y, 0});   // -X
  add_quad(m, {lo.x, hi.y, hi.z}, {d.x, 0, 0}, {0, 0, -d.z});  // +Y
  add_quad(m, {lo.x, lo.y, lo.z}, {d.x, 0, 0}, {0, 0, d.z});   // -Y
}

void add_sphere(Mesh& m, float radius, int rings, int segments) {
  const std::uint32_t base = std::uint32_t(m.position.size());
  for (int r = 0; r <= rings; ++r) {
    const float th = kPi * float(r) / float(rings);
    for (int s = 0; s <= segments; ++s) {
      const float ph = 2.0f * kPi * float(s) / float(segments);
      const glm::vec3 n(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
      m.position.push_back(radius * n);
      m.normal.push_back(n);
      m.uv.push_back({float(s) / float(segments), float(r) / float(rings)});
    }
  }
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const std::uint32_t a = base + std::uint32_t(r * (segments + 1) + s),
                          b = a + std::uint32_t(segments + 1);
      for (std::uint32_t i : {a, a + 1, b, b, a + 1, b + 1}) m.indices.push_back(i);
    }
}

// Tangent-space normal map (glTF: RGB = (n + 1) / 2, +Y up) from a height field h(x, y) in
// [0, 1] over the unit square, `size` texels square, wrapping.
template <class Height>
Image normal_map(const std::string& name, int size, float strength, Height height) {
  Image img;
  img.name = name;
  img.width = img.height = size;
  img.rgba.resize(4 * std::size_t(size) * std::size_t(size));
  auto h = [&](int x, int y) {
    return height((float((x + size) % size) + 0.5f) / float(size),
                  (float((y + size) % size) + 0.5f) / float(size));
  };
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      // Rows run top to bottom while v runs up: the v gradient flips sign.
      const float dx = (h(x + 1, y) - h(x - 1, y)) * strength, dy = -(h(x, y + 1) - h(x, y - 1)) * strength;
      const glm::vec3 n = glm::normalize(glm::vec3(-dx, -dy, 1.0f));
      std::uint8_t* p = img.rgba.data() + 4 * (std::size_t(y) * std::size_t(size) + std::size_t(x));
      for (int c = 0; c < 3; ++c) p[c] = std::uint8_t(std::lround((n[c] * 0.5f + 0.5f) * 255.0f));
      p[3] = 255;
    }
  return img;
}

// Running-bond bricks, 4 rows x 2 bricks per unit, mortar grooves 0.06 wide.
float brick_height(float u, float v) {
  const float rows = 4.0f, row = std::floor(v * rows);
  const float x = u * 2.0f + (int(row) % 2 ? 0.5f : 0.0f);
  const float fu = x - std::floor(x), fv = v * rows - row;
  const float edge = std::min({fu, 1.0f - fu, fv * 0.5f, (1.0f - fv) * 0.5f});
  return std::clamp(edge / 0.03f, 0.0f, 1.0f);
}

// Square floor tiles, 3 per unit, with bevelled edges.
float tile_height(float u, float v) {
  const float fu = u * 3.0f - std::floor(u * 3.0f), fv = v * 3.0f - std::floor(v * 3.0f);
  const float edge = std::min({fu, 1.0f - fu, fv, 1.0f - fv});
  return std::clamp(edge / 0.05f, 0.0f, 1.0f);
}

// Canonical coordinates of a world point in a mildly warped block (a few fixed-point steps
// of the trilinear map's inverse; the default scene's warp is 8 % of a cell at most).
glm::dvec3 world_to_canonical_guess(const std::array<glm::dvec3, 8>& corners, const glm::vec3& world) {
  const glm::dvec3 lo = corners[0], size = corners[7] - corners[0];
  glm::dvec3 q = (glm::dvec3(world) - lo) / size;
  for (int i = 0; i < 20; ++i) q += (glm::dvec3(world) - trilinear(corners, q)) / size;
  return q;
}

double polygon_area2(const std::vector<glm::dvec2>& p) {
  double a = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    a += p[i].x * p[(i + 1) % p.size()].y - p[(i + 1) % p.size()].x * p[i].y;
  return a;
}

}  // namespace

void add_wall_meshes(DemoScene& scene, int subdivisions) {
  std::map<std::tuple<float, float, float>, int> material_of;
  std::map<int, Mesh> meshes;  // by material
  const int k = std::max(1, subdivisions);
  for (std::size_t bi = 0; bi < scene.level.blocks.size(); ++bi) {
    const BlockDescription& b = scene.level.blocks[bi];
    const std::array<glm::dvec3, 8> corners = block_corners(scene.level, b);
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(b.faces, f)) continue;
      const glm::vec3 color(b.albedo[std::size_t(f)]);
      auto key = std::make_tuple(color.r, color.g, color.b);
      auto it = material_of.find(key);
      if (it == material_of.end())
        it =
            material_of.emplace(key, add_material(scene, "wall " + std::to_string(material_of.size()), color))
                .first;
      Mesh& m = meshes[it->second];
      m.material = it->second;
      auto at = [&](double u, double v) { return glm::vec3(trilinear(corners, face_point(f, u, v))); };
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
          const double u0 = double(i) / k, v0 = double(j) / k, u1 = double(i + 1) / k, v1 = double(j + 1) / k;
          const glm::vec3 p[4] = {at(u0, v0), at(u1, v0), at(u1, v1), at(u0, v1)};
          const glm::vec3 n = glm::normalize(glm::cross(p[2] - p[0], p[3] - p[1]));
          const std::uint32_t base = std::uint32_t(m.position.size());
          const glm::vec2 uv[4] = {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}};
          for (int q = 0; q < 4; ++q) {
            m.position.push_back(p[q]);
            m.normal.push_back(n);
            m.tangent.push_back(glm::vec4(glm::normalize(p[1] - p[0]), 1.0f));
            m.uv.push_back(uv[q]);
          }
          for (std::uint32_t q : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + q);
        }
    }
  }
  for (auto& [material, mesh] : meshes) {
    mesh.name = scene.materials[std::size_t(material)].name;
    scene.meshes.push_back(std::move(mesh));
  }
}

Result<DemoScene> default_scene() {
  precompute::MazeSettings settings;
  settings.blocks = 11;
  settings.seed = 7;  // the maze11 preset's layout
  settings.warp = 0.08;
  Result<LevelDescription> level = precompute::generate_maze(settings);
  if (!level.ok()) return level.status();
  DemoScene scene;
  scene.name = "default (11-block warped maze)";
  scene.level = std::move(level).value();
  scene.level.name = "modrt-demo default";
  scene.level.lights.clear();
  // Darker neutral walls than the generator's (0.7 / 0.6 floor): the coloured walls' bleeding
  // then stands out against them, and a few bounces do not wash the maze out.
  for (BlockDescription& b : scene.level.blocks)
    for (glm::dvec3& a : b.albedo)
      if (a.x == a.y && a.y == a.z) a = glm::dvec3(a.x * 0.6);

  // Block 0 gets a brick wall and a tiled floor, normal-mapped.
  scene.images.push_back(normal_map("bricks", 256, 6.0f, brick_height));
  scene.images.push_back(normal_map("tiles", 256, 4.0f, tile_height));
  add_wall_meshes(scene, 4);
  const BlockDescription& b0 = scene.level.blocks[0];
  const std::array<glm::dvec3, 8> c0 = block_corners(scene.level, b0);
  int open_face = -1, brick_face = -1;
  for (int f : {kFaceNegZ, kFacePosZ, kFaceNegX, kFacePosX})
    if (!face_present(b0.faces, f) && open_face < 0) open_face = f;
  // Bricks on a side wall the camera sees: perpendicular to the view through the opening.
  const bool view_along_z = open_face == kFaceNegZ || open_face == kFacePosZ;
  for (int f : view_along_z ? std::array{kFaceNegX, kFacePosX} : std::array{kFaceNegZ, kFacePosZ})
    if (face_present(b0.faces, f) && brick_face < 0) brick_face = f;
  if (open_face < 0 || brick_face < 0)
    return Status::error(ErrorCode::internal_error, "default scene: block 0 has no opening or no side wall");
  const int bricks = add_material(scene, "brick wall", glm::vec3(b0.albedo[std::size_t(brick_face)]), 0);
  const int tiles = add_material(scene, "tiled floor", glm::vec3(b0.albedo[kFaceNegY]), 1);
  // Those two faces as their own normal-mapped meshes, just in front of the plain walls
  // (a millimetre inside, so the depth test picks them).
  for (auto [face_index, material] : {std::pair{brick_face, bricks}, std::pair{int(kFaceNegY), tiles}}) {
    const int face = face_index;  // a structured binding cannot be captured (C++20, clang)
    Mesh m;
    m.name = scene.materials[std::size_t(material)].name;
    m.material = material;
    const FaceFrame& fr = face_frame(face);
    const glm::vec3 inset(fr.normal * 1e-3);
    const int k = 8;
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < k; ++i) {
        auto at = [&](double u, double v) {
          return glm::vec3(trilinear(c0, face_point(face, u, v))) + inset;
        };
        const double u0 = double(i) / k, v0 = double(j) / k, u1 = double(i + 1) / k, v1 = double(j + 1) / k;
        const glm::vec3 p00 = at(u0, v0), p10 = at(u1, v0), p11 = at(u1, v1), p01 = at(u0, v1);
        const glm::vec3 n = glm::normalize(glm::cross(p10 - p00, p01 - p00));
        const std::uint32_t base = std::uint32_t(m.position.size());
        const glm::vec3 p[4] = {p00, p10, p11, p01};
        const glm::vec2 uv[4] = {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}};
        for (int q = 0; q < 4; ++q) {
          m.position.push_back(p[q]);
          m.normal.push_back(n);
          m.tangent.push_back(glm::vec4(glm::normalize(p10 - p00), 1.0f));
          m.uv.push_back(uv[q]);
        }
        for (std::uint32_t q : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + q);
      }
    scene.meshes.push_back(std::move(m));
  }

  // Detail geometry, deterministic per block: a pillar in each corner where two walls meet,
  // a crate or two on the floor, a ceiling beam, a bench along one wall.
  const int wood = add_material(scene, "wood", {0.55f, 0.36f, 0.2f});
  const int stone = add_material(scene, "stone", {0.62f, 0.6f, 0.56f});
  const int crate_paint = add_material(scene, "painted crate", {0.75f, 0.62f, 0.15f});
  Mesh pillars, beams, crates, benches;
  pillars.name = "pillars", pillars.material = stone;
  beams.name = "beams", beams.material = wood;
  crates.name = "crates", crates.material = crate_paint;
  benches.name = "benches", benches.material = wood;
  for (std::size_t bi = 0; bi < scene.level.blocks.size(); ++bi) {
    const BlockDescription& b = scene.level.blocks[bi];
    const glm::vec3 o(glm::dvec3(b.cell) * scene.level.cell_size);
    const float w = 0.09f;
    for (int cx = 0; cx < 2; ++cx)
      for (int cz = 0; cz < 2; ++cz) {
        const int fx = cx ? kFacePosX : kFaceNegX, fz = cz ? kFacePosZ : kFaceNegZ;
        if (!face_present(b.faces, fx) || !face_present(b.faces, fz)) continue;
        const glm::vec3 lo =
            o + glm::vec3(cx ? 1.0f - w - 0.06f : 0.06f, 0.0f, cz ? 1.0f - w - 0.06f : 0.06f);
        add_box(pillars, lo, lo + glm::vec3(w, 0.94f, w));
      }
    if (bi % 2 == 0) add_box(beams, o + glm::vec3(0.08f, 0.9f, 0.45f), o + glm::vec3(0.92f, 0.96f, 0.55f));
    if (bi % 3 == 1 || bi == 0) {
      const float s = 0.18f + 0.04f * float(bi % 2);
      const glm::vec3 lo = o + glm::vec3(0.6f, 0.002f, 0.22f);
      add_box(crates, lo, lo + glm::vec3(s));
      if (bi % 2 == 1)
        add_box(crates, lo + glm::vec3(0.03f, s, 0.02f), lo + glm::vec3(0.03f, s, 0.02f) + glm::vec3(0.12f));
    }
    if (bi % 4 == 2) {
      for (int f : {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ}) {
        if (!face_present(b.faces, f)) continue;
        const bool along_z = f == kFaceNegX || f == kFacePosX;
        const float near = (f == kFacePosX || f == kFacePosZ) ? 0.8f : 0.08f;
        const glm::vec3 lo = along_z ? o + glm::vec3(near, 0.18f, 0.25f) : o + glm::vec3(0.25f, 0.18f, near);
        const glm::vec3 size = along_z ? glm::vec3(0.12f, 0.04f, 0.5f) : glm::vec3(0.5f, 0.04f, 0.12f);
        add_box(benches, lo, lo + size);
        break;
      }
    }
  }
  for (Mesh* m : {&pillars, &beams, &crates, &benches})
    if (!m->indices.empty()) scene.meshes.push_back(std::move(*m));

  // The camera stands at the back of block 0 looking out through its opening; the light
  // moves from block 0 into the block beyond and back.
  const glm::vec3 centre(trilinear(c0, glm::dvec3(0.5)));
  glm::vec3 out(face_frame(open_face).normal * -1.0);  // outward through the opening
  out.y = 0.0f;
  out = glm::normalize(out);
  scene.camera.position =
      centre - 0.38f * out + glm::vec3(0.0f, 0.05f, 0.0f) + 0.12f * glm::cross(out, glm::vec3(0, 1, 0));
  scene.camera.target = centre + 1.2f * out + glm::vec3(0.0f, -0.12f, 0.0f);
  scene.camera.yfov = 1.2f;
  DemoLight light;
  // Out through the opening and close to the far block's side wall (the green one in the
  // default maze), so that its colour bleeds back into the first block, then back.
  const glm::vec3 right = glm::cross(out, glm::vec3(0.0f, 1.0f, 0.0f));
  light.path = {centre + glm::vec3(0.0f, -0.05f, 0.0f) + 0.1f * out,
                centre + 0.55f * out + glm::vec3(0.0f, -0.02f, 0.0f) + 0.1f * right,
                centre + 1.1f * out + glm::vec3(0.0f, -0.05f, 0.0f) + 0.3f * right,
                centre + 0.55f * out + glm::vec3(0.0f, 0.05f, 0.0f) - 0.05f * right};
  light.period = 96;
  light.color = {1.0f, 0.9f, 0.75f};
  light.intensity = 0.6f;
  light.radius = 0.02f;
  scene.lights.push_back(light);

  // DRT clutter (docs/drt.md): a terracotta pillar standing on block 0's floor beside the
  // light's path, a mesh with lightmap UVs. Its indirect shadow and the light it reflects
  // onto the walls, and its own indirect light, come from the DRT operators. The footprint is
  // a square in block 0's canonical frame carried onto its warped floor; the pillar stands
  // 3 mm above the floor's highest point under it.
  {
    const int terracotta = add_material(scene, "terracotta pillar", {0.8f, 0.42f, 0.28f});
    const glm::dvec3 q = world_to_canonical_guess(c0, centre + 0.22f * out - 0.24f * right);
    ClutterPrism pillar;
    pillar.name = "clutter pillar";
    pillar.material = terracotta;
    pillar.block = 0;
    double floor = -1e30;
    for (const glm::dvec2 d : {glm::dvec2(-1, -1), glm::dvec2(1, -1), glm::dvec2(1, 1), glm::dvec2(-1, 1)}) {
      const glm::dvec3 p = trilinear(c0, glm::dvec3(q.x + 0.07 * d.x, 0.0, q.z + 0.07 * d.y));
      pillar.polygon.emplace_back(p.x, p.z);
      floor = std::max(floor, p.y);
    }
    if (polygon_area2(pillar.polygon) < 0.0) std::reverse(pillar.polygon.begin(), pillar.polygon.end());
    pillar.cap_triangles = {0, 1, 2, 0, 2, 3};
    pillar.y0 = floor + 0.003;
    pillar.y1 = floor + 0.62;
    if (Status st = add_clutter_prism(scene, pillar); !st.ok()) return st;
  }

  // The dynamic sphere: from the far side of the opening towards the camera and back.
  Mesh sphere;
  sphere.name = "dynamic sphere";
  sphere.material = add_material(scene, "sphere", {0.85f, 0.85f, 0.85f});
  sphere.dynamic = true;
  add_sphere(sphere, 0.11f, 16, 32);
  scene.meshes.push_back(std::move(sphere));
  scene.dynamic_path = {centre + 1.1f * out + glm::vec3(0.0f, -0.39f, 0.0f),
                        centre + 0.25f * out + glm::vec3(0.1f, -0.39f, 0.0f)};
  scene.dynamic_period = 120;
  return scene;
}

}  // namespace modrt::demo
