// SPDX-License-Identifier: MIT
#include "modrt/precompute/level_scene.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include "embree_rays.h"

#include "modrt/clutter_mesh.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/sampling.h"

namespace modrt::precompute {

namespace {
struct RunBox {
  glm::dvec3 lo, hi;
};
}  // namespace

struct LevelScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  struct Cell {
    int block, face, i, j;
  };
  std::vector<Cell> cells;  // per quad (primID / 2)
  int subdivisions = 1;
  unsigned clutter_geometry = RTC_INVALID_GEOMETRY_ID;
  std::vector<Cell> clutter_cells;  // per clutter quad: block = object, face = box face
  // Mesh clutter: per triangle, block = object and face = the triangle in its mesh; the
  // unit normal of each, and each object's first triangle.
  unsigned clutter_mesh_geometry = RTC_INVALID_GEOMETRY_ID;
  std::vector<Cell> clutter_mesh_cells;
  std::vector<glm::dvec3> clutter_mesh_normals;
  std::vector<std::size_t> clutter_mesh_first;
  // Runs (occluded_from): maximal straight chains of box-shaped blocks joined through missing
  // faces along one world axis; their union is an axis-aligned box with no wall inside it.
  // Per block and world axis, its run, or -1 (a warped block).
  std::vector<RunBox> runs;
  std::vector<std::array<int, 3>> block_runs;
};

namespace {

// Walls of neighbouring blocks coincide back to back; a ray must only see the side facing
// it. Triangles wind so that Ng = (v1 - v0) x (v2 - v0) is the inward normal.
void front_faces_only(const RTCFilterFunctionNArguments* args) {
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const float dot = RTCRayN_dir_x(args->ray, args->N, i) * RTCHitN_Ng_x(args->hit, args->N, i) +
                      RTCRayN_dir_y(args->ray, args->N, i) * RTCHitN_Ng_y(args->hit, args->N, i) +
                      RTCRayN_dir_z(args->ray, args->N, i) * RTCHitN_Ng_z(args->hit, args->N, i);
    if (dot >= 0.0f) args->valid[i] = 0;
  }
}

// One triangle geometry (xyz floats, three indices per triangle) attached to the scene; its id.
unsigned attach_triangles(RTCDevice device, RTCScene scene, const std::vector<float>& vertices,
                          const std::vector<unsigned>& indices, RTCFilterFunctionN filter, const char* what) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), vertices.size() / 3));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), indices.size() / 3));
  if (!vb || !ib) {
    rtcReleaseGeometry(geom);
    throw std::runtime_error(std::string("Embree: cannot allocate ") + what);
  }
  std::copy(vertices.begin(), vertices.end(), vb);
  std::copy(indices.begin(), indices.end(), ib);
  if (filter) rtcSetGeometryIntersectFilterFunction(geom, filter);
  rtcCommitGeometry(geom);
  const unsigned id = rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  return id;
}

