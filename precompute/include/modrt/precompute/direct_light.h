// modrt precompute — direct light from sphere lights at the samples of a block, with
// visibility by Embree shadow rays. This is the direct-light model of the lighting prior
// (MRT §4, SPEC §3.2) and of the references the runtime is checked against.
#pragma once

#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/cube.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/linalg.h"

namespace modrt::precompute {

// A sphere light of radiant intensity `intensity` (W/sr, as a point light at its centre).
// Irradiance at x with normal n: E = I * V * max(0, n.w) / max(d^2, radius^2), where w and
// d are direction and distance to the centre and V is the fraction of `samples` points on
// the sphere's surface that x sees unoccluded (soft shadows). radius 0 = point light.
struct SphereLight {
  glm::dvec3 center{0.5};
  double radius = 0.05;
  double intensity = 1.0;
};

// ld = E / pi at every sample (albedo 1; the caller scales by albedo), into out[n].
void direct_light(const BlockScene& scene, const SampleLayout& layout, const SphereLight& light,
                  int samples, std::span<double> out);

// Positions of the prior's sphere lights: a grid^3 lattice of cell centres inside the
// block, plus the same lattice in the neighbouring cell beyond each missing side face
// (light that enters through interfaces).
std::vector<glm::dvec3> prior_light_positions(FaceMask mask, int grid);

// Ld (n x m): one column per prior light, each normalised to unit L2 norm so that lights
// near walls do not dominate the prior's SVD (all-zero columns are dropped).
// normalise = false keeps raw intensities (for comparison with MRT Table 2 only).
MatrixXd light_prior_matrix(const BlockScene& scene, const SampleLayout& layout, int grid,
                            double radius, int samples, bool normalise = true);

}  // namespace modrt::precompute
