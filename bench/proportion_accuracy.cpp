// SPDX-License-Identifier: MIT
// modrt-proportion-accuracy: blocks that are not cubes (SPEC §4, MRT §8 Figure 12). For a few
// rooms whose proportions are not a cube's, modrt's indirect light is compared with the path
// tracer on the real room geometry (SPEC §8), for two proxies of each room:
//   - one block, warped so that it spans the whole room (the block is stretched), and
//   - unit cubes joined through missing faces (the proxy a cube dictionary is made for),
// each built with cube operators (LevelBuildSettings::shaped_operators = false) and with
// operators for the block's box (true). Error: relative L2 over points and channels
// (docs/accuracy.md), at each proxy's lightmap texels and at the camera pixels of a view
// into the room (the proxy's lightmap looked up bilinearly at each pixel's hit), one bounce
// and converged multi-bounce; for the camera also modrt / reference per third of the room's
// long axis, near = the light's end (a stretched block's cube operators carry light too far or
// not far enough along it).
//
//   modrt-proportion-accuracy [--res 6|16] [--markdown FILE] [--paths N] [--paths-multi N]
//
// The dictionary comes from the dictionary cache (dictionary_cache.h), with modrt-bench's
// settings for the resolution: DictionarySettings{} with res 6 or 16.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <random>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>

#include "image_output.h"
#include "modrt/cube.h"
#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/level_description.h"
#include "modrt/level_geometry.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/bake.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_json.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/maze.h"
#include "modrt/precompute/path_tracer.h"
#include "modrt/precompute/shaped_operators.h"
#include "modrt/reduced_feedback.h"