// An unwarped block: its corners are those of the box [corners[0], corners[7]].
bool block_box(const LevelBlock& b, glm::dvec3& lo, glm::dvec3& hi) {
  lo = b.corners[0];
  hi = b.corners[7];
  if (!(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z)) return false;
  for (int k = 0; k < 8; ++k)
    if (b.corners[std::size_t(k)] !=
        glm::dvec3((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z))
      return false;
  return true;
}

// The runs of Impl: along each world axis, chains of box blocks whose shared face is missing
// and whose boxes meet exactly (same cross-section).
void build_runs(const Level& level, std::vector<RunBox>& runs, std::vector<std::array<int, 3>>& block_runs) {
  const std::size_t n = level.blocks.size();
  std::vector<RunBox> box(n);
  std::vector<std::uint8_t> is_box(n);
  // Per block and world face: the neighbour through it when the face is missing, else -1.
  std::vector<std::array<int, kFaceCount>> open(n);
  for (std::size_t i = 0; i < n; ++i) {
    const LevelBlock& b = level.blocks[i];
    is_box[i] = block_box(b, box[i].lo, box[i].hi);
    const FaceMask mask = dictionary_shape_mask(b.shape);
    for (int f = 0; f < kFaceCount; ++f)
      open[i][std::size_t(rotate_face(f, b.quarter_turns))] =
          face_present(mask, f) ? -1 : b.neighbour[std::size_t(f)];
  }
  block_runs.assign(n, {-1, -1, -1});
  // The box block through world face w of block i that continues its run, or -1.
  auto next = [&](std::size_t i, int w) -> int {
    const int nb = open[i][std::size_t(w)];
    if (nb < 0 || std::size_t(nb) >= n || !is_box[std::size_t(nb)]) return -1;
    const int a = w / 2;
    const RunBox &p = box[i], &q = box[std::size_t(nb)];
    for (int c = 0; c < 3; ++c)
      if (c != a && (p.lo[c] != q.lo[c] || p.hi[c] != q.hi[c])) return -1;
    const bool meet = (w & 1) ? q.lo[a] == p.hi[a] : q.hi[a] == p.lo[a];
    return meet && open[std::size_t(nb)][std::size_t(w ^ 1)] == int(i) ? nb : -1;
  };
  for (int a = 0; a < 3; ++a)
    for (std::size_t i = 0; i < n; ++i) {
      if (!is_box[i] || block_runs[i][std::size_t(a)] >= 0) continue;
      std::size_t start = i;  // walk to the run's -a end (coordinates strictly decrease: no cycle)
      for (int k; (k = next(start, 2 * a)) >= 0;) start = std::size_t(k);
      const int id = int(runs.size());
      RunBox run = box[start];
      for (int k = int(start); k >= 0; k = next(std::size_t(k), 2 * a + 1)) {
        block_runs[std::size_t(k)][std::size_t(a)] = id;
        run.lo = glm::min(run.lo, box[std::size_t(k)].lo);
        run.hi = glm::max(run.hi, box[std::size_t(k)].hi);
      }
      runs.push_back(run);
    }
}

}  // namespace

LevelScene::LevelScene(const Level& level, int subdivisions)
    : LevelScene(level, subdivisions, std::span<const ClutterObject>{}) {}

