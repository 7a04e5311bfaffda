// SPDX-License-Identifier: MIT
// modrt precompute — the one-bounce operator F of a block (architecture.md §3.3, MRT §3.1).
//
// Row s of F maps outgoing diffuse radiance at every sample to E_ind / pi at sample s:
// cosine-weighted stratified gather rays; a ray that hits a present face samples that
// face's texel grid bilinearly (weights 1/rays); a ray leaving through a missing face
// contributes nothing. So a row sums to the cosine-weighted fraction of the hemisphere
// that sees present faces (1 in a closed box).
#pragma once

#include <cstdint>

#include "modrt/cube.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/linalg.h"

namespace modrt::precompute {

// Rows [row_begin, row_end) are gathered (row_end < 0: all); other rows stay zero.
RowMatrixXd gather_transport(const BlockScene& scene, const SampleLayout& layout, int rays,
                             std::uint64_t seed, int row_begin = 0, int row_end = -1);

// Averages F over the symmetries of the shape's box (shape_symmetries): F(s, t) <- mean over
// g of F(g s, g t). The exact operator has these symmetries; its Monte Carlo estimate only
// approximately.
void symmetrize_transport(RowMatrixXd& F, const SampleLayout& layout,
                          const glm::dvec3& extent = glm::dvec3(1.0));

}  // namespace modrt::precompute
