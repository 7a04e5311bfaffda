// SPDX-License-Identifier: MIT
// modrt — Delta Radiance Transfer (architecture.md §6, [Loos et al. 2012] "DRT"): clutter objects
// inside blocks, their delta operators and the scalar reference runtime that applies them.
//
// A clutter object is an oriented box or a closed triangle mesh in world space owned by one
// block. Each lit face of a box carries a res x res texel grid; a mesh carries the texels of
// its lightmap UV atlas (clutter_mesh.h), its UV charts standing in for faces.
// The operators of one object:
//   dUb  (DRT §4.1) rows = (level sample, source block) pairs, kb columns (the level's kb, b's
//        stride: zero past the source block's own modes, level.h block_kb): the antiradiance
//        of the clutter; the row's sample gets dUb_row . b(source block). The source block
//        is the block whose Limp the occluded ray sampled, so shadows cast across a block
//        boundary use the b that lit the hidden wall.
//   Td_c (DRT §4.2) f x m: clutter direct light -> c, per-face constant basis (f lit faces).
//   dUc  (DRT §4.2) affected samples x f: light reflected by the clutter onto the scene.
//   Cb   (DRT §4.3) m x (kb * |Cb_blocks|) = Uc Vc, SVD-truncated: clutter texels' indirect
//        light from the b of every block the clutter sees.
//   Cc   (beyond the paper) m x (faces of other objects): light of other clutter objects'
//        lit faces onto this object's texels, from the same c.
// Rays see all clutter: a scene ray is charged to the first object it enters, so overlapping
// shadows do not add, and a clutter texel's ray that enters another object brings that
// object's light (Cc) instead of the wall's (Cb). Moving one object can change the others'
// operators (precompute's DrtBuilder::rebuild_object rebuilds what it affects).
//
// Signals are RGB-interleaved as in level_runtime.h. Clutter-wide signals (clutter_ld,
// clutter lightmap) concatenate the objects' texels in object order; c concatenates 3 f per
// object. A level without clutter has an empty DrtOperators: nothing is allocated and the
// runtime returns at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/reference_runtime.h"

