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
  const double texel_area = layout.res > 0 ? 1.0 / (double(layout.res) * layout.res) : 0.0;
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 64), [&](const tbb::blocked_range<int>& range) {
    for (int s = range.begin(); s != range.end(); ++s)
      out[std::size_t(s)] =
          sphere_light_E_over_pi(layout.position(s), layout.normal(s), light, points, texel_area, occluded);
  });
}

std::vector<glm::dvec3> prior_light_positions(FaceMask mask, int grid) {
  std::vector<glm::dvec3> lattice;
  for (int k = 0; k < grid; ++k)
    for (int j = 0; j < grid; ++j)
      for (int i = 0; i < grid; ++i)
        lattice.push_back({(i + 0.5) / grid, (j + 0.5) / grid, (k + 0.5) / grid});
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
  const std::vector<glm::dvec3> positions = prior_light_positions(layout.mask, grid);
  const int n = layout.sample_count();
  MatrixXd Ld(n, Eigen::Index(positions.size()));
  std::vector<double> column(static_cast<std::size_t>(n));
  Eigen::Index kept = 0;
  for (const glm::dvec3& c : positions) {
    direct_light(scene, layout, SphereLight{c, radius, 1.0}, samples, column);
    Eigen::Map<const VectorXd> col(column.data(), n);
    const double norm = col.norm();
    if (!(norm > 1e-12)) continue;
    Ld.col(kept++) = normalise ? VectorXd(col / norm) : VectorXd(col);
  }
  Ld.conservativeResize(Eigen::NoChange, kept);
  return Ld;
}

}  // namespace modrt::precompute
