// SPDX-License-Identifier: MIT
// modrt precompute — the dictionary bake (architecture.md §3, MRT §7.1): per dictionary shape, the
// lighting prior, F, the reduced transfer with enrichment, vector irradiance and volume
// probes; then the float Dictionary the run time loads.
#pragma once

#include <cstdint>

#include <functional>
#include <string>

#include "modrt/dictionary.h"
#include "modrt/precompute/linalg.h"
#include "modrt/precompute/reduction.h"

namespace modrt::precompute {

// Everything computed for one shape, in double, before conversion to float. Tests and
// reports use the intermediate matrices; the dictionary keeps only the operators.
struct ShapeBake {
  FaceMask mask = kAllFaces;
  glm::dvec3 extent{1.0};  // the box's edge lengths (bake_box_shape); the unit cube otherwise
  SampleLayout layout;
  RowMatrixXd F;                 // n x n one-bounce operator
  MatrixXd Ld;                   // n x m prior lighting patterns (unit columns)
  LightPrior prior;              // final prior (after enrichment)
  LightPrior raw_prior;          // prior before enrichment
  ReducedTransfer transfer;      // final Ub, Td_b, Limp
  ReducedTransfer raw_transfer;  // before enrichment
  MatrixXd Ub_vec;               // 4n x kb OHLSH vector irradiance
  MatrixXd Ubvol;                // 9 g^3 x kb probe SH
};

struct BakeProgress {
  // Called after each stage: stage name, shape index, seconds the stage took.
  std::function<void(const std::string& stage, int shape, double seconds)> on_stage;
};

// Bakes one shape. `with_sh` = false skips vector irradiance and probes (tests that only
// need F and the reduced transfer). Throws std::runtime_error / std::invalid_argument; the
// tool and API boundaries convert to Status.
ShapeBake bake_shape(FaceMask mask, const DictionarySettings& settings, bool with_sh = true,
                     const BakeProgress& progress = {});

// bake_shape for the box [0, extent] instead of the unit cube (MRT §8, Figure 12: a block
// whose proportions are not a cube's): the same samples (res^2 per present face, stretched
// with their faces), the prior lattice stretched to the box (light_radius unchanged, so pass
// an extent of about unit size, e.g. geometric mean 1), F re-traced in the box and reduced
// and enriched as bake_shape does; the symmetrisation uses only the box's symmetries.
// Throws std::invalid_argument for an extent that is not finite and > 0.
ShapeBake bake_box_shape(FaceMask mask, const glm::dvec3& extent, const DictionarySettings& settings,
                         bool with_sh = true, const BakeProgress& progress = {});

// bake_shape with a given prior lighting matrix Ld (n x m: the direct light of m prior lights
// at the shape's samples, e.g. from direct_light()) in place of the settings' sphere-light
// lattice; prior_grid, light_radius and light_samples are then unused. The numerical stress
// tests feed it near-singular priors (duplicate, colinear and on-wall lights). Throws
// std::invalid_argument when Ld is not finite, has no column or the wrong row count.
ShapeBake bake_shape_with_prior(FaceMask mask, const DictionarySettings& settings, const MatrixXd& Ld,
                                bool with_sh = true, const BakeProgress& progress = {});

ShapeOperators to_operators(const ShapeBake& bake);

// The interface part of the dictionary settings.
struct InterfaceSettings;
InterfaceSettings interface_settings(const DictionarySettings& settings);

// Bakes the six-shape 2D cube dictionary and, unless settings.lightfield_spatial == 0, the
// interface operators (shape index -1 in progress reports). Never throws: errors come back as a Status.
// The bake's peak memory, estimated up front from the settings (bytes, double precision,
// saturating at UINT64_MAX), by its parts: each shape's one-bounce operator F (n x n, n =
// 6 res^2) with the working copy of M = F P S; the prior lattice (n x 5 grid^3 lights, with
// the SVD's copy and thin U); per worker thread the ray directions of one sample (the
// largest of rays, sh_rays, response_rays) and one light's light_samples points; the
// operators kept per shape; with interfaces, the dead end's lightfield response
// (n_dead x S^2 D^2) and its copy.
struct BakeMemoryEstimate {
  std::uint64_t transport = 0, prior = 0, thread_buffers = 0, shape_operators = 0, lightfield = 0;
  std::uint64_t total = 0;
};
BakeMemoryEstimate estimate_bake_memory(const DictionarySettings& settings);
std::uint64_t estimate_bake_bytes(const DictionarySettings& settings);  // estimate_bake_memory().total
inline constexpr std::uint64_t kDefaultBakeMemoryBudget = std::uint64_t(8) << 30;  // 8 GiB

// Fails with resource_limit, before allocating anything, when estimate_bake_bytes exceeds
// `memory_budget` (the message gives both and the settings to lower). `lightfield_basis`,
// when given and the bake has interfaces, receives the reduced lightfield basis Hrlf
// (S^2 D^2 x krlf, interfaces.h) that the dictionary's interface operators are expressed in:
// the level build needs it to trace interfaces of shaped blocks (shaped_interfaces.h), and
// it cannot be re-derived from the dictionary's floats (the basis would rotate).
Result<Dictionary> bake_dictionary(const DictionarySettings& settings, const BakeProgress& progress = {},
                                   std::uint64_t memory_budget = kDefaultBakeMemoryBudget,
                                   Matrix* lightfield_basis = nullptr);

// A small, fast bake at `res` (a few seconds at res 8, two cores): the tests' dictionary,
// modrt-bench --quick's and the accuracy tools' smoke runs. Fewer rays and SH rays than the
// default, a 2^3 probe grid and a coarse interface lightfield; kb and kd stay the default's.
DictionarySettings quick_dictionary_settings(std::uint32_t res);

}  // namespace modrt::precompute
