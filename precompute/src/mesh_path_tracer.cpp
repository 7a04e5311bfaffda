// SPDX-License-Identifier: MIT
#include "modrt/precompute/mesh_path_tracer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <string>
#include <utility>

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

#include "embree_rays.h"
#include "modrt/dictionary.h"
#include "modrt/precompute/direct_light.h"
#include "path_kernel.h"

namespace modrt::precompute {

namespace {

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string fmt(const glm::dvec3& v) { return "(" + fmt(v.x) + ", " + fmt(v.y) + ", " + fmt(v.z) + ")"; }

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

Status fail(ErrorCode code, const std::string& message) { return Status::error(code, message); }

// The context of a ray that ignores up to two triangles (Embree's ids): the filter functions
// receive the context rtcIntersect1 / rtcOccluded1 were given, so it carries them.
struct IgnoreContext {
  RTCIntersectContext base;
  unsigned ignore[2];
};

void ignore_triangles(const RTCFilterFunctionNArguments* args) {
  const auto* context = reinterpret_cast<const IgnoreContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    if (prim == context->ignore[0] || prim == context->ignore[1]) args->valid[i] = 0;
  }
}

}  // namespace

struct MeshScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  // Per caller triangle: unit normal in the caller's winding (0: degenerate), albedo, its
  // Embree id (RTC_INVALID_GEOMETRY_ID: degenerate, not in Embree), and for each Embree corner
  // the caller's corner (0, 1, 2).
  std::vector<glm::dvec3> normal, albedo;
  std::vector<unsigned> embree_id;
  std::vector<std::array<std::uint8_t, 3>> corner;
  std::vector<unsigned> caller_id;  // per Embree triangle
  std::size_t degenerate = 0;
  double epsilon = 1e-12;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
  unsigned to_embree(int triangle) const {
    return triangle >= 0 && std::size_t(triangle) < embree_id.size() ? embree_id[std::size_t(triangle)]
                                                                     : RTC_INVALID_GEOMETRY_ID;
  }
  void init_context(IgnoreContext& c, int a, int b) const {
    rtcInitIntersectContext(&c.base);
    c.ignore[0] = to_embree(a);
    c.ignore[1] = to_embree(b);
  }
};

MeshScene::MeshScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
MeshScene::MeshScene(MeshScene&&) noexcept = default;
MeshScene& MeshScene::operator=(MeshScene&&) noexcept = default;
MeshScene::~MeshScene() = default;

