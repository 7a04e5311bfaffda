// SPDX-License-Identifier: MIT
#include "modrt/precompute/direct_light.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

#include "modrt/precompute/sampling.h"

namespace modrt::precompute {

void sphere_light_points(const glm::dvec3& center, double radius, int samples, std::vector<glm::dvec3>& out) {
  if (!light_in_reach(center, radius))
    out.clear();
  else if (radius > 0.0 && samples > 1)
    sphere_surface_points(center, radius, samples, out);
  else
    out.assign(1, center);
}

void direct_light(const BlockScene& scene, const SampleLayout& layout, const SphereLight& light, int samples,
                  std::span<double> out) {
  std::vector<glm::dvec3> points;
  sphere_light_points(light.center, light.radius, samples, points);
  auto occluded = [&](const glm::dvec3& a, const glm::dvec3& b) { return scene.occluded(a, b); };
  const int n = layout.sample_count();
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 64), [&](const tbb::blocked_range<int>& range) {
    for (int s = range.begin(); s != range.end(); ++s)
      out[std::size_t(s)] =
          sphere_light_E_over_pi(scene.point(layout.position(s)), layout.normal(s), light, points,
                                 scene.texel_area(layout.face_of(s), layout.res), occluded);
  });
}

glm::ivec3 prior_lattice(int grid, const glm::dvec3& extent) {
  const double shortest = std::min({extent.x, extent.y, extent.z});
  glm::dvec3 want;
  for (int a = 0; a < 3; ++a) want[a] = grid * extent[a] / shortest;
  // At most kMaxPriorLatticeFactor grid^3 lights: a very long box gets a sparser lattice.
  const double cap = kMaxPriorLatticeFactor * double(grid) * grid * grid, lights = want.x * want.y * want.z;
  if (lights > cap) want *= std::cbrt(cap / lights);
  glm::ivec3 out;
  for (int a = 0; a < 3; ++a) out[a] = std::max(1, int(std::lround(want[a])));
  return out;
}

std::vector<glm::dvec3> prior_light_positions(FaceMask mask, int grid) {
  return prior_light_positions(mask, glm::ivec3(grid));
}

std::vector<glm::dvec3> prior_light_positions(FaceMask mask, const glm::ivec3& grid) {
  std::vector<glm::dvec3> lattice;
  for (int k = 0; k < grid.z; ++k)
    for (int j = 0; j < grid.y; ++j)
      for (int i = 0; i < grid.x; ++i)
        lattice.push_back({(i + 0.5) / grid.x, (j + 0.5) / grid.y, (k + 0.5) / grid.z});
  std::vector<glm::dvec3> positions = lattice;
  for (int f = 0; f < kFaceCount; ++f) {
    if (face_present(mask, f)) continue;
    const glm::dvec3 outward = -face_frame(f).normal;
    for (const glm::dvec3& p : lattice) positions.push_back(p + outward);
  }
  return positions;
}

MatrixXd light_prior_matrix(const BlockScene& scene, const SampleLayout& layout, int grid, double radius,
                            int samples, bool normalise) {
  const std::vector<glm::dvec3> positions =
      prior_light_positions(layout.mask, prior_lattice(grid, scene.extent()));
  const int n = layout.sample_count();
  MatrixXd Ld(n, Eigen::Index(positions.size()));
  std::vector<double> column(static_cast<std::size_t>(n));
  Eigen::Index kept = 0;
  for (const glm::dvec3& c : positions) {
    // A shaped block's lattice is stretched with it (MRT §8: the prior follows the box).
    direct_light(scene, layout, SphereLight{scene.point(c), radius, 1.0}, samples, column);
    Eigen::Map<const VectorXd> col(column.data(), n);
    const double norm = col.norm();
    if (!(norm > 1e-12)) continue;
    Ld.col(kept++) = normalise ? VectorXd(col / norm) : VectorXd(col);
  }
  Ld.conservativeResize(Eigen::NoChange, kept);
  return Ld;
}

}  // namespace modrt::precompute
