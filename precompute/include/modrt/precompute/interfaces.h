// SPDX-License-Identifier: MIT
// modrt precompute — interface lightfields and the operators that couple blocks
// (MRT §5, §6.3, appendix A; architecture.md §3.8).
//
// A lightfield lives on a side face of a cell and describes radiance crossing it. It is
// expressed in the *exit frame* of the face it leaves through: position (u, v) on the
// face (cube.h face frame), travel direction t = x u_axis + y v_axis + z out, out = the
// face's outward normal, (x, y) = concentric_square_to_disk(a, b) and z = sqrt(1-x^2-y^2).
// Square (a, b) bins are equal projected solid angle (concentric + Malley). Sample index:
//   ((py * S + px) * D + dy) * D + dx,   s = S^2 D^2,
// positions at bin centres ((px + 0.5) / S, ...), directions averaged over an
// supersample^2 grid inside each direction bin.
// Light entering a cell through face e is described in the exit frame of the neighbour's
// opposite face (entry_frame(e)), so the lightfield leaving one block is the lightfield
// entering the next without resampling. All side walls are rotations of each other with
// matching frames, so one canonical set of operators serves every interface.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "modrt/cube.h"
#include "modrt/dictionary.h"
#include "modrt/precompute/linalg.h"
#include "modrt/status.h"

