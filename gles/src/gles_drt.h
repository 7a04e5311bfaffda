// SPDX-License-Identifier: MIT
// The DRT passes of the GLES runtime (architecture.md §5 step 7, [Loos et al. 2012] §4): operators in
// textures, fragment-shader passes, as the level passes. Private to modrt::gles; owned by
// GlesLevelRuntime, which creates one only when a level has clutter.
//
//   drt_c.frag        c = Td_c clutter_ld, one fragment per clutter face
//   drt_feedback.frag multi-bounce with clutter albedo: the clutter light fed back, read by
//                     a FEEDBACK instance of drt_c.frag
//   drt_delta.frag    dUb b + dUc c per level sample (0 where no clutter reaches); atlas.frag
//                     built with DRT 1 adds it, so padding texels get it too. Two more
//                     instances, when the operators have them: dUb_vec b + dUc_vec c (4 per
//                     sample, added by vector.frag) and Udyn b + Udyn_c c (9 per probe, added
//                     by probes.frag)
//   drt_vc.frag       y = Vc b per (object, mode)
//   drt_clutter.frag  clutter atlas = Uc y + Cc c (clutter-to-clutter) + clutter direct light
// With the real-radiance gather (DrtOperators::has_gather; without it none of this runs):
//   drt_light.frag    x_s = this evaluation's ld as a signal (unless it is one: the feedback
//                     pass's), before the delta pass; x_t = clutter_ld as a signal, when the
//                     clutter's light changed (a feedback step's x_t is drt_feedback.frag's)
//   drt_delta.frag    the scalar instance, built with GATHER, adds Ht x_t - Hs x_s
//   drt_clutter.frag  built with GATHER, adds Gs x_s + Gt x_t (drt_gather.glsl)
// Layouts: gles/README.md, "DRT".
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "modrt/drt.h"
#include "modrt/level.h"
#include "modrt/platform/gl_functions.h"
#include "modrt/staged_backend.h"
#include "modrt/status.h"

namespace modrt::gles {

struct GlesDrtSetup {
  const std::string* defines = nullptr;  // the runtime's "#version 300 es" and size defines
  GLenum operator_format = 0;            // GL_RGBA32F or GL_RGBA16F
  GLenum output_format = 0;              // the atlas's internal format
  const char* output_format_name = "";   // for framebuffer errors
  bool output_bits = false;              // RGBA32UI float bits (TargetFormat::bits32)
  int max_texture_size = 0;
  bool vector = false;          // the runtime renders vector irradiance: apply dUb_vec / dUc_vec
  std::size_t probe_count = 0;  // probes the runtime renders (blocks x g^3; 0: none): apply U_dyn
};

// This evaluation's ld, the x_s of the real-radiance gather: the feedback pass's signal target,
// or the RGB32F upload or the caller's texture, read through `sampler` (texel by texel, as
// b.frag reads it).
struct GlesDrtLd {
  GLuint texture = 0;
  bool signal = false;
  GLuint sampler = 0;
};

class GlesDrt {
 public:
  // Packs and uploads the operators (checked by the caller with check_drt_operators),
  // allocates the targets and compiles the four programs.
  static Result<std::unique_ptr<GlesDrt>> create(const platform::GlFunctions& gl, const Level& level,
                                                 const DrtOperators& drt, const GlesDrtSetup& setup);
  ~GlesDrt();
  GlesDrt(const GlesDrt&) = delete;
  GlesDrt& operator=(const GlesDrt&) = delete;

  const DrtBufferSizes& sizes() const { return sizes_; }
  // Uploads the clutter's light, validated by the caller (StagedBackend::set_clutter_light;
  // clutter_direct may be empty); the next run_scene computes c of it.
  void set_light(std::span<const float> clutter_ld, std::span<const float> clutter_direct);
  // The clutter's albedo for multi-bounce, clamped by the caller (StagedBackend::
  // set_clutter_albedo); empty: none. The next run_scene without feedback returns c to the
  // direct light's.
  void set_albedo(std::span<const float> rho_c);
  // c and the per-sample delta, from b's planes. c is Td_c clutter_ld (recomputed when the
  // light changed or after feedback); with `feedback` (a multi-bounce step with a clutter
  // albedo) it is Td_c of the light fed back from the clutter atlas of the last run, clamped
  // at feedback.bound() (drt_feedback_bound). ld_max_texture (not 0): the walls' ld is on the
  // GPU and ld_max is that texture's texel (GlesLevelRuntime's ld_max.frag), not feedback's.
  // keep_c: c is the converged solve's (solve_step), kept for this evaluation's deltas.
  // ld: this evaluation's (x_s of the gather, read by this delta pass and the next run_clutter;
  // unused without the gather); x_t is the light fed back in a feedback step, else clutter_ld.
  void run_scene(const std::array<GLuint, 3>& b, const GlesDrtLd& ld, bool feedback,
                 const ClutterFeedback& bound, GLuint ld_max_texture = 0, bool keep_c = false);
  // The converged solve's clutter terms (GlesLevelRuntime::stage_solve; core's
  // reduced_feedback.h, ReducedClutter). solve_start: c = c0 = Td_c clutter_ld. solve_step, one
  // Jacobi step from b's planes and the c on hand: delta_texture() = dUb b + dUc c, and with a
  // clutter albedo c <- Td_c (clutter_ld + scale rho_c (Cb b + Cc c)) (drt_feedback.frag's
  // LINEAR instance: no clamps, the solve is linear).
  void solve_start();
  void solve_step(const std::array<GLuint, 3>& b, float scale);
  bool has_delta() const { return scalar_.entries != 0; }
  // The clutter atlas from b's planes (and the c of run_scene, for Cc; with the gather its x_s
  // and x_t).
  void run_clutter(const std::array<GLuint, 3>& b);
  // Deltas (RGBA32UI float bits, linear layout): per sample, read by atlas.frag; per sample
  // and OHLSH coefficient (4 s + i), read by vector.frag; per probe coefficient (9 p + j), read
  // by probes.frag. The last two are 0 when the operators lack them or the runtime does not
  // render vector irradiance / probes.
  GLuint delta_texture() const { return scalar_.target.texture; }
  GLuint vector_delta_texture() const { return vector_.entries ? vector_.target.texture : 0; }
  GLuint probe_delta_texture() const { return probes_.entries ? probes_.target.texture : 0; }
  GLuint clutter_texture() const { return clutter_.texture; }
  int clutter_width() const { return clutter_.width; }
  int clutter_height() const { return clutter_.height; }
  // Atlas texel (x, y) of clutter texel t of object `object` (see gles/README.md).
  std::array<int, 2> clutter_texel(std::size_t object, std::uint32_t t) const;
  // Copies the clutter atlas into core's layout (3 floats per clutter texel).
  Status read_clutter_lightmap(std::span<float> out);
  // The clutter's vector irradiance (DRT §5: Uc_vec (Vc_vec b) + Cc_vec c) from b's planes and
  // the c of the last run_scene, rendered on request into a linear target of 4 rows per
  // clutter texel and copied into core's layout (12 floats per clutter texel).
  Status read_clutter_vector_lightmap(const std::array<GLuint, 3>& b, std::span<float> out);

