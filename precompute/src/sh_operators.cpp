// SPDX-License-Identifier: MIT
#include "modrt/precompute/sh_operators.h"

#include <numbers>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

#include "modrt/precompute/sampling.h"
#include "modrt/sh.h"

namespace modrt::precompute {
namespace {

using Sh9xK = Eigen::Matrix<double, kSh9Count, Eigen::Dynamic>;

// Accumulates sum over rays of y(dir_local) * L(hit)^T, L = the kb Limp values seen.
void accumulate_ray(const BlockScene& scene, const SampleLayout& layout, const MatrixXd& Limp,
                    const glm::dvec3& origin, const glm::dvec3& dir_world, const glm::dvec3& dir_local,
                    Eigen::RowVectorXd& radiance, Sh9xK& acc) {
  const FaceHit hit = scene.intersect(origin, dir_world);
  if (hit.face < 0) return;
  const BilinearTaps taps = bilinear_taps(hit.u, hit.v, layout.res);
  radiance.setZero();
  for (int t = 0; t < 4; ++t) radiance += taps.w[t] * Limp.row(layout.index(hit.face, taps.i[t], taps.j[t]));
  double y[kSh9Count];
  sh9_eval(dir_local, y);
  acc.noalias() += Eigen::Map<const Eigen::Matrix<double, kSh9Count, 1>>(y) * radiance;
}

}  // namespace

MatrixXd vector_irradiance_operator(const BlockScene& scene, const SampleLayout& layout, const MatrixXd& Limp,
                                    int rays, std::uint64_t seed) {
  const int n = layout.sample_count();
  const Eigen::Index kb = Limp.cols();
  MatrixXd out = MatrixXd::Zero(4 * Eigen::Index(n), kb);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4), [&](const tbb::blocked_range<int>& range) {
    std::vector<glm::dvec2> strata;
    Eigen::RowVectorXd radiance(kb);
    Sh9xK acc(kSh9Count, kb);
    for (int s = range.begin(); s != range.end(); ++s) {
      Rng rng(seed, std::uint64_t(s));
      stratified_square(rays, rng, strata);
      const FaceFrame& frame = face_frame(layout.face_of(s));
      const glm::dvec3 x = scene.point(layout.position(s));
      acc.setZero();
      for (const glm::dvec2& u : strata) {
        const glm::dvec3 local = uniform_hemisphere(u);
        accumulate_ray(scene, layout, Limp, x, to_world(local, frame.u_axis, frame.v_axis, frame.normal),
                       local, radiance, acc);
      }
      // Monte Carlo with pdf 1/(2 pi); then clamped-cosine convolution to E/pi; then OHLSH.
      acc *= 2.0 * std::numbers::pi / rays;
      for (Eigen::Index k = 0; k < kb; ++k) {
        double L[kSh9Count], E[kSh9Count], a[kOhlshCount];
        for (int j = 0; j < kSh9Count; ++j) L[j] = acc(j, k);
        irradiance_from_radiance_sh9(L, E);
        ohlsh_from_sh9(E, a);
        for (int i = 0; i < kOhlshCount; ++i) out(4 * Eigen::Index(s) + i, k) = a[i];
      }
    }
  });
  return out;
}

glm::dvec3 probe_position(int probe, int grid) {
  const int ix = probe % grid;
  const int iy = (probe / grid) % grid;
  const int iz = probe / (grid * grid);
  return {(ix + 0.5) / grid, (iy + 0.5) / grid, (iz + 0.5) / grid};
}

MatrixXd volume_probe_operator(const BlockScene& scene, const SampleLayout& layout, const MatrixXd& Limp,
                               int grid, int rays, std::uint64_t seed) {
  const int probes = grid * grid * grid;
  const Eigen::Index kb = Limp.cols();
  MatrixXd out = MatrixXd::Zero(9 * Eigen::Index(probes), kb);
  tbb::parallel_for(tbb::blocked_range<int>(0, probes, 1), [&](const tbb::blocked_range<int>& range) {
    std::vector<glm::dvec2> strata;
    Eigen::RowVectorXd radiance(kb);
    Sh9xK acc(kSh9Count, kb);
    for (int p = range.begin(); p != range.end(); ++p) {
      Rng rng(seed, std::uint64_t(p));
      stratified_square(rays, rng, strata);
      const glm::dvec3 x = scene.point(probe_position(p, grid));
      acc.setZero();
      for (const glm::dvec2& u : strata) {
        const glm::dvec3 dir = uniform_sphere(u);
        accumulate_ray(scene, layout, Limp, x, dir, dir, radiance, acc);
      }
      acc *= 4.0 * std::numbers::pi / rays;  // pdf 1/(4 pi)
      out.middleRows(9 * Eigen::Index(p), 9) = acc;
    }
  });
  return out;
}

}  // namespace modrt::precompute
