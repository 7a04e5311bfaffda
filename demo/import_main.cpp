// SPDX-License-Identifier: MIT
// modrt-import: an artist's glTF interior to a lit level with no hand markup (docs/import.md).
//
//   modrt-import IN.gltf|glb OUT.gltf|glb [--level-json OUT.level.json] [--modrtlevel OUT.modrtlevel]
//                [--report DIR] [--res N]
//
// Reads IN with the demo's glTF loader; when it has no modrt markup the proxy blocks come from
// its geometry (precompute/scene_import.h). Writes OUT: the same file (materials, textures,
// lights, cameras, animations, nodes kept) with every static mesh cut at block boundaries and
// given TEXCOORD_1, the lightmap coordinates of modrt's atlas at --res texels per face side
// (core's proxy mapping, modrt/mesh_lightmap_uv.h); buffers and images embedded.
#include <unistd.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <tiny_gltf.h>
#include <CLI/CLI.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include "image_output.h"
#include "modrt/file_io.h"
#include "modrt/level_io.h"
#include "modrt/mesh_lightmap_uv.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_json.h"
#include "modrt/precompute/shaped_operators.h"
#include "scene/gltf_scene.h"

namespace fs = std::filesystem;
using namespace modrt;

namespace {

glm::dmat4 local_matrix(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) return glm::make_mat4(n.matrix.data());
  glm::dmat4 t(1.0), r(1.0), s(1.0);
  if (n.translation.size() == 3) t[3] = glm::dvec4(n.translation[0], n.translation[1], n.translation[2], 1.0);
  if (n.rotation.size() == 4)
    r = glm::mat4_cast(glm::dquat(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]));
  if (n.scale.size() == 3)
    s = glm::dmat4(
        glm::dmat3(glm::dvec3(n.scale[0], 0, 0), glm::dvec3(0, n.scale[1], 0), glm::dvec3(0, 0, n.scale[2])));
  return t * r * s;
}

void world_matrices(const tinygltf::Model& model, int node, const glm::dmat4& parent,
                    std::vector<glm::dmat4>& out, int depth) {
  if (node < 0 || std::size_t(node) >= model.nodes.size() || depth > 256) return;
  out[std::size_t(node)] = parent * local_matrix(model.nodes[std::size_t(node)]);
  for (int c : model.nodes[std::size_t(node)].children)
    world_matrices(model, c, out[std::size_t(node)], out, depth + 1);
}

// Appends `bytes` to buffer 0's tail buffer view and an accessor over it; returns the accessor.
int add_accessor(tinygltf::Model& model, int buffer, const std::vector<float>& data, int type, int components,
                 bool min_max) {
  tinygltf::Buffer& b = model.buffers[std::size_t(buffer)];
  while (b.data.size() % 4) b.data.push_back(0);
  tinygltf::BufferView view;
  view.buffer = buffer;
  view.byteOffset = b.data.size();
  view.byteLength = data.size() * sizeof(float);
  view.target = TINYGLTF_TARGET_ARRAY_BUFFER;
  const unsigned char* p = reinterpret_cast<const unsigned char*>(data.data());
  b.data.insert(b.data.end(), p, p + view.byteLength);
  model.bufferViews.push_back(view);
  tinygltf::Accessor a;
  a.bufferView = int(model.bufferViews.size()) - 1;
  a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  a.count = data.size() / std::size_t(components);
  a.type = type;
  if (min_max && a.count > 0) {
    a.minValues.assign(std::size_t(components), 1e300);
    a.maxValues.assign(std::size_t(components), -1e300);
    for (std::size_t i = 0; i < data.size(); ++i) {
      const std::size_t c = i % std::size_t(components);
      a.minValues[c] = std::min(a.minValues[c], double(data[i]));
      a.maxValues[c] = std::max(a.maxValues[c], double(data[i]));
    }
  }
  model.accessors.push_back(a);
  return int(model.accessors.size()) - 1;
}

