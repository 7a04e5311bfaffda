// SPDX-License-Identifier: MIT
#include "modrt/precompute/svd.h"

// The one instantiation the extern declaration in svd.h refers to.
template class Eigen::BDCSVD<Eigen::MatrixXd>;