namespace {

using namespace modrt;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string fmt(const char* format, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

// ---------------------------------------------------------------- rooms and their proxies

struct Camera {
  glm::dvec3 eye, target;
  double vertical_fov_degrees = 60;
};

struct Room {
  std::string key, name;
  glm::dvec3 size{1.0};
  FaceMask faces = kAllFaces;  // present walls of the box (cube.h numbering)
  std::array<glm::dvec3, kFaceCount> albedo{};
  LightDescription light;
  // Cells per axis of the multi-block proxy; zero: one block is the room's natural proxy.
  glm::ivec3 cells{0};
  // Cells of a coarser proxy of stretched blocks joined by interfaces (zero: none).
  glm::ivec3 coarse_cells{0};
  int axis = 0;  // long axis; its low end is where the light is (the "near" third)
  Camera camera;
};

constexpr FaceMask open_at(int face) { return FaceMask(kAllFaces & ~(1u << face)); }

std::array<glm::dvec3, kFaceCount> grey_walls() {
  std::array<glm::dvec3, kFaceCount> a{};
  a.fill(glm::dvec3(0.7));
  return a;
}

LightDescription sphere_light(const glm::dvec3& position) {
  LightDescription l;
  l.position = position;
  l.radius = 0.05;
  l.intensity = 1.0;  // indirect E/pi of O(0.1) at a wall distance of about 0.5
  return l;
}

std::vector<Room> make_rooms() {
  std::vector<Room> rooms;
  Room r;
  r.key = "long";
  r.name = "long room 3x1x1";
  r.size = {3, 1, 1};
  r.faces = open_at(kFacePosZ);
  r.albedo = grey_walls();
  r.albedo[kFaceNegX] = {0.8, 0.2, 0.2};
  r.albedo[kFacePosX] = {0.2, 0.8, 0.2};
  r.light = sphere_light({0.4, 0.6, 0.5});
  r.cells = {3, 1, 1};
  r.coarse_cells = {2, 1, 1};
  r.axis = 0;
  // In front of the open long side: sees the whole back wall and both ends through it.
  r.camera = {{1.5, 0.5, 2.2}, {1.5, 0.45, 0.0}, 60};
  rooms.push_back(r);

  // The same room at 2 : 1: how far one block may be stretched before its 32 modes show.
  r.key = "long2";
  r.name = "long room 2x1x1";
  r.size = {2, 1, 1};
  r.cells = {2, 1, 1};
  r.coarse_cells = {0, 0, 0};
  r.camera = {{1.0, 0.5, 1.9}, {1.0, 0.45, 0.0}, 60};
  rooms.push_back(r);

  r = Room{};
  r.key = "corridor";
  r.name = "corridor 1x1x6";
  r.size = {1, 1, 6};
  r.faces = open_at(kFacePosZ);
  r.albedo = grey_walls();
  r.light = sphere_light({0.5, 0.6, 0.5});
  r.cells = {1, 1, 6};
  r.coarse_cells = {1, 1, 2};
  r.axis = 2;
  // Just outside the open end, looking down the corridor towards the light.
  r.camera = {{0.5, 0.5, 6.6}, {0.5, 0.45, 0.0}, 60};
  rooms.push_back(r);

  r = Room{};
  r.key = "room";
  r.name = "room 2x1x2";
  r.size = {2, 1, 2};
  r.faces = open_at(kFacePosZ);
  r.albedo = grey_walls();
  r.light = sphere_light({0.6, 0.6, 0.5});  // off-centre, towards the -X back corner
  r.cells = {2, 1, 2};
  r.coarse_cells = {2, 1, 1};  // two 1 x 1 x 2 blocks side by side
  r.axis = 2;
  r.camera = {{1.0, 0.5, 2.8}, {1.0, 0.45, 0.0}, 60};
  rooms.push_back(r);

  r = Room{};
  r.key = "slab";
  r.name = "slab 1x0.3x1";
  r.size = {1, 0.3, 1};
  r.faces = open_at(kFacePosZ);
  r.albedo = grey_walls();
  r.light = sphere_light({0.2, 0.15, 0.5});
  r.cells = {0, 0, 0};  // one block is the natural proxy of a slab
  r.axis = 0;
  // Inside the open face: from outside, floor and ceiling are seen only at grazing angles.
  r.camera = {{0.5, 0.15, 0.95}, {0.5, 0.15, 0.0}, 70};
  rooms.push_back(r);
  return rooms;
}

// The corners of box [lo, hi] in level_description.h order (x + 2y + 4z).
std::array<glm::dvec3, 8> box_corners(const glm::dvec3& lo, const glm::dvec3& hi) {
  std::array<glm::dvec3, 8> c{};
  for (int k = 0; k < 8; ++k)
    c[std::size_t(k)] = lo + (hi - lo) * glm::dvec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
  return c;
}

LevelDescription room_level(const Room& room, const std::string& suffix) {
  LevelDescription d;
  d.name = room.key + suffix;
  d.cell_size = 1.0;
  d.lights = {room.light};
  return d;
}

// (A) One block at cell (0,0,0) warped onto the whole room: the stretched block.
LevelDescription one_block_proxy(const Room& room) {
  LevelDescription d = room_level(room, "-one-block");
  BlockDescription b;
  b.faces = room.faces;
  b.warped = true;
  b.corners = box_corners(glm::dvec3(0.0), room.size);
  b.albedo = room.albedo;
  b.name = "room";
  d.blocks.push_back(b);
  return d;
}

// (B) The room cut into room.cells boxes (unit cubes for the rooms above); faces inside the
// room are missing on both sides, so the cells connect; walls on the room's boundary are
// the room's.
LevelDescription multi_block_proxy(const Room& room) {
  LevelDescription d = room_level(room, "-blocks");
  const glm::dvec3 step = room.size / glm::dvec3(room.cells);
  for (int z = 0; z < room.cells.z; ++z)
    for (int y = 0; y < room.cells.y; ++y)
      for (int x = 0; x < room.cells.x; ++x) {
        const glm::ivec3 cell(x, y, z);
        const bool on_boundary[kFaceCount] = {x == 0, x == room.cells.x - 1, y == 0, y == room.cells.y - 1,
                                              z == 0, z == room.cells.z - 1};
        BlockDescription b;
        b.cell = cell;
        b.faces = 0;
        for (int f = 0; f < kFaceCount; ++f)
          if (on_boundary[f] && face_present(room.faces, f)) b.faces = FaceMask(b.faces | (1u << f));
        const glm::dvec3 lo = glm::dvec3(cell) * step, hi = lo + step;
        // Grid cubes stay unwarped; other cell boxes are warped onto their part of the room.
        b.warped = step != glm::dvec3(1.0);
        b.corners = box_corners(lo, hi);
        b.albedo = room.albedo;
        b.name = "cell " + std::to_string(x) + "," + std::to_string(y) + "," + std::to_string(z);
        d.blocks.push_back(b);
      }
  return d;
}

// ---------------------------------------------------------------- ground truth

struct Truth {
  std::vector<float> value;  // E_ind / pi, RGB interleaved
  double noise_floor = 0;    // RMS standard error / RMS value (conservative, path_tracer.h)
  int paths = 0;
};

Truth trace_truth(const precompute::LevelScene& scene, const LevelDescription& desc,
                  std::span<const glm::dvec3> positions, std::span<const glm::dvec3> normals, int bounces,
                  int paths, std::uint64_t seed) {
  precompute::PathTracerSettings pts;
  pts.paths = paths;
  pts.bounces = bounces;
  pts.seed = seed;
  // As modrt-bench: light vertices find the lit spots that cosine paths rarely hit.
  pts.light_vertex_sources = precompute::level_light_centres(desc);
  const precompute::IndirectEstimate est =
      precompute::trace_indirect(scene, positions, normals, precompute::level_direct_radiance(scene, desc, 8),
                                 precompute::level_surface_albedo(scene, desc), pts);
  Truth t;
  t.value = est.value;
  t.paths = paths;
  t.noise_floor = precompute::relative_noise_floor(est);
  return t;
}

// Front-facing camera hits on the real room: pixels that see nothing, or the outside of a
// wall, carry no lightmap and are left out.
struct CameraView {
  int pixels = 0, width = 0, height = 0;
  std::vector<glm::dvec3> position, normal;
  std::vector<int> pixel;  // image index (row-major, top row first) of each kept point
};

CameraView camera_view(const precompute::LevelScene& scene, const Camera& cam, int width, int height) {
  const precompute::CameraHits hits = precompute::camera_hits(scene, cam.eye, cam.target, glm::dvec3(0, 1, 0),
                                                              cam.vertical_fov_degrees, width, height);
  CameraView view;
  view.pixels = width * height;
  view.width = width;
  view.height = height;
  for (std::size_t k = 0; k < hits.hit.size(); ++k) {
    const precompute::LevelHit& h = hits.hit[k];
    if (h.block < 0 || h.clutter >= 0) continue;
    // camera_hits turns the normal towards the eye; the wall's own normal points inward.
    if (glm::dot(scene.hit_normal(h), hits.normal[k]) < 0.0) continue;
    view.position.push_back(hits.position[k]);
    view.normal.push_back(hits.normal[k]);
    view.pixel.push_back(int(k));
  }
  return view;
}

// ---------------------------------------------------------------- modrt's values at world points

// A point on a proxy's wall in its lightmap's terms: block, canonical face, face (u, v).
struct FacePoint {
  int block = -1, face = -1;
  double u = 0, v = 0;
};

// Finds the present face of the proxy that holds world point x with inward normal n. The
// proxy's walls are the room's walls, so every camera hit lies on one; -1 when none does.
FacePoint locate(const Level& level, const glm::dvec3& x, const glm::dvec3& n) {
  constexpr double kInside = 1e-4;  // canonical units: slack of the Newton inverse
  FacePoint best;
  double best_distance = kInside;
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& blk = level.blocks[bi];
    const glm::dvec3 p = world_to_block(blk, x);
    if (glm::any(glm::lessThan(p, glm::dvec3(-kInside))) ||
        glm::any(glm::greaterThan(p, glm::dvec3(1 + kInside))))
      continue;
    const FaceMask mask = dictionary_shape_mask(blk.shape);
    const double distance[kFaceCount] = {p.x, 1 - p.x, p.y, 1 - p.y, p.z, 1 - p.z};
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(mask, f) || std::abs(distance[f]) > best_distance) continue;
      const FaceFrame& fr = face_frame(f);
      const double u = std::clamp(glm::dot(p - fr.origin, fr.u_axis), 0.0, 1.0);
      const double v = std::clamp(glm::dot(p - fr.origin, fr.v_axis), 0.0, 1.0);
      // At an edge two faces are as close: the normal tells which one the hit is on.
      if (glm::dot(block_face_normal(blk, f, u, v), n) < 0.5) continue;
      best = {int(bi), f, u, v};
      best_distance = std::abs(distance[f]);
    }
  }
  return best;
}