struct WriteStats {
  std::size_t primitives = 0, triangles_in = 0, triangles_out = 0, split = 0, outside = 0;
  std::size_t clutter_triangles = 0;  // furniture made DRT clutter: its own mesh and charts
};

// Replaces every mapped primitive of `model` by its pieces with TEXCOORD_1 (a mesh per node),
// and every piece of furniture made clutter by its closed mesh with the clutter lightmap's
// charts as TEXCOORD_1.
Status add_lightmap_coordinates(tinygltf::Model& model, const demo::DemoScene& scene, const Level& layout,
                                WriteStats& stats, std::vector<std::string>& warnings) {
  std::vector<glm::dmat4> world(model.nodes.size(), glm::dmat4(1.0));
  const int scene_index = model.defaultScene >= 0 ? model.defaultScene : 0;
  if (std::size_t(scene_index) < model.scenes.size())
    for (int root : model.scenes[std::size_t(scene_index)].nodes)
      world_matrices(model, root, glm::dmat4(1.0), world, 0);
  std::map<int, std::vector<std::size_t>> meshes_of_node;
  for (std::size_t m = 0; m < scene.meshes.size(); ++m)
    if (!scene.meshes[m].dynamic && scene.meshes[m].source_node >= 0 &&
        (scene.meshes[m].clutter < 0 || !scene.meshes[m].lightmap_uv.empty()))
      meshes_of_node[scene.meshes[m].source_node].push_back(m);
  if (meshes_of_node.empty()) return Status::success();
  model.buffers.emplace_back();
  const int buffer = int(model.buffers.size()) - 1;
  const glm::vec2 atlas(float(layout.atlas.width), float(layout.atlas.height));
  for (const auto& [node_index, mesh_list] : meshes_of_node) {
    tinygltf::Node& node = model.nodes[std::size_t(node_index)];
    tinygltf::Mesh mesh = model.meshes[std::size_t(node.mesh)];
    const glm::dmat4 inv = glm::inverse(world[std::size_t(node_index)]);
    const glm::dmat3 inv3(inv), normal_to_local = glm::transpose(glm::dmat3(world[std::size_t(node_index)]));
    const bool mirrored = glm::determinant(glm::dmat3(world[std::size_t(node_index)])) < 0.0;
    for (std::size_t mi : mesh_list) {
      const demo::Mesh& dm = scene.meshes[mi];
      if (dm.source_primitive < 0 || std::size_t(dm.source_primitive) >= mesh.primitives.size()) continue;
      tinygltf::Primitive& prim = mesh.primitives[std::size_t(dm.source_primitive)];
      std::vector<float> pos, nrm, uv0, tan, uv1;
      // One output corner: world position and normal, the material's uv and tangent, and the
      // lightmap coordinate in [0, 1]^2.
      auto emit = [&](const glm::vec3& position, const glm::vec3& normal, const glm::vec2* uv,
                      const glm::vec4* tangent, glm::vec2 lightmap) {
        const glm::dvec3 p = glm::dvec3(inv * glm::dvec4(glm::dvec3(position), 1.0));
        glm::dvec3 n = normal_to_local * glm::dvec3(normal);
        n = glm::length(n) > 0.0 ? glm::normalize(n) : glm::dvec3(0, 1, 0);
        pos.insert(pos.end(), {float(p.x), float(p.y), float(p.z)});
        nrm.insert(nrm.end(), {float(n.x), float(n.y), float(n.z)});
        if (uv) uv0.insert(uv0.end(), {uv->x, uv->y});
        if (tangent) {
          glm::dvec3 tl = inv3 * glm::dvec3(*tangent);
          tl = glm::length(tl) > 0.0 ? glm::normalize(tl) : glm::dvec3(1, 0, 0);
          tan.insert(tan.end(), {float(tl.x), float(tl.y), float(tl.z), tangent->w});
        }
        uv1.insert(uv1.end(), {lightmap.x, lightmap.y});
      };
      const int order[3] = {0, mirrored ? 2 : 1, mirrored ? 1 : 2};
      stats.primitives += 1;
      if (dm.clutter >= 0) {
        // Furniture made DRT clutter: its closed mesh with the clutter lightmap's charts.
        for (std::size_t t = 0; 3 * t < dm.indices.size(); ++t)
          for (int k : order) {
            const std::uint32_t v = dm.indices[3 * t + std::size_t(k)];
            emit(dm.position[v], dm.normal[v], dm.uv.empty() ? nullptr : &dm.uv[v],
                 dm.tangent.empty() ? nullptr : &dm.tangent[v], dm.lightmap_uv[v]);
          }
        stats.clutter_triangles += dm.indices.size() / 3;
      } else {
        MeshLightmapInput input{StridedVec3::tight(dm.position), StridedVec3::tight(dm.normal),
                                dm.position.size(), dm.indices};
        Result<MeshLightmapStats> mapped =
            map_mesh_lightmap(layout, input, [&](const std::array<MappedCorner, 3>& c) {
              for (int k : order) {
                const MappedCorner& mc = c[std::size_t(k)];
                const std::uint32_t* tri = &dm.indices[3 * std::size_t(mc.triangle)];
                glm::vec2 u(0.0f);
                glm::vec4 t(0.0f);
                for (int j = 0; j < 3; ++j) {
                  if (!dm.uv.empty()) u += mc.barycentric[j] * dm.uv[tri[j]];
                  if (!dm.tangent.empty()) t += mc.barycentric[j] * dm.tangent[tri[j]];
                }
                if (!dm.tangent.empty()) t.w = dm.tangent[tri[0]].w;
                emit(mc.position, mc.normal, dm.uv.empty() ? nullptr : &u, dm.tangent.empty() ? nullptr : &t,
                     mc.lightmap / atlas);
              }
            });
        if (!mapped.ok())
          return Status::error(mapped.status().code(), dm.name + ": " + mapped.status().message());
        stats.triangles_in += mapped->triangles;
        stats.triangles_out += mapped->corners / 3;
        stats.split += mapped->split_triangles;
        stats.outside += mapped->triangles_outside;
      }
      const bool had_uv = prim.attributes.count("TEXCOORD_0") > 0;
      for (const char* dropped : {"COLOR_0", "TEXCOORD_2", "JOINTS_0", "WEIGHTS_0"})
        if (prim.attributes.count(dropped))
          warnings.push_back(dm.name + ": " + dropped + " is not carried onto the cut pieces");
      if (!prim.targets.empty())
        warnings.push_back(dm.name + ": morph targets are dropped from the cut pieces");
      prim.attributes.clear();
      prim.targets.clear();
      prim.attributes["POSITION"] = add_accessor(model, buffer, pos, TINYGLTF_TYPE_VEC3, 3, true);
      prim.attributes["NORMAL"] = add_accessor(model, buffer, nrm, TINYGLTF_TYPE_VEC3, 3, false);
      if (had_uv && !uv0.empty())
        prim.attributes["TEXCOORD_0"] = add_accessor(model, buffer, uv0, TINYGLTF_TYPE_VEC2, 2, false);
      if (!tan.empty())
        prim.attributes["TANGENT"] = add_accessor(model, buffer, tan, TINYGLTF_TYPE_VEC4, 4, false);
      // The lightmap coordinates as TEXCOORD_1 (glTF asks for a TEXCOORD_0 before it).
      if (!prim.attributes.count("TEXCOORD_0")) {
        prim.attributes["TEXCOORD_0"] = add_accessor(model, buffer, uv1, TINYGLTF_TYPE_VEC2, 2, false);
      }
      prim.attributes["TEXCOORD_1"] = add_accessor(model, buffer, uv1, TINYGLTF_TYPE_VEC2, 2, false);
      prim.indices = -1;
      prim.mode = TINYGLTF_MODE_TRIANGLES;
    }
    model.meshes.push_back(mesh);
    node.mesh = int(model.meshes.size()) - 1;
  }
  return Status::success();
}