// Validates the input and builds the scene; `Vec` is glm::vec3 or glm::dvec3.
template <class Vec>
Result<MeshScene> MeshScene::build(std::span<const Vec> positions, std::span<const std::uint32_t> indices,
                                   std::span<const glm::dvec3> albedo) {
  if (indices.size() % 3 != 0)
    return fail(ErrorCode::invalid_argument, "mesh scene: " + std::to_string(indices.size()) +
                                                 " indices is not a multiple of 3 (three per triangle)");
  const std::size_t triangles = indices.size() / 3;
  if (triangles > kMaxMeshTriangles)
    return fail(ErrorCode::resource_limit, "mesh scene: " + std::to_string(triangles) + " triangles exceed " +
                                               std::to_string(kMaxMeshTriangles));
  if (positions.size() > kMaxMeshVertices)
    return fail(ErrorCode::resource_limit, "mesh scene: " + std::to_string(positions.size()) +
                                               " vertices exceed " + std::to_string(kMaxMeshVertices));
  if (albedo.size() != triangles)
    return fail(ErrorCode::invalid_argument, "mesh scene: " + std::to_string(albedo.size()) +
                                                 " albedo values for " + std::to_string(triangles) +
                                                 " triangles (one per triangle)");
  double largest = 0.0;
  for (std::size_t k = 0; k < positions.size(); ++k) {
    const glm::dvec3 p(positions[k]);
    if (!finite(p))
      return fail(ErrorCode::non_finite,
                  "mesh scene: vertex " + std::to_string(k) + ": position " + fmt(p) + " is not finite");
    if (!traceable(p))
      return fail(ErrorCode::invalid_argument, "mesh scene: vertex " + std::to_string(k) + ": position " +
                                                   fmt(p) +
                                                   " is beyond the traceable range (light_policy.h)");
    largest = std::max({largest, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  }
  for (std::size_t t = 0; t < triangles; ++t) {
    for (int c = 0; c < 3; ++c)
      if (indices[3 * t + std::size_t(c)] >= positions.size())
        return fail(ErrorCode::invalid_argument,
                    "mesh scene: triangle " + std::to_string(t) + ": index " + std::to_string(c) + " is " +
                        std::to_string(indices[3 * t + std::size_t(c)]) + ", beyond the " +
                        std::to_string(positions.size()) + " vertices");
    const glm::dvec3& a = albedo[t];
    if (!finite(a))
      return fail(ErrorCode::non_finite,
                  "mesh scene: triangle " + std::to_string(t) + ": albedo " + fmt(a) + " is not finite");
    if (!(a.x >= 0.0 && a.x <= 1.0 && a.y >= 0.0 && a.y <= 1.0 && a.z >= 0.0 && a.z <= 1.0))
      return fail(ErrorCode::invalid_argument, "mesh scene: triangle " + std::to_string(t) + ": albedo " +
                                                   fmt(a) + " must be in [0, 1] in every channel");
  }

  auto impl = std::make_unique<Impl>();
  impl->epsilon = std::max(1e-6 * largest, 1e-12);
  impl->normal.assign(triangles, glm::dvec3(0.0));
  impl->albedo.assign(albedo.begin(), albedo.end());
  impl->embree_id.assign(triangles, RTC_INVALID_GEOMETRY_ID);
  impl->corner.assign(triangles, {0, 1, 2});
  std::vector<unsigned> embree_indices;
  embree_indices.reserve(indices.size());
  for (std::size_t t = 0; t < triangles; ++t) {
    // Corners in index order: a triangle and its mirror winding are the same to Embree (the
    // same hits, bit for bit) and their normals differ in sign only, exactly.
    std::array<std::uint8_t, 3> order{0, 1, 2};
    const std::uint32_t* idx = &indices[3 * t];
    std::sort(order.begin(), order.end(), [&](std::uint8_t a, std::uint8_t b) { return idx[a] < idx[b]; });
    const bool odd = (order[0] == 0 && order[1] == 2) || (order[0] == 1 && order[1] == 0) ||
                     (order[0] == 2 && order[1] == 1);
    const glm::dvec3 p0(positions[idx[order[0]]]), p1(positions[idx[order[1]]]), p2(positions[idx[order[2]]]);
    const glm::dvec3 n = glm::cross(p1 - p0, p2 - p0);
    const double m = std::max({std::abs(n.x), std::abs(n.y), std::abs(n.z)});
    if (!(m > 0.0) || !std::isfinite(m)) {
      ++impl->degenerate;
      continue;
    }
    const glm::dvec3 unit = glm::normalize(n / m);
    impl->normal[t] = odd ? -unit : unit;
    impl->corner[t] = order;
    impl->embree_id[t] = unsigned(impl->caller_id.size());
    impl->caller_id.push_back(unsigned(t));
    embree_indices.insert(embree_indices.end(), {idx[order[0]], idx[order[1]], idx[order[2]]});
  }

  impl->device = rtcNewDevice("set_affinity=0");  // no threads=N: see LevelScene
  if (!impl->device) return fail(ErrorCode::internal_error, "mesh scene: Embree: rtcNewDevice failed");
  impl->scene = rtcNewScene(impl->device);
  // Robust traversal: rays must not slip between the triangles of a closed mesh.
  rtcSetSceneFlags(impl->scene, RTC_SCENE_FLAG_ROBUST);
  if (!embree_indices.empty()) {
    RTCGeometry geom = rtcNewGeometry(impl->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), positions.size()));
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), embree_indices.size() / 3));
    if (!vb || !ib) {
      rtcReleaseGeometry(geom);
      return fail(ErrorCode::internal_error, "mesh scene: Embree: cannot allocate the triangle buffers");
    }
    for (std::size_t k = 0; k < positions.size(); ++k) {
      vb[3 * k + 0] = float(positions[k].x);
      vb[3 * k + 1] = float(positions[k].y);
      vb[3 * k + 2] = float(positions[k].z);
    }
    std::copy(embree_indices.begin(), embree_indices.end(), ib);
    rtcSetGeometryIntersectFilterFunction(geom, ignore_triangles);
    rtcSetGeometryOccludedFilterFunction(geom, ignore_triangles);
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl->scene, geom);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl->scene);
  if (rtcGetDeviceError(impl->device) != RTC_ERROR_NONE)
    return fail(ErrorCode::internal_error, "mesh scene: Embree: the scene build failed");
  return MeshScene(std::move(impl));
}

