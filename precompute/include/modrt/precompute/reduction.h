// SPDX-License-Identifier: MIT
// modrt precompute — reduced direct-to-indirect transfer (MRT §4, appendix A; architecture.md §3.2–3.5).
//
// All in double. Names follow MRT Table 1:
//   Ld = Ud Sd Vd^T,  P = first kd columns of Ud,  S = diag of their singular values;
//   M = F P S = Um Sm Vm^T;  Ub = Um~ Sm~;  Limp = P S Vm~;
//   Td_b = Sm~^-1 Um~^T F P P^T  (equal to Vm~^T S^-1 P^T in exact arithmetic, but it never
//   divides by the prior's small singular values).
#pragma once

#include "modrt/cube.h"
#include "modrt/precompute/linalg.h"

namespace modrt::precompute {

struct LightPrior {
  MatrixXd P;  // n x kd, orthonormal columns
  VectorXd S;  // kd singular values (descending)
};

struct ReducedTransfer {
  MatrixXd Ub;       // n x kb
  MatrixXd Td_b;     // kb x n
  MatrixXd Limp;     // n x kb
  VectorXd sigma_M;  // all singular values of M
};

// Number of leading modes to keep: at most k, without numerically zero values (below
// 1e-13 sigma_0), and never splitting a cluster of equal values (gap <= 1e-9 sigma_0).
Eigen::Index cluster_safe_rank(const VectorXd& sigma, Eigen::Index k);

// Left singular vectors and values of `columns`, truncated to cluster_safe_rank(k).
LightPrior truncated_left_svd(const MatrixXd& columns, int k);

ReducedTransfer reduce_transfer(const RowMatrixXd& F, const LightPrior& prior, int kb);

// Per-face constant columns (1 on the samples of one present face, 0 elsewhere).
MatrixXd face_constant_columns(const SampleLayout& layout);

// Appendix A: rescale P S, the per-face constants and Ub to the same Frobenius norm,
// concatenate, SVD, keep kd -> the enriched prior.
LightPrior enrich_prior(const LightPrior& prior, const MatrixXd& face_constants, const MatrixXd& Ub, int kd);

// Number of leading singular values holding `fraction` of the energy sum(sigma^2).
int modes_for_energy(const VectorXd& sigma, double fraction);

}  // namespace modrt::precompute
