// SPDX-License-Identifier: MIT
// modrt precompute — Eigen's BDCSVD on dense double matrices, compiled in one translation unit.
//
// Include this instead of <Eigen/SVD>. BDCSVD<MatrixXd> is instantiated once, in svd.cpp; every
// other file that decomposes only declares it (extern template), because each implicit
// instantiation costs about 40 s of -O2 compile time and seven files use it (CI's budget).
#pragma once

#include <Eigen/Core>
#include <Eigen/SVD>

extern template class Eigen::BDCSVD<Eigen::MatrixXd>;
