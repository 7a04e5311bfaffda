// SPDX-License-Identifier: MIT
// modrt precompute — direct light from sphere lights at the samples of a block, with
// visibility by Embree shadow rays. This is the direct-light model of the lighting prior
// (MRT §4, architecture.md §3.2) and of the references the runtime is checked against.
#pragma once

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/cube.h"
#include "modrt/light_policy.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/linalg.h"

namespace modrt::precompute {

// A sphere light of radiant intensity `intensity` (W/sr, as a point light at its centre).
// Irradiance at a texel x with normal n and footprint area A:
//   E = I * V * max(0, n.w) / light_falloff_d2(d^2, radius, A)   (modrt/light_policy.h),
// i.e. I cos / d^2 with d^2 bounded below by radius^2 and by A / (2 pi), the bound a texel's
// footprint puts on a point light's irradiance; w and d are direction and distance to the
// centre and V is the fraction of `samples` points on the sphere's surface that x sees
// unoccluded (soft shadows). radius 0 = point light. A light out of reach (light_in_reach)
// gives 0.
struct SphereLight {
  glm::dvec3 center{0.5};
  double radius = 0.05;
  double intensity = 1.0;
};

// Visibility sample points of a sphere light: its centre for a point light (radius 0 or
// one sample), else rings on its surface (sampling.h sphere_surface_points). None for a
// light out of reach.
void sphere_light_points(const glm::dvec3& center, double radius, int samples, std::vector<glm::dvec3>& out);

// E / pi at point x with normal n and texel footprint area `texel_area` (0: a point, only the
// absolute floor) from a sphere light whose visibility points are `points`; occluded(x, p)
// tells whether the segment x -> p is blocked. The model of SphereLight.
template <class Occluded>
double sphere_light_E_over_pi(const glm::dvec3& x, const glm::dvec3& n, const SphereLight& light,
                              std::span<const glm::dvec3> points, double texel_area,
                              const Occluded& occluded) {
  if (points.empty() || !light_in_reach(light.center, light.radius)) return 0.0;
  const glm::dvec3 to_light = light.center - x;
  const double d2 = to_light.x * to_light.x + to_light.y * to_light.y + to_light.z * to_light.z;
  const double cosine =
      (n.x * to_light.x + n.y * to_light.y + n.z * to_light.z) / std::sqrt(std::max(d2, 1e-300));
  if (!(cosine > 0.0)) return 0.0;
  int visible = 0;
  for (const glm::dvec3& p : points) {
    const glm::dvec3 to_p = p - x;
    // A light point behind the sample's own plane cannot be seen through it.
    if (n.x * to_p.x + n.y * to_p.y + n.z * to_p.z > 0.0 && !occluded(x, p)) ++visible;
  }
  return light.intensity * double(visible) / double(points.size()) * cosine /
         light_falloff_d2(d2, light.radius, texel_area) / 3.14159265358979323846;
}

// ld = E / pi at every sample (albedo 1; the caller scales by albedo), into out[n]; the
// texels' footprint is the scene's texel_area (1 / res^2 in a unit block).
void direct_light(const BlockScene& scene, const SampleLayout& layout, const SphereLight& light, int samples,
                  std::span<double> out);

// Positions of the prior's sphere lights: a grid^3 lattice of cell centres inside the
// block, plus the same lattice in the neighbouring cell beyond each missing side face
// (light that enters through interfaces).
std::vector<glm::dvec3> prior_light_positions(FaceMask mask, int grid);
// The same with grid.x x grid.y x grid.z lattice cells (canonical coordinates).
std::vector<glm::dvec3> prior_light_positions(FaceMask mask, const glm::ivec3& grid);

// Lights per axis of the prior lattice in the box [0, extent] (MRT §8: the prior stretched to
// a shaped block): the cube's density, `grid` lights along the shortest edge and
// proportionally more along the others, at most kMaxPriorLatticeFactor grid^3 lights in all
// (a 100:1:1 box gets a sparser lattice). The unit cube gets grid^3.
inline constexpr double kMaxPriorLatticeFactor = 8.0;
glm::ivec3 prior_lattice(int grid, const glm::dvec3& extent);

// Ld (n x m): one column per prior light, each normalised to unit L2 norm so that lights
// near walls do not dominate the prior's SVD (all-zero columns are dropped).
// normalise = false keeps raw intensities (for comparison with MRT Table 2 only).
MatrixXd light_prior_matrix(const BlockScene& scene, const SampleLayout& layout, int grid, double radius,
                            int samples, bool normalise = true);

}  // namespace modrt::precompute