Result<MeshScene> MeshScene::create(std::span<const glm::dvec3> positions,
                                    std::span<const std::uint32_t> indices,
                                    std::span<const glm::dvec3> albedo) {
  return build(positions, indices, albedo);
}

Result<MeshScene> MeshScene::create(std::span<const glm::vec3> positions,
                                    std::span<const std::uint32_t> indices,
                                    std::span<const glm::dvec3> albedo) {
  return build(positions, indices, albedo);
}

MeshHit MeshScene::intersect(const glm::dvec3& origin, const glm::dvec3& dir, int ignore) const {
  MeshHit hit;
  const double length = std::sqrt(glm::dot(dir, dir));
  if (!(length > 0.0)) return hit;
  IgnoreContext context;
  impl_->init_context(context, ignore, -1);
  const RTCRayHit rh = embree_intersect(impl_->scene, origin, dir, impl_->epsilon / length, &context.base);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
  const unsigned t = impl_->caller_id[rh.hit.primID];
  hit.triangle = int(t);
  hit.t = double(rh.ray.tfar);
  // Embree's (u, v) weigh its second and third corners; map the weights to the caller's corners.
  const double w[3] = {1.0 - double(rh.hit.u) - double(rh.hit.v), double(rh.hit.u), double(rh.hit.v)};
  double caller[3] = {0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) caller[impl_->corner[t][std::size_t(k)]] = w[k];
  hit.u = caller[1];
  hit.v = caller[2];
  return hit;
}

bool MeshScene::occluded(const glm::dvec3& origin, const glm::dvec3& target, int ignore_a,
                         int ignore_b) const {
  const glm::dvec3 d = target - origin;
  const double length = std::sqrt(glm::dot(d, d));
  if (!std::isfinite(length)) return true;     // cannot be traced (light_policy.h)
  if (length <= impl_->epsilon) return false;  // nothing fits between the ends
  IgnoreContext context;
  impl_->init_context(context, ignore_a, ignore_b);
  return embree_occluded(impl_->scene, origin, target, impl_->epsilon / length, &context.base);
}

std::size_t MeshScene::triangle_count() const { return impl_->normal.size(); }
std::size_t MeshScene::degenerate_triangle_count() const { return impl_->degenerate; }
glm::dvec3 MeshScene::normal(int triangle) const { return impl_->normal[std::size_t(triangle)]; }
glm::dvec3 MeshScene::albedo(int triangle) const { return impl_->albedo[std::size_t(triangle)]; }
double MeshScene::ray_epsilon() const { return impl_->epsilon; }

glm::dvec3 MeshScene::hit_normal(const MeshHit& hit, const glm::dvec3& dir) const {
  if (hit.triangle < 0) return glm::dvec3(0.0);
  const glm::dvec3 n = normal(hit.triangle);
  return glm::dot(n, dir) > 0.0 ? -n : n;
}

// ---- lights ----

Status validate_mesh_lights(std::span<const MeshLight> lights) {
  for (std::size_t i = 0; i < lights.size(); ++i) {
    const LightDescription& l = lights[i].light;
    const std::string label = "light " + std::to_string(i) + ": ";
    if (!finite(l.position))
      return fail(ErrorCode::non_finite, label + "position " + fmt(l.position) + " is not finite");
    if (!std::isfinite(l.radius) || l.radius < 0.0)
      return fail(ErrorCode::invalid_argument,
                  label + "radius " + fmt(l.radius) + " must be finite and >= 0");
    if (!finite(l.color) || l.color.x < 0.0 || l.color.y < 0.0 || l.color.z < 0.0)
      return fail(ErrorCode::invalid_argument, label + "color " + fmt(l.color) + " must be finite and >= 0");
    if (!std::isfinite(l.intensity) || l.intensity < 0.0)
      return fail(ErrorCode::invalid_argument,
                  label + "intensity " + fmt(l.intensity) + " must be finite and >= 0");
    if (!light_brightness_allowed(l.intensity, l.color))
      return fail(ErrorCode::invalid_argument,
                  label + "intensity x max(1, color) = " +
                      fmt(l.intensity * std::max({1.0, l.color.x, l.color.y, l.color.z})) + " exceeds " +
                      fmt(kMaxLightIntensity) + " (kMaxLightIntensity, light_policy.h)");
    if (!light_in_reach(l.position, l.radius))
      return fail(ErrorCode::invalid_argument, label + "position " + fmt(l.position) + " with radius " +
                                                   fmt(l.radius) +
                                                   " is beyond the traceable range (light_policy.h)");
    if (!lights[i].spot) continue;
    const SpotCone& s = *lights[i].spot;
    if (!finite(s.direction))
      return fail(ErrorCode::non_finite, label + "spot direction " + fmt(s.direction) + " is not finite");
    const double m = std::max({std::abs(s.direction.x), std::abs(s.direction.y), std::abs(s.direction.z)});
    if (!(m > 0.0) || !(glm::length(s.direction / m) * m > 1e-6))
      return fail(ErrorCode::invalid_argument,
                  label + "spot direction " + fmt(s.direction) + " has length <= 1e-6");
    if (!(s.outer_angle > 0.0 && s.outer_angle <= std::numbers::pi))
      return fail(ErrorCode::invalid_argument,
                  label + "spot outer_angle " + fmt(s.outer_angle) + " must be in (0, pi]");
    if (!(s.inner_angle >= 0.0 && s.inner_angle <= s.outer_angle))
      return fail(ErrorCode::invalid_argument, label + "spot inner_angle " + fmt(s.inner_angle) +
                                                   " must be in [0, outer_angle = " + fmt(s.outer_angle) +
                                                   "]");
  }
  return Status::success();
}

