// SPDX-License-Identifier: MIT
#include "modrt/precompute/transport.h"

#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "modrt/precompute/sampling.h"
#include "modrt/precompute/symmetry.h"

namespace modrt::precompute {

RowMatrixXd gather_transport(const BlockScene& scene, const SampleLayout& layout, int rays,
                             std::uint64_t seed, int row_begin, int row_end) {
  const int n = layout.sample_count();
  if (row_end < 0 || row_end > n) row_end = n;
  RowMatrixXd F = RowMatrixXd::Zero(n, n);
  const double weight = 1.0 / rays;
  tbb::parallel_for(
      tbb::blocked_range<int>(row_begin, row_end, 8), [&](const tbb::blocked_range<int>& range) {
        std::vector<glm::dvec2> strata;
        for (int s = range.begin(); s != range.end(); ++s) {
          Rng rng(seed, std::uint64_t(s));
          stratified_square(rays, rng, strata);
          const FaceFrame& frame = face_frame(layout.face_of(s));
          const glm::dvec3 x = scene.point(layout.position(s));
          double* row = F.row(s).data();
          for (const glm::dvec2& u : strata) {
            const glm::dvec3 dir = to_world(cosine_hemisphere(u), frame.u_axis, frame.v_axis, frame.normal);
            const FaceHit hit = scene.intersect(x, dir);
            if (hit.face < 0) continue;
            const BilinearTaps taps = bilinear_taps(hit.u, hit.v, layout.res);
            for (int t = 0; t < 4; ++t)
              row[layout.index(hit.face, taps.i[t], taps.j[t])] += weight * taps.w[t];
          }
        }
      });
  return F;
}

void symmetrize_transport(RowMatrixXd& F, const SampleLayout& layout, const glm::dvec3& extent) {
  const std::vector<BlockSymmetry> group = shape_symmetries(layout.mask, extent);
  if (group.size() <= 1) return;
  std::vector<std::vector<int>> perms;
  for (const BlockSymmetry& g : group) perms.push_back(sample_permutation(layout, g));
  const Eigen::Index n = F.rows();
  RowMatrixXd sum = RowMatrixXd::Zero(n, n);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, 16),
                    [&](const tbb::blocked_range<Eigen::Index>& range) {
                      for (Eigen::Index s = range.begin(); s != range.end(); ++s)
                        for (const std::vector<int>& p : perms) {
                          const double* src = F.row(p[std::size_t(s)]).data();
                          double* dst = sum.row(s).data();
                          for (Eigen::Index t = 0; t < n; ++t) dst[t] += src[p[std::size_t(t)]];
                        }
                    });
  F = sum / double(group.size());
}

}  // namespace modrt::precompute