std::vector<FacePoint> locate_all(const Level& level, const CameraView& view) {
  std::vector<FacePoint> out(view.position.size());
  for (std::size_t k = 0; k < out.size(); ++k) out[k] = locate(level, view.position[k], view.normal[k]);
  return out;
}

// Bilinear lookup of the lightmap over the res x res texels of the point's face (clamped at
// the face's edge texels, as the atlas padding copies them).
glm::dvec3 lightmap_at(const Level& level, std::span<const float> lightmap, const FacePoint& fp) {
  const LevelBlock& blk = level.blocks[std::size_t(fp.block)];
  const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(blk.shape), level.res);
  const precompute::BilinearTaps taps = precompute::bilinear_taps(fp.u, fp.v, level.res);
  glm::dvec3 acc(0.0);
  for (int k = 0; k < 4; ++k) {
    const std::size_t idx = blk.sample_offset + std::size_t(layout.index(fp.face, taps.i[k], taps.j[k]));
    for (int c = 0; c < 3; ++c) acc[c] += taps.w[k] * lightmap[3 * idx + std::size_t(c)];
  }
  return acc;
}

std::vector<float> lightmap_at_points(const Level& level, std::span<const float> lightmap,
                                      std::span<const FacePoint> points) {
  std::vector<float> out(3 * points.size(), 0.0f);
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (points[k].block < 0) continue;  // counted as black: locate_all's misses are reported
    const glm::dvec3 v = lightmap_at(level, lightmap, points[k]);
    for (int c = 0; c < 3; ++c) out[3 * k + std::size_t(c)] = float(v[c]);
  }
  return out;
}

// ---------------------------------------------------------------- error measures

double rel_l2(std::span<const float> x, std::span<const float> ref) {
  double num = 0, den = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const double d = double(x[i]) - ref[i];
    num += d * d;
    den += double(ref[i]) * ref[i];
  }
  return den > 0 ? std::sqrt(num / den) : 0.0;
}

// Sum of modrt over sum of the reference (all channels) in the near / middle / far third of
// the room's long axis, near = the low end where the light is. A ratio of sums, not a mean of
// per-pixel ratios: dark pixels would make the latter pure noise.
std::array<double, 3> third_ratios(const Room& room, std::span<const glm::dvec3> positions,
                                   std::span<const float> x, std::span<const float> ref) {
  std::array<double, 3> num{}, den{};
  for (std::size_t k = 0; k < positions.size(); ++k) {
    const double t = positions[k][room.axis] / room.size[room.axis];
    const std::size_t third = std::size_t(std::clamp(int(3.0 * t), 0, 2));
    for (std::size_t c = 0; c < 3; ++c) {
      num[third] += x[3 * k + c];
      den[third] += ref[3 * k + c];
    }
  }
  std::array<double, 3> ratio{};
  for (std::size_t i = 0; i < 3; ++i) ratio[i] = den[i] > 0 ? num[i] / den[i] : 0.0;
  return ratio;
}

// ---------------------------------------------------------------- one proxy, one build setting

struct Row {
  std::string room, proxy, error;
  double build_s = 0;
  double texels_one = 0, texels_converged = 0, camera_one = 0, camera_converged = 0;
  std::array<double, 3> thirds{};
  std::size_t camera_missed = 0;         // camera points that no proxy face holds (should be 0)
  std::vector<float> camera_one_values;  // modrt's one bounce at the camera points (RGB)
};

struct NoiseRow {
  std::string room, points;
  std::size_t count = 0;
  int paths_one = 0, paths_multi = 0;
  double one = 0, multi = 0;
};

struct Options {
  int res = 6;
  int paths = 256;        // paths per point, one bounce
  int paths_multi = 256;  // paths per point, 16 bounces
  int bounces_multi = 16;
  int width = 96, height = 64;
  std::string cache_dir, markdown, images;
  std::vector<std::string> rooms;
  const Matrix* interface_basis = nullptr;  // the dictionary's Hrlf: connected shaped blocks
};

// The references one room needs, traced once and shared by its proxies and build settings.
struct RoomTruth {
  const precompute::LevelScene* scene = nullptr;  // the real room (the one-block proxy's walls)
  const LevelDescription* desc = nullptr;
  CameraView view;
  Truth camera_one, camera_multi;
};

struct ProxyTruth {
  std::vector<glm::dvec3> position;  // the proxy's lightmap texels
  Truth one, multi;
};

ProxyTruth trace_proxy_texels(const Options& opt, const RoomTruth& rt, const Level& level,
                              std::vector<NoiseRow>& noise, const std::string& room,
                              const std::string& label) {
  const LevelSampleGeometry g = level_sample_geometry(level);
  ProxyTruth pt;
  pt.position = g.position;
  pt.one = trace_truth(*rt.scene, *rt.desc, g.position, g.normal, 1, opt.paths, 11);
  pt.multi = trace_truth(*rt.scene, *rt.desc, g.position, g.normal, opt.bounces_multi, opt.paths_multi, 12);
  noise.push_back(NoiseRow{room, label + " texels", g.position.size(), opt.paths, opt.paths_multi,
                           pt.one.noise_floor, pt.multi.noise_floor});
  return pt;
}

