// SPDX-License-Identifier: MIT
// modrt precompute — ground truth on an artist's triangle meshes: the diffuse path tracer of
// path_tracer.h (the same estimator, path_kernel.h) on a scene of world-space triangles instead
// of the level's proxy blocks, so that what a scene importer makes of the meshes (proxy blocks,
// clutter) can be compared with the light the meshes themselves carry.
//
// Light model: the runtime's (direct_light.h sphere_light_E_over_pi: I V cos / max(d^2, r^2,
// 1e-12) with V the visible fraction of `light_samples` points on the light's sphere), plus an
// optional spot cone with glTF KHR_lights_punctual's smooth falloff (light_policy.h
// spot_factor, the CPU evaluator's and the GLES pass's formula). Points are shaded as points:
// no texel footprint bounds the falloff (as the GLES camera image, u_falloff_floor_d2 = 0).
//
// Surfaces are two-sided (an artist's walls have any winding): a ray hits a triangle from
// either side, and the normal at a hit faces the ray. The winding changes nothing: each
// triangle is given to Embree with its corners in index order, so flipping it gives
// bit-identical results. Rays and shadow rays that leave a surface point ignore that point's
// own triangle, and start `ray_epsilon()` along the ray (relative to the scene's size).
//
// Errors: every function that takes caller data validates it and returns a Status naming the
// offending index (vertex, triangle, light, point, setting); nothing throws on bad input, and a
// valid input gives finite results.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/level_description.h"
#include "modrt/light_policy.h"
#include "modrt/precompute/path_tracer.h"
#include "modrt/status.h"

namespace modrt::precompute {

// A ray's first hit in a MeshScene.
struct MeshHit {
  int triangle = -1;  // -1: nothing hit (or, for a path's start, a point on no known triangle)
  double t = 0.0;     // distance along the ray's direction (in units of its length)
  // Barycentric weights of the triangle's second and third corners (index order as given).
  double u = 0.0, v = 0.0;
};

// Largest triangle and vertex counts of a MeshScene (Embree's 32-bit primitive ids).
inline constexpr std::size_t kMaxMeshTriangles = std::size_t(1) << 30;
inline constexpr std::size_t kMaxMeshVertices = std::size_t(1) << 31;

class MeshScene {
 public:
  // positions: world-space vertices, finite and within kMaxTraceCoordinate (light_policy.h);
  // indices: three per triangle, each < positions.size(); albedo: one linear-RGB diffuse
  // albedo per triangle, every channel in [0, 1]. Degenerate triangles (zero area in double)
  // are kept in the numbering but nothing hits them. An empty mesh is valid (every ray
  // misses). Errors: invalid_argument (sizes, an index out of range, albedo outside [0, 1]),
  // non_finite (a NaN or Inf vertex or albedo, named by index), resource_limit (above
  // kMaxMeshTriangles / kMaxMeshVertices), internal_error (Embree failed).
  static Result<MeshScene> create(std::span<const glm::dvec3> positions,
                                  std::span<const std::uint32_t> indices, std::span<const glm::dvec3> albedo);
  // The same for float positions (a glTF accessor's).
  static Result<MeshScene> create(std::span<const glm::vec3> positions,
                                  std::span<const std::uint32_t> indices, std::span<const glm::dvec3> albedo);

  MeshScene(MeshScene&&) noexcept;
  MeshScene& operator=(MeshScene&&) noexcept;
  ~MeshScene();
  MeshScene(const MeshScene&) = delete;
  MeshScene& operator=(const MeshScene&) = delete;

  // The first hit along origin + t dir for t > ray_epsilon() / |dir|, ignoring triangle
  // `ignore` (the one the origin lies on; -1: none). A ray that cannot be traced (light_policy.h)
  // misses.
  MeshHit intersect(const glm::dvec3& origin, const glm::dvec3& dir, int ignore = -1) const;
  // Whether anything but triangles ignore_a and ignore_b blocks the segment origin -> target
  // (its ends excluded: ray_epsilon() at the origin, 1e-6 of its length at the target). A
  // segment that cannot be traced counts as blocked.
  bool occluded(const glm::dvec3& origin, const glm::dvec3& target, int ignore_a = -1,
                int ignore_b = -1) const;

  std::size_t triangle_count() const;
  std::size_t degenerate_triangle_count() const;
  // Unit geometric normal of a triangle: (p1 - p0) x (p2 - p0) in the given winding; 0 for a
  // degenerate triangle. Requires triangle < triangle_count().
  glm::dvec3 normal(int triangle) const;
  glm::dvec3 albedo(int triangle) const;
  // The normal at a hit facing a ray of direction `dir` (dot(normal, dir) <= 0).
  glm::dvec3 hit_normal(const MeshHit& hit, const glm::dvec3& dir) const;
  // The smallest ray offset: 1e-6 x the largest |coordinate| of any vertex, at least 1e-9.
  double ray_epsilon() const;

