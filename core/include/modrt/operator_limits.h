// SPDX-License-Identifier: MIT
// modrt — plausibility limits of baked operators: the one place that says how large a
// dictionary's or level's operator may be (docs/robustness.md, "Issue 18: binary loaders").
//
// The loaders (parse_dictionary via validate_dictionary, parse_level) check finiteness and
// then these limits, so a file with valid checksums but a huge value poked into an operator
// is refused naming the section. The limits follow from how the bake normalises its
// operators (precompute/reduction.h, direct_light.h):
//
// * The prior's lighting matrix has unit-norm columns, so its singular values are at most
//   prior_scale(settings) = sqrt(prior_grid^3) (Frobenius norm), or sqrt(3) after
//   enrichment (enrich_prior scales its three blocks to unit Frobenius norm).
//   Measured in the tests' and committed dictionaries: see the constants below.
// * Ub = Um~ Sm~ and Td_b = Sm~^-1 Um~^T F P P^T: for every mode k, ||Ub_k||_2 ||Td_b,k||_2
//   <= ||F||_2 <= 1 (row sums of F <= 1, F symmetric up to Monte Carlo noise for the equal-area
//   samples of a face grid). The product is scale free; ||Ub_k||_2 = sigma_k(M) <=
//   ||F||_2 prior_scale bounds the scale, and ||Limp_k||_2 = ||P S v_k||_2 <= prior_scale.
// * Ub_vec, Ubvol and Rb_rlf gather the light Limp_k emits (SH / lightfield projections
//   with bounded weights), so their columns are at most a fixed factor times prior_scale.
// * The interface operators and a level's response operators have no prior in front; their
//   limits are the measured maxima of the baked dictionaries times a stated margin.
//
// On top of these, check_level_gain (run by check_level_operators, i.e. by every backend at
// creation) bounds the amplification from ld to every intermediate (b, r) and output
// (lightmap, probes, vector irradiance) computed with absolute values: with ld <=
// kMaxLightValue no float can overflow, so every update's output is finite.
#pragma once

#include <string>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/status.h"

namespace modrt {

// Measured maxima (docs/robustness.md, test_operator_limits) are in the comments.
// Tolerance on the physical bounds (<= 1): Monte Carlo asymmetry of F, float rounding.
inline constexpr double kOperatorBoundTolerance = 0.5;
// ||Ub_k||_2 ||Td_b,k||_2 <= ||F||_2 (1 + tolerance); measured 1.0000.
// ||Ub_k||_2 <= (1 + tolerance) prior_scale; measured 0.82 prior_scale.
inline constexpr double kModeTransferLimit = 1.0 + kOperatorBoundTolerance;
// A shaped block's box (Level::shaped, MRT §8) has texels of different areas, so F is no
// longer symmetric: ||F||_1 <= A_max / A_min (reciprocity A_i F_ij = A_j F_ji, rows sum to at
// most 1) and ||F||_2 <= sqrt(||F||_1 ||F||_inf) <= sqrt(longest edge / shortest edge). Both
// limits above are scaled by that factor for shaped operators.
double shaped_transfer_factor(const glm::vec3& extent);
// ||Limp_k||_2 <= kLimpScaleLimit prior_scale. Derived: <= 1 (Limp = P S Vm~); the committed
// tiny dictionaries (res 2, 16 rays) reach 1.78, not explained, so 4 (unused at run time).
inline constexpr double kLimpScaleLimit = 4.0;
// max |entry| / prior_scale of the operators gathering Limp's light.
inline constexpr double kUbVecGatherLimit = 4.0;  // OHLSH coefficients of E/pi; measured 0.51
inline constexpr double kUbvolGatherLimit = 8.0;  // SH9 radiance: 4 pi max |Y_lm| = 7.93; measured 0.87
// Rb_rlf: a reduced coefficient is a unit vector times the S^2 D^2 lightfield values, so at
// most S D times the largest radiance: max |entry| <= kRbRlfGatherLimit S D prior_scale
// (S = lightfield_spatial, D = lightfield_directional); measured 0.57 S D prior_scale.
inline constexpr double kRbRlfGatherLimit = 4.0;
// Interface operators and level responses (T, turned Urvol / Ur_vec): largest |entry|;
// measured 2.03 (Urvol and probe_response), 1.17 (R_straight), 0.66 (T).
inline constexpr double kInterfaceEntryLimit = 64.0;
// Largest amplification from ld (max over samples and channels) to any intermediate or
// output value, over every block and slot of a level; measured 352 (b, res 8), 58.7 (probes).
// Every ld the transport sees is at most kMaxLightValue (validated; the CPU runtime validates
// its fed-back ld like any other, GLES refuses a multi-bounce step whose fed-back ld could
// exceed it), so every partial sum stays below kMaxOutputGain x kMaxLightValue = 1e36, a
// factor 340 under FLT_MAX = 3.4e38.
inline constexpr double kMaxOutputGain = 1e6;

// Upper bound on the prior's singular values implied by the bake's normalisation.
double prior_scale(const DictionarySettings& settings);

// One measured quantity and its limit; `where` names the section and entry.
struct OperatorMeasure {
  std::string where;  // e.g. "shape 1 (dead_end): Td_b row 3"
  std::string what;   // e.g. "||Ub_k||_2 ||Td_b,k||_2"
  double value = 0.0;
  double limit = 0.0;
};

// Every limit of the dictionary's operators, measured (the largest value per operator and
// shape). Sizes must already be valid (validate_dictionary's size checks).
std::vector<OperatorMeasure> measure_dictionary_operators(const Dictionary& dict);
// The level's own operators (records' T, probe and vector responses).
std::vector<OperatorMeasure> measure_level_operators(const Level& level);
// The amplification bound of check_level_gain, per intermediate / output, and the level's
// shaped operators measured as measure_dictionary_operators measures a shape.
std::vector<OperatorMeasure> measure_level_gain(const Level& level, const Dictionary& dict);

// The first measure above its limit, as invalid_argument "<what>: <where>: <what> = v, above
// the limit l (operator_limits.h): <reason>".
inline constexpr const char* kImplausibleOperator =
    "not a plausible baked operator (corrupt or crafted file?)";
Status check_measures(const std::vector<OperatorMeasure>& measures, const std::string& what,
                      const char* reason = kImplausibleOperator);

// measure_level_gain + check_measures; sizes must be valid (check_level_operators).
Status check_level_gain(const Level& level, const Dictionary& dict);

}  // namespace modrt
