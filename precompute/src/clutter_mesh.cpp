// SPDX-License-Identifier: MIT
#include "modrt/precompute/clutter_mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>

#include <embree3/rtcore.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "embree_rays.h"
#include "modrt/precompute/sampling.h"

namespace modrt::precompute {
namespace {

using Polygon = std::vector<glm::dvec2>;

double cross2(const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; }

double polygon_area(const Polygon& p) {
  double a = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) a += cross2(p[i], p[(i + 1) % p.size()]);
  return 0.5 * std::abs(a);
}

// Sutherland–Hodgman: the part of `p` on the side of the line where (q - o)·n >= 0.
Polygon clip(const Polygon& p, const glm::dvec2& o, const glm::dvec2& n) {
  Polygon out;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const glm::dvec2 &a = p[i], &b = p[(i + 1) % p.size()];
    const double da = glm::dot(a - o, n), db = glm::dot(b - o, n);
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

// UV area of a triangle inside the square [x0, x1] x [y0, y1].
double overlap_area(const std::array<glm::dvec2, 3>& t, double x0, double y0, double x1, double y1) {
  Polygon p(t.begin(), t.end());
  p = clip(p, {x0, 0}, {1, 0});
  if (p.size() >= 3) p = clip(p, {x1, 0}, {-1, 0});
  if (p.size() >= 3) p = clip(p, {0, y0}, {0, 1});
  if (p.size() >= 3) p = clip(p, {0, y1}, {0, -1});
  return p.size() >= 3 ? polygon_area(p) : 0.0;
}

// Barycentric coordinates of q in the UV triangle (signed area `area2` = twice its area).
glm::dvec3 barycentric(const std::array<glm::dvec2, 3>& t, double area2, const glm::dvec2& q) {
  const double w0 = cross2(t[1] - q, t[2] - q) / area2;
  const double w1 = cross2(t[2] - q, t[0] - q) / area2;
  return {w0, w1, 1.0 - w0 - w1};
}

glm::dvec2 closest_on_segment(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& q) {
  const glm::dvec2 d = b - a;
  const double t = std::clamp(glm::dot(q - a, d) / glm::dot(d, d), 0.0, 1.0);
  return a + d * t;
}

// The point of the UV triangle closest to q.
glm::dvec2 closest_in_triangle(const std::array<glm::dvec2, 3>& t, double area2, const glm::dvec2& q) {
  const glm::dvec3 w = barycentric(t, area2, q);
  if (w.x >= 0 && w.y >= 0 && w.z >= 0) return q;
  glm::dvec2 best = t[0];
  double best_d = INFINITY;
  for (int e = 0; e < 3; ++e) {
    const glm::dvec2 c = closest_on_segment(t[std::size_t(e)], t[std::size_t((e + 1) % 3)], q);
    const double d = glm::dot(c - q, c - q);
    if (d < best_d) best_d = d, best = c;
  }
  return best;
}

struct Triangle {
  std::array<glm::dvec2, 3> uv;
  std::array<glm::dvec3, 3> p;
  double uv_area2 = 0;      // signed, twice the UV area
  double world_per_uv = 0;  // world area / UV area
  glm::dvec3 normal{0};
  glm::dvec3 tangent{0};  // unit dP/du, perpendicular to the normal
};

int find_root(std::vector<int>& parent, int i) {
  while (parent[std::size_t(i)] != i)
    i = parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
  return i;
}

Status bad(const std::string& what, const std::string& problem) {
  return Status::error(ErrorCode::invalid_argument, what + ": " + problem);
}

// Sizes, indices, finite values (and UVs in [0, 1] when the mesh needs them), non-degenerate
// triangles.
Status check_mesh(const ClutterMesh& mesh, bool uvs, const std::string& what) {
  if (uvs && mesh.uvs.size() != mesh.positions.size())
    return bad(what, std::to_string(mesh.positions.size()) + " positions but " +
                         std::to_string(mesh.uvs.size()) + " lightmap UVs (one per position needed)");
  if (mesh.indices.empty() || mesh.indices.size() % 3 != 0)
    return bad(what, std::to_string(mesh.indices.size()) + " indices is not a positive multiple of 3");
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::dvec3& p = mesh.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return bad(what, "vertex " + std::to_string(v) + " has a NaN or Inf position");
    // Embree and the runtime hold positions as float.
    if (std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) > 1e30)
      return bad(what, "vertex " + std::to_string(v) + " lies beyond float range (|coordinate| > 1e30)");
    if (!uvs) continue;
    const glm::dvec2& uv = mesh.uvs[v];
    if (!std::isfinite(uv.x) || !std::isfinite(uv.y))
      return bad(what, "vertex " + std::to_string(v) + " has a NaN or Inf UV");
    if (uv.x < 0 || uv.x > 1 || uv.y < 0 || uv.y > 1)
      return bad(what, "vertex " + std::to_string(v) + ": UV (" + std::to_string(uv.x) + ", " +
                           std::to_string(uv.y) + ") is outside [0, 1]");
  }
  for (std::size_t t = 0; t < mesh.indices.size() / 3; ++t) {
    for (std::size_t k = 0; k < 3; ++k)
      if (mesh.indices[3 * t + k] >= mesh.positions.size())
        return bad(what, "triangle " + std::to_string(t) + " uses vertex " +
                             std::to_string(mesh.indices[3 * t + k]) + ", the mesh has " +
                             std::to_string(mesh.positions.size()));
    const glm::dvec3 &p0 = mesh.positions[mesh.indices[3 * t]], &p1 = mesh.positions[mesh.indices[3 * t + 1]],
                     &p2 = mesh.positions[mesh.indices[3 * t + 2]];
    double uv_area2 = 1.0;
    if (uvs) {
      const glm::dvec2 &a = mesh.uvs[mesh.indices[3 * t]], &b = mesh.uvs[mesh.indices[3 * t + 1]],
                       &c = mesh.uvs[mesh.indices[3 * t + 2]];
      uv_area2 = cross2(b - a, c - a);
    }
    // A texel of a 1024^2 grid has UV area ~1e-6; triangles far below that are degenerate.
    if (!(0.5 * glm::length(glm::cross(p1 - p0, p2 - p0)) > 1e-14) || !(std::abs(uv_area2) > 1e-14))
      return bad(what, "triangle " + std::to_string(t) + " has zero world or UV area");
  }
  return Status::success();
}

}  // namespace