 private:
  struct Impl;
  explicit MeshScene(std::unique_ptr<Impl> impl);
  template <class Vec>
  static Result<MeshScene> build(std::span<const Vec> positions, std::span<const std::uint32_t> indices,
                                 std::span<const glm::dvec3> albedo);
  std::unique_ptr<Impl> impl_;
};

// A spot cone of a light (glTF KHR_lights_punctual): full inside inner_angle, fading smoothly to
// 0 at outer_angle (half-angles about `direction`, radians; light_policy.h spot_factor).
struct SpotCone {
  glm::dvec3 direction{0.0, -1.0, 0.0};  // the axis the light shines along; finite, length > 1e-6
  double inner_angle = 0.5;              // 0 <= inner <= outer
  double outer_angle = 0.7;              // 0 < outer <= pi
};

// A point or sphere light (LevelDescription's light: position, radius, colour, intensity in
// W/sr), optionally a spot.
struct MeshLight {
  LightDescription light;
  std::optional<SpotCone> spot;
};

// The checks the tracers make of the lights: those of validate_level for a level's lights
// (finite position, radius, colour and intensity >= 0, light_brightness_allowed, light_in_reach)
// and the spot's (SpotCone); invalid_argument or non_finite naming "light <index>" and the field.
Status validate_mesh_lights(std::span<const MeshLight> lights);

// The centres of the lights, as light-vertex sources (PathTracerSettings).
std::vector<glm::dvec3> mesh_light_centres(std::span<const MeshLight> lights);

// Points the tracers shade: position, unit normal (the side light is gathered on; any nonzero
// finite length is normalised) and, optionally, the triangle each lies on (-1: none), whose hits
// the rays leaving the point ignore. `triangles` empty: none for every point.
struct MeshPoints {
  std::span<const glm::dvec3> positions;
  std::span<const glm::dvec3> normals;
  std::span<const int> triangles;
};

// E_direct / pi (light colour included, no albedo) at each point, RGB interleaved (3 per point):
// the sum over lights of the model above, with shadow rays against the scene (`light_samples`
// points per sphere light, in [1, kMaxSettingsLightSamples]). Errors: a bad light, point
// (non-finite or untraceable position, zero or non-finite normal, triangle out of range), sizes
// that differ, or light_samples out of range.
Result<std::vector<float>> trace_mesh_direct(const MeshScene& scene, std::span<const MeshLight> lights,
                                             const MeshPoints& points, int light_samples);

// E_ind / pi at each point by the path tracer of trace_indirect (path_tracer.h): cosine-weighted
// paths of settings.bounces segments, each segment's hit y bringing back albedo(y) E_direct(y) / pi
// (next-event estimation to every light with shadow rays) plus albedo(y) times the next segment's
// estimate; with settings.light_vertex_sources, light-vertex connections share the estimate by
// MIS (mesh_light_centres gives the lights' centres). Per point, standard errors as in
// IndirectEstimate. TBB-parallel, the same result for the same seed whatever the thread count.
// Errors: those of trace_mesh_direct, validate_path_tracer_settings, or a light-vertex source
// that cannot be traced.
Result<IndirectEstimate> trace_mesh_indirect(const MeshScene& scene, std::span<const MeshLight> lights,
                                             const MeshPoints& points, const PathTracerSettings& settings);
// The same for points on no known triangle (positions, normals).
Result<IndirectEstimate> trace_mesh_indirect(const MeshScene& scene, std::span<const MeshLight> lights,
                                             std::span<const glm::dvec3> positions,
                                             std::span<const glm::dvec3> normals,
                                             const PathTracerSettings& settings);

// A pinhole camera's primary hits, row 0 at the top (image-space references). Per pixel the
// hit triangle (-1: the ray saw nothing; then position and normal are 0), the hit position and
// the normal facing the camera. points() gives the hit pixels' points for the tracers.
struct MeshCameraHits {
  int width = 0, height = 0;
  std::vector<int> triangle;
  std::vector<glm::dvec3> position, normal;

  // Indices (py * width + px) of the pixels that hit, and their points, in that order.
  std::vector<std::size_t> hit_pixels() const;
  struct Points {
    std::vector<glm::dvec3> positions, normals;
    std::vector<int> triangles;
    MeshPoints view() const { return {positions, normals, triangles}; }
  };
  Points points() const;
};

// Largest image side of mesh_camera_hits.
inline constexpr int kMaxCameraSide = 16384;
// width, height in [1, kMaxCameraSide]; vertical_fov_degrees in (0, 180); eye traceable,
// target - eye and up nonzero, finite and not parallel. invalid_argument naming the parameter.
Result<MeshCameraHits> mesh_camera_hits(const MeshScene& scene, const glm::dvec3& eye,
                                        const glm::dvec3& target, const glm::dvec3& up,
                                        double vertical_fov_degrees, int width, int height);

}  // namespace modrt::precompute
