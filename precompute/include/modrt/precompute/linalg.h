// modrt precompute — dense double matrices (Eigen) used throughout the bake.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace modrt::precompute {

using MatrixXd = Eigen::MatrixXd;
using VectorXd = Eigen::VectorXd;
// F is filled row by row from independent threads, so it is stored row-major.
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using SparseRowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

}  // namespace modrt::precompute