// The plan seen from above: rooms in colours, walls dark, outside white; block faces in blue,
// openings (missing faces through a wall) thick green, faces joining blocks of a room thin.
std::vector<std::uint8_t> plan_picture(const precompute::SceneImport& imp, int& w, int& h) {
  const precompute::ImportPlan& p = imp.plan;
  const int scale = std::max(1, 1200 / std::max(p.width, p.height));
  w = p.width * scale;
  h = p.height * scale;
  std::vector<std::uint8_t> rgb(std::size_t(w) * std::size_t(h) * 3, 255);
  auto put = [&](int x, int y, glm::vec3 c) {
    if (x < 0 || y < 0 || x >= w || y >= h) return;
    const std::size_t o = (std::size_t(y) * std::size_t(w) + std::size_t(x)) * 3;
    rgb[o] = std::uint8_t(c.r * 255);
    rgb[o + 1] = std::uint8_t(c.g * 255);
    rgb[o + 2] = std::uint8_t(c.b * 255);
  };
  for (int k = 0; k < p.height; ++k)
    for (int i = 0; i < p.width; ++i) {
      const std::size_t s = std::size_t(k) * std::size_t(p.width) + std::size_t(i);
      glm::vec3 c(1.0f);
      if (p.wall[s])
        c = glm::vec3(0.25f);
      else if (p.label[s] >= 0) {
        const int r = p.label[s];
        c = glm::vec3(0.65f + 0.3f * float((r * 37) % 7) / 7.0f, 0.7f + 0.25f * float((r * 53) % 5) / 5.0f,
                      0.75f + 0.2f * float((r * 71) % 3) / 3.0f);
      }
      for (int y = 0; y < scale; ++y)
        for (int x = 0; x < scale; ++x) put(i * scale + x, k * scale + y, c);
    }
  auto to_px = [&](double x, double z) {
    return glm::dvec2((x - p.origin.x) / p.cell * scale, (z - p.origin.y) / p.cell * scale);
  };
  auto line = [&](glm::dvec2 a, glm::dvec2 b, glm::vec3 c, int thick) {
    const int n = int(glm::length(b - a)) + 1;
    for (int s = 0; s <= n; ++s) {
      const glm::dvec2 q = a + (b - a) * (double(s) / n);
      for (int dy = -thick; dy <= thick; ++dy)
        for (int dx = -thick; dx <= thick; ++dx) put(int(q.x) + dx, int(q.y) + dy, c);
    }
  };
  // Present faces first, then the missing ones over them (a doorway shows on its wall).
  for (int pass = 0; pass < 2; ++pass)
    for (const BlockDescription& b : imp.level.blocks) {
      const auto& c = b.corners;
      const int side_corners[4][2] = {{0, 4}, {1, 5}, {0, 1}, {4, 5}};  // -X, +X, -Z, +Z at the floor
      const int faces[4] = {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ};
      for (int e = 0; e < 4; ++e) {
        const bool present = face_present(b.faces, faces[e]);
        if (present != (pass == 0)) continue;
        const glm::dvec3 a = c[std::size_t(side_corners[e][0])], d = c[std::size_t(side_corners[e][1])];
        // A missing face through a wall (its middle on a wall cell) is an opening.
        const glm::dvec2 mid = glm::floor(to_px(0.5 * (a.x + d.x), 0.5 * (a.z + d.z)) / double(scale));
        const bool opening = !present && mid.x >= 0 && mid.y >= 0 && mid.x < p.width && mid.y < p.height &&
                             p.wall[std::size_t(mid.y) * std::size_t(p.width) + std::size_t(mid.x)];
        line(to_px(a.x, a.z), to_px(d.x, d.z),
             present   ? glm::vec3(0.1f, 0.1f, 0.6f)
             : opening ? glm::vec3(0.0f, 0.75f, 0.1f)
                       : glm::vec3(0.55f, 0.8f, 0.55f),
             present   ? 1
             : opening ? 3
                       : 0);
      }
    }
  return rgb;
}