LevelScene::LevelScene(const Level& level, int subdivisions, std::span<const ClutterObject> clutter)
    : impl_(std::make_unique<Impl>()),
      level_(level),
      samples_(level_sample_geometry(level)),
      clutter_(clutter.begin(), clutter.end()) {
  impl_->subdivisions = subdivisions;
  // No "threads=N": with Embree's TBB tasking, threads=N installs a process-wide
  // tbb::global_control(max_allowed_parallelism, N) for the device's lifetime, so threads=1
  // made every parallel_for that runs while a LevelScene exists (the DRT build, the path
  // tracer) single-threaded.
  impl_->device = rtcNewDevice("set_affinity=0");
  if (!impl_->device) throw std::runtime_error("Embree: rtcNewDevice failed");
  impl_->scene = rtcNewScene(impl_->device);
  std::vector<float> vertices;
  std::vector<unsigned> indices;
  const int m = subdivisions;
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& b = level.blocks[bi];
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(dictionary_shape_mask(b.shape), f)) continue;
      const unsigned base = unsigned(vertices.size() / 3);
      for (int j = 0; j <= m; ++j)
        for (int i = 0; i <= m; ++i) {
          const glm::dvec3 p = block_to_world(b, face_point(f, double(i) / m, double(j) / m));
          vertices.insert(vertices.end(), {float(p.x), float(p.y), float(p.z)});
        }
      for (int j = 0; j < m; ++j)
        for (int i = 0; i < m; ++i) {
          const unsigned v00 = base + unsigned(j * (m + 1) + i), v10 = v00 + 1, v01 = v00 + unsigned(m + 1),
                         v11 = v01 + 1;
          indices.insert(indices.end(), {v00, v10, v11, v00, v11, v01});
          impl_->cells.push_back({int(bi), f, i, j});
        }
    }
  }
  // An empty level (allowed, docs/level-format.md) has no walls: an empty scene, every ray misses.
  if (!indices.empty())
    attach_triangles(impl_->device, impl_->scene, vertices, indices, front_faces_only, "level geometry");
  std::vector<float> mv;
  std::vector<unsigned> mi;
  impl_->clutter_mesh_first.assign(clutter_.size(), 0);
  for (std::size_t k = 0; k < clutter_.size(); ++k) {
    impl_->clutter_mesh_first[k] = impl_->clutter_mesh_cells.size();
    if (clutter_[k].kind != ClutterKind::mesh || !clutter_[k].mesh) continue;
    const ClutterMesh& mesh = clutter_[k].mesh->mesh;
    const unsigned base = unsigned(mv.size() / 3);
    for (const glm::dvec3& p : mesh.positions) mv.insert(mv.end(), {float(p.x), float(p.y), float(p.z)});
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      mi.insert(mi.end(), {base + mesh.indices[t], base + mesh.indices[t + 1], base + mesh.indices[t + 2]});
      impl_->clutter_mesh_cells.push_back({int(k), int(t / 3), 0, 0});
      const glm::dvec3 &p0 = mesh.positions[mesh.indices[t]], &p1 = mesh.positions[mesh.indices[t + 1]],
                       &p2 = mesh.positions[mesh.indices[t + 2]];
      impl_->clutter_mesh_normals.push_back(glm::normalize(glm::cross(p1 - p0, p2 - p0)));
    }
  }
  if (!mi.empty()) {
    impl_->clutter_mesh_geometry =
        attach_triangles(impl_->device, impl_->scene, mv, mi, nullptr, "clutter mesh geometry");
  }
  const bool any_box = std::any_of(clutter_.begin(), clutter_.end(),
                                   [](const ClutterObject& o) { return o.kind == ClutterKind::box; });
  if (any_box) {
    std::vector<float> cv;
    std::vector<unsigned> ci;
    for (std::size_t k = 0; k < clutter_.size(); ++k)
      for (int f = 0; f < kFaceCount && clutter_[k].kind == ClutterKind::box; ++f) {
        const unsigned base = unsigned(cv.size() / 3);
        for (int j = 0; j <= 1; ++j)
          for (int i = 0; i <= 1; ++i) {
            const glm::dvec3 p = clutter_face_point(clutter_[k].box, f, double(i), double(j));
            cv.insert(cv.end(), {float(p.x), float(p.y), float(p.z)});
          }
        ci.insert(ci.end(), {base, base + 1, base + 3, base, base + 3, base + 2});
        impl_->clutter_cells.push_back({int(k), f, 0, 0});
      }
    impl_->clutter_geometry =
        attach_triangles(impl_->device, impl_->scene, cv, ci, nullptr, "clutter geometry");
  }
  if (clutter_.empty()) build_runs(level, impl_->runs, impl_->block_runs);
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE)
    throw std::runtime_error("Embree: level scene build failed");
}

LevelScene::~LevelScene() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

LevelHit LevelScene::intersect(const glm::dvec3& origin, const glm::dvec3& dir, double t_near) const {
  const RTCRayHit rh = embree_intersect(impl_->scene, origin, dir, t_near);
  return make_hit(rh.hit.geomID, rh.hit.primID, rh.hit.u, rh.hit.v, rh.ray.tfar);
}

