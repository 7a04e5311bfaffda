// SPDX-License-Identifier: MIT
// modrt precompute — dense double matrices (Eigen) used throughout the bake.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "modrt/dictionary.h"

namespace modrt::precompute {

using MatrixXd = Eigen::MatrixXd;
using VectorXd = Eigen::VectorXd;
// F is filled row by row from independent threads, so it is stored row-major.
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using SparseRowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

// Bake results are double; the dictionary and levels store float (architecture.md §3.4).
inline Matrix to_float(const MatrixXd& m) {
  Matrix out(std::uint32_t(m.rows()), std::uint32_t(m.cols()));
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out(std::uint32_t(r), std::uint32_t(c)) = float(m(r, c));
  return out;
}

inline MatrixXd to_eigen(const Matrix& m) {
  using RowMajorFloat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  return Eigen::Map<const RowMajorFloat>(m.data.data(), m.rows, m.cols).cast<double>();
}

}  // namespace modrt::precompute