// Builds one proxy with one setting, runs modrt (one bounce, converged) and measures it.
// exact: in place of modrt, the proxy's dense F ld by ray tracing (no low rank, no prior):
// what the proxy's texel grid and ld sampling alone allow, the floor under any operator.
Row measure(const Room& room, const LevelDescription& desc, const Dictionary& dict, bool shaped, bool exact,
            const std::string& proxy_label, const RoomTruth& rt, const ProxyTruth& pt,
            const Matrix* interface_basis = nullptr) {
  Row row;
  row.room = room.name;
  row.proxy = proxy_label;
  precompute::LevelBuildSettings bs;
  bs.shaped_operators = shaped;
  bs.interface_basis = interface_basis;
  const auto t0 = Clock::now();
  Result<Level> built = precompute::build_level(desc, dict, bs);
  row.build_s = seconds_since(t0);
  if (!built.ok()) {
    row.error = "build_level: " + built.status().to_string();
    return row;
  }
  const Level& level = built.value();
  const LevelSampleGeometry g = level_sample_geometry(level);
  if (g.position != pt.position) {
    row.error = "this build's lightmap texels differ from the cube-operator build's";
    return row;
  }
  const precompute::LevelScene scene(level, 2);
  const std::vector<float> albedo = level_sample_albedo(level);
  const std::vector<float> ld = precompute::level_direct_light(scene, desc.lights, albedo, 16);
  const LevelBufferSizes sz = level_buffer_sizes(level, dict);
  std::vector<float> b(sz.b), r(sz.r), one(sz.lightmap), converged(sz.lightmap);
  if (Status st = level_evaluate(level, dict, ld, b, r, one); !st.ok()) {
    row.error = "level_evaluate: " + st.to_string();
    return row;
  }
  Result<ConvergedBounceReport> conv = level_converged_bounce(level, dict, ld, albedo, {}, b, r, converged);
  if (!conv.ok()) {
    row.error = "level_converged_bounce: " + conv.status().to_string();
    return row;
  }
  if (exact) {
    constexpr int kRays = 4096, kBounces = 16;
    one = precompute::level_one_bounce(scene, ld, kRays, 31);
    std::vector<float> feed = ld;
    converged = one;
    for (int k = 1; k < kBounces; ++k) {
      for (std::size_t i = 0; i < feed.size(); ++i) feed[i] = ld[i] + albedo[i] * converged[i];
      converged = precompute::level_one_bounce(scene, feed, kRays, 32 + std::uint64_t(k));
    }
  }
  row.texels_one = rel_l2(one, pt.one.value);
  row.texels_converged = rel_l2(converged, pt.multi.value);

  const std::vector<FacePoint> fps = locate_all(level, rt.view);
  row.camera_missed =
      std::size_t(std::count_if(fps.begin(), fps.end(), [](const FacePoint& f) { return f.block < 0; }));
  const std::vector<float> cam_one = lightmap_at_points(level, one, fps);
  const std::vector<float> cam_conv = lightmap_at_points(level, converged, fps);
  row.camera_one = rel_l2(cam_one, rt.camera_one.value);
  row.camera_converged = rel_l2(cam_conv, rt.camera_multi.value);
  row.thirds = third_ratios(room, rt.view.position, cam_one, rt.camera_one.value);
  row.camera_one_values = cam_one;
  return row;
}

// ---------------------------------------------------------------- pictures

// One bounce through the camera, left to right: the path tracer, then the rows of `proxies`
// (two: cube operators, shaped operators). One exposure for all three (the truth's 99th
// percentile at 0.8), pixels that see no wall black.
Status write_camera_strip(const Options& opt, const Room& room, const RoomTruth& rt,
                          const std::vector<Row>& rows, const std::array<std::string, 2>& proxies,
                          const std::string& file) {
  const CameraView& v = rt.view;
  std::vector<const std::vector<float>*> panels = {&rt.camera_one.value};
  for (const std::string& proxy : proxies)
    for (const Row& r : rows)
      if (r.room == room.name && r.proxy == proxy && r.camera_one_values.size() == rt.camera_one.value.size())
        panels.push_back(&r.camera_one_values);
  if (panels.size() != 3)
    return Status::error(ErrorCode::internal_error, room.name + ": missing camera values");
  std::vector<float> sorted = rt.camera_one.value;
  std::sort(sorted.begin(), sorted.end());
  const float p99 = sorted.empty() ? 1.0f : sorted[sorted.size() * 99 / 100];
  const int w = v.width, h = v.height, gap = 4, strip_w = 3 * w + 2 * gap;
  std::vector<float> linear(std::size_t(strip_w) * std::size_t(h) * 3, 0.0f);
  for (std::size_t p = 0; p < panels.size(); ++p)
    for (std::size_t i = 0; i < v.pixel.size(); ++i) {
      const int x = v.pixel[i] % w + int(p) * (w + gap), y = v.pixel[i] / w;
      for (int c = 0; c < 3; ++c)
        linear[(std::size_t(y) * std::size_t(strip_w) + std::size_t(x)) * 3 + std::size_t(c)] =
            (*panels[p])[3 * i + std::size_t(c)];
    }
  std::vector<std::uint8_t> rgb(linear.size());
  demo::encode_srgb8(linear, p99 > 0.0f ? 0.8f / p99 : 1.0f, rgb);
  // Each camera pixel as a 3 x 3 block, to be seen in the docs (no detail is added).
  constexpr int kZoom = 3;
  std::vector<std::uint8_t> big(rgb.size() * kZoom * kZoom);
  for (int y = 0; y < h * kZoom; ++y)
    for (int x = 0; x < strip_w * kZoom; ++x)
      for (int c = 0; c < 3; ++c)
        big[(std::size_t(y) * std::size_t(strip_w * kZoom) + std::size_t(x)) * 3 + std::size_t(c)] =
            rgb[(std::size_t(y / kZoom) * std::size_t(strip_w) + std::size_t(x / kZoom)) * 3 +
                std::size_t(c)];
  return demo::write_rgb8_image(opt.images + "/" + file, strip_w * kZoom, h * kZoom, big);
}

// ---------------------------------------------------------------- one room