void LevelScene::intersect_many(const glm::dvec3& origin, std::span<const glm::dvec3> dirs,
                                std::span<LevelHit> out, double t_near) const {
  constexpr std::size_t W = 8;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  for (std::size_t base = 0; base < dirs.size(); base += W) {
    alignas(32) RTCRayHit8 rh{};
    alignas(32) int valid[W];
    for (std::size_t k = 0; k < W; ++k) {
      const std::size_t i = base + k;
      // Padding lanes and rays that cannot be traced (embree_rays.h) stay invalid: a miss.
      valid[k] = i < dirs.size() && traceable_ray(origin, dirs[i], t_near, 1e30) ? -1 : 0;
      const glm::dvec3 d = valid[k] ? dirs[i] : glm::dvec3(0, 0, 1), o = valid[k] ? origin : glm::dvec3(0.0);
      rh.ray.org_x[k] = float(o.x);
      rh.ray.org_y[k] = float(o.y);
      rh.ray.org_z[k] = float(o.z);
      rh.ray.dir_x[k] = float(d.x);
      rh.ray.dir_y[k] = float(d.y);
      rh.ray.dir_z[k] = float(d.z);
      rh.ray.tnear[k] = float(t_near);
      rh.ray.tfar[k] = 1e30f;
      rh.ray.mask[k] = 0xFFFFFFFFu;
      rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(valid, impl_->scene, &context, &rh);
    for (std::size_t k = 0; k < W && base + k < dirs.size(); ++k)
      out[base + k] = make_hit(rh.hit.geomID[k], rh.hit.primID[k], rh.hit.u[k], rh.hit.v[k], rh.ray.tfar[k]);
  }
}

LevelHit LevelScene::make_hit(unsigned geom_id, unsigned prim_id, float u, float v, float t_far) const {
  LevelHit hit;
  if (geom_id == RTC_INVALID_GEOMETRY_ID) return hit;
  if (geom_id == impl_->clutter_mesh_geometry) {
    const Impl::Cell& c = impl_->clutter_mesh_cells[prim_id];
    hit.clutter = c.block;
    hit.block = clutter_[std::size_t(c.block)].block;
    hit.face = c.face;
    hit.u = u;
    hit.v = v;
    hit.t = t_far;
    return hit;
  }
  const bool on_clutter = geom_id == impl_->clutter_geometry;
  const Impl::Cell& c = on_clutter ? impl_->clutter_cells[prim_id / 2] : impl_->cells[prim_id / 2];
  // Barycentrics of (v00, v10, v11) or (v00, v11, v01) -> position inside the cell.
  double s, t;
  if (prim_id % 2 == 0) {
    s = u + v;
    t = v;
  } else {
    s = u;
    t = u + v;
  }
  if (on_clutter) {
    hit.clutter = c.block;
    hit.block = clutter_[std::size_t(c.block)].block;
    hit.face = c.face;
    hit.u = std::clamp(s, 0.0, 1.0);
    hit.v = std::clamp(t, 0.0, 1.0);
    hit.t = t_far;
    return hit;
  }
  const int m = impl_->subdivisions;
  hit.block = c.block;
  hit.face = c.face;
  hit.u = std::clamp((c.i + s) / m, 0.0, 1.0);
  hit.v = std::clamp((c.j + t) / m, 0.0, 1.0);
  hit.t = t_far;
  return hit;
}

glm::dvec3 LevelScene::hit_normal(const LevelHit& hit) const {
  if (hit.clutter >= 0 && clutter_[std::size_t(hit.clutter)].kind == ClutterKind::mesh)
    return impl_
        ->clutter_mesh_normals[impl_->clutter_mesh_first[std::size_t(hit.clutter)] + std::size_t(hit.face)];
  if (hit.clutter >= 0) return clutter_face_normal(clutter_[std::size_t(hit.clutter)].box, hit.face);
  return block_face_normal(level_.blocks[std::size_t(hit.block)], hit.face, hit.u, hit.v);
}

bool LevelScene::occluded(const glm::dvec3& origin, const glm::dvec3& target, double t_near) const {
  return embree_occluded(impl_->scene, origin, target, t_near);
}

bool LevelScene::occluded_from(int block, const glm::dvec3& origin, const glm::dvec3& target,
                               double t_near) const {
  // Inside one run's box (convex, no wall inside), a segment from a point of the closed box to a
  // point strictly inside it crosses no wall: no ray. The margins (1e-9 of the coordinates) keep
  // targets on or near the box's boundary for Embree.
  if (block >= 0 && std::size_t(block) < impl_->block_runs.size() && traceable(target) && traceable(origin)) {
    for (const int r : impl_->block_runs[std::size_t(block)]) {
      if (r < 0) continue;
      const RunBox& box = impl_->runs[std::size_t(r)];
      bool inside = true;
      for (int a = 0; a < 3 && inside; ++a) {
        const double margin = 1e-9 * (std::abs(box.lo[a]) + std::abs(box.hi[a]) + (box.hi[a] - box.lo[a]));
        inside = target[a] > box.lo[a] + margin && target[a] < box.hi[a] - margin &&
                 origin[a] >= box.lo[a] - margin && origin[a] <= box.hi[a] + margin;
      }
      if (inside) return false;
    }
  }
  return embree_occluded(impl_->scene, origin, target, t_near);
}

std::vector<double> level_texel_areas(const Level& level) {
  std::vector<double> area;
  area.reserve(level.blocks.size());
  for (const LevelBlock& b : level.blocks) area.push_back(block_texel_area(b.corners, level.res));
  return area;
}

std::vector<float> level_direct_light(const LevelScene& scene, std::span<const LightDescription> lights,
                                      std::span<const float> albedo, int light_samples,
                                      const std::function<void(double)>& progress) {
  const LevelSampleGeometry& g = scene.samples();
  const std::size_t n = g.position.size();
  std::vector<float> ld(3 * n, 0.0f);
  const std::vector<double> texel_area = level_texel_areas(scene.level());
  const double total = double(n) * double(lights.size());
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex;
  auto last_report = std::chrono::steady_clock::now();
  for (const LightDescription& light : lights) {
    const SphereLight sphere{light.position, light.radius, light.intensity};
    std::vector<glm::dvec3> points;
    sphere_light_points(light.position, light.radius, light_samples, points);
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& range) {
          for (std::size_t s = range.begin(); s != range.end(); ++s) {
            const int block = g.block[s];
            auto occluded = [&](const glm::dvec3& a, const glm::dvec3& b) {
              return scene.occluded_from(block, a, b);
            };
            const double E_over_pi = sphere_light_E_over_pi(g.position[s], g.normal[s], sphere, points,
                                                            texel_area[std::size_t(g.block[s])], occluded);
            if (E_over_pi <= 0.0) continue;
            for (int c = 0; c < 3; ++c)
              ld[3 * s + std::size_t(c)] +=
                  float(double(albedo[3 * s + std::size_t(c)]) * light.color[c] * E_over_pi);
          }
          const std::size_t now_done = done += range.size();
          if (!progress) return;
          const std::unique_lock lock(progress_mutex, std::try_to_lock);
          const auto now = std::chrono::steady_clock::now();
          if (lock.owns_lock() && now - last_report >= std::chrono::milliseconds(500)) {
            last_report = now;
            progress(double(now_done) / std::max(total, 1.0));
          }
        });
  }
  if (progress) progress(1.0);
  return ld;
}

