// SPDX-License-Identifier: MIT
// modrt precompute — deterministic sampling: a seeded RNG per work item, stratified
// square samples, and the maps from the square to the disk, hemisphere and sphere.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace modrt::precompute {

// SplitMix64: tiny, statistically solid, and seedable per (seed, stream) so that results
// do not depend on how TBB schedules work across threads.
class Rng {
 public:
  Rng(std::uint64_t seed, std::uint64_t stream);
  std::uint64_t next_u64();
  double next_double();  // uniform in [0, 1)
  // Points uniform in [0, 1)^2 and [0, 1)^3, drawn in a fixed order. The arguments of a call such
  // as glm::dvec2(next_double(), next_double()) are unsequenced: GCC drew the last first and
  // clang the first, so bakes, path-traced references and tests differed between compilers.
  // The last coordinate is drawn first, as GCC did, so GCC-built results stay the same.
  glm::dvec2 next_dvec2() {
    const double y = next_double();
    const double x = next_double();
    return {x, y};
  }
  glm::dvec3 next_dvec3() {
    const double z = next_double();
    const double y = next_double();
    const double x = next_double();
    return {x, y, z};
  }

 private:
  std::uint64_t state_;
};

// `count` jittered samples on [0,1)^2, stratified on an nx x ny grid with nx*ny == count
// (nx the largest divisor of count not above its square root).
void stratified_square(int count, Rng& rng, std::vector<glm::dvec2>& out);

// Shirley–Chiu concentric map of the square [0,1]^2 onto the unit disk, and its inverse.
glm::dvec2 concentric_square_to_disk(const glm::dvec2& s);
glm::dvec2 concentric_disk_to_square(const glm::dvec2& d);

// Cosine-weighted hemisphere direction around +z (pdf = cos(theta) / pi).
glm::dvec3 cosine_hemisphere(const glm::dvec2& s);
// Uniform hemisphere around +z (pdf = 1 / (2 pi)) and uniform sphere (pdf = 1 / (4 pi)).
glm::dvec3 uniform_hemisphere(const glm::dvec2& s);
glm::dvec3 uniform_sphere(const glm::dvec2& s);

// A tangent t and bitangent b completing the unit normal n to an orthonormal frame (any
// rotation about n: the hemisphere samplers are symmetric about +z).
inline void tangent_frame(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
  const glm::dvec3 helper = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  t = glm::normalize(glm::cross(helper, n));
  b = glm::cross(n, t);
}

// Direction given in a local frame (x = tangent, y = bitangent, z = normal) to world.
inline glm::dvec3 to_world(const glm::dvec3& local, const glm::dvec3& t, const glm::dvec3& b,
                           const glm::dvec3& n) {
  return local.x * t + local.y * b + local.z * n;
}

// About `count` points on the sphere of radius r around c: latitude rings about +Y with a
// multiple of 4 longitudes (the count is rounded to such a set), symmetric under quarter
// turns about Y and the X/Z mirrors.
void sphere_surface_points(const glm::dvec3& c, double r, int count, std::vector<glm::dvec3>& out);

}  // namespace modrt::precompute
