// SPDX-License-Identifier: MIT
// modrt-import-accuracy: modrt's indirect light on an imported scene's proxy blocks against the
// path tracer on the scene's real triangles (docs/import.md, "Accuracy against the path tracer").
//
//   modrt-import-accuracy SCENE.gltf [--res 16] [--cache-dir DIR] [--points 400] [--paths 256]
//                         [--bounces 16] [--ld demo|cpu|mesh] [--proxy-truth] [--truth-without-clutter]
//                         [--markdown FILE] [--check-room TOL] [--check-door TOL]
//
// 1. The scene is loaded with the demo's glTF loader (import on the fly, no proxy wall meshes), the
//    level built with the cached dictionary (res 16: the default one; another res: a quick small
//    bake) and shaped operators, as modrt-demo builds it.
// 2. modrt: --ld demo (the default) renders one frame of modrt-demo's own run (DemoRun: the GPU
//    ld pass with its shadow cube maps, DRT for the furniture, the CPU backend's converged
//    multi-bounce) and reads its atlas back: what a user of the demo sees. --ld cpu (the CPU
//    direct-light evaluator, shadows from the proxy walls) and --ld mesh (ld traced from the proxy
//    samples through every mesh) take the furniture out of modrt's side (no DRT) and run the
//    scalar reference's converged multi-bounce (level_converged_bounce): diagnoses.
// 3. Points on the real geometry: per room, stratified by area over the pieces of the structural
//    objects' triangles (the proxy mapping cuts them at block boundaries; the room is the piece's
//    block's), each read from the atlas bilinearly at its lightmap coordinate, as a renderer does.
//    Points inside a closed solid (a floor under a wall box) are left out: nobody sees them.
// 4. Truth: trace_mesh_indirect on every static triangle (furniture included) with its material's
//    albedo, at the same points; point lights as the demo shades them (one visibility sample).
// 5. Region means (luminance of E_ind / pi) per room, and per pair of rooms joined by doorways the
//    mean of the next room relative to the lit room's. Diagnosis: the direct light at the same
//    points (modrt's ld read like the lightmap against the real geometry's), per surface (floor,
//    walls, ceiling); --proxy-truth adds the path tracer on the proxy blocks themselves (modrt's
//    direct-light model) at the points' projections onto their proxy faces, separating MRT's own
//    error (modrt / proxy PT) from the proxies' (proxy PT / truth); --truth-without-clutter takes
//    the furniture out of the truth.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <glm/geometric.hpp>

#include "demo_run.h"
#include "modrt/cpu/direct_light.h"
#include "modrt/file_io.h"
#include "modrt/level_geometry.h"
#include "modrt/level_runtime.h"
#include "modrt/light_policy.h"
#include "modrt/mesh_lightmap_uv.h"
#include "modrt/platform/gl_context.h"
#include "modrt/precompute/bake.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/mesh_path_tracer.h"
#include "modrt/precompute/path_tracer.h"
#include "modrt/precompute/shaped_operators.h"
#include "modrt/reduced_feedback.h"
#include "scene/gltf_scene.h"
#include "scene/scene_import_glue.h"

using namespace modrt;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Rec. 709 luminance of linear RGB.
constexpr double kLum[3] = {0.2126, 0.7152, 0.0722};
double luminance(const float* rgb) { return kLum[0] * rgb[0] + kLum[1] * rgb[1] + kLum[2] * rgb[2]; }

// The dictionary for `res`: the default one at 16; otherwise a quick bake (the tests' small
// settings at that res), minutes cheaper and good enough for a smoke test.
DictionarySettings dictionary_settings(int res) {
  if (res == int(DictionarySettings{}.res)) return DictionarySettings{};
  return precompute::quick_dictionary_settings(std::uint32_t(res));
}

// A piece of a structural triangle as the proxy mapping cut it: world corners, their atlas
// coordinates, the tile's block and canonical face, the triangle in the MeshScene.
struct Piece {
  std::array<glm::dvec3, 3> p;
  std::array<glm::dvec2, 3> lm;
  int block = 0, face = 0, triangle = 0;
  double area = 0.0;
};

// A measured point.
struct Point {
  glm::dvec3 position, normal;
  glm::dvec2 lightmap;
  int triangle = 0, block = 0, face = 0, room = 0;
  glm::dvec3 proxy_position, proxy_normal;  // its projection onto its proxy face
};

// The point of face `face` of `block` that the proxy mapping projects `x` onto (canonical
// coordinates clamped to the block, the face's axis set to its side), and the face's inward
// normal there.
void project_onto_face(const LevelBlock& block, int face, const glm::dvec3& x, glm::dvec3& position,
                       glm::dvec3& normal) {
  glm::dvec3 c = glm::clamp(world_to_block(block, x), 0.0, 1.0);
  c[face / 2] = (face % 2) ? 1.0 : 0.0;
  position = block_to_world(block, c);
  const FaceFrame& fr = face_frame(face);
  normal =
      block_face_normal(block, face, glm::dot(c - fr.origin, fr.u_axis), glm::dot(c - fr.origin, fr.v_axis));
}