namespace modrt::precompute {

struct InterfaceSettings {
  int spatial = 12;      // S: positions per interface edge (12^2)
  int directional = 24;  // D: direction bins per square edge (24^2)
  int supersample = 5;   // directional super-sampling per bin edge (5^2)
  int krlf = 128;        // reduced lightfield modes (columns of Hrlf)
  int kr = 32;           // response modes (columns of Ur)
  int enrichment_iterations = 3;
  int response_rays = 4096;  // gather rays per sample for G = Frlf Hrlf
  int probe_grid = 4;        // g: volume probes per axis of the receiving cell
  int probe_rays = 1024;     // sphere rays per probe
  std::uint64_t seed = 0x1f1f;
};

// Every count in [1, its DictionarySettings bound] (kMaxSettings*, dictionary.h; the
// enrichment passes in [0, 16]); invalid_argument naming the setting. bake_interfaces
// checks it (these settings are ints: a caller's count that wrapped arrives negative).
Status validate_interface_settings(const InterfaceSettings& settings);

// A face's lightfield frame: origin, in-plane axes and the direction light travels.
struct LightfieldFrame {
  glm::dvec3 origin, u_axis, v_axis, out;
};
LightfieldFrame exit_frame(int face);
LightfieldFrame entry_frame(int face);  // frame of light entering through `face`

// Canonical configuration: light enters through -Z (travelling +Z); it leaves straight on
// through +Z, to the left through +X, to the right through -X.
inline constexpr int kCanonicalEntryFace = kFaceNegZ;
enum class Propagation { straight = 0, left = 1, right = 2 };
int propagation_exit_face(Propagation p);  // in the canonical configuration
// For light entering a cell through `entry` and leaving through `exit` (both side faces),
// the propagation kind (straight/left/right); fails for exit == entry.
bool classify_propagation(int entry, int exit, Propagation& out);
// Quarter turns that map the canonical entry face (-Z) onto side face `face`.
int turns_to_face(int face);

// Operators in double, before conversion to the dictionary's floats.
struct InterfaceBake {
  InterfaceSettings settings;
  MatrixXd Hrlf;              // s x krlf (enriched)
  std::array<MatrixXd, 3> R;  // krlf x krlf, indexed by Propagation
  // Rb_rlf[shape][face]: krlf x kb for each missing side face of each dictionary shape.
  std::array<std::array<MatrixXd, kFaceCount>, kDictionaryShapeCount> Rb_rlf;
  MatrixXd G;         // n(dead end) x krlf response to Hrlf
  MatrixXd Ur;        // n(dead end) x kr
  MatrixXd Trlf_r;    // kr x krlf
  MatrixXd Urvol;     // 9 g^3 x kr probe response (SH9 radiance)
  MatrixXd Ur_vec;    // 4n(dead end) x kr OHLSH vector irradiance response
  VectorXd sigma_lf;  // singular values of the raw Hlf
  VectorXd sigma_G;
};

// Limp of each dictionary shape (n_shape x kb, canonical sample layout at `res`).
using ShapeLimps = std::array<const MatrixXd*, kDictionaryShapeCount>;

InterfaceBake bake_interfaces(const ShapeLimps& limps, int res, const InterfaceSettings& settings,
                              const std::function<void(const std::string&, double)>& on_stage = {});

// Coefficients of lightfields x (s x m) in the basis Hrlf = U S (orthogonal columns):
// S^-2 (U S)^T x, krlf x m; a zero column of Hrlf gets zero coefficients.
MatrixXd project_onto_lightfield_basis(const MatrixXd& Hrlf, const MatrixXd& x);
// project_onto_lightfield_basis(Hrlf, P Hrlf) without forming P Hrlf: the reduced R of a
// propagation operator P.
MatrixXd reduced_propagation(const MatrixXd& Hrlf, const SparseRowMatrix& P);

// --- pieces, exposed for tests ---
// The box forms (`extent` != 1) serve shaped blocks (shaped_interfaces.h). A lightfield
// keeps the cube's parameterisation on every face of a box: positions normalised to the
// face, directions physical; two connected faces have the same world size, so the lightfield
// leaving one is the lightfield entering the other, whatever the boxes behind them.
//
// Lightfield leaving `shape_mask`'s missing face `face` for each column of Limp (samples of
// the box `extent`, face coordinates normalised as in bake_box_shape).
MatrixXd exit_lightfield(FaceMask shape_mask, int face, const MatrixXd& Limp, int res,
                         const InterfaceSettings& s, const glm::dvec3& extent = glm::dvec3(1.0));
// P_dir: resamples a lightfield entering through -Z to the given exit face (free space).
SparseRowMatrix propagation_operator(Propagation dir, const InterfaceSettings& s);
// The same through the box `extent`, for light entering through side face `entry` (in
// entry_frame(entry)) and leaving through side face `exit` (in exit_frame(exit)).
// box_propagation_operator(1, -Z, propagation_exit_face(dir)) is propagation_operator(dir).
SparseRowMatrix box_propagation_operator(const glm::dvec3& extent, int entry, int exit,
                                         const InterfaceSettings& s);
MatrixXd propagate_lightfield(const MatrixXd& in, Propagation dir, const InterfaceSettings& s);
// Frlf * in: E/pi at the samples of the dead-end shape (the box `extent`) lit by lightfields
// entering through -Z.
MatrixXd response_to_lightfield(const MatrixXd& in, int res, const InterfaceSettings& s,
                                const glm::dvec3& extent = glm::dvec3(1.0));
// The same averaged with its mirror image (x -> 1 - x, which maps the dead-end box onto
// itself): Frlf has that symmetry, its Monte Carlo estimate only approximately.
MatrixXd symmetric_response_to_lightfield(const MatrixXd& in, int res, const InterfaceSettings& s,
                                          const glm::dvec3& extent = glm::dvec3(1.0));
// The same response as OHLSH vector irradiance E/pi in each sample's face frame (sh.h):
// 4n x in.cols(), row 4 s + i = coefficient i of sample s.
MatrixXd vector_response_to_lightfield(const MatrixXd& in, int res, const InterfaceSettings& s);
// Radiance SH9 at the dead end's g^3 volume probes (sh_operators.h layout) lit by
// lightfields entering through -Z: 9 g^3 x in.cols().
MatrixXd probe_response_to_lightfield(const MatrixXd& in, const InterfaceSettings& s);

}  // namespace modrt::precompute
