// SPDX-License-Identifier: MIT
// modrt — the scene-independent dictionary: per-shape light transport operators
// (architecture.md §3, MRT §4, §6.4, §6.5).
//
// Operators are computed in double by precompute/ and stored here as float32 for the
// run time. Matrices are dense and row-major; the math names follow MRT Table 1.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/cube.h"

namespace modrt {

// Dense row-major float matrix (rows x cols).
struct Matrix {
  std::uint32_t rows = 0;
  std::uint32_t cols = 0;
  std::vector<float> data;

  Matrix() = default;
  Matrix(std::uint32_t r, std::uint32_t c) : rows(r), cols(c), data(std::size_t(r) * c, 0.0f) {}
  float& operator()(std::uint32_t r, std::uint32_t c) { return data[std::size_t(r) * cols + c]; }
  float operator()(std::uint32_t r, std::uint32_t c) const { return data[std::size_t(r) * cols + c]; }
  std::span<const float> row(std::uint32_t r) const { return {data.data() + std::size_t(r) * cols, cols}; }
  bool empty() const { return data.empty(); }
};

// Everything the bake was asked to do; stored in the file so a dictionary is self-describing
// and a cache can be matched against requested settings.
struct DictionarySettings {
  std::uint32_t res = 16;                   // texels per face edge (mobile preset: 6)
  std::uint32_t kd = 64;                    // prior modes (columns of P)
  std::uint32_t kb = 32;                    // indirect modes (columns of Ub) = kself
  std::uint32_t rays = 16384;               // gather rays per sample for F (stratified)
  std::uint32_t enrichment_iterations = 1;  // MRT appendix A passes (0 = none)
  std::uint32_t prior_grid = 6;             // sphere lights per axis inside the block (6^3)
  std::uint32_t light_samples = 16;         // points per sphere light for soft visibility
  float light_radius = 0.05f;               // sphere light radius (block units)
  std::uint32_t sh_rays = 1024;             // rays per sample / probe for SH projections
  std::uint32_t probe_grid = 4;             // g: volume probes per block axis (g^3 probes)
  std::uint64_t seed = 0x6d6f647274ull;     // all sampling is deterministic given the seed
  // Interfaces (MRT §5, §7.1). lightfield_spatial = 0 bakes no interface operators.
  std::uint32_t lightfield_spatial = 12;      // S: positions per interface edge (S^2)
  std::uint32_t lightfield_directional = 24;  // D: direction bins per edge of the concentric square (D^2)
  std::uint32_t lightfield_supersample = 5;   // directional super-sampling per bin edge
  std::uint32_t krlf = 128;                   // reduced lightfield modes
  std::uint32_t kr = 32;                      // response modes
  std::uint32_t interface_enrichment_iterations = 3;
  std::uint32_t response_rays = 4096;  // gather rays per sample for G = Frlf Hrlf

  bool operator==(const DictionarySettings&) const = default;
};

// Upper bounds of the count settings, checked by validate_settings (so by every bake, every
// dictionary load and the tools' flags alike). Each is far above every preset and what a
// useful bake needs, and low enough that every count fits an int (the bake's loops) and
// every product the bake forms fits 64 bits; the bake's memory is bounded separately by
// estimate_bake_bytes and its budget.
inline constexpr std::uint32_t kMaxSettingsRes = 256;                    // n = 6 res^2 samples
inline constexpr std::uint32_t kMaxSettingsModes = 4096;                 // kd, kb, krlf, kr
inline constexpr std::uint32_t kMaxSettingsRays = 1u << 20;              // rays, sh_rays, response_rays
inline constexpr std::uint32_t kMaxSettingsPriorGrid = 16;               // 16^3 prior lights per cell
inline constexpr std::uint32_t kMaxSettingsLightSamples = 1024;          // points per prior sphere light
inline constexpr std::uint32_t kMaxSettingsProbeGrid = 32;               // 32^3 probes per block
inline constexpr std::uint32_t kMaxSettingsEnrichment = 16;              // enrichment passes
inline constexpr std::uint32_t kMaxSettingsLightfieldSpatial = 64;       // S
inline constexpr std::uint32_t kMaxSettingsLightfieldDirectional = 128;  // D
inline constexpr std::uint32_t kMaxSettingsLightfieldSupersample = 16;

// Validates ranges (res in [1, 256], rays in [1, kMaxSettingsRays], kb <= kd, ...);
// messages name the field and the range.
Status validate_settings(const DictionarySettings& s);

// Operators of one dictionary shape. n = face_count(face_mask) * res^2 samples (see
// SampleLayout for their order); kb = columns of Ub.
struct ShapeOperators {
  FaceMask face_mask = kAllFaces;
  Matrix Ub;    // n x kb: indirect light basis, Ub = Um~ Sm~ (MRT §4.1, eq. 3)
  Matrix Td_b;  // kb x n: direct light -> b, Sm~^-1 Um~^T F P P^T (MRT §4.1, stable form)
  Matrix Limp;  // n x kb: implicit lighting environment, Ub = F Limp (MRT §4.1)
  Matrix
      Ub_vec;  // 4n x kb: OHLSH vector irradiance, row 4*s + i = coefficient i of sample s (MRT §6.4, App. B)
  Matrix Ubvol;                // 9 g^3 x kb: radiance SH9 of the volume probes, row 9*p + j (MRT §6.5)
  std::vector<float> sigma_M;  // singular values of M = F P S (all of them, for reports)
  // Rb_rlf[f]: krlf x kb, b -> reduced lightfield leaving through missing side face f
  // (canonical frame); empty for present faces (MRT §5.1).
  std::array<Matrix, kFaceCount> Rb_rlf;

  std::uint32_t sample_count() const { return Ub.rows; }
  std::uint32_t kb() const { return Ub.cols; }
};

// Operators shared by every interface (one canonical interface, MRT §5.1, architecture.md §3.8):
// light enters a cell through -Z (see precompute/interfaces.h for the lightfield frames).
struct InterfaceOperators {
  Matrix R_straight;  // krlf x krlf: entering -Z -> leaving +Z
  Matrix R_left;      // krlf x krlf: entering -Z -> leaving +X
  Matrix R_right;     // krlf x krlf: entering -Z -> leaving -X
  Matrix Trlf_r;      // kr x krlf: reduced lightfield -> response coefficients r
  Matrix Ur;          // n(dead end) x kr: E_ind/pi on the dead-end shape's samples per r mode
  Matrix Urvol;       // 9 g^3 x kr: radiance SH9 at the dead end's volume probes per r mode
  Matrix Ur_vec;      // 4n(dead end) x kr: OHLSH vector irradiance per r mode, Ub_vec's row layout

  bool empty() const { return Ur.empty(); }
};

struct Dictionary {
  DictionarySettings settings;
  std::vector<ShapeOperators> shapes;  // kDictionaryShapeCount entries, dictionary order
  InterfaceOperators interfaces;       // empty when settings.lightfield_spatial == 0
};

// Checks that every shape's operators have the sizes the settings imply and hold only
// finite values. `what` prefixes messages (e.g. the file name).
Status validate_dictionary(const Dictionary& dict, const std::string& what);

}  // namespace modrt