// Whether a surface point lies inside a closed solid (a floor under a wall box or a bed, a
// ceiling above a wall): more than half of `rays` cosine-distributed rays from it hit the back
// of a triangle (objects face out of their volume once imported). No viewer sees such a point.
bool hidden_point(const precompute::MeshScene& mesh, const glm::dvec3& x, const glm::dvec3& n, int triangle,
                  int rays) {
  const glm::dvec3 a = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 t = glm::normalize(glm::cross(n, a)), b = glm::cross(n, t);
  const int side = int(std::ceil(std::sqrt(double(rays))));
  int back = 0, total = 0;
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i) {
      const double u = (i + 0.5) / side, v = (j + 0.5) / side;
      const double r = std::sqrt(u), phi = 2.0 * 3.14159265358979323846 * v;
      const glm::dvec3 dir = r * std::cos(phi) * t + r * std::sin(phi) * b + std::sqrt(1.0 - u) * n;
      const precompute::MeshHit hit = mesh.intersect(x, dir, triangle);
      ++total;
      if (hit.triangle >= 0 && glm::dot(mesh.normal(hit.triangle), dir) > 0.0) ++back;
    }
  return 2 * back > total;
}

enum Surface { kFloor = 0, kWalls = 1, kCeiling = 2 };
int surface_of(int canonical_face) {
  return canonical_face == kFaceNegY ? kFloor : canonical_face == kFacePosY ? kCeiling : kWalls;
}
const char* const kSurfaceName[3] = {"floor", "walls", "ceiling"};

// The padded atlas (RGB per texel) read bilinearly at continuous texel coordinates (x + 0.5 is a
// texel centre), as a renderer's linear sampler does.
glm::dvec3 sample_atlas(const Level& level, std::span<const float> atlas, glm::dvec2 at) {
  const int w = level.atlas.width, h = level.atlas.height;
  const double x = at.x - 0.5, y = at.y - 0.5;
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  glm::dvec3 sum(0.0);
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const int xi = std::clamp(x0 + i, 0, w - 1), yi = std::clamp(y0 + j, 0, h - 1);
      const double wgt = (i ? fx : 1.0 - fx) * (j ? fy : 1.0 - fy);
      const std::size_t t = 3 * (std::size_t(yi) * std::size_t(w) + std::size_t(xi));
      sum += wgt * glm::dvec3(atlas[t], atlas[t + 1], atlas[t + 2]);
    }
  return sum;
}

std::string fixed(double v, int d) {
  char t[64];
  std::snprintf(t, sizeof t, "%.*f", d, v);
  return t;
}
std::string percent(double ratio) {
  char t[64];
  std::snprintf(t, sizeof t, "%+.1f %%", 100.0 * (ratio - 1.0));
  return t;
}