Status run_room(const Options& opt, const Room& room, const Dictionary& dict, std::vector<Row>& rows,
                std::vector<NoiseRow>& noise) {
  const auto t0 = Clock::now();
  std::fprintf(stderr, "%s: ", room.name.c_str());
  const LevelDescription desc_one = one_block_proxy(room);
  // The one-block proxy's walls are the room's: its cube-operator build is the real geometry.
  precompute::LevelBuildSettings cube;
  cube.shaped_operators = false;
  Result<Level> real = precompute::build_level(desc_one, dict, cube);
  if (!real.ok()) return Status::error(real.status().code(), room.name + ": " + real.status().to_string());
  const precompute::LevelScene real_scene(real.value(), 2);

  RoomTruth rt;
  rt.scene = &real_scene;
  rt.desc = &desc_one;
  rt.view = camera_view(real_scene, room.camera, opt.width, opt.height);
  rt.camera_one = trace_truth(real_scene, desc_one, rt.view.position, rt.view.normal, 1, opt.paths, 21);
  rt.camera_multi = trace_truth(real_scene, desc_one, rt.view.position, rt.view.normal, opt.bounces_multi,
                                opt.paths_multi, 22);
  noise.push_back(NoiseRow{
      room.name,
      "camera (" + std::to_string(rt.view.position.size()) + " of " + std::to_string(rt.view.pixels) + " px)",
      rt.view.position.size(), opt.paths, opt.paths_multi, rt.camera_one.noise_floor,
      rt.camera_multi.noise_floor});
  std::fprintf(stderr, "camera truth %.0f s; ", seconds_since(t0));

  struct Proxy {
    LevelDescription desc;
    std::string label;
  };
  std::vector<Proxy> proxies = {{desc_one, "1 block"}};
  if (room.cells.x > 0) {
    const int n = room.cells.x * room.cells.y * room.cells.z;
    proxies.push_back({multi_block_proxy(room), std::to_string(n) + " blocks"});
  }
  if (room.coarse_cells.x > 0) {
    Room coarse = room;
    coarse.cells = room.coarse_cells;
    const int n = coarse.cells.x * coarse.cells.y * coarse.cells.z;
    proxies.push_back({multi_block_proxy(coarse), std::to_string(n) + " stretched blocks"});
  }
  for (const Proxy& p : proxies) {
    // Texel positions come from the cube-operator build; measure() checks the shaped one's.
    Result<Level> geometry = precompute::build_level(p.desc, dict, cube);
    if (!geometry.ok())
      return Status::error(geometry.status().code(),
                           room.name + " " + p.label + ": " + geometry.status().to_string());
    const ProxyTruth pt = trace_proxy_texels(opt, rt, geometry.value(), noise, room.name, p.label);
    for (const bool shaped : {false, true}) {
      rows.push_back(measure(room, p.desc, dict, shaped, false,
                             p.label + (shaped ? ", shaped ops" : ", cube ops"), rt, pt));
      if (!rows.back().error.empty())
        std::fprintf(stderr, "\n  %s: %s\n", rows.back().proxy.c_str(), rows.back().error.c_str());
    }
    if (p.label.ends_with("stretched blocks") && opt.interface_basis)  // connected: traced interfaces
      rows.push_back(measure(room, p.desc, dict, true, false, p.label + ", shaped ops, traced interfaces", rt,
                             pt, opt.interface_basis));
    rows.push_back(measure(room, p.desc, dict, false, true, p.label + ", exact F ld (texel floor)", rt, pt));
  }
  std::fprintf(stderr, "done in %.0f s\n", seconds_since(t0));
  if (opt.images.empty()) return Status::success();
  if (Status s = write_camera_strip(opt, room, rt, rows, {"1 block, cube ops", "1 block, shaped ops"},
                                    "proportions-" + room.key + ".png");
      !s.ok())
    return s;
  // The coarse proxy's connected stretched blocks: cube operators, then traced interfaces.
  if (room.coarse_cells.x > 0 && opt.interface_basis) {
    const std::string coarse =
        std::to_string(room.coarse_cells.x * room.coarse_cells.y * room.coarse_cells.z) + " stretched blocks";
    return write_camera_strip(opt, room, rt, rows,
                              {coarse + ", cube ops", coarse + ", shaped ops, traced interfaces"},
                              "proportions-" + room.key + "-connected.png");
  }
  return Status::success();
}

// ---------------------------------------------------------------- report

std::string results_table(const std::vector<Row>& rows) {
  std::ostringstream o;
  o << "| room | proxy | texels 1 bounce | texels converged | camera 1 bounce | camera converged | "
       "near / mid / far (camera, 1 bounce) | build s |\n"
       "|---|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    o << "| " << r.room << " | " << r.proxy << " | ";
    if (!r.error.empty()) {
      o << r.error << " | | | | | " << fmt("%.2f", r.build_s) << " |\n";
      continue;
    }
    o << fmt("%.3f", r.texels_one) << " | " << fmt("%.3f", r.texels_converged) << " | "
      << fmt("%.3f", r.camera_one) << " | " << fmt("%.3f", r.camera_converged) << " | "
      << fmt("%.2f", r.thirds[0]) << " / " << fmt("%.2f", r.thirds[1]) << " / " << fmt("%.2f", r.thirds[2])
      << (r.camera_missed ? " (" + std::to_string(r.camera_missed) + " px unmapped)" : std::string()) << " | "
      << fmt("%.2f", r.build_s) << " |\n";
  }
  return o.str();
}

const Row* find_row(const std::vector<Row>& rows, const std::string& room, const std::string& prefix,
                    const std::string& suffix) {
  for (const Row& r : rows)
    if (r.room == room && r.error.empty() && r.proxy.starts_with(prefix) && r.proxy.ends_with(suffix))
      return &r;
  return nullptr;
}

// Per room, the one block with shaped operators against the N unit blocks with cube operators
// (the proxy a cube dictionary is made for) and against the same block with cube operators:
// error ratios, below 1 where the shaped block is better.
std::string ratio_table(const std::vector<Row>& rows, const std::vector<Room>& rooms) {
  std::ostringstream o;
  o << "| room | vs N blocks: texels 1 bounce | texels converged | camera 1 bounce | camera converged | "
       "vs 1 block cube ops: camera 1 bounce | camera converged |\n"
       "|---|---|---|---|---|---|---|\n";
  auto ratio = [](const Row* a, const Row* b, double Row::*error) {
    return a && b && b->*error > 0 ? fmt("%.2f", a->*error / b->*error) : std::string("n/a");
  };
  for (const Room& room : rooms) {
    const Row* shaped = find_row(rows, room.name, "1 block", "shaped ops");
    const Row* cube = find_row(rows, room.name, "1 block", "cube ops");
    const std::string n_blocks = std::to_string(room.cells.x * room.cells.y * room.cells.z) + " blocks";
    const Row* multi = room.cells.x > 0 ? find_row(rows, room.name, n_blocks, "cube ops") : nullptr;
    o << "| " << room.name << " | " << ratio(shaped, multi, &Row::texels_one) << " | "
      << ratio(shaped, multi, &Row::texels_converged) << " | " << ratio(shaped, multi, &Row::camera_one)
      << " | " << ratio(shaped, multi, &Row::camera_converged) << " | "
      << ratio(shaped, cube, &Row::camera_one) << " | " << ratio(shaped, cube, &Row::camera_converged)
      << " |\n";
  }
  return o.str();
}

