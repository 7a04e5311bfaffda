// SPDX-License-Identifier: MIT
// modrt precompute — operators driven by the implicit lighting environment Limp:
// vector irradiance U_vec_b (MRT §6.4, appendix B; architecture.md §3.6) and volume probes Ubvol
// (MRT §6.5; architecture.md §3.7). Both light the block with each column of Limp (outgoing radiance
// at the samples, looked up bilinearly where rays hit present faces) and project the
// incident radiance to SH9.
#pragma once

#include <cstdint>

#include "modrt/cube.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/linalg.h"

namespace modrt::precompute {

// 4n x kb: row 4*s + i holds OHLSH coefficient i of E_ind/pi at sample s, in the face
// frame (x = u_axis, y = v_axis, z = inward normal). Uniform stratified hemisphere rays.
MatrixXd vector_irradiance_operator(const BlockScene& scene, const SampleLayout& layout, const MatrixXd& Limp,
                                    int rays, std::uint64_t seed);

// 9 g^3 x kb: row 9*p + j holds SH9 coefficient j of the incident *radiance* at probe p
// (block coordinates, y up), p = (iz * g + iy) * g + ix at ((ix, iy, iz) + 0.5) / g.
// Uniform stratified sphere rays; rays leaving through missing faces see nothing.
MatrixXd volume_probe_operator(const BlockScene& scene, const SampleLayout& layout, const MatrixXd& Limp,
                               int grid, int rays, std::uint64_t seed);

glm::dvec3 probe_position(int probe, int grid);

}  // namespace modrt::precompute