// Region statistics of one set of points: area-uniform mean of the luminance, and the standard
// error of the truth's mean (independent points; per point the channels' errors added, which
// bounds the luminance's).
struct Region {
  std::size_t points = 0;
  double modrt = 0.0, truth = 0.0, proxy = 0.0, truth_se2 = 0.0, direct_modrt = 0.0, direct_truth = 0.0;
  void add(double m, double t, double p, double se, double dm, double dt) {
    ++points;
    modrt += m;
    truth += t;
    proxy += p;
    truth_se2 += se * se;
    direct_modrt += dm;
    direct_truth += dt;
  }
  double mean_modrt() const { return points ? modrt / double(points) : 0.0; }
  double mean_truth() const { return points ? truth / double(points) : 0.0; }
  double mean_proxy() const { return points ? proxy / double(points) : 0.0; }
  double direct_ratio() const { return direct_truth > 0.0 ? direct_modrt / direct_truth : 0.0; }
  // Relative standard error of the truth's mean.
  double noise() const {
    return points && truth > 0.0 ? std::sqrt(truth_se2) / double(points) / mean_truth() : 0.0;
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "modrt-import-accuracy: indirect light of modrt on an imported glTF scene's proxies against the path "
      "tracer on its real geometry, per room and per doorway (docs/import.md)"};
  std::string input, markdown, cache_dir = precompute::default_cache_dir();
  int res = 16, points_per_room = 400, paths = 256, bounces = 16, light_samples = 1, proxy_paths = 128;
  std::uint64_t seed = 1;
  bool proxy_truth = false, truth_without_clutter = false;
  std::string ld_model = "demo", gl_platform = "egl-surfaceless";
  double check_room = 0.0, check_door = 0.0;
  app.add_option("scene", input, "glTF 2.0 scene without modrt markup (.gltf or .glb)")->required();
  app.add_option("--res", res,
                 "lightmap texels per face side: 16 is the default dictionary; others bake a quick small one")
      ->check(CLI::Range(2, 64))
      ->capture_default_str();
  app.add_option("--cache-dir", cache_dir, "dictionary and shaped-operator cache")->capture_default_str();
  app.add_option("--points", points_per_room, "points per room on the real geometry")
      ->check(CLI::Range(8, 100000))
      ->capture_default_str();
  app.add_option("--paths", paths, "path tracer: paths per point")
      ->check(CLI::Range(1, 65536))
      ->capture_default_str();
  app.add_option("--bounces", bounces, "path tracer: path segments (bounces of indirect light)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  app.add_option("--light-samples", light_samples, "path tracer: visibility points per light")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_flag(
      "--proxy-truth", proxy_truth,
      "also trace the proxy blocks themselves (modrt's direct-light model) at the points' proxy faces");
  app.add_option(
         "--ld", ld_model,
         "modrt's side: demo (modrt-demo's frame: the GPU ld pass, DRT clutter, the CPU backend's converged "
         "solve), cpu (modrt::cpu's direct-light evaluator, shadows from the proxy walls, no DRT) or mesh "
         "(ld "
         "traced from the proxy samples through every mesh, no DRT); cpu and mesh use the scalar reference's "
         "converged multi-bounce")
      ->check(CLI::IsMember({"demo", "cpu", "mesh"}))
      ->capture_default_str();
  app.add_option("--gl-platform", gl_platform, "--ld demo: the GL platform (modrt-demo --platform's names)")
      ->capture_default_str();
  app.add_flag(
      "--truth-without-clutter", truth_without_clutter,
      "diagnosis: leave the objects the importer calls clutter (furniture) out of the truth's scene");
  app.add_option("--proxy-paths", proxy_paths, "paths per point of --proxy-truth")
      ->check(CLI::Range(1, 65536))
      ->capture_default_str();
  app.add_option("--seed", seed, "sampling seed (points and paths)")->capture_default_str();
  app.add_option("--markdown", markdown, "also write the report (markdown) to this file");
  app.add_option("--check-room", check_room,
                 "exit 2 when a room's mean differs from the truth by more than this fraction (0: no check)")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--check-door", check_door,
                 "exit 2 when a doorway's light ratio differs from the truth's by more than this fraction")
      ->check(CLI::Range(0.0, 100.0));
  CLI11_PARSE(app, argc, argv);
  if (!markdown.empty())
    if (Status s = check_writable_file(markdown); !s.ok()) {
      std::fprintf(stderr, "modrt-import-accuracy: --markdown: %s\n", s.to_string().c_str());
      return 1;
    }
  auto fail = [](const std::string& what, const Status& s) {
    std::fprintf(stderr, "modrt-import-accuracy: %s: %s\n", what.c_str(), s.to_string().c_str());
    return 1;
  };
  auto log = [](const std::string& m) { std::printf("%s\n", m.c_str()); };

  // 1. The scene, imported on the fly, and its level.
  const Clock::time_point t_all = Clock::now();
  std::vector<std::string> warnings;
  precompute::SceneImport imp;
  demo::GltfSceneOptions options;
  options.warnings = &warnings;
  options.import_result = &imp;
  options.proxy_walls = false;  // the truth sees the artist's triangles only, not the proxies drawn as walls
  Clock::time_point t = Clock::now();
  Result<demo::DemoScene> loaded = demo::load_gltf_scene(input, options);
  if (!loaded.ok()) return fail(input, loaded.status());
  const demo::DemoScene& scene = loaded.value();
  const double t_import = seconds_since(t);
  if (imp.level.blocks.empty() || imp.rooms.empty()) {
    std::fprintf(stderr, "modrt-import-accuracy: %s has modrt markup (no import, no rooms to measure)\n",
                 input.c_str());
    return 1;
  }
  for (const std::string& w : warnings) std::printf("warning: %s\n", w.c_str());

  t = Clock::now();
  const DictionarySettings ds = dictionary_settings(res);
  if (Status s = precompute::check_cache_dir(cache_dir); !s.ok()) return fail("--cache-dir", s);
  Result<Dictionary> dict = precompute::load_or_bake_dictionary(ds, cache_dir, {}, log);
  if (!dict.ok()) return fail("dictionary", dict.status());
  Result<Matrix> basis = precompute::load_or_bake_interface_basis(ds, cache_dir, {}, log);
  if (!basis.ok()) return fail("interface basis", basis.status());
  const double t_dict = seconds_since(t);
  t = Clock::now();
  precompute::ShapedOperatorCache shaped_cache(cache_dir);
  precompute::LevelBuildSettings bs;
  bs.interface_basis = &basis.value();
  bs.shaped_cache = &shaped_cache;
  // --ld demo: modrt-demo's own run (the level built the same way, with the shaped cache).
  std::unique_ptr<platform::GlContext> context;
  std::unique_ptr<demo::DemoRun> run;
  Result<Level> built = Status::error(ErrorCode::invalid_argument, "no level");
  if (ld_model == "demo") {
    platform::ContextRequest request{};
    if (!platform::parse_context_request(gl_platform, &request))
      return fail("--gl-platform",
                  Status::error(ErrorCode::invalid_argument, "unknown platform " + gl_platform));
    Result<std::unique_ptr<platform::GlContext>> created = platform::create_context(request);
    if (!created.ok()) return fail("GL context (--ld demo)", created.status());
    context = std::move(created).value();
    demo::DemoRunOptions ro;
    ro.backend = demo::DemoBackend::cpu;  // its converged solve, clutter included
    ro.direct = demo::DemoDirect::gpu;    // modrt-demo's default ld
    ro.renderer.width = ro.renderer.height = 64;
    ro.camera_skip = false;  // every block's lightmap, not only those the camera sees
    ro.shaped_cache_dir = cache_dir;
    ro.drt_cache_dir = cache_dir;
    ro.interface_basis = &basis.value();
    Result<std::unique_ptr<demo::DemoRun>> made = demo::DemoRun::create(scene, dict.value(), *context, ro);
    if (!made.ok()) return fail("demo run", made.status());
    run = std::move(made).value();
  } else {
    built = precompute::build_level(scene.level, dict.value(), bs);
    if (!built.ok()) return fail("level build", built.status());
  }
  const Level& level = run ? run->level() : built.value();
  const double t_build = seconds_since(t);

  // The lights: the CPU evaluator's and the path tracer's forms of each.
  std::vector<cpu::CpuLight> cpu_lights;
  std::vector<precompute::MeshLight> mesh_lights;
  for (const demo::DemoLight& light : scene.lights) {
    if (light.directional) {
      // The mesh path tracer has point and spot lights: the truth would miss the sun.
      std::fprintf(stderr, "modrt-import-accuracy: %s has a directional light; the path tracer has none\n",
                   input.c_str());
      return 1;
    }
    const cpu::CpuLight& c = cpu_lights.emplace_back(demo::cpu_light(light, demo::light_position(light, 0)));
    const bool spot = c.type == cpu::LightType::spot;
    precompute::MeshLight& m = mesh_lights.emplace_back();
    m.light.position = glm::dvec3(c.position);
    m.light.radius = light.radius;
    m.light.color = glm::dvec3(light.color);
    m.light.intensity = light.intensity;
    if (spot)
      m.spot = precompute::SpotCone{glm::dvec3(c.direction), double(c.inner_angle), double(c.outer_angle)};
  }
  // The real geometry: every static triangle in one MeshScene (the truth's, and the shadows of
  // --ld mesh).
  std::vector<glm::vec3> positions;
  std::vector<std::uint32_t> indices;
  std::vector<glm::dvec3> tri_albedo;
  // The importer's object of each mesh (scene_import_glue sets it; clutter meshes keep their
  // object's).
  auto role_of = [&](std::size_t mi) {
    const int object = scene.meshes[mi].import_object;
    return object < 0 || std::size_t(object) >= imp.object_role.size() ? precompute::ObjectRole::outside
                                                                       : imp.object_role[std::size_t(object)];
  };
  std::vector<std::size_t> mesh_first(scene.meshes.size(), 0);
  std::size_t clutter_triangles_left_out = 0;
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const demo::Mesh& m = scene.meshes[mi];
    mesh_first[mi] = indices.size() / 3;
    if (m.dynamic) continue;
    if (truth_without_clutter && (m.clutter >= 0 || role_of(mi) == precompute::ObjectRole::clutter)) {
      clutter_triangles_left_out += m.indices.size() / 3;
      continue;
    }
    const std::uint32_t base = std::uint32_t(positions.size());
    positions.insert(positions.end(), m.position.begin(), m.position.end());
    for (std::uint32_t i : m.indices) indices.push_back(base + i);
    tri_albedo.insert(tri_albedo.end(), m.indices.size() / 3, demo::material_albedo(scene, m.material));
  }
  Result<precompute::MeshScene> mesh_scene = precompute::MeshScene::create(
      std::span<const glm::vec3>(positions), std::span<const std::uint32_t>(indices), tri_albedo);
  if (!mesh_scene.ok()) return fail("mesh scene", mesh_scene.status());

  // 2. modrt: ld and the converged multi-bounce.
  t = Clock::now();
  const std::vector<float> albedo = level_sample_albedo(level);
  const LevelBufferSizes sizes = level_buffer_sizes(level, dict.value());
  std::vector<float> ld(sizes.ld), b(sizes.b), r(sizes.r), lightmap(sizes.lightmap), atlas(sizes.atlas);
  std::size_t solve_iterations = 0;
  if (run) {
    // One frame of the demo: ld from the GPU pass (shadow cube maps of every mesh), DRT's
    // clutter deltas and the CPU backend's converged multi-bounce; its atlas and ld read back.
    const std::size_t pixels = 3 * std::size_t(run->width()) * std::size_t(run->height());
    std::vector<float> linear(pixels);
    std::vector<std::uint8_t> srgb(pixels);
    if (Status s = run->render(0, linear, srgb); !s.ok()) return fail("demo frame", s);
    if (Status s = run->backend().read_atlas(atlas); !s.ok()) return fail("demo atlas", s);
    const std::span<const float> run_ld = run->ld();
    if (run_ld.size() != ld.size())
      return fail("demo ld", Status::error(ErrorCode::internal_error,
                                           "ld of " + std::to_string(run_ld.size()) +
                                               " values, the level has " + std::to_string(ld.size())));
    std::copy(run_ld.begin(), run_ld.end(), ld.begin());
    solve_iterations = std::size_t(run->backend().converged_stats().last.iterations);
  } else if (ld_model == "cpu") {
    cpu::CpuDirectLightOptions dlo;
    dlo.max_lights = std::max<std::size_t>(1, cpu_lights.size());
    Result<cpu::CpuDirectLight> direct = cpu::CpuDirectLight::create(level, albedo, dlo);
    if (!direct.ok()) return fail("direct light", direct.status());
    if (Status s = direct->evaluate(cpu_lights, ld); !s.ok()) return fail("direct light", s);
  } else {
    // The GPU pass's model (gles light.glsl): shadows from every mesh, the sample moved along its
    // normal by 0.004 + 0.004 d against acne, one light at a time.
    const LevelSampleGeometry g = level_sample_geometry(level);
    std::vector<glm::dvec3> moved(g.position.size());
    for (const precompute::MeshLight& ml : mesh_lights) {
      for (std::size_t i = 0; i < moved.size(); ++i)
        moved[i] =
            g.position[i] + g.normal[i] * (0.004 + 0.004 * glm::length(ml.light.position - g.position[i]));
      Result<std::vector<float>> e = precompute::trace_mesh_direct(
          mesh_scene.value(), std::span(&ml, 1), precompute::MeshPoints{moved, g.normal, {}}, 1);
      if (!e.ok()) return fail("direct light (--ld mesh)", e.status());
      for (std::size_t i = 0; i < ld.size(); ++i) ld[i] += albedo[i] * e.value()[i];
    }
  }
  if (!run) {
    Result<ConvergedBounceReport> conv =
        level_converged_bounce(level, dict.value(), ld, albedo, {}, b, r, lightmap);
    if (!conv.ok()) return fail("converged multi-bounce", conv.status());
    solve_iterations = conv->solve.iterations;
    level_fill_atlas(level, lightmap, atlas);
  }
  const double t_modrt = seconds_since(t);
  // modrt's direct E / pi (ld without the albedo), read like the lightmap: how the proxies' direct
  // light compares with the real geometry's.
  std::vector<float> direct_e(ld.size(), 0.0f), direct_atlas(sizes.atlas);
  for (std::size_t i = 0; i < ld.size(); ++i) direct_e[i] = albedo[i] > 0.0f ? ld[i] / albedo[i] : 0.0f;
  level_fill_atlas(level, direct_e, direct_atlas);

  // 3. The structural objects' triangles through the proxy mapping, as pieces per room.
  t = Clock::now();
  const std::size_t room_count = imp.rooms.size();
  std::vector<std::vector<Piece>> room_pieces(room_count);
  std::size_t pieces_disagree = 0;
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const demo::Mesh& m = scene.meshes[mi];
    if (role_of(mi) != precompute::ObjectRole::structure) continue;
    const MeshLightmapInput in{StridedVec3::tight(m.position), StridedVec3::tight(m.normal),
                               m.position.size(), m.indices};
    Result<MeshLightmapStats> mapped =
        map_mesh_lightmap(level, in, [&](const std::array<MappedCorner, 3>& c) {
          // Pieces in no block (outer faces of outer walls, slab edges) light no room.
          if (c[0].outside || c[1].outside || c[2].outside) return;
          Piece pc;
          for (int k = 0; k < 3; ++k) {
            pc.p[std::size_t(k)] = glm::dvec3(c[std::size_t(k)].position);
            pc.lm[std::size_t(k)] = glm::dvec2(c[std::size_t(k)].lightmap);
          }
          pc.block = int(c[0].block);
          pc.face = c[0].face;
          pc.triangle = int(mesh_first[mi] + c[0].triangle);
          const glm::dvec3 cr = glm::cross(pc.p[1] - pc.p[0], pc.p[2] - pc.p[0]);
          pc.area = 0.5 * glm::length(cr);
          if (!(pc.area > 1e-10)) return;
          // The mapping decided the piece's side from the vertex normals; the truth's side is the
          // (importer-turned) winding. Count where they disagree.
          const glm::dvec3 vn = glm::dvec3(c[0].normal + c[1].normal + c[2].normal);
          if (glm::dot(vn, mesh_scene->normal(pc.triangle)) < 0.0) ++pieces_disagree;
          const int room =
              std::size_t(pc.block) < imp.block_room.size() ? imp.block_room[std::size_t(pc.block)] : -1;
          if (room >= 0 && std::size_t(room) < room_count) room_pieces[std::size_t(room)].push_back(pc);
        });
    if (!mapped.ok()) return fail("proxy mapping of " + m.name, mapped.status());
  }

  // Stratified points per room: systematic sampling of the pieces by area, a uniform point in
  // each piece.
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::vector<Point> points;
  std::vector<double> room_area(room_count, 0.0);
  std::vector<std::size_t> hidden(room_count, 0), misfaced(room_count, 0);
  for (std::size_t room = 0; room < room_count; ++room) {
    const std::vector<Piece>& pieces = room_pieces[room];
    double total = 0.0;
    for (const Piece& pc : pieces) total += pc.area;
    room_area[room] = total;
    if (pieces.empty()) continue;
    const double step = total / double(points_per_room);
    double next = uni(rng) * step, acc = 0.0;
    for (const Piece& pc : pieces) {
      while (next < acc + pc.area) {
        double u = uni(rng), v = uni(rng);
        if (u + v > 1.0) {
          u = 1.0 - u;
          v = 1.0 - v;
        }
        Point q;
        q.position = pc.p[0] + u * (pc.p[1] - pc.p[0]) + v * (pc.p[2] - pc.p[0]);
        q.lightmap = pc.lm[0] + u * (pc.lm[1] - pc.lm[0]) + v * (pc.lm[2] - pc.lm[0]);
        q.normal = mesh_scene->normal(pc.triangle);
        q.triangle = pc.triangle;
        q.block = pc.block;
        q.face = pc.face;
        q.room = int(room);
        next += step;
        if (hidden_point(mesh_scene.value(), q.position, q.normal, q.triangle, 36)) {
          ++hidden[room];
          continue;
        }
        project_onto_face(level.blocks[std::size_t(q.block)], q.face, q.position, q.proxy_position,
                          q.proxy_normal);
        // A piece mapped onto a proxy face turned more than 60 degrees from it (a wall onto a
        // floor or ceiling where the block's side face is missing).
        if (glm::dot(q.normal, q.proxy_normal) < 0.5) ++misfaced[room];
        points.push_back(q);
      }
      acc += pc.area;
    }
  }
  const double t_points = seconds_since(t);

  // 4. The truth on the real geometry.
  t = Clock::now();
  std::vector<glm::dvec3> pos(points.size()), nrm(points.size());
  std::vector<int> tris(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    pos[i] = points[i].position;
    nrm[i] = points[i].normal;
    tris[i] = points[i].triangle;
  }
  precompute::PathTracerSettings pts;
  pts.paths = paths;
  pts.bounces = bounces;
  pts.light_samples = light_samples;
  pts.seed = seed + 7;
  pts.light_vertex_sources = precompute::mesh_light_centres(mesh_lights);
  Result<precompute::IndirectEstimate> truth = precompute::trace_mesh_indirect(
      mesh_scene.value(), mesh_lights, precompute::MeshPoints{pos, nrm, tris}, pts);
  if (!truth.ok()) return fail("path tracer", truth.status());
  Result<std::vector<float>> truth_direct = precompute::trace_mesh_direct(
      mesh_scene.value(), mesh_lights, precompute::MeshPoints{pos, nrm, tris}, light_samples);
  if (!truth_direct.ok()) return fail("direct light on the real geometry", truth_direct.status());
  const double t_truth = seconds_since(t);

  // Optional: the path tracer on the proxies (modrt's geometry and direct-light model) at each
  // point's projection onto its proxy face.
  t = Clock::now();
  std::vector<float> proxy(3 * points.size(), 0.0f);
  if (proxy_truth) {
    try {
      const precompute::LevelScene lscene(level, 4);
      const std::vector<double> texel_area = precompute::level_texel_areas(level);
      const precompute::SurfaceAlbedo surface_albedo = precompute::level_surface_albedo(lscene, scene.level);
      const precompute::DirectRadiance direct_radiance = [&](const precompute::LevelHit& hit,
                                                             const glm::dvec3& x, const glm::dvec3& n) {
        glm::dvec3 sum(0.0);
        for (const precompute::MeshLight& ml : mesh_lights) {
          const glm::dvec3 centre = ml.light.position;
          const std::array<glm::dvec3, 1> at{centre};
          const double e = precompute::sphere_light_E_over_pi(
              x, n, precompute::SphereLight{centre, ml.light.radius, ml.light.intensity}, at,
              hit.block >= 0 ? texel_area[std::size_t(hit.block)] : 0.0,
              [&](const glm::dvec3& a, const glm::dvec3& c) { return lscene.occluded(a, c); });
          double s = 1.0;
          if (ml.spot && e > 0.0) {
            const glm::dvec3 w = x - centre;
            s = spot_factor(spot_falloff(ml.spot->inner_angle, ml.spot->outer_angle),
                            glm::dot(glm::normalize(ml.spot->direction), w) / glm::length(w));
          }
          sum += ml.light.color * e * s;
        }
        return surface_albedo(hit) * sum;
      };
      std::vector<glm::dvec3> ppos(points.size()), pnrm(points.size());
      for (std::size_t i = 0; i < points.size(); ++i) {
        ppos[i] = points[i].proxy_position;
        pnrm[i] = points[i].proxy_normal;
      }
      precompute::PathTracerSettings pps = pts;
      pps.paths = proxy_paths;
      pps.light_vertex_sources = precompute::level_light_centres(scene.level);
      const precompute::IndirectEstimate est =
          precompute::trace_indirect(lscene, ppos, pnrm, direct_radiance, surface_albedo, pps);
      proxy = est.value;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "modrt-import-accuracy: proxy path tracer: %s\n", e.what());
      return 1;
    }
  }
  const double t_proxy = seconds_since(t);

  // 5. Region means.
  std::vector<Region> rooms(room_count);
  std::vector<std::array<Region, 3>> surfaces(room_count);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point& q = points[i];
    const glm::dvec3 mv = sample_atlas(level, atlas, q.lightmap);
    const float m3[3] = {float(mv.x), float(mv.y), float(mv.z)};
    const double se = kLum[0] * truth->standard_error[3 * i] + kLum[1] * truth->standard_error[3 * i + 1] +
                      kLum[2] * truth->standard_error[3 * i + 2];
    const double m = luminance(m3), tr = luminance(&truth->value[3 * i]), px = luminance(&proxy[3 * i]);
    const glm::dvec3 dv = sample_atlas(level, direct_atlas, q.lightmap);
    const float d3[3] = {float(dv.x), float(dv.y), float(dv.z)};
    const double dm = luminance(d3), dt = luminance(&truth_direct.value()[3 * i]);
    rooms[std::size_t(q.room)].add(m, tr, px, se, dm, dt);
    surfaces[std::size_t(q.room)][std::size_t(surface_of(q.face))].add(m, tr, px, se, dm, dt);
  }
  // Which rooms hold a light (the plan cell under it).
  std::vector<int> lights_in(room_count, 0);
  const precompute::ImportPlan& plan = imp.plan;
  for (const precompute::MeshLight& ml : mesh_lights) {
    const int i = int(std::floor((ml.light.position.x - plan.origin.x) / plan.cell));
    const int k = int(std::floor((ml.light.position.z - plan.origin.y) / plan.cell));
    if (i < 0 || k < 0 || i >= plan.width || k >= plan.height) continue;
    const int label = plan.label[std::size_t(k) * std::size_t(plan.width) + std::size_t(i)];
    if (label >= 0 && std::size_t(label) < room_count) ++lights_in[std::size_t(label)];
  }

  int failures = 0;
  std::string md;
  const std::string name = std::filesystem::path(input).stem().string();
  md += "### " + name + "\n\n";
  md +=
      "`" + input + "`: " + std::to_string(room_count) + " rooms, " + std::to_string(imp.openings.size()) +
      " openings, " + std::to_string(level.blocks.size()) + " blocks (" +
      std::to_string(level.shaped.size()) + " shaped operator sets), " + std::to_string(scene.lights.size()) +
      " lights, res " + std::to_string(res) + " dictionary (kb " + std::to_string(dict->settings.kb) +
      "); ld: " +
      (ld_model == "demo" ? std::string("modrt-demo's frame (GPU ld pass with shadow cube maps, DRT clutter, "
                                        "the CPU backend's converged solve)")
       : ld_model == "cpu" ? std::string("modrt::cpu evaluator (shadows from the proxy walls, no clutter)")
                           : std::string("traced from the proxy samples through every mesh, no DRT")) +
      "; converged solve " + std::to_string(solve_iterations) +
      " iterations. Truth: " + std::to_string(indices.size() / 3) + " triangles" +
      (truth_without_clutter ? " (**without the " + std::to_string(clutter_triangles_left_out) +
                                   " triangles of clutter objects**)"
                             : std::string()) +
      ", " + std::to_string(paths) + " paths x " + std::to_string(bounces) + " segments per point, " +
      std::to_string(points.size()) + " points (" + std::to_string(points_per_room) + " per room)" +
      (proxy_truth ? "; proxy PT: " + std::to_string(proxy_paths) + " paths per point" : std::string()) +
      ". Time: import " + fixed(t_import, 2) + " s, dictionary " + fixed(t_dict, 1) + " s, level build " +
      fixed(t_build, 1) + " s, ld + converged bounce " + fixed(t_modrt, 2) + " s, mapping and points " +
      fixed(t_points, 2) + " s, truth " + fixed(t_truth, 1) + " s" +
      (proxy_truth ? ", proxy PT " + fixed(t_proxy, 1) + " s" : std::string()) + ".";
  if (pieces_disagree)
    md += " Structural pieces whose vertex normals face against their winding: " +
          std::to_string(pieces_disagree) + ".";
  md +=
      "\n\nRegion means of E_ind / pi (luminance) over area-uniform points on the room's structural surfaces "
      "(direct: E_direct / pi at the same points, modrt's ld read from the atlas against the real "
      "geometry's):"
      "\n\n";
  md +=
      "| room | lights | plan x | plan z | visible area m² | modrt | truth | modrt / truth | noise | direct "
      "modrt / "
      "truth |";
  if (proxy_truth) md += " proxy PT | modrt / proxy PT | proxy PT / truth |";
  md += " within 15 % |\n|---|---|---|---|---|---|---|---|---|---|";
  if (proxy_truth) md += "---|---|---|";
  md += "---|\n";
  for (std::size_t room = 0; room < room_count; ++room) {
    const Region& g = rooms[room];
    const precompute::ImportedRoom& ir = imp.rooms[room];
    const double ratio = g.mean_truth() > 0.0 ? g.mean_modrt() / g.mean_truth() : 0.0;
    const bool ok = std::abs(ratio - 1.0) <= 0.15;
    if (check_room > 0.0 && !(std::abs(ratio - 1.0) <= check_room)) ++failures;
    md +=
        "| " + std::to_string(room) + " | " + std::to_string(lights_in[room]) + " | " + fixed(ir.min.x, 2) +
        " .. " + fixed(ir.max.x, 2) + " | " + fixed(ir.min.y, 2) + " .. " + fixed(ir.max.y, 2) + " | " +
        fixed(room_area[room] * double(g.points) / double(std::max<std::size_t>(1, g.points + hidden[room])),
              1) +
        " | " + fixed(g.mean_modrt(), 4) + " | " + fixed(g.mean_truth(), 4) + " | " + fixed(ratio, 3) + " (" +
        percent(ratio) + ") | " + fixed(100.0 * g.noise(), 2) + " % | " + fixed(g.direct_ratio(), 3) + " |";
    if (proxy_truth)
      md += " " + fixed(g.mean_proxy(), 4) + " | " +
            fixed(g.mean_modrt() / std::max(g.mean_proxy(), 1e-30), 3) + " | " +
            fixed(g.mean_proxy() / std::max(g.mean_truth(), 1e-30), 3) + " |";
    md += std::string(" ") + (ok ? "yes" : "**no**") + " |\n";
  }
  md += "\nPer surface, indirect modrt / truth (points; direct modrt / truth):\n\n| room | " +
        std::string(kSurfaceName[0]) + " | " + kSurfaceName[1] + " | " + kSurfaceName[2] +
        " |\n|---|---|---|---|\n";
  for (std::size_t room = 0; room < room_count; ++room) {
    md += "| " + std::to_string(room);
    for (int sf = 0; sf < 3; ++sf) {
      const Region& g = surfaces[room][std::size_t(sf)];
      md += " | " + (g.points && g.mean_truth() > 0.0
                         ? fixed(g.mean_modrt() / g.mean_truth(), 3) + " (" + std::to_string(g.points) +
                               "; " + fixed(g.direct_ratio(), 2) + ")"
                         : std::string("—"));
    }
    md += " |\n";
  }

  md +=
      "\nPoints per room: kept; left out as hidden (inside a closed solid: under a wall box, a bed, "
      "the slab edge); kept points whose proxy face is turned more than 60 degrees from their surface (a "
      "wall mapped onto a floor or ceiling face where its block's side face is missing):\n\n"
      "| room | blocks | points | hidden | on a turned face |\n|---|---|---|---|---|\n";
  for (std::size_t room = 0; room < room_count; ++room) {
    const std::size_t kept = rooms[room].points, all = kept + hidden[room];
    md += "| " + std::to_string(room) + " | " + std::to_string(imp.rooms[room].blocks) + " | " +
          std::to_string(kept) + " | " + std::to_string(hidden[room]) + " (" +
          fixed(all ? 100.0 * double(hidden[room]) / double(all) : 0.0, 1) + " %) | " +
          std::to_string(misfaced[room]) + " (" +
          fixed(kept ? 100.0 * double(misfaced[room]) / double(kept) : 0.0, 1) + " %) |\n";
  }

  // Doorways: the next room's mean relative to the lit room's (the one with a light; with lights
  // on both sides or neither, the one the truth finds brighter).
  bool any_door = false;
  std::string dm =
      "\nLight reaching the next room through each doorway: mean of the next room / mean of the lit room:\n\n"
      "| doorways (wall, jambs) | from → to | modrt | truth | modrt / truth | noise |";
  if (proxy_truth) dm += " proxy PT | proxy PT / truth |";
  dm += " within 20 % |\n|---|---|---|---|---|---|";
  if (proxy_truth) dm += "---|---|";
  dm += "---|\n";
  // One row per pair of rooms (a colonnade's gaps are several doorways between the same rooms).
  std::map<std::pair<int, int>, std::vector<std::size_t>> pairs;
  for (std::size_t o = 0; o < imp.openings.size(); ++o) {
    const precompute::ImportedOpening& op = imp.openings[o];
    if (op.kind != precompute::OpeningKind::doorway || op.room_a < 0 || op.room_b < 0 ||
        std::size_t(op.room_a) >= room_count || std::size_t(op.room_b) >= room_count)
      continue;
    pairs[{std::min(op.room_a, op.room_b), std::max(op.room_a, op.room_b)}].push_back(o);
  }
  for (const auto& [pair, openings] : pairs) {
    int from = pair.first, to = pair.second;
    const bool la = lights_in[std::size_t(from)] > 0, lb = lights_in[std::size_t(to)] > 0;
    if ((lb && !la) ||
        (la == lb && rooms[std::size_t(to)].mean_truth() > rooms[std::size_t(from)].mean_truth()))
      std::swap(from, to);
    const Region& f = rooms[std::size_t(from)];
    const Region& g = rooms[std::size_t(to)];
    if (f.mean_truth() <= 0.0 || f.mean_modrt() <= 0.0 || g.mean_truth() <= 0.0) continue;
    any_door = true;
    const double rm = g.mean_modrt() / f.mean_modrt(), rt = g.mean_truth() / f.mean_truth();
    const double ratio = rm / rt;
    const bool ok = std::abs(ratio - 1.0) <= 0.20;
    if (check_door > 0.0 && !(std::abs(ratio - 1.0) <= check_door)) ++failures;
    std::string where;
    for (std::size_t o : openings) {
      const precompute::ImportedOpening& op = imp.openings[o];
      where += (where.empty() ? "" : "; ") + std::to_string(o) + ": " +
               (op.normal_axis == 0 ? "x = " : "z = ") + fixed(op.position, 2) + ", " +
               fixed(op.span_min, 2) + " .. " + fixed(op.span_max, 2) +
               (op.removes_face ? "" : " (face kept)");
    }
    dm += "| " + where + " | " + std::to_string(from) + (la || lb ? "" : " (unlit)") + " → " +
          std::to_string(to) + " | " + fixed(rm, 3) + " | " + fixed(rt, 3) + " | " + fixed(ratio, 3) + " (" +
          percent(ratio) + ") | " + fixed(100.0 * std::hypot(f.noise(), g.noise()), 2) + " % |";
    if (proxy_truth) {
      const double rp = g.mean_proxy() / std::max(f.mean_proxy(), 1e-30);
      dm += " " + fixed(rp, 3) + " | " + fixed(rp / rt, 3) + " |";
    }
    dm += std::string(" ") + (ok ? "yes" : "**no**") + " |\n";
  }
  if (any_door) md += dm;
  md += "\n";
  std::printf("\n%s", md.c_str());
  std::printf("total %.1f s\n", seconds_since(t_all));
  if (!markdown.empty())
    if (Status s = write_file_atomic(markdown, std::as_bytes(std::span<const char>(md.data(), md.size())));
        !s.ok())
      return fail(markdown, s);
  if (failures > 0) {
    std::fprintf(stderr, "modrt-import-accuracy: %d rooms or doorways beyond the --check tolerances\n",
                 failures);
    return 2;
  }
  return 0;
}