std::vector<int> clutter_mesh_charts(const ClutterMesh& mesh) {
  const std::size_t triangle_count = mesh.indices.size() / 3;
  std::vector<int> parent(triangle_count);
  std::iota(parent.begin(), parent.end(), 0);
  if (mesh.uvs.size() == mesh.positions.size()) {
    auto key = [](const glm::dvec2& a) {
      return std::pair{std::llround(a.x * 1048576.0), std::llround(a.y * 1048576.0)};
    };
    std::map<std::pair<std::pair<long long, long long>, std::pair<long long, long long>>, int> edges;
    for (std::size_t t = 0; t < triangle_count; ++t)
      for (std::size_t e = 0; e < 3; ++e) {
        const std::uint32_t i0 = mesh.indices[3 * t + e], i1 = mesh.indices[3 * t + (e + 1) % 3];
        if (i0 >= mesh.uvs.size() || i1 >= mesh.uvs.size()) continue;
        auto a = key(mesh.uvs[i0]), b = key(mesh.uvs[i1]);
        if (b < a) std::swap(a, b);
        auto [it, inserted] = edges.emplace(std::pair{a, b}, int(t));
        if (!inserted) parent[std::size_t(find_root(parent, int(t)))] = find_root(parent, it->second);
      }
  }
  std::vector<int> chart_of(triangle_count, -1);
  std::map<int, int> chart_index;
  for (std::size_t t = 0; t < triangle_count; ++t) {
    auto [it, inserted] = chart_index.emplace(find_root(parent, int(t)), int(chart_index.size()));
    chart_of[t] = it->second;
  }
  return chart_of;
}