std::vector<glm::dvec3> mesh_light_centres(std::span<const MeshLight> lights) {
  std::vector<glm::dvec3> centres;
  for (const MeshLight& l : lights) centres.push_back(l.light.position);
  return centres;
}

namespace {

// A validated light with its visibility points and spot falloff.
struct PreparedLight {
  SphereLight sphere;
  glm::dvec3 color{1.0};
  bool spot = false;
  glm::dvec3 axis{0.0, -1.0, 0.0};
  SpotFalloff cone;
  std::vector<glm::dvec3> points;
};

std::vector<PreparedLight> prepare_lights(std::span<const MeshLight> lights, int light_samples) {
  std::vector<PreparedLight> out(lights.size());
  for (std::size_t i = 0; i < lights.size(); ++i) {
    const LightDescription& l = lights[i].light;
    PreparedLight& p = out[i];
    p.sphere = SphereLight{l.position, l.radius, l.intensity};
    p.color = l.color;
    sphere_light_points(l.position, l.radius, light_samples, p.points);
    if (lights[i].spot) {
      const SpotCone& s = *lights[i].spot;
      const double m = std::max({std::abs(s.direction.x), std::abs(s.direction.y), std::abs(s.direction.z)});
      p.spot = true;
      p.axis = glm::normalize(s.direction / m);
      p.cone = spot_falloff(s.inner_angle, s.outer_angle);
    }
  }
  return out;
}

// E / pi at x (unit normal n) from every light, shadow rays ignoring triangle `ignore`: the
// runtime's sphere-light model (a point: no texel footprint), times the spot factor.
glm::dvec3 direct_E_over_pi(const MeshScene& scene, std::span<const PreparedLight> lights,
                            const glm::dvec3& x, const glm::dvec3& n, int ignore) {
  auto occluded = [&](const glm::dvec3& a, const glm::dvec3& b) { return scene.occluded(a, b, ignore); };
  glm::dvec3 sum(0.0);
  for (const PreparedLight& l : lights) {
    double s = 1.0;
    if (l.spot) {
      // cos a: the axis against the direction from the light to x.
      const glm::dvec3 w = x - l.sphere.center;
      s = spot_factor(l.cone, glm::dot(l.axis, w) / std::sqrt(std::max(glm::dot(w, w), 1e-300)));
      if (!(s > 0.0)) continue;
    }
    sum += l.color * (s * sphere_light_E_over_pi(x, n, l.sphere, l.points, 0.0, occluded));
  }
  return sum;
}

// The mesh as the estimator's geometry (path_kernel.h).
struct MeshPathGeometry {
  using Hit = MeshHit;
  using Vertex = detail::PathVertex<MeshHit>;
  const MeshScene& scene;
  std::span<const PreparedLight> lights;