namespace modrt {

inline constexpr int kClutterDefaultRes = 16;
// Bounds on a recorded texel cell (DrtObjectOperators::texel_cell) that check_drt_operators
// enforces: the grid's edge and the face (box face or mesh chart) index.
inline constexpr std::uint32_t kMaxClutterCellRes = 4096;
inline constexpr std::uint32_t kMaxClutterCellFaces = std::uint32_t(1) << 24;

// Kinds of clutter geometry: an oriented box (analytic texels and ray queries) or a closed
// triangle mesh with lightmap UVs (texels by rasterising the UV atlas, DRT §3; ray queries
// by Embree in precompute). The operators only see texel positions, normals and faces.
enum class ClutterKind : int { box = 0, mesh = 1 };
struct ClutterMeshData;  // clutter_mesh.h

// World point of local box coordinates q in [0,1]^3: center + rotation * ((q - 0.5) * 2 *
// half_extent). rotation's columns are the box axes in world space (orthonormal).
struct ClutterBox {
  glm::dvec3 center{0.5};
  glm::dvec3 half_extent{0.1};
  glm::dmat3 rotation{1.0};
};

struct ClutterObject {
  ClutterKind kind = ClutterKind::box;
  int block = 0;  // owning level block
  // box: the object. mesh: the mesh's axis-aligned bounds (culling and bounding sphere only).
  ClutterBox box;
  // Lit faces (cube.h numbering in the box's local frame); a face resting on a wall receives
  // no light and can be left out, so it costs no texels. mesh: every chart is lit (kAllFaces).
  FaceMask faces = kAllFaces;
  glm::dvec3 albedo{0.5};
  // box: texels per face edge. mesh: the atlas grid's edge (mesh->atlas.res).
  int res = kClutterDefaultRes;
  // mesh only: the mesh and its lightmap atlas (precompute's make_mesh_clutter fills it).
  std::shared_ptr<const ClutterMeshData> mesh;
};

// Texels of a box: lit faces in ascending face order, then row j, then column i (as
// SampleLayout). Face f's frame: p(u, v) = the unit cube's face_point(f, v, u) mapped
// through the box, so that cross(u_axis, v_axis) is the outward normal. Texels of a mesh:
// its atlas's covered cells in row-major cell order; its "faces" are the atlas's charts.
int clutter_face_count(const ClutterObject& object);
int clutter_texel_count(const ClutterObject& object);
glm::dvec3 clutter_to_world(const ClutterBox& box, const glm::dvec3& q);
glm::dvec3 clutter_face_point(const ClutterBox& box, int face, double u, double v);
glm::dvec3 clutter_face_normal(const ClutterBox& box, int face);  // unit, outward
// Whether world point p lies inside the box grown by `margin` on every side.
bool clutter_contains(const ClutterBox& box, const glm::dvec3& p, double margin);
// Bounding sphere (centre = box centre).
double clutter_bounding_radius(const ClutterBox& box);

struct ClutterTexelGeometry {
  std::vector<glm::dvec3> position;  // texel centres
  std::vector<glm::dvec3> normal;    // outward
  std::vector<int> face;             // box face (mesh: chart) per texel
  // Unit, perpendicular to the normal: the lightmap's u direction (box: the face's u axis;
  // mesh: dP/du of the texel's triangle). The frame of the clutter's vector irradiance
  // (drt_clutter_vector_lightmap) is (tangent, cross(normal, tangent), normal).
  std::vector<glm::dvec3> tangent;
};
ClutterTexelGeometry clutter_texel_geometry(const ClutterObject& object);
// The lightmap cell each texel stands for, in texel order, so that an app can address the
// clutter lightmap from its own mesh's UVs: cell (u, v) (column, row) of a res x res grid on
// face `face`. A box: its lit face (cube.h numbering in the box's local frame), the texel
// centre at clutter_face_point(box, face, (u + 0.5) / res, (v + 0.5) / res). A mesh: its
// chart, the cell of its lightmap atlas (ClutterMeshAtlas::cell_texel[v res + u] is the
// texel), covering UV [u, u + 1] / res x [v, v + 1] / res.
struct ClutterTexelCells {
  int res = 0;
  std::vector<int> face;
  std::vector<glm::ivec2> cell;  // (u, v)
};
ClutterTexelCells clutter_texel_cells(const ClutterObject& object);
// World area each texel stands for (a box face's area / res^2; a mesh texel's share of its
// triangle), in texel order.
std::vector<double> clutter_texel_area(const ClutterObject& object);

// Checks the objects against the level: owning block exists, finite box with positive
// extents and an orthonormal rotation, res >= 1, albedo in [0, 1], at least one lit face;
// for a mesh, its data present and consistent (atlas of res, at least one texel, charts).
Status validate_clutter(const Level& level, std::span<const ClutterObject> objects);

// Sparse rows (CSR) of non-negative weights: row r's entries are [start[r], start[r + 1]) of
// index and weight. No rows: all three empty.
struct DrtSparseRows {
  std::vector<std::uint32_t> start;  // rows + 1
  std::vector<std::uint32_t> index;
  std::vector<float> weight;