// Per room with a coarse proxy: its stretched blocks with traced interfaces against the N
// unit blocks and against the same blocks with cube operators.
std::string connected_ratio_table(const std::vector<Row>& rows, const std::vector<Room>& rooms) {
  std::ostringstream o;
  o << "| room | proxy | vs N blocks: camera 1 bounce | camera converged | vs the same blocks, cube ops: "
       "camera 1 "
       "bounce | camera converged |\n|---|---|---|---|---|---|\n";
  auto ratio = [](const Row* a, const Row* b, double Row::*error) {
    return a && b && b->*error > 0 ? fmt("%.2f", a->*error / b->*error) : std::string("n/a");
  };
  for (const Room& room : rooms) {
    if (room.coarse_cells.x == 0 || room.cells.x == 0) continue;
    const std::string coarse =
        std::to_string(room.coarse_cells.x * room.coarse_cells.y * room.coarse_cells.z) + " stretched blocks";
    const Row* traced = find_row(rows, room.name, coarse, "traced interfaces");
    const Row* cube = find_row(rows, room.name, coarse, "cube ops");
    const Row* multi = find_row(
        rows, room.name, std::to_string(room.cells.x * room.cells.y * room.cells.z) + " blocks", "cube ops");
    o << "| " << room.name << " | " << coarse << " | " << ratio(traced, multi, &Row::camera_one) << " | "
      << ratio(traced, multi, &Row::camera_converged) << " | " << ratio(traced, cube, &Row::camera_one)
      << " | " << ratio(traced, cube, &Row::camera_converged) << " |\n";
  }
  return o.str();
}

std::string noise_table(const std::vector<NoiseRow>& noise, int bounces_multi) {
  std::ostringstream o;
  o << "| room | points | count | paths (1 / " << bounces_multi << " bounces) | noise floor 1 bounce | "
    << "noise floor " << bounces_multi << " bounces |\n|---|---|---|---|---|---|\n";
  for (const NoiseRow& n : noise)
    o << "| " << n.room << " | " << n.points << " | " << n.count << " | " << n.paths_one << " / "
      << n.paths_multi << " | " << fmt("%.4f", n.one) << " | " << fmt("%.4f", n.multi) << " |\n";
  return o.str();
}

std::string report(const Options& opt, const std::string& command, const std::string& dict_name,
                   const std::vector<Room>& rooms, const std::vector<Row>& rows,
                   const std::vector<NoiseRow>& noise, double total_s) {
  std::ostringstream o;
  o << "# Blocks that are not cubes: modrt against the path tracer\n\n"
    << "`" << command << "`: dictionary `" << dict_name << "`, " << fmt("%.0f", total_s) << " s.\n\n"
    << "Relative L2 over points and channels against `trace_indirect` on the real room (1 bounce, and "
    << opt.bounces_multi
    << " path segments against modrt's converged multi-bounce `level_converged_bounce`); "
    << "texels: the proxy's lightmap texels; camera: " << opt.width << "x" << opt.height
    << " pixels into the room through its open +Z face, modrt = bilinear lookup of the proxy's lightmap "
       "on the hit's face. near / mid / far: sum of modrt over sum of the reference in thirds of the "
       "room's long axis, near = the light's end. Cube ops: `shaped_operators = false`; shaped ops: true "
       "(without an interface basis only blocks that connect to no other block get them); traced interfaces: "
       "with "
       "the dictionary's interface basis (`interface_basis`), connected blocks too, their R, Rb->rlf and "
       "response traced in their box. Exact F ld: "
       "the proxy's dense one-bounce operator by ray tracing (16 bounces by iteration), the floor its texels "
       "and ld sampling allow.\n\n"
    << results_table(rows) << "\n## One block with shaped operators over the other proxies\n\n"
    << "Error ratios; below 1: the stretched block with its own operators is better.\n\n"
    << ratio_table(rows, rooms)
    << "\n## Connected stretched blocks with traced interfaces over the other proxies\n\n"
    << "The coarse proxy's blocks (e.g. two 1.5 x 1 x 1 blocks for the long room), connected through "
       "interfaces traced in their boxes; error ratios.\n\n"
    << connected_ratio_table(rows, rooms) << "\n## Ground-truth noise floors\n\n"
    << "RMS standard error / RMS value (conservative: the first direction is stratified).\n\n"
    << noise_table(noise, opt.bounces_multi);
  return o.str();
}

// ---------------------------------------------------------------- level build time

// maze_level(blocks) on a rectilinear, non-uniform grid (what a scene importer produces):
// random widths per grid column, depths per grid row and one height, each in [0.5, 2], so
// that nearly every block has proportions of its own. Neighbours share their faces exactly.
Result<LevelDescription> random_proportion_maze(int blocks, std::uint64_t seed) {
  Result<LevelDescription> maze = precompute::maze_level(blocks);
  if (!maze.ok()) return maze;
  LevelDescription d = std::move(maze).value();
  glm::ivec3 lo(1 << 30), hi(-(1 << 30));
  for (const BlockDescription& b : d.blocks) lo = glm::min(lo, b.cell), hi = glm::max(hi, b.cell);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> size(0.5, 2.0);
  auto edges = [&](int count) {
    std::vector<double> e(std::size_t(count) + 1, 0.0);
    for (int i = 1; i <= count; ++i) e[std::size_t(i)] = e[std::size_t(i) - 1] + size(rng);
    return e;
  };
  const std::vector<double> x = edges(hi.x - lo.x + 1), z = edges(hi.z - lo.z + 1);
  const double height = size(rng);
  for (BlockDescription& b : d.blocks) {
    const glm::ivec3 c = b.cell - lo;
    b.warped = true;
    for (int k = 0; k < 8; ++k)
      b.corners[std::size_t(k)] = {x[std::size_t(c.x + (k & 1))] + lo.x, ((k >> 1) & 1) * height,
                                   z[std::size_t(c.z + ((k >> 2) & 1))] + lo.z};
  }
  for (LightDescription& l : d.lights)
    l.position = d.blocks[0].corners[0] + glm::dvec3(0.3, 0.3 * height, 0.3);
  return d;
}