std::vector<float> level_one_bounce(const LevelScene& scene, std::span<const float> ld, int rays,
                                    std::uint64_t seed) {
  const Level& level = scene.level();
  const LevelSampleGeometry& g = scene.samples();
  const std::size_t n = g.position.size();
  std::vector<float> out(3 * n, 0.0f);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, 8), [&](const tbb::blocked_range<std::size_t>& range) {
        std::vector<glm::dvec2> strata;
        for (std::size_t s = range.begin(); s != range.end(); ++s) {
          Rng rng(seed, s);
          stratified_square(rays, rng, strata);
          // Tangent frame of the warped face at the sample.
          const glm::dvec3 nrm = g.normal[s];
          const glm::dvec3 helper = std::abs(nrm.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
          const glm::dvec3 t = glm::normalize(glm::cross(helper, nrm));
          const glm::dvec3 b = glm::cross(nrm, t);
          double acc[3] = {0, 0, 0};
          for (const glm::dvec2& u : strata) {
            const LevelHit hit = scene.intersect(g.position[s], to_world(cosine_hemisphere(u), t, b, nrm));
            // Clutter has no level ld: this reference sees it as black (DRT's dUc adds its light).
            if (hit.block < 0 || hit.clutter >= 0) continue;
            const LevelBlock& hb = level.blocks[std::size_t(hit.block)];
            const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(hb.shape), level.res);
            const BilinearTaps taps = bilinear_taps(hit.u, hit.v, level.res);
            for (int k = 0; k < 4; ++k) {
              const std::size_t idx =
                  hb.sample_offset + std::size_t(layout.index(hit.face, taps.i[k], taps.j[k]));
              for (int c = 0; c < 3; ++c) acc[c] += taps.w[k] * ld[3 * idx + std::size_t(c)];
            }
          }
          for (int c = 0; c < 3; ++c) out[3 * s + std::size_t(c)] = float(acc[c] / rays);
        }
      });
  return out;
}

}  // namespace modrt::precompute