 private:
  struct Target {
    GLuint texture = 0, framebuffer = 0;
    int width = 0, height = 0;
  };
  struct DeltaPass {  // one drt_delta.frag instance (DELTA_ROWS = rows)
    GLuint dub = 0, duc = 0, item_entries = 0, entries = 0, program = 0;
    Target target;
    int rows = 1;
    std::size_t count = 0;  // items x rows
  };
  struct Placement {  // an object's rectangle in the clutter atlas
    int y = 0, res = 0, width = 0;
    bool tiles = false;  // m = f res^2: faces side by side; else rows of `width` texels
  };
  explicit GlesDrt(const platform::GlFunctions& gl) : gl_(gl) {}
  void draw(GLuint program, const Target& target, std::initializer_list<GLuint> textures);
  // The gather's x_s and x_t for this evaluation (xs_signal_, xt_signal_); fed: a feedback
  // step's, x_t = fed_.
  void gather_inputs(const GlesDrtLd& ld, bool fed);
  // A target in the output format (the clutter atlas or its vector twin) into readback_.
  void read_back(const Target& target);

  const platform::GlFunctions& gl_;
  const DrtOperators* drt_ = nullptr;
  DrtBufferSizes sizes_;
  bool output_bits_ = false, light_changed_ = true;
  int faces_ = 0, modes_ = 0;
  std::vector<Placement> placement_;
  std::vector<std::size_t> texel0_;
  GLuint td_c_ = 0, vc_ = 0, uc_ = 0, cc_ = 0, cc_faces_ = 0, cc_map_ = 0;
  GLuint face_info_ = 0, mode_info_ = 0, cb_blocks_ = 0, texel_map_ = 0;
  GLuint clutter_ld_ = 0, clutter_direct_ = 0;
  // Clutter feedback: clamped albedo, each clutter texel's atlas position, the light fed back.
  GLuint rho_c_ = 0, texel_xy_ = 0;
  bool feed_ = false;
  Target c_, y_, clutter_, fed_;
  // Vector clutter (only when some object has Uc_vec or Cc_vec): tables and targets of the
  // second drt_vc / drt_clutter instance.
  bool has_vector_ = false;
  GLuint vc_vec_ = 0, uc_vec_ = 0, cc_vec_ = 0, mode_info_vec_ = 0, cb_blocks_vec_ = 0, cc_faces_vec_ = 0;
  GLuint vec_map_ = 0, vec_cc_map_ = 0, prog_vc_vec_ = 0, prog_clutter_vec_ = 0;
  Target y_vec_, clutter_vec_;
  DeltaPass scalar_, vector_, probes_;
  // The real-radiance gather (only when some object has it): the packed rows (RG32UI), each
  // clutter texel's Gs / Gt row, the x_s and x_t signals drt_light.frag writes, whether x_t
  // holds the current clutter_ld, and the x_s and x_t of this evaluation (xs_ or the feedback
  // pass's ld; xt_ or fed_).
  bool gather_ = false, xt_current_ = false;
  GLuint gather_entries_ = 0, gather_texels_ = 0, prog_light_ld_ = 0, prog_light_clutter_ = 0;
  Target xs_, xt_;
  GLuint xs_signal_ = 0, xt_signal_ = 0;
  GLuint prog_c_ = 0, prog_vc_ = 0, prog_clutter_ = 0, prog_feedback_ = 0, prog_c_fed_ = 0,
         prog_feedback_linear_ = 0;
  GLint u_feedback_bound_ = -1, u_feedback_scale_ = -1, u_feedback_clutter_max_ = -1, u_linear_scale_ = -1;
  std::vector<GLuint> textures_, framebuffers_, programs_;
  std::vector<float> zeros_, readback_;
};

}  // namespace modrt::gles
