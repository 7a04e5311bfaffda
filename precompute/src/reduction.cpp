// SPDX-License-Identifier: MIT
#include "modrt/precompute/reduction.h"

#include <algorithm>

#include "modrt/precompute/svd.h"

namespace modrt::precompute {

Eigen::Index cluster_safe_rank(const VectorXd& sigma, Eigen::Index k) {
  Eigen::Index keep = std::min<Eigen::Index>(k, sigma.size());
  if (keep == 0) return 0;
  const double floor = 1e-13 * sigma(0);
  while (keep > 0 && !(sigma(keep - 1) > floor)) --keep;
  // Never cut through a cluster of (numerically) equal singular values: its subspace is
  // invariant under the shape's symmetries, any part of it is not.
  const double tie = 1e-9 * sigma(0);
  while (keep > 0 && keep < sigma.size() && sigma(keep - 1) - sigma(keep) <= tie) --keep;
  return keep;
}

LightPrior truncated_left_svd(const MatrixXd& columns, int k) {
  Eigen::BDCSVD<MatrixXd> svd(columns, Eigen::ComputeThinU);
  const VectorXd& sigma = svd.singularValues();
  const Eigen::Index keep = cluster_safe_rank(sigma, k);
  return {svd.matrixU().leftCols(keep), sigma.head(keep)};
}

ReducedTransfer reduce_transfer(const RowMatrixXd& F, const LightPrior& prior, int kb) {
  const MatrixXd PS = prior.P * prior.S.asDiagonal();
  const MatrixXd M = F * PS;
  Eigen::BDCSVD<MatrixXd> svd(M, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const VectorXd& sigma = svd.singularValues();
  const Eigen::Index k = cluster_safe_rank(sigma, kb);

  ReducedTransfer out;
  out.sigma_M = sigma;
  const MatrixXd Um = svd.matrixU().leftCols(k);
  const MatrixXd Vm = svd.matrixV().leftCols(k);
  out.Ub = MatrixXd::Zero(F.rows(), kb);
  out.Limp = MatrixXd::Zero(F.rows(), kb);
  out.Td_b = MatrixXd::Zero(kb, F.rows());
  out.Ub.leftCols(k) = Um * sigma.head(k).asDiagonal();
  out.Limp.leftCols(k) = PS * Vm;
  // Stable Td_b: modes whose singular value is numerically zero map to b = 0 instead of
  // amplifying noise by 1/sigma.
  VectorXd inv(k);
  for (Eigen::Index i = 0; i < k; ++i) inv(i) = sigma(i) > 1e-12 * sigma(0) ? 1.0 / sigma(i) : 0.0;
  const MatrixXd UtF = Um.transpose() * F;
  out.Td_b.topRows(k) = inv.asDiagonal() * ((UtF * prior.P) * prior.P.transpose());
  return out;
}

MatrixXd face_constant_columns(const SampleLayout& layout) {
  const int n = layout.sample_count();
  const int faces = face_count(layout.mask);
  MatrixXd C = MatrixXd::Zero(n, faces);
  for (int s = 0; s < n; ++s) C(s, s / layout.texels_per_face()) = 1.0;
  return C;
}

LightPrior enrich_prior(const LightPrior& prior, const MatrixXd& face_constants, const MatrixXd& Ub, int kd) {
  const MatrixXd PS = prior.P * prior.S.asDiagonal();
  auto unit = [](const MatrixXd& m) -> MatrixXd {
    const double norm = m.norm();
    return norm > 0.0 ? MatrixXd(m / norm) : m;
  };
  MatrixXd all(PS.rows(), PS.cols() + face_constants.cols() + Ub.cols());
  all << unit(PS), unit(face_constants), unit(Ub);
  return truncated_left_svd(all, kd);
}

int modes_for_energy(const VectorXd& sigma, double fraction) {
  const double total = sigma.squaredNorm();
  double acc = 0.0;
  for (Eigen::Index i = 0; i < sigma.size(); ++i) {
    acc += sigma(i) * sigma(i);
    if (acc >= fraction * total) return int(i + 1);
  }
  return int(sigma.size());
}

}  // namespace modrt::precompute