  bool trace(const Vertex& from, const glm::dvec3& dir, Vertex& to) const {
    to.hit = scene.intersect(from.position, dir, from.hit.triangle);
    if (to.hit.triangle < 0) return false;
    to.position = from.position + to.hit.t * dir;
    to.normal = scene.normal(to.hit.triangle);
    return true;
  }
  // Neither end's own triangle can block the segment (it meets their planes only at its ends).
  bool sees(const Vertex& from, const Vertex& to) const {
    return !scene.occluded(from.position, to.position, from.hit.triangle, to.hit.triangle);
  }
  glm::dvec3 direct(const Vertex& y) const {
    return scene.albedo(y.hit.triangle) *
           direct_E_over_pi(scene, lights, y.position, y.normal, y.hit.triangle);
  }
  glm::dvec3 albedo(const Vertex& y) const { return scene.albedo(y.hit.triangle); }
};

// The points' checks; on success `unit` holds the normalised normals.
Status check_points(const MeshScene& scene, const MeshPoints& points, std::vector<glm::dvec3>& unit) {
  if (points.normals.size() != points.positions.size())
    return fail(ErrorCode::invalid_argument, std::to_string(points.positions.size()) + " positions but " +
                                                 std::to_string(points.normals.size()) + " normals");
  if (!points.triangles.empty() && points.triangles.size() != points.positions.size())
    return fail(ErrorCode::invalid_argument, std::to_string(points.positions.size()) + " positions but " +
                                                 std::to_string(points.triangles.size()) +
                                                 " triangles (one per point, or none)");
  unit.resize(points.positions.size());
  for (std::size_t i = 0; i < points.positions.size(); ++i) {
    const std::string label = "point " + std::to_string(i) + ": ";
    const glm::dvec3 &p = points.positions[i], &n = points.normals[i];
    if (!finite(p)) return fail(ErrorCode::non_finite, label + "position " + fmt(p) + " is not finite");
    if (!traceable(p))
      return fail(ErrorCode::invalid_argument,
                  label + "position " + fmt(p) + " is beyond the traceable range (light_policy.h)");
    if (!finite(n)) return fail(ErrorCode::non_finite, label + "normal " + fmt(n) + " is not finite");
    const double m = std::max({std::abs(n.x), std::abs(n.y), std::abs(n.z)});
    if (!(m > 0.0)) return fail(ErrorCode::invalid_argument, label + "normal " + fmt(n) + " is zero");
    unit[i] = glm::normalize(n / m);
    if (!points.triangles.empty()) {
      const int t = points.triangles[i];
      if (t < -1 || (t >= 0 && std::size_t(t) >= scene.triangle_count()))
        return fail(ErrorCode::invalid_argument, label + "triangle " + std::to_string(t) +
                                                     " is not -1 or below " +
                                                     std::to_string(scene.triangle_count()));
    }
  }
  return Status::success();
}

Status check_light_samples(int light_samples) {
  if (light_samples < 1 || std::int64_t(light_samples) > std::int64_t(kMaxSettingsLightSamples))
    return fail(ErrorCode::invalid_argument, "light_samples = " + std::to_string(light_samples) +
                                                 ": must be in [1, " +
                                                 std::to_string(kMaxSettingsLightSamples) + "]");
  return Status::success();
}

int point_triangle(const MeshPoints& points, std::size_t i) {
  return points.triangles.empty() ? -1 : points.triangles[i];
}

}  // namespace

Result<std::vector<float>> trace_mesh_direct(const MeshScene& scene, std::span<const MeshLight> lights,
                                             const MeshPoints& points, int light_samples) {
  std::vector<glm::dvec3> normals;
  if (Status s = check_light_samples(light_samples); !s.ok()) return s;
  if (Status s = validate_mesh_lights(lights); !s.ok()) return s;
  if (Status s = check_points(scene, points, normals); !s.ok()) return s;
  const std::vector<PreparedLight> prepared = prepare_lights(lights, light_samples);
  std::vector<float> out(3 * points.positions.size(), 0.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.positions.size(), 16),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const glm::dvec3 e = direct_E_over_pi(scene, prepared, points.positions[i],
                                                              normals[i], point_triangle(points, i));
                        for (int c = 0; c < 3; ++c) out[3 * i + std::size_t(c)] = float(e[c]);
                      }
                    });
  return out;
}