  std::size_t rows() const { return start.empty() ? 0 : start.size() - 1; }
  bool empty() const { return start.empty(); }
};

struct DrtObjectOperators {
  std::uint32_t texel_count = 0;  // m
  std::uint32_t face_count = 0;   // f: entries of c (lit faces, mesh charts or lighting-prior modes)
  // DRT §4.1 (and §5 inpainting): dUb row k applies to sample dUb_sample[k] with the b of
  // block dUb_block[k]; rows sorted by (sample, block), at most one row per pair.
  std::vector<std::uint32_t> dUb_sample;
  std::vector<std::uint32_t> dUb_block;
  Matrix dUb;                             // rows x kb
  Matrix Td_c;                            // f x m (DRT §4.2)
  std::vector<std::uint32_t> dUc_sample;  // sorted, unique
  Matrix dUc;                             // |dUc_sample| x f (DRT §4.2)
  // DRT §4.3: Cb = Uc Vc; Vc's columns are kb per block of Cb_blocks (in that order).
  std::vector<std::uint32_t> Cb_blocks;
  Matrix Uc;  // m x modes
  Matrix Vc;  // modes x (kb * |Cb_blocks|)
  // Of the uncompressed Cb: all singular values, and ||Cb - Uc Vc||_F / ||Cb||_F.
  std::vector<float> Cb_sigma;
  float Cb_truncation_error = 0.0f;
  // Clutter-to-clutter light: texel rays that enter another object before any wall sample
  // its per-face constant basis (as dUc does for scene samples). Cc_objects: the source
  // objects (indices into DrtOperators::objects, ascending, never this object); Cc's columns
  // are the face_count faces of each source, sources in that order. Empty: no clutter light
  // reaches this object (drt_clutter_add_cc does nothing).
  std::vector<std::uint32_t> Cc_objects;
  Matrix Cc;  // m x (sum of the sources' face_count)
  // Vector versions of dUb and dUc (DRT §5, "Vector and Volume Response"): the same deltas
  // as OHLSH E/pi (sh.h) in each sample's face frame, the layout and frame of
  // level_compute_vector_irradiance. Rows 4 k .. 4 k + 3 are the coefficients of entry k of
  // dUb_vec_sample / dUb_vec_block (their own entry list, sorted by (sample, block), one per
  // pair) and of dUc_vec_sample (sorted, unique). Empty: no vector delta (not built).
  std::vector<std::uint32_t> dUb_vec_sample, dUb_vec_block;
  Matrix dUb_vec;  // 4 entries x kb
  std::vector<std::uint32_t> dUc_vec_sample;
  Matrix dUc_vec;  // 4 entries x f
  // Clutter-aware volume probes (DRT §5, U_dyn): the delta of the probes' SH9 radiance (the
  // layout and block frame of level_compute_probes) from the rays whose first hit is this
  // object: -Limp b of the wall behind it and its faces' c. Rows 9 k .. 9 k + 8 are the SH9
  // coefficients of entry k of Udyn_probe / Udyn_block (global probe index = block *
  // DrtOperators::probes_per_block + probe; sorted by (probe, block), one per pair), and of
  // Udyn_c_probe (sorted, unique) for Udyn_c. Empty: no probe delta (not built).
  std::vector<std::uint32_t> Udyn_probe, Udyn_block;
  Matrix Udyn;  // 9 entries x kb
  std::vector<std::uint32_t> Udyn_c_probe;
  Matrix Udyn_c;  // 9 entries x f
  // Vector Cb and Cc (DRT §5, C_b vector): the clutter texels' indirect light as OHLSH E/pi
  // (sh.h) in each texel's frame (ClutterTexelGeometry::tangent), rows 4 t + i. Cb_vec =
  // Uc_vec Vc_vec (SVD-truncated like Cb) over the b of Cb_vec_blocks; Cc_vec's columns are
  // the c entries of Cc_vec_objects (as Cc). Empty: not built (drt_clutter_vector_lightmap
  // writes zeros for this object).
  std::vector<std::uint32_t> Cb_vec_blocks;
  Matrix Uc_vec;  // 4m x modes
  Matrix Vc_vec;  // modes x (kb * |Cb_vec_blocks|)
  float Cb_vec_truncation_error = 0.0f;
  std::vector<std::uint32_t> Cc_vec_objects;
  Matrix Cc_vec;  // 4m x (sum of the sources' face_count)
  // Where the texels are (ClutterTexelGeometry's position and outward normal, world space, 3
  // floats per texel in texel order), so that an app computes the clutter's direct light
  // (clutter_ld) at them without the clutter scene; the runtime's operators do not read them.
  // Empty: not recorded (both or neither).
  std::vector<float> texel_position, texel_normal;
  // The lightmap cell of each texel (clutter_texel_cells): 3 per texel in texel order, face,
  // u, v, with u, v < cell_res; distinct texels have distinct cells. Empty (and cell_res 0):
  // not recorded.
  std::uint32_t cell_res = 0;
  std::vector<std::uint32_t> texel_cell;
  // The real-radiance gather (beyond the paper; docs/drt.md "Gathering the real radiance",
  // precompute's DrtBuildSettings::gather): the same rays as Cb, Cc, dUb and dUc, weighing the
  // radiance the scene and the clutter emit in this evaluation instead of Limp b and c, in
  // sparse rows of non-negative weights (1 / rays a ray, bilinear taps on the scene samples):
  //   x_s: the scene samples' exitant radiance, the ld that Td_b reads (ld_direct + rho
  //        lightmap in multi-bounce), 3 per level sample;
  //   x_t: the clutter texels' exitant radiance, clutter_ld (or its fed-back light), 3 per
  //        clutter texel in clutter-wide texel order.
  // Clutter side, one row per texel of this object (empty: not built): Gs over x_s (the wall
  // samples its rays reach) and Gt over x_t (the other objects' texels they enter first);
  // G_s x_s + G_t x_t is a sum of non-negative terms, so that the clutter lightmap cannot go
  // below 0. Built with the gather, the object has no Cb (Uc, Vc) and no Cc.
  // Scene side, one row per sample of H_sample (sorted, unique; the traced samples charged to
  // this object): the sample loses Hs x_s (the samples its rays no longer reach; the weights
  // are subtracted) and gains Ht x_t (this object's texels they enter). Built with the gather,
  // dUb and dUc keep only the inpainted rows of samples inside clutter.
  DrtSparseRows Gs, Gt;
  std::vector<std::uint32_t> H_sample;
  DrtSparseRows Hs, Ht;