Result<ClutterMeshAtlas> rasterize_clutter_mesh(const ClutterMesh& mesh, int res, const std::string& what) {
  if (res < 1 || res > 1024) return bad(what, "res " + std::to_string(res) + " is not 1..1024");
  if (Status st = check_mesh(mesh, true, what); !st.ok()) return st;
  const std::size_t triangle_count = mesh.indices.size() / 3;
  std::vector<Triangle> tris(triangle_count);
  for (std::size_t t = 0; t < triangle_count; ++t) {
    Triangle& tri = tris[t];
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.indices[3 * t + k];
      tri.uv[k] = mesh.uvs[v];
      tri.p[k] = mesh.positions[v];
    }
    const glm::dvec3 n = glm::cross(tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
    const double world_area = 0.5 * glm::length(n);
    tri.uv_area2 = cross2(tri.uv[1] - tri.uv[0], tri.uv[2] - tri.uv[0]);
    tri.world_per_uv = world_area / (0.5 * std::abs(tri.uv_area2));
    tri.normal = n / (2.0 * world_area);
    // dP/du from the UV parametrization (uv_area2 is nonzero: checked above).
    const glm::dvec3 dp1 = tri.p[1] - tri.p[0], dp2 = tri.p[2] - tri.p[0];
    const glm::dvec2 d1 = tri.uv[1] - tri.uv[0], d2 = tri.uv[2] - tri.uv[0];
    glm::dvec3 dpdu = (dp1 * d2.y - dp2 * d1.y) / tri.uv_area2;
    dpdu -= glm::dot(dpdu, tri.normal) * tri.normal;
    const double len = glm::length(dpdu);
    if (len > 0.0) {
      tri.tangent = dpdu / len;
    } else {
      glm::dvec3 b;
      tangent_frame(tri.normal, tri.tangent, b);
    }
  }

  const std::vector<int> chart_of = clutter_mesh_charts(mesh);
  const int chart_count = chart_of.empty() ? 0 : *std::max_element(chart_of.begin(), chart_of.end()) + 1;

  const std::size_t cells = std::size_t(res) * std::size_t(res);
  const double cell = 1.0 / res;
  std::vector<std::int32_t> owner(cells, -1);     // triangle whose interior holds the centre
  std::vector<double> owner_depth(cells, -1.0);   // its smallest barycentric coordinate there
  std::vector<std::int32_t> fallback(cells, -1);  // conservative: triangle overlapping most
  std::vector<double> fallback_overlap(cells, 0.0);
  std::vector<double> area(cells, 0.0);
  for (std::size_t t = 0; t < triangle_count; ++t) {
    const Triangle& tri = tris[t];
    double x_lo = 1, y_lo = 1, x_hi = 0, y_hi = 0;
    for (const glm::dvec2& uv : tri.uv) {
      x_lo = std::min(x_lo, uv.x), x_hi = std::max(x_hi, uv.x);
      y_lo = std::min(y_lo, uv.y), y_hi = std::max(y_hi, uv.y);
    }
    const int i0 = std::clamp(int(std::floor(x_lo * res)), 0, res - 1),
              i1 = std::clamp(int(std::floor(x_hi * res)), 0, res - 1);
    const int j0 = std::clamp(int(std::floor(y_lo * res)), 0, res - 1),
              j1 = std::clamp(int(std::floor(y_hi * res)), 0, res - 1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const std::size_t c = std::size_t(j) * std::size_t(res) + std::size_t(i);
        const double overlap = overlap_area(tri.uv, i * cell, j * cell, (i + 1) * cell, (j + 1) * cell);
        if (overlap <= 0) continue;
        area[c] += overlap * tri.world_per_uv;
        const glm::dvec3 w = barycentric(tri.uv, tri.uv_area2, {(i + 0.5) * cell, (j + 0.5) * cell});
        const double depth = std::min({w.x, w.y, w.z});
        // Centres on a shared edge (depth ~ 0 in both triangles) go to either; a centre deep
        // inside two triangles means their UVs overlap.
        constexpr double kEdge = 1e-9;
        if (depth >= -kEdge) {
          if (owner[c] >= 0 && depth > kEdge && owner_depth[c] > kEdge)
            return bad(what, "triangles " + std::to_string(owner[c]) + " and " + std::to_string(t) +
                                 " overlap in UV space (both cover texel " + std::to_string(i) + ", " +
                                 std::to_string(j) + "): lightmap UVs must not overlap");
          if (depth > owner_depth[c]) owner[c] = std::int32_t(t), owner_depth[c] = depth;
        }
        if (overlap > fallback_overlap[c]) fallback[c] = std::int32_t(t), fallback_overlap[c] = overlap;
      }
  }

  ClutterMeshAtlas atlas;
  atlas.res = res;
  atlas.chart_count = chart_count;
  atlas.cell_texel.assign(cells, -1);
  for (std::size_t c = 0; c < cells; ++c) {
    const std::int32_t t = owner[c] >= 0 ? owner[c] : fallback[c];
    if (t < 0) continue;
    const Triangle& tri = tris[std::size_t(t)];
    const glm::dvec2 centre{(double(c % std::size_t(res)) + 0.5) * cell,
                            (double(c / std::size_t(res)) + 0.5) * cell};
    const glm::dvec3 w = barycentric(tri.uv, tri.uv_area2, closest_in_triangle(tri.uv, tri.uv_area2, centre));
    atlas.cell_texel[c] = std::int32_t(atlas.triangle.size());
    atlas.texels.position.push_back(w.x * tri.p[0] + w.y * tri.p[1] + w.z * tri.p[2]);
    atlas.texels.normal.push_back(tri.normal);
    atlas.texels.tangent.push_back(tri.tangent);
    atlas.texels.face.push_back(chart_of[std::size_t(t)]);
    atlas.triangle.push_back(std::uint32_t(t));
    atlas.area.push_back(area[c]);
  }

  // One ring of padding: 4-neighbours first, then diagonals, in a fixed order.
  constexpr std::array<std::array<int, 2>, 8> kNeighbours{
      {{-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {1, -1}, {-1, 1}, {1, 1}}};
  for (int j = 0; j < res; ++j)
    for (int i = 0; i < res; ++i) {
      const std::size_t c = std::size_t(j) * std::size_t(res) + std::size_t(i);
      if (atlas.cell_texel[c] >= 0) continue;
      for (const auto& [di, dj] : kNeighbours) {
        const int ni = i + di, nj = j + dj;
        if (ni < 0 || nj < 0 || ni >= res || nj >= res) continue;
        const std::size_t n = std::size_t(nj) * std::size_t(res) + std::size_t(ni);
        if (atlas.cell_texel[n] >= 0) {
          atlas.padding.emplace_back(std::uint32_t(c), std::uint32_t(n));
          break;
        }
      }
    }
  return atlas;
}

// ---- ClutterMeshShape ----

struct ClutterMeshShape::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<glm::dvec3> normal;  // per triangle, outward (counter-clockwise seen from outside)
  std::vector<int> chart;          // per triangle
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

ClutterMeshShape::~ClutterMeshShape() = default;
ClutterMeshShape::ClutterMeshShape(ClutterMeshShape&&) noexcept = default;
ClutterMeshShape& ClutterMeshShape::operator=(ClutterMeshShape&&) noexcept = default;

Result<ClutterObject> make_mesh_clutter(ClutterMesh mesh, int block, const glm::dvec3& albedo, int res,
                                        const std::string& what) {
  Result<ClutterMeshAtlas> atlas = rasterize_clutter_mesh(mesh, res, what);
  if (!atlas.ok()) return atlas.status();
  auto data = std::make_shared<ClutterMeshData>();
  data->chart_of_triangle = clutter_mesh_charts(mesh);
  data->atlas = std::move(atlas.value());
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (const glm::dvec3& p : mesh.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
  data->mesh = std::move(mesh);
  ClutterObject object;
  object.kind = ClutterKind::mesh;
  object.block = block;
  object.albedo = albedo;
  object.res = res;
  object.faces = kAllFaces;
  object.box.center = 0.5 * (lo + hi);
  // Grown a little so that a flat mesh still has positive extents (validate_clutter).
  object.box.half_extent = 0.5 * (hi - lo) + glm::dvec3(1e-9);
  object.mesh = std::move(data);
  return object;
}

Result<ClutterMeshShape> ClutterMeshShape::create(const ClutterMesh& mesh, std::vector<int> chart_of_triangle,
                                                  const std::string& what) {
  if (Status st = check_mesh(mesh, false, what); !st.ok()) return st;
  const std::size_t triangle_count = mesh.indices.size() / 3;
  if (chart_of_triangle.size() != triangle_count)
    return bad(what, std::to_string(chart_of_triangle.size()) + " chart indices for " +
                         std::to_string(triangle_count) + " triangles");
  ClutterMeshShape shape;
  shape.impl_ = std::make_unique<Impl>();
  Impl& impl = *shape.impl_;
  impl.chart = std::move(chart_of_triangle);
  // No "threads=N": it would cap every TBB parallel_for while the shape lives (level_scene.cpp).
  impl.device = rtcNewDevice("set_affinity=0");
  if (!impl.device) return Status::error(ErrorCode::internal_error, what + ": Embree: rtcNewDevice failed");
  impl.scene = rtcNewScene(impl.device);
  RTCGeometry geom = rtcNewGeometry(impl.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), mesh.positions.size()));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), triangle_count));
  if (!vb || !ib) {
    rtcReleaseGeometry(geom);
    return Status::error(ErrorCode::internal_error, what + ": Embree: cannot allocate the mesh buffers");
  }
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::dvec3& p = mesh.positions[v];
    vb[3 * v] = float(p.x), vb[3 * v + 1] = float(p.y), vb[3 * v + 2] = float(p.z);
    lo = glm::min(lo, p), hi = glm::max(hi, p);
  }
  std::copy(mesh.indices.begin(), mesh.indices.end(), ib);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl.scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl.scene);
  if (rtcGetDeviceError(impl.device) != RTC_ERROR_NONE)
    return Status::error(ErrorCode::internal_error, what + ": Embree: scene build failed");
  impl.normal.resize(triangle_count);
  for (std::size_t t = 0; t < triangle_count; ++t) {
    const glm::dvec3 &p0 = mesh.positions[mesh.indices[3 * t]], &p1 = mesh.positions[mesh.indices[3 * t + 1]],
                     &p2 = mesh.positions[mesh.indices[3 * t + 2]];
    impl.normal[t] = glm::normalize(glm::cross(p1 - p0, p2 - p0));
  }
  shape.center_ = 0.5 * (lo + hi);
  for (const glm::dvec3& p : mesh.positions)
    shape.radius_ = std::max(shape.radius_, glm::length(p - shape.center_));
  return shape;
}