// A level file's blocks as they are (the warped maze): cube against shaped operators at the
// level's own texels, against the path tracer on its geometry.
int run_level(const Options& opt, const std::string& path, const Dictionary& dict) {
  Result<LevelDescription> d = precompute::load_level_json(path);
  if (!d.ok()) {
    std::fprintf(stderr, "modrt-proportion-accuracy: %s\n", d.status().to_string().c_str());
    return 1;
  }
  if (d->lights.empty()) {  // every error would be 0 / 0
    std::fprintf(stderr, "modrt-proportion-accuracy: %s: lights: the level has none, nothing to compare\n",
                 path.c_str());
    return 1;
  }
  precompute::LevelBuildSettings cube;
  cube.shaped_operators = false;
  Result<Level> real = precompute::build_level(d.value(), dict, cube);
  if (!real.ok()) {
    std::fprintf(stderr, "modrt-proportion-accuracy: %s\n", real.status().to_string().c_str());
    return 1;
  }
  const precompute::LevelScene scene(real.value(), 2);
  const LevelSampleGeometry g = level_sample_geometry(real.value());
  const Truth one = trace_truth(scene, d.value(), g.position, g.normal, 1, opt.paths, 41);
  const Truth multi =
      trace_truth(scene, d.value(), g.position, g.normal, opt.bounces_multi, opt.paths_multi, 42);
  std::printf(
      "| level | operators | shaped sets | texels 1 bounce | texels converged | noise floor 1 / %d |\n"
      "|---|---|---|---|---|---|\n",
      opt.bounces_multi);
  for (const bool shaped : {false, true}) {
    precompute::LevelBuildSettings bs;
    bs.shaped_operators = shaped;
    bs.interface_basis = opt.interface_basis;  // connected blocks too, their interfaces traced
    Result<Level> level = precompute::build_level(d.value(), dict, bs);
    if (!level.ok()) {
      std::fprintf(stderr, "modrt-proportion-accuracy: %s\n", level.status().to_string().c_str());
      return 1;
    }
    const std::vector<float> albedo = level_sample_albedo(level.value());
    const std::vector<float> ld = precompute::level_direct_light(scene, d->lights, albedo, 16);
    const LevelBufferSizes sz = level_buffer_sizes(level.value(), dict);
    std::vector<float> b(sz.b), r(sz.r), lm_one(sz.lightmap), lm_conv(sz.lightmap);
    if (!level_evaluate(level.value(), dict, ld, b, r, lm_one).ok() ||
        !level_converged_bounce(level.value(), dict, ld, albedo, {}, b, r, lm_conv).ok()) {
      std::fprintf(stderr, "modrt-proportion-accuracy: evaluation failed\n");
      return 1;
    }
    std::printf("| %s | %s | %zu | %.3f | %.3f | %.3f / %.3f |\n", path.c_str(), shaped ? "shaped" : "cube",
                level->shaped.size(), rel_l2(lm_one, one.value), rel_l2(lm_conv, multi.value),
                one.noise_floor, multi.noise_floor);
  }
  return 0;
}

int run_build_time(int blocks, const Dictionary& dict, const Matrix& basis, const std::string& dict_name,
                   int steps) {
  Result<LevelDescription> d = random_proportion_maze(blocks, 7);
  if (!d.ok()) {
    std::fprintf(stderr, "modrt-proportion-accuracy: %s\n", d.status().to_string().c_str());
    return 1;
  }
  precompute::ShapedOperatorCache cache;
  precompute::LevelBuildSettings settings;
  settings.shaped_cache = &cache;
  settings.proportion_steps_per_octave = steps;
  settings.interface_basis = &basis;  // every block of the maze connects: bake them all
  double seconds[3] = {0, 0, 0};
  std::size_t sets = 0, runtime_floats = 0, dictionary_floats = 0;
  for (const ShapeOperators& op : dict.shapes)
    dictionary_floats +=
        op.Ub.data.size() + op.Td_b.data.size() + op.Ub_vec.data.size() + op.Ubvol.data.size();
  for (int pass = 0; pass < 3; ++pass) {
    settings.shaped_operators = pass > 0;
    const auto t0 = Clock::now();
    Result<Level> level = precompute::build_level(d.value(), dict, settings);
    seconds[pass] = seconds_since(t0);
    if (!level.ok()) {
      std::fprintf(stderr, "modrt-proportion-accuracy: %s\n", level.status().to_string().c_str());
      return 1;
    }
    sets = level->shaped.size();
    // What a backend uploads per set: Ub, Td_b, Ub_vec, Ubvol (Limp only feeds the DRT build).
    runtime_floats = 0;
    for (const ShapedOperators& so : level->shaped)
      runtime_floats += so.operators.Ub.data.size() + so.operators.Td_b.data.size() +
                        so.operators.Ub_vec.data.size() + so.operators.Ubvol.data.size();
  }
  constexpr double kMiB = 1024.0 * 1024.0;
  std::printf("| %zu | %s | %d | %zu | %.2f | %.1f | %.2f | %.1f / %.1f | %.1f |\n", d->blocks.size(),
              dict_name.c_str(), steps, sets, seconds[0], seconds[1], seconds[2],
              4.0 * double(runtime_floats) / kMiB, 2.0 * double(runtime_floats) / kMiB,
              4.0 * double(dictionary_floats) / kMiB);
  return 0;
}