std::string fixed(double v, int d = 2) {
  char t[64];
  std::snprintf(t, sizeof t, "%.*f", d, v);
  return t;
}

Status write_report(const std::string& dir, const std::string& input, const precompute::SceneImport& imp,
                    const demo::DemoScene& scene, const WriteStats& ws, double seconds,
                    const std::vector<std::string>& warnings) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  int w = 0, h = 0;
  const std::vector<std::uint8_t> rgb = plan_picture(imp, w, h);
  if (Status s = demo::write_rgb8_image((fs::path(dir) / "plan.png").string(), w, h, rgb); !s.ok()) return s;
  std::string md = "# modrt-import report: " + input + "\n\n";
  md += "![plan](plan.png)\n\nPlan cut at y = " + fixed(imp.plan.cut_height) + " m, raster cell " +
        fixed(imp.plan.cell, 3) +
        " m (rooms in colour, walls dark; block faces blue, openings thick green, faces joining blocks of "
        "one room thin green).\n\n";
  md += "- import time: " + fixed(seconds * 1000.0, 0) + " ms\n- rooms: " + std::to_string(imp.rooms.size()) +
        "\n- openings: " + std::to_string(imp.openings.size()) +
        "\n- blocks: " + std::to_string(imp.level.blocks.size());
  int faces = 0, missing = 0;
  for (const BlockDescription& b : imp.level.blocks)
    for (int f = 0; f < kFaceCount; ++f) (face_present(b.faces, f) ? faces : missing) += 1;
  md += "\n- present faces: " + std::to_string(faces) + ", missing faces: " + std::to_string(missing) +
        "\n- triangles: " + std::to_string(imp.triangles) +
        " (turned to face their room: " + std::to_string(imp.triangles_flipped) +
        ")\n- mapped primitives: " + std::to_string(ws.primitives) + ", " + std::to_string(ws.triangles_in) +
        " triangles -> " + std::to_string(ws.triangles_out) + " pieces (" + std::to_string(ws.split) +
        " cut at block boundaries, " + std::to_string(ws.outside) +
        " with a part in no block)\n- clutter (DRT): " + std::to_string(scene.clutter.size()) + " objects, " +
        std::to_string(ws.clutter_triangles) +
        " triangles with their own lightmap charts\n\n## Rooms\n\n| room | plan x | plan z | area m² | floor "
        "| ceiling | "
        "blocks |\n|---|---|---|---|---|---|---|\n";
  for (std::size_t r = 0; r < imp.rooms.size(); ++r) {
    const precompute::ImportedRoom& room = imp.rooms[r];
    md += "| " + std::to_string(r) + " | " + fixed(room.min.x) + " .. " + fixed(room.max.x) + " | " +
          fixed(room.min.y) + " .. " + fixed(room.max.y) + " | " + fixed(room.area, 1) + " | " +
          fixed(room.floor) + " | " + fixed(room.ceiling) + " | " + std::to_string(room.blocks) + " |\n";
  }
  md +=
      "\n## Openings\n\n| kind | rooms | wall | jambs | sill .. head | face covered | face removed "
      "|\n|---|---|---|---|---|---|---|\n";
  for (const precompute::ImportedOpening& o : imp.openings)
    md += std::string("| ") + (o.kind == precompute::OpeningKind::doorway ? "doorway" : "exterior") + " | " +
          std::to_string(o.room_a) + " – " +
          (o.room_b >= 0 ? std::to_string(o.room_b) : std::string("outside")) + " | " +
          (o.normal_axis == 0 ? "x = " : "z = ") + fixed(o.position) + " | " + fixed(o.span_min) + " .. " +
          fixed(o.span_max) + " | " + fixed(o.sill) + " .. " + fixed(o.head) + " | " +
          fixed(100.0 * o.coverage, 0) + " % | " + (o.removes_face ? "yes" : "no") + " |\n";
  md += "\n## Objects\n\n| object | role | area beyond " +
        fixed(precompute::ImportSettings{}.clutter_distance) + " m of its face |\n|---|---|---|\n";
  std::vector<std::string> names;
  for (const demo::Mesh& m : scene.meshes)
    if (!m.dynamic && m.clutter < 0 && (names.empty() || names.back() != m.name)) names.push_back(m.name);
  for (std::size_t o = 0; o < imp.object_role.size(); ++o) {
    const char* role = imp.object_role[o] == precompute::ObjectRole::clutter   ? "clutter"
                       : imp.object_role[o] == precompute::ObjectRole::outside ? "outside the level"
                                                                               : "structure";
    md += "| " + (o < names.size() ? names[o] : std::to_string(o)) + " | " + role + " | " +
          fixed(100.0 * imp.object_far_fraction[o], 0) + " % |\n";
  }
  md +=
      "\n## Face albedo (linear RGB, from the geometry mapped onto each face)\n\n| block | -X | +X | floor | "
      "ceiling | -Z | +Z |\n|---|---|---|---|---|---|---|\n";
  for (const BlockDescription& b : imp.level.blocks) {
    md += "| " + b.name;
    for (int f = 0; f < kFaceCount; ++f)
      md += " | " + (face_present(b.faces, f)
                         ? fixed(b.albedo[std::size_t(f)].r) + " " + fixed(b.albedo[std::size_t(f)].g) + " " +
                               fixed(b.albedo[std::size_t(f)].b)
                         : std::string("—"));
    md += " |\n";
  }
  md += "\n## Warnings\n\n";
  for (const std::string& w2 : warnings) md += "- " + w2 + "\n";
  if (warnings.empty()) md += "none\n";
  return write_file_atomic((fs::path(dir) / "report.md").string(),
                           std::as_bytes(std::span<const char>(md.data(), md.size())));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modrt-import: proxy blocks and lightmap coordinates for a glTF interior (docs/import.md)"};
  std::string input, output, level_json, modrtlevel, report;
  int res = 16;
  app.add_option("input", input, "glTF 2.0 scene (.gltf or .glb)")->required();
  app.add_option("output", output, "the scene with TEXCOORD_1 (.gltf, or .glb for binary)")->required();
  app.add_option("--level-json", level_json, "write the generated level description (docs/level-format.md)");
  app.add_option("--modrtlevel", modrtlevel,
                 "build the level with the cached res-N dictionary (baked on first use) and save it");
  app.add_option("--report", report, "write report.md and plan.png into this folder");
  app.add_option("--res", res, "lightmap texels per face side of the atlas TEXCOORD_1 addresses")
      ->check(CLI::Range(1, 256));
  CLI11_PARSE(app, argc, argv);

  std::vector<std::string> warnings;
  precompute::SceneImport imported;
  demo::GltfSceneOptions options;
  options.warnings = &warnings;
  options.import_result = &imported;
  const auto t0 = std::chrono::steady_clock::now();
  Result<demo::DemoScene> scene = demo::load_gltf_scene(input, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!scene.ok()) {
    std::fprintf(stderr, "modrt-import: %s\n", scene.status().message().c_str());
    return 1;
  }
  const bool was_imported = !imported.level.blocks.empty();
  std::printf("%s: %zu blocks%s in %.2f s\n", input.c_str(), scene->level.blocks.size(),
              was_imported ? " generated from the geometry" : " from the file's markup", seconds);
  Result<Level> layout = precompute::build_level_layout(scene->level, res);
  if (!layout.ok()) {
    std::fprintf(stderr, "modrt-import: %s: the level does not validate: %s\n", input.c_str(),
                 layout.status().message().c_str());
    return 1;
  }
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  const bool binary = fs::path(input).extension() == ".glb";
  if (!(binary ? loader.LoadBinaryFromFile(&model, &err, &warn, input)
               : loader.LoadASCIIFromFile(&model, &err, &warn, input))) {
    std::fprintf(stderr, "modrt-import: %s: %s\n", input.c_str(), err.c_str());
    return 1;
  }
  WriteStats ws;
  if (Status s = add_lightmap_coordinates(model, scene.value(), layout.value(), ws, warnings); !s.ok()) {
    std::fprintf(stderr, "modrt-import: %s: %s\n", input.c_str(), s.message().c_str());
    return 1;
  }
  if (model.asset.generator.empty())
    model.asset.generator = "modrt-import";
  else
    model.asset.generator += " + modrt-import";
  const std::string tmp = output + ".tmp" + std::to_string(::getpid());
  const bool out_binary = fs::path(output).extension() == ".glb";
  if (!loader.WriteGltfSceneToFile(&model, tmp, true, true, true, out_binary)) {
    std::fprintf(stderr, "modrt-import: %s: could not write\n", output.c_str());
    return 1;
  }
  std::error_code ec;
  fs::rename(tmp, output, ec);
  if (ec) {
    std::fprintf(stderr, "modrt-import: %s: %s\n", output.c_str(), ec.message().c_str());
    return 1;
  }
  std::printf(
      "%s: %zu primitives, %zu triangles -> %zu (cut at block boundaries: %zu), TEXCOORD_1 at res %d "
      "(atlas %d x %d); %zu clutter objects, %zu triangles with their own lightmap charts\n",
      output.c_str(), ws.primitives, ws.triangles_in, ws.triangles_out, ws.split, res, layout->atlas.width,
      layout->atlas.height, scene->clutter.size(), ws.clutter_triangles);
  if (!level_json.empty()) {
    if (Status s = precompute::save_level_json(level_json, scene->level); !s.ok()) {
      std::fprintf(stderr, "modrt-import: %s\n", s.message().c_str());
      return 1;
    }
  }
  if (!modrtlevel.empty()) {
    // The default dictionary (res 16, the demo's); TEXCOORD_1 must address its atlas.
    const DictionarySettings ds;
    if (int(ds.res) != res) {
      std::fprintf(stderr,
                   "modrt-import: --modrtlevel builds with the default res-%u dictionary; give --res %u\n",
                   ds.res, ds.res);
      return 1;
    }
    const std::string cache = precompute::default_cache_dir();
    auto log = [](const std::string& m) { std::printf("%s\n", m.c_str()); };
    Result<Dictionary> dict = precompute::load_or_bake_dictionary(ds, cache, {}, log);
    if (!dict.ok()) {
      std::fprintf(stderr, "modrt-import: dictionary: %s\n", dict.status().message().c_str());
      return 1;
    }
    Result<Matrix> basis = precompute::load_or_bake_interface_basis(ds, cache, {}, log);
    precompute::LevelBuildSettings bs;
    if (basis.ok()) bs.interface_basis = &basis.value();
    // Shaped blocks' operators are baked once per proportion and kept beside the dictionary.
    precompute::ShapedOperatorCache shaped_cache(cache);
    bs.shaped_cache = &shaped_cache;
    Result<Level> built = precompute::build_level(scene->level, dict.value(), bs);
    if (!built.ok()) {
      std::fprintf(stderr, "modrt-import: level build: %s\n", built.status().message().c_str());
      return 1;
    }
    if (Status s = save_level(modrtlevel, built.value()); !s.ok()) {
      std::fprintf(stderr, "modrt-import: %s\n", s.message().c_str());
      return 1;
    }
  }
  if (!report.empty() && was_imported) {
    if (Status s = write_report(report, input, imported, scene.value(), ws, seconds, warnings); !s.ok()) {
      std::fprintf(stderr, "modrt-import: report: %s\n", s.message().c_str());
      return 1;
    }
  }
  for (const std::string& w : warnings) std::printf("warning: %s\n", w.c_str());
  return 0;
}