ClutterMeshShape::Entry ClutterMeshShape::enter(const glm::dvec3& origin, const glm::dvec3& dir) const {
  const RTCRayHit rh = embree_intersect(impl_->scene, origin, dir, 0.0);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID || !(rh.ray.tfar > 0.0f)) return {};
  if (glm::dot(dir, impl_->normal[rh.hit.primID]) >= 0.0) return {};  // leaving: the origin is inside
  return {true,          double(rh.ray.tfar), impl_->chart[rh.hit.primID],
          rh.hit.primID, double(rh.hit.u),    double(rh.hit.v)};
}

bool ClutterMeshShape::contains(const glm::dvec3& p) const {
  // Irrational-looking directions, so that axis-aligned meshes' edges are not grazed.
  static const glm::dvec3 kDirs[3] = {glm::normalize(glm::dvec3(0.5773, 0.6123, 0.5402)),
                                      glm::normalize(glm::dvec3(-0.3311, 0.8715, -0.3617)),
                                      glm::normalize(glm::dvec3(0.7071, -0.2113, -0.6748))};
  int inside_votes = 0;
  for (const glm::dvec3& d : kDirs) {
    int crossings = 0;
    double t_near = 0.0;
    // Each crossing restarts just past the hit; a closed mesh is crossed a finite number of
    // times, and the cap guards against a degenerate one.
    for (int k = 0; k < 1024; ++k) {
      const RTCRayHit rh = embree_intersect(impl_->scene, p, d, t_near);
      if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) break;
      ++crossings;
      t_near = std::nextafter(rh.ray.tfar, INFINITY) + 1e-7 * radius_;
    }
    inside_votes += crossings % 2;
  }
  return inside_votes >= 2;
}

}  // namespace modrt::precompute
