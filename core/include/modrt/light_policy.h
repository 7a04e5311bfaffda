// SPDX-License-Identifier: MIT
// modrt — the light policy every direct-light path follows: precompute's Embree direct light
// (block, level, clutter, path tracer), the CPU evaluator of the C API (cpu_neon) and the
// parsers that accept lights (level JSON, modrt-relight). One place for: which lights and rays
// can be traced, how bright a light may be, and the bound on the inverse-square singularity at
// a texel (docs/robustness.md, "Issue 18: lights and rays").
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <glm/vec3.hpp>

namespace modrt {

// ---- traceable coordinates ----
// Largest |coordinate| of a traced point: a ray origin, a light centre, a point on a light's
// sphere. Embree refuses (asserts on) a ray whose origin or direction has a coordinate beyond
// FLT_LARGE = 1.844e18 (RayK::valid()); a shadow ray's direction is target - origin, up to twice
// this bound, so 1e15 leaves a factor of ~900.
inline constexpr double kMaxTraceCoordinate = 1e15;

inline bool traceable(double v) { return std::abs(v) <= kMaxTraceCoordinate; }  // false for NaN
inline bool traceable(const glm::dvec3& p) { return traceable(p.x) && traceable(p.y) && traceable(p.z); }

// The rule for a light out of reach: a positioned light whose sphere (centre +- radius on every
// axis) is not inside the traceable box contributes exactly 0 on every path (no ray is traced
// to it). Such a light is > 1e15 - |level| away from every sample, so its true E = I / d^2 is
// below I x 1e-29; the CPU evaluator's float arithmetic already gave it 0 (d^2 overflows).
// Parsers that know the level's extent refuse such positions instead (light_position_in_level).
inline bool light_in_reach(const glm::dvec3& centre, double radius) {
  return radius >= 0.0 && traceable(radius) && traceable(std::abs(centre.x) + radius) &&
         traceable(std::abs(centre.y) + radius) && traceable(std::abs(centre.z) + radius);
}

// The contract of authored lights (level JSON, modrt-relight --light): the centre lies in the
// level's bounding box [lo, hi] grown by its largest extent (at least one cell) on every side.
// A light farther out lights nothing a closed level can show (walls are one-sided and face
// inward), so such a position is an authoring error, not a light.
inline bool light_position_in_level(const glm::dvec3& centre, const glm::dvec3& lo, const glm::dvec3& hi,
                                    double cell_size) {
  const double grow = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, cell_size});
  for (int a = 0; a < 3; ++a)
    if (!(centre[a] >= lo[a] - grow && centre[a] <= hi[a] + grow)) return false;
  return traceable(centre);
}

// ---- brightness ----
// Largest intensity x max(1, colour) of an authored light (W/sr). With the falloff floor below
// (d^2 >= 1e-12) its E / pi stays under 3.2e29, inside the CPU evaluator's kMaxLightScale (1e30)
// and far from float overflow once thousands of lights are summed.
inline constexpr double kMaxLightIntensity = 1e18;

// The bound above for a light of `intensity` W/sr and linear RGB `color` (NaN is refused).
inline bool light_brightness_allowed(double intensity, const glm::dvec3& color) {
  return intensity >= 0.0 && intensity * std::max({1.0, color.x, color.y, color.z}) <= kMaxLightIntensity;
}

// ---- spot cones (glTF KHR_lights_punctual) ----
// A spot light is the point model times s(cos a), a the angle between the spot's axis and the
// direction from the light to the lit point: s is smoothstep from cos(outer) (0) to cos(inner)
// (1), t = (cos a - cos outer) / max(cos inner - cos outer, 1e-4) clamped to [0, 1],
// s = t^2 (3 - 2t); inner and outer are half-angles in radians, 0 <= inner <= outer <= pi.
// The CPU evaluator's influence bounds and the path tracers use these functions; its SIMD
// kernel (cpu_neon direct_light.cpp) and the GLSL pass (gles light.glsl) are their float twins.
struct SpotFalloff {
  double cos_outer = -2.0;  // below every cosine: s = 1 everywhere (a point light)
  double inv_range = 1.0;   // 1 / max(cos inner - cos outer, 1e-4)
};

inline SpotFalloff spot_falloff(double inner_angle, double outer_angle) {
  const double cos_outer = std::cos(outer_angle);
  return {cos_outer, 1.0 / std::max(std::cos(inner_angle) - cos_outer, 1e-4)};
}

// s(cos a) of a spot cone.
inline double spot_factor(const SpotFalloff& spot, double cos_angle) {
  const double t = std::clamp((cos_angle - spot.cos_outer) * spot.inv_range, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

// ---- the point-light singularity (issue 18, item 7) ----
// A texel does not record the irradiance at its centre but the mean over its footprint; model
// the footprint as a disc of the texel's area A (radius rho, A = pi rho^2). A point light of
// intensity I at height h above the disc's centre gives the mean
//   E_avg(h) = (1/A) int_0^rho I h / (h^2 + s^2)^(3/2) 2 pi s ds = (2 I / rho^2)(1 - h / sqrt(h^2 + rho^2)),
// which decreases in h (and off axis) from its largest value 2 I / rho^2 = I / (A / (2 pi)) for a
// light on the surface. So the irradiance a texel can record from a point light never exceeds
// I / (A / 2pi): the inverse-square law I cos / d^2 is evaluated with d^2 bounded below by
// A / (2 pi). Farther than sqrt(A / 2pi) (0.4 texel widths) nothing changes. A sphere light
// of radius r is also bounded by its value on its surface (d^2 >= r^2), and 1e-12 is an
// absolute floor for a zero-area footprint.
inline constexpr double kMinFalloffD2 = 1e-12;

// The texel footprint's contribution to the floor: A / (2 pi).
inline double texel_footprint_d2(double texel_area) {
  return std::max(texel_area, 0.0) / (2.0 * std::numbers::pi);
}

// The denominator of E = I cos / d^2 for a light of radius `radius` at squared distance d2 from
// a texel of footprint area `texel_area`.
inline double light_falloff_d2(double d2, double radius, double texel_area) {
  return std::max({d2, radius * radius, texel_footprint_d2(texel_area), kMinFalloffD2});
}

// The footprint area of a level block's texels: (h / res)^2 with h the shortest edge of the
// block's corner bounding box (cell_size for an unwarped block). One value per block, and for
// a long or warped block no more than its smallest texel's (a 100:1:1 block's 12.5 x 0.125
// wall texels count as 0.125 x 0.125): the floor then never exceeds what the true footprint
// allows, and only acts within 0.4 of the narrow texel width of a light.
inline double block_texel_area(const std::array<glm::dvec3, 8>& corners, int res) {
  glm::dvec3 lo = corners[0], hi = corners[0];
  for (const glm::dvec3& c : corners)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
  const double h = std::min({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  return res > 0 && h > 0.0 ? (h / res) * (h / res) : 0.0;
}

}  // namespace modrt