Result<IndirectEstimate> trace_mesh_indirect(const MeshScene& scene, std::span<const MeshLight> lights,
                                             const MeshPoints& points, const PathTracerSettings& settings) {
  std::vector<glm::dvec3> normals;
  if (Status s = validate_path_tracer_settings(settings); !s.ok()) return s;
  for (std::size_t k = 0; k < settings.light_vertex_sources.size(); ++k)
    if (!traceable(settings.light_vertex_sources[k]))
      return fail(ErrorCode::invalid_argument,
                  "path tracer settings: light_vertex_sources[" + std::to_string(k) + "] = " +
                      fmt(settings.light_vertex_sources[k]) + " is not finite or beyond the traceable range");
  if (Status s = validate_mesh_lights(lights); !s.ok()) return s;
  if (Status s = check_points(scene, points, normals); !s.ok()) return s;
  const std::vector<PreparedLight> prepared = prepare_lights(lights, settings.light_samples);
  const MeshPathGeometry geometry{scene, prepared};
  return detail::trace_paths(
      geometry, points.positions.size(),
      [&](std::size_t i) {
        detail::PathVertex<MeshHit> v;
        v.hit.triangle = point_triangle(points, i);
        v.position = points.positions[i];
        v.normal = normals[i];
        return v;
      },
      settings);
}

Result<IndirectEstimate> trace_mesh_indirect(const MeshScene& scene, std::span<const MeshLight> lights,
                                             std::span<const glm::dvec3> positions,
                                             std::span<const glm::dvec3> normals,
                                             const PathTracerSettings& settings) {
  return trace_mesh_indirect(scene, lights, MeshPoints{positions, normals, {}}, settings);
}

// ---- camera ----

std::vector<std::size_t> MeshCameraHits::hit_pixels() const {
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < triangle.size(); ++k)
    if (triangle[k] >= 0) out.push_back(k);
  return out;
}

MeshCameraHits::Points MeshCameraHits::points() const {
  Points p;
  for (std::size_t k : hit_pixels()) {
    p.positions.push_back(position[k]);
    p.normals.push_back(normal[k]);
    p.triangles.push_back(triangle[k]);
  }
  return p;
}

Result<MeshCameraHits> mesh_camera_hits(const MeshScene& scene, const glm::dvec3& eye,
                                        const glm::dvec3& target, const glm::dvec3& up,
                                        double vertical_fov_degrees, int width, int height) {
  auto bad = [](const std::string& what) { return fail(ErrorCode::invalid_argument, "camera: " + what); };
  if (width < 1 || width > kMaxCameraSide || height < 1 || height > kMaxCameraSide)
    return bad("image " + std::to_string(width) + " x " + std::to_string(height) +
               ": each side must be in [1, " + std::to_string(kMaxCameraSide) + "]");
  if (!(vertical_fov_degrees > 0.0 && vertical_fov_degrees < 180.0))
    return bad("vertical_fov_degrees " + fmt(vertical_fov_degrees) + " must be in (0, 180)");
  if (!traceable(eye)) return bad("eye " + fmt(eye) + " is not finite or beyond the traceable range");
  if (!traceable(target))
    return bad("target " + fmt(target) + " is not finite or beyond the traceable range");
  const glm::dvec3 forward = target - eye;
  if (!(glm::length(forward) > 0.0)) return bad("target " + fmt(target) + " is the eye");
  if (!finite(up) || !(glm::length(up) > 0.0)) return bad("up " + fmt(up) + " must be finite and nonzero");
  const glm::dvec3 f = glm::normalize(forward), u = glm::normalize(up);
  if (!(glm::length(glm::cross(f, u)) > 1e-9)) return bad("up " + fmt(up) + " is parallel to target - eye");
  MeshCameraHits cam;
  cam.width = width;
  cam.height = height;
  const std::size_t count = std::size_t(width) * std::size_t(height);
  cam.triangle.assign(count, -1);
  cam.position.assign(count, glm::dvec3(0.0));
  cam.normal.assign(count, glm::dvec3(0.0));
  const detail::PinholeCamera camera(eye, target, up, vertical_fov_degrees, width, height);
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int py = rows.begin(); py != rows.end(); ++py)
      for (int px = 0; px < width; ++px) {
        const glm::dvec3 dir = camera.direction(px, py);
        const std::size_t k = std::size_t(py) * std::size_t(width) + std::size_t(px);
        const MeshHit hit = scene.intersect(eye, dir);
        if (hit.triangle < 0) continue;
        cam.triangle[k] = hit.triangle;
        cam.position[k] = eye + hit.t * dir;
        cam.normal[k] = scene.hit_normal(hit, dir);
      }
  });
  return cam;
}

}  // namespace modrt::precompute