// How much of one stretched block's error is its mode count: the 3 x 1 x 1 box (the long
// side open) baked at kb = 32, 64, 96 (kd = 2 kb, 4096 rays), one bounce Ub Td_b ld at its
// own samples against its exact F ld, for a light near one end and one mid-room.
int run_rank_study(int res) {
  const double g = std::cbrt(3.0);
  const glm::dvec3 extent(3.0 / g, 1.0 / g, 1.0 / g);
  const FaceMask mask = dictionary_shape_mask(1);
  const glm::dvec3 lights[2] = {{0.13, 0.6, 0.5}, {0.5, 0.3, 0.4}};  // canonical coordinates
  std::printf("| res | kb | kd | light near one end | light mid-room |\n|---|---|---|---|---|\n");
  for (const std::uint32_t kb : {32u, 64u, 96u}) {
    DictionarySettings s;
    s.res = std::uint32_t(res);
    s.kb = kb;
    s.kd = 2 * kb;
    s.rays = 4096;
    const precompute::ShapeBake b = precompute::bake_box_shape(mask, extent, s, false);
    const precompute::BlockScene scene(mask, extent);
    std::printf("| %d | %u | %u |", res, kb, s.kd);
    Eigen::VectorXd ld(b.layout.sample_count());
    for (const glm::dvec3& c : lights) {
      precompute::SphereLight light;
      light.center = scene.point(c);
      precompute::direct_light(scene, b.layout, light, 16,
                               std::span<double>(ld.data(), std::size_t(ld.size())));
      const Eigen::VectorXd exact = b.F * ld;
      const Eigen::VectorXd mrt = b.transfer.Ub * (b.transfer.Td_b * ld);
      std::printf(" %.4f |", (mrt - exact).norm() / exact.norm());
    }
    std::printf("\n");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modrt-proportion-accuracy: stretched blocks vs unit-cube proxies against the path tracer"};
  Options opt;
  opt.cache_dir = precompute::default_cache_dir();
  app.add_option("--res", opt.res, "dictionary resolution: 6 (fast) or 16 (full quality)")
      ->check(CLI::IsMember({6, 16}))
      ->capture_default_str();
  app.add_option("--markdown", opt.markdown, "also write the report to this Markdown file");
  app.add_option("--paths", opt.paths, "ground-truth paths per point, one bounce")
      ->check(CLI::Range(1, 65536))
      ->capture_default_str();
  app.add_option("--paths-multi", opt.paths_multi, "ground-truth paths per point, multi-bounce")
      ->check(CLI::Range(1, 65536))
      ->capture_default_str();
  app.add_option("--cache-dir", opt.cache_dir, "dictionary cache directory")->capture_default_str();
  app.add_option("--rooms", opt.rooms, "only these rooms (long, long2, corridor, room, slab)");
  app.add_option(
      "--images", opt.images,
      "also write per room a PNG of the camera's one bounce: path tracer | one block, cube "
      "operators | one block, shaped operators (proportions-<room>.png); for rooms with a proxy of "
      "connected stretched blocks also path tracer | those with cube operators | with traced "
      "interfaces (proportions-<room>-connected.png)");
  int build_time_blocks = 0, steps = 8;
  std::string level_file;
  app.add_option("--level", level_file,
                 "instead: a level JSON as it is (e.g. data/levels/maze11_warped.json), cube against shaped "
                 "operators at its texels");
  app.add_option("--build-time", build_time_blocks,
                 "instead: time build_level on a maze of this many blocks of random proportions (cube "
                 "operators, shaped operators cold, then again from the cache)")
      ->check(CLI::Range(1, 100000));
  bool rank_study = false;
  app.add_flag(
      "--rank-study", rank_study,
      "instead: one 3 x 1 x 1 block's one-bounce reduction error (Ub Td_b ld against its exact F ld) "
      "at kb 32, 64, 96, at --res");
  app.add_option("--steps", steps, "proportion_steps_per_octave for --build-time")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  std::string command = "modrt-proportion-accuracy";
  for (int i = 1; i < argc; ++i) command += std::string(" ") + argv[i];

  if (rank_study) return run_rank_study(opt.res);
  std::vector<Room> rooms = make_rooms();
  if (!opt.rooms.empty()) {
    std::erase_if(rooms, [&](const Room& r) {
      return std::find(opt.rooms.begin(), opt.rooms.end(), r.key) == opt.rooms.end();
    });
    if (rooms.empty()) {
      std::fprintf(stderr, "modrt-proportion-accuracy: --rooms matched no room\n");
      return 2;
    }
  }

  // modrt-bench's presets: the default settings at res 16, the same at the mobile res 6.
  DictionarySettings ds;
  ds.res = std::uint32_t(opt.res);
  const std::string dict_name = precompute::cache_file_name(ds);
  std::fprintf(stderr, "dictionary %s (loading or baking in %s)\n", dict_name.c_str(), opt.cache_dir.c_str());
  Result<Dictionary> dict = precompute::load_or_bake_dictionary(
      ds, opt.cache_dir, {}, [](const std::string& m) { std::fprintf(stderr, "%s\n", m.c_str()); });
  if (!dict.ok()) {
    std::fprintf(stderr, "modrt-proportion-accuracy: dictionary: %s\n", dict.status().to_string().c_str());
    return 1;
  }

  Result<Matrix> basis = precompute::load_or_bake_interface_basis(
      ds, opt.cache_dir, {}, [](const std::string& m) { std::fprintf(stderr, "%s\n", m.c_str()); });
  if (!basis.ok()) {
    std::fprintf(stderr, "modrt-proportion-accuracy: interface basis: %s\n",
                 basis.status().to_string().c_str());
    return 1;
  }
  opt.interface_basis = &basis.value();
  if (!level_file.empty()) return run_level(opt, level_file, dict.value());
  if (build_time_blocks > 0) {
    std::printf(
        "| blocks | dictionary | steps per octave | shaped sets | build s, cube operators | build s, "
        "shaped cold | build s, shaped from the cache | shaped operators MiB, float32 / float16 | "
        "dictionary shapes MiB, float32 |\n|---|---|---|---|---|---|---|---|---|\n");
    return run_build_time(build_time_blocks, dict.value(), basis.value(), dict_name, steps);
  }
  const auto start = Clock::now();
  std::vector<Row> rows;
  std::vector<NoiseRow> noise;
  try {
    for (const Room& room : rooms)
      if (Status st = run_room(opt, room, dict.value(), rows, noise); !st.ok()) {
        std::fprintf(stderr, "modrt-proportion-accuracy: %s\n", st.to_string().c_str());
        return 1;
      }
  } catch (const std::exception& e) {  // LevelScene and trace_indirect throw
    std::fprintf(stderr, "modrt-proportion-accuracy: %s\n", e.what());
    return 1;
  }
  const std::string text = report(opt, command, dict_name, rooms, rows, noise, seconds_since(start));
  std::fputs(text.c_str(), stdout);
  if (!opt.markdown.empty()) {
    std::ofstream f(opt.markdown);
    f << text;
    if (!f) {
      std::fprintf(stderr, "modrt-proportion-accuracy: cannot write %s\n", opt.markdown.c_str());
      return 1;
    }
  }
  return 0;
}