  bool empty() const { return dUb.empty() && dUc.empty() && Uc.empty() && Td_c.empty(); }
  bool has_gather() const { return !Gs.empty() || !Gt.empty() || !H_sample.empty(); }
};

struct DrtOperators {
  std::uint32_t kb = 0;
  std::vector<DrtObjectOperators> objects;
  std::uint32_t probes_per_block = 0;  // g^3 of the U_dyn operators; 0 when they were not built
  // The level they were built for, so that operators of another level are refused
  // (check_drt_operators) rather than applied to samples they do not describe; 0: not recorded.
  std::uint32_t level_blocks = 0, level_samples = 0;

  bool empty() const { return objects.empty(); }
  // Whether any object carries the real-radiance gather (DrtObjectOperators::Gs ...).
  bool has_gather() const;
  // Bytes of the run-time operators (float32 matrices and uint32 indices; not the sigmas).
  std::size_t storage_bytes() const;
};

struct DrtBufferSizes {
  std::size_t clutter_texels = 0;  // sum of m
  std::size_t clutter_ld = 0;      // 3 * clutter_texels
  std::size_t clutter_lightmap = 0;
  std::size_t c = 0;                        // 3 * sum of f
  std::size_t clutter_vector_lightmap = 0;  // 12 * clutter_texels (drt_clutter_vector_lightmap)
};
DrtBufferSizes drt_buffer_sizes(const DrtOperators& drt);

// Every size and index the runtime relies on (kb, sample and block indices, Td_c / dUc / Uc
// / Vc shapes, sorted rows, finite values). Backends call it once at creation.
Status check_drt_operators(const Level& level, const DrtOperators& drt);

// c = Td_c clutter_ld per object (validates clutter_ld: finite, non-negative).
Status drt_compute_c(const DrtOperators& drt, std::span<const float> clutter_ld, std::span<float> c);
// architecture.md §5 step 7: lightmap += dUb b + dUc c, on the affected samples only. b as
// level_compute_b (3 kb per block), c as drt_compute_c. This is the delta operator (applied
// to zeros it gives the delta alone, which is negative where clutter blocks light), so it
// does not clamp; what outputs the corrected lightmap clamps it (the lightmap policy,
// reference_runtime.h: drt_multi_bounce, the CPU backend, the GLES atlas pass).
void drt_apply(const Level& level, const DrtOperators& drt, std::span<const float> b,
               std::span<const float> c, std::span<float> lightmap);
// The real-radiance gather's scene side: lightmap += Ht x_t - Hs x_s on the H_sample rows
// (x_s = ld of the evaluation, 3 per level sample; x_t = the clutter's exitant radiance, 3 per
// clutter texel). A delta like drt_apply, unclamped; nothing for objects without the gather.
void drt_apply_gather(const DrtOperators& drt, std::span<const float> ld,
                      std::span<const float> clutter_radiance, std::span<float> lightmap);
// Its clutter side: out += Gs x_s + Gt x_t per texel (3 per clutter texel).
void drt_clutter_add_gather(const DrtOperators& drt, std::span<const float> ld,
                            std::span<const float> clutter_radiance, std::span<float> out);
// The clutter's indirect light, unclamped: out = Cb b + Cc c + Gs x_s + Gt x_t (the terms the
// operators carry): what the clutter lightmap shows besides its direct light and what the
// clutter feedback reads.
void drt_clutter_indirect(const DrtOperators& drt, std::span<const float> b, std::span<const float> c,
                          std::span<const float> ld, std::span<const float> clutter_radiance,
                          std::span<float> out);
// Clutter lightmaps: out = Cb b (+ clutter_direct when it is not empty), 3 per texel.
void drt_clutter_lightmap(const DrtOperators& drt, std::span<const float> b,
                          std::span<const float> clutter_direct, std::span<float> out);
// Vector irradiance (architecture.md §5 step 9 with DRT): vector_lightmap += dUb_vec b + dUc_vec c, the
// layout of level_compute_vector_irradiance (3 (4 s + i) + channel); nothing for objects
// without vector operators.
void drt_apply_vector(const Level& level, const DrtOperators& drt, std::span<const float> b,
                      std::span<const float> c, std::span<float> vector_lightmap);
// Clutter-aware volume probes (U_dyn): probes += Udyn b + Udyn_c c, probes as
// level_compute_probes (3 (9 p + j) + channel, p the global probe index); nothing for objects
// without U_dyn operators.
void drt_apply_probes(const DrtOperators& drt, std::span<const float> b, std::span<const float> c,
                      std::span<float> probes);
// The clutter's vector irradiance (DRT §5, C_b vector): out = Uc_vec (Vc_vec b) + Cc_vec c,
// 12 floats per clutter texel (3 (4 t + i) + channel, OHLSH E/pi in the texel's frame, as
// level_compute_vector_irradiance); zeros for objects without vector clutter operators.
void drt_clutter_vector_lightmap(const DrtOperators& drt, std::span<const float> b, std::span<const float> c,
                                 std::span<float> out);
// Clutter-to-clutter light: out += Cc c per object (c as drt_compute_c, out the clutter
// lightmap of drt_clutter_lightmap). Nothing happens for objects without Cc.
void drt_clutter_add_cc(const DrtOperators& drt, std::span<const float> c, std::span<float> out);
// The clutter lightmap every backend outputs (architecture.md §6): out = indirect +
// clutter_direct, indirect = drt_clutter_indirect (Cb b + Cc c + Gs x_s + Gt x_t), clamped at
// 0 like every lightmap (clamp_lightmap, reference_runtime.h): Cb b can be negative where the
// real light is not (Limp's weak point, docs/drt.md); the gather cannot. `indirect`, when not
// empty, receives the unclamped indirect light (what the next feedback step reads).
void drt_evaluate_clutter_lightmap(const DrtOperators& drt, std::span<const float> b,
                                   std::span<const float> c, std::span<const float> ld,
                                   std::span<const float> clutter_radiance,
                                   std::span<const float> clutter_direct, std::span<float> out,
                                   std::span<float> indirect = {});

// The converged multi-bounce with gather operators (docs/drt.md "The real-radiance gather"):
// the reduced solve in b and c cannot express the gather (it reads ld and the clutter's light,
// not b and c), so it converges the level without the clutter's terms, and this many feedback
// steps with the clutter (drt_multi_bounce's, from that evaluation) follow. The clutter changes
// the light locally and each step carries its error on with at most the largest albedo: after
// three, what is left of it is rho^3 (0.34 at rho 0.7) of the clutter's own share, against
// the whole scene's rho^5 / (1 - rho) that five feedback steps from the direct light leave.
inline constexpr int kGatherConvergedSteps = 3;

// Multi-bounce with clutter (docs/drt.md, "Multi-bounce"): level_multi_bounce where every
// evaluation is followed by drt_apply(b, c), so the feedback reads the lightmap with the DRT
// delta (shadows and clutter light bounce on). c starts as Td_c clutter_ld (the clutter's
// direct light); with clutter_albedo (3 per clutter texel) each iteration first feeds the
// clutter's own indirect light back, c = Td_c drt_clutter_feedback(...) of the previous
// evaluation's Cb b + Cc c, so light bounces off the clutter too. Empty clutter_albedo: c
// stays that of the direct light (the clutter's indirect light is not fed back). On return
// c (3 per clutter face) is the c of the last evaluation, the one drt_clutter_add_cc takes.
// With the real-radiance gather (DrtObjectOperators::has_gather) every evaluation also adds
// drt_apply_gather(ld, x_t), ld that evaluation's (ld_direct, then ld_direct + rho lightmap)
// and x_t the clutter's light (clutter_ld, or with clutter_albedo its fed-back light, the
// previous evaluation's indirect light drt_clutter_indirect fed back); last_ld and
// last_clutter_radiance, when not empty (3 per sample, 3 per clutter texel), receive the last
// evaluation's, the inputs of its clutter lightmap (drt_evaluate_clutter_lightmap). With
// from_evaluation, b, r, lightmap and c on entry are already an evaluation of ld_direct and
// clutter_ld (its deltas included, the lightmap clamped): it is not recomputed, and the
// iterations continue from it (the converged solve's steps, kGatherConvergedSteps).
// The oracle for the backends' multi_bounce_step with clutter; allocates per call.
Result<MultiBounceReport> drt_multi_bounce(
    const Level& level, const Dictionary& dict, const DrtOperators& drt, std::span<const float> ld_direct,
    std::span<const float> albedo, std::span<const float> clutter_ld, std::span<const float> clutter_albedo,
    const MultiBounceSettings& settings, std::span<float> b, std::span<float> r, std::span<float> lightmap,
    std::span<float> c, std::span<float> last_ld = {}, std::span<float> last_clutter_radiance = {},
    bool from_evaluation = false);

// The clutter's light for the next bounce: out = clutter_ld + rho_c * min(max(indirect, 0),
// bound), rho_c the clutter albedo clamped to max_albedo and indirect = Cb b + Cc c of the
// last evaluation (apply_feedback's clamp). All spans 3 per clutter texel.
void drt_clutter_feedback(std::span<const float> clutter_ld, std::span<const float> rho_c,
                          std::span<const float> indirect, float bound, std::span<float> out);
// The bound of that clamp: max(ld_max, clutter_ld_max) / (1 - max(rho_max, rho_c_max)), the
// most any texel can reach when every surface reflects at most the larger albedo (ld_max and
// clutter_ld_max: the largest values of ld_direct and clutter_ld).
float drt_feedback_bound(float ld_max, float rho_max, float clutter_ld_max, float rho_c_max);

}  // namespace modrt
