// SPDX-License-Identifier: MIT
// modrt::gles — the OpenGL ES 3.0 level runtime (architecture.md §5 steps 2–6, 8, 9): operators live
// in textures, every stage is a fragment-shader pass into float render targets, and the
// lightmap ends in a padded atlas texture that a renderer samples directly.
//
// Passes per update (gles/README.md has the texture layouts):
//   b.frag      partial sums of b = Td_b ld over 64-sample chunks (Td_b packed four modes
//               per RGBA texel); reduce.frag adds them
//   r.frag      r = Tb->r b, split by input mode group (records as 4x4 blocks, summed per
//               slot); reduce.frag adds the parts
//   atlas.frag  Ub b + Ur r into the padded atlas; padding texels evaluate their source
//   probes.frag Ubvol b + turned Urvol r (when the dictionary has probes and they are on)
//   vector.frag Ub_vec b + turned Ur_vec r into four atlas-sized targets, one OHLSH
//               coefficient each (GlesRuntimeOptions::vector_irradiance)
//   feedback.frag ld = ld_direct + rho min(max(atlas, 0), bound) (multi_bounce_step only)
//   drt_*.frag  with clutter only (set_clutter; gles_drt.h): c = Td_c clutter_ld and the
//               per-sample delta dUb b + dUc c before the atlas pass, which adds it (and
//               the vector and probe deltas, added by vector.frag and probes.frag); the
//               clutter atlas Uc (Vc b) + Cc c + clutter direct light after it
// Shaders are strictly "#version 300 es" with no extension required.
//
// Intermediate signals (b, r, feedback ld) are RGBA32UI render targets holding float bit
// patterns: exact float32 in every ES 3.0 context (they are never filtered). The outputs a
// renderer samples, the atlas and the probes, use the TargetFormat:
//   float32  RGBA32F; renderable with EXT_color_buffer_float (and on desktop GL);
//   float16  RGBA16F; renderable with EXT_color_buffer_half_float or _float;
//   bits32   RGBA32UI holding float bit patterns: exact, renderable in every ES 3.0
//            context, so it is the fallback when no float target is renderable. It cannot
//            be filtered: a renderer fetches the four texels and filters in its shader.
// Default: the first of float32, float16, bits32 that the context can render to.
//
// The GL context must be current on the calling thread for every call, and the Level and
// Dictionary are borrowed (must outlive the runtime). GL objects are released by the
// destructor, which also needs the context current.
#pragma once

#include <array>
#include <initializer_list>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "modrt/backend.h"
#include "modrt/feedback_policy.h"
#include "modrt/level.h"
#include "modrt/level_dirty.h"
#include "modrt/platform/gl_functions.h"
#include "modrt/platform/gpu_timer.h"
#include "modrt/staged_backend.h"

namespace modrt::gles {

enum class TargetFormat { float32, float16, bits32 };
enum class OperatorFormat { float32, float16 };
const char* target_format_name(TargetFormat f);      // "float32", "float16", "bits32"
const char* operator_format_name(OperatorFormat f);  // "float32", "float16"

struct GlesRuntimeOptions {
  std::optional<TargetFormat> target;                  // none: best renderable (see above); else required
  OperatorFormat operators = OperatorFormat::float32;  // float16 halves operator memory
  bool probes = true;  // evaluate volume probes in update() when the dictionary has them
  // Evaluate vector irradiance (MRT §6.4: four OHLSH coefficient atlases, for normal maps) in
  // update(). Off by default: it costs about four atlas passes. When on, create() fails if
  // the dictionary or level lacks the vector operators (check_level_vector_operators).
  bool vector_irradiance = false;
  bool check_errors = true;  // glGetError after every pass (a failed check names the pass)
  // update() recomputes only what an ld change reaches (see GlesSkipStats); exact, so off
  // only to measure the full path.
  bool skip_unchanged = true;
  // A pass runs over its changed items only while they are at most this fraction of all
  // (b: at most half of the blocks regardless); past it, one draw over everything costs less
  // than many small ones. 1 always takes the partial path (tests); 0 never.
  float partial_fraction = 0.25f;
};

// What update() skipped. Exact skipping (error bound 0: every skipped value's inputs are
// bit-identical to the last update's): a block whose ld did not change keeps its b; a slot
// none of whose records has a changed source keeps its r; atlas tiles and probes of blocks
// whose b and incoming r are unchanged are not redrawn; identical ld skips the frame. A pass
// runs over everything (one draw instead of many) when more than partial_fraction of its
// items changed; the counters count what was recomputed.
struct GlesSkipStats {
  std::uint64_t frames = 0;          // update() calls that succeeded
  std::uint64_t frames_skipped = 0;  // ld identical to the last update: nothing ran
  std::uint64_t frames_partial = 0;  // at least the b pass ran over changed blocks only
  std::uint64_t blocks_b = 0;        // blocks whose b was recomputed, summed over frames
  std::uint64_t slots_r = 0;         // slots whose r was recomputed
  std::uint64_t blocks_redrawn = 0;  // blocks whose atlas tiles (and probes) were redrawn
};

// Per-pass time of the last update()/multi_bounce_step(), nanoseconds, when timing is on.
using GlesPassTimes = BackendStageTimes;

class GlesDrt;

// The GLES stages of core's StagedBackend (staged_backend.h): the pipeline validates, tracks
// what changed and sequences the frame; this class draws the passes. b, r, the atlas and the
// probes run over the changed items only while they are few (partial_fraction); the tiles are
// drawn by the atlas pass, and c with the DRT deltas.
class GlesLevelRuntime final : public StagedBackend {
 public:
  // Checks the level against the dictionary, the context's limits and formats, compiles the
  // shaders (a failure names the shader and carries the compiler log), uploads every
  // operator once and allocates every texture. Nothing is allocated per frame afterwards.
  // `gl` is the current context's table (platform::GlContext::gl(), or loaded from the host
  // app's context); `gles_context` is false for a desktop GL core context (OSMesa), where
  // float targets are always renderable and timer queries are core.
  static Result<std::unique_ptr<GlesLevelRuntime>> create(const platform::GlFunctions& gl, bool gles_context,
                                                          const Level& level, const Dictionary& dict,
                                                          const GlesRuntimeOptions& options = {});
  ~GlesLevelRuntime() override;

  BackendKind kind() const override { return BackendKind::gles; }
  const char* description() const override { return description_.c_str(); }
  // DRT (Backend::set_clutter): with clutter, the atlas pass adds the delta and the atlas is
  // always redrawn whole (a delta can change where ld did not); a change of the clutter's
  // light alone is not a skipped frame. read_clutter_vector_lightmap renders on request (two
  // passes) from the last update's b and c.
  // The clutter atlas (the atlas's format; RGB in .rgb), 0 without clutter. Object k's texels
  // fill a band of rows: with m = f res^2 (boxes) its f faces side by side, res x res each,
  // texel (i, j) of its n-th lit face at (n res + i, y_k + j); otherwise rows of 256 texels.
  // clutter_atlas_texel gives the position of texel t of object k.
  GLuint clutter_texture() const;
  std::array<int, 2> clutter_atlas_texel(std::size_t object, std::uint32_t t) const override;
  TextureSize clutter_atlas_size() const override;
  // GPU-resident ld (architecture.md §5 step 1 on the GPU; Backend::update_from_texture): ld
  // read from `ld_texture`, a GL_TEXTURE_2D the caller rendered (its own direct-light pass over
  // the samples, e.g. GlesDirectLight), in the runtime's linear layout: sample s at texel
  // (s % width, s / width) of ld_layout(), RGB in .rgb, a float format (RGBA32F, RGBA16F,
  // RGB32F). Its level 0 is read with texelFetch through a nearest sampler object, so its own
  // filters and mipmaps do not matter. Nothing is read back: ld is not validated on the CPU;
  // the b pass reads NaN and negative values as 0 and clamps at kMaxLightValue. Every block is
  // recomputed (the runtime does not see the values to skip). Fails for 0 or a name that is
  // not a texture; then nothing changes. multi_bounce_step_from_texture: the bound from the
  // texture's largest value, found by two GPU passes (ld_max.frag); the fed-back ld is clamped
  // at kMaxLightValue (the CPU path refuses such light instead). With a clutter albedo the
  // clutter's feedback bound takes the same GPU maximum.
  using LinearLayout = TextureSize;
  LinearLayout ld_layout() const;
  TextureSize ld_texture_size() const override { return ld_layout(); }
  TargetFormat target_format() const { return target_; }
  // The padded lightmap atlas (level.atlas.width x height; RGB in .rgb). Sample it with
  // texelFetch for bits32; float32 needs OES_texture_float_linear to filter.
  GLuint atlas_texture() const { return atlas_.texture; }
  // Vector irradiance atlas of OHLSH coefficient i (0..3; same layout and format as the
  // atlas, RGB in .rgb, coefficient frames: sh.h). 0 without vector_irradiance.
  GLuint vector_texture(int i) const {
    return has_vector_ && i >= 0 && i < 4 ? vector_.textures[std::size_t(i)] : 0;
  }
  // The b and r of the last update (level_runtime.h layouts), for tests and tools.
  Status read_b(std::span<float> b);
  Status read_r(std::span<float> r);
  // Per-pass timing (Backend::set_timing; GpuTimer: GPU queries where available, else a
  // glFinish per pass). Off by default.
  const GlesPassTimes& pass_times() const { return stage_times(); }
  std::uint32_t output_texture(BackendOutput output) const override;
  int output_texture_format() const override { return int(target_); }
  GlesSkipStats skip_stats() const;
  Result<std::uint32_t> world_probe_texture() override;

 protected:
  Status stage_ld(std::span<const float> ld, const StageWork& work) override;
  Status stage_ld_texture(std::uint32_t ld_texture) override;
  Status stage_feedback(std::span<const float> ld_direct, float bound) override;
  Status stage_feedback_texture(std::uint32_t ld_texture, float bound_per_ld) override;
  Status stage_albedo(std::span<const float> rho) override;
  Status stage_b(const StageWork& work) override;
  // The converged solve on the GPU (gles_reduced_solve.cpp, reduced_solve.frag): x <- c + G x
  // as fragment passes over b-shaped signals, r = Tb->r x by the r pass; with clutter the
  // clutter's c is solved with b (GlesDrt::solve_step, reduced_solve.frag STAGE 4). Nothing is
  // read back: it starts from b0 every frame and runs reduced_solve_iterations's
  // a-priori count (no warm start: a start it cannot check could be far from b*); with timing
  // on it also reads the last step's residual back (ReducedSolveReport::measured).
  Status stage_solve(const ReducedFeedback& op, ReducedSolver& solver, std::span<float> x, bool warm,
                     const ReducedSolveSettings& settings, ReducedSolveReport& report) override;
  bool stage_solve_available() const override { return true; }
  Status stage_r(const StageWork& work) override;
  Status stage_tiles(const StageWork&) override { return Status::success(); }  // in stage_atlas
  Status stage_atlas(const StageWork& work) override;
  // The camera skip: the atlas pass draws the rectangles of work.atlas only. A padding texel
  // evaluates its source sample from b and r (texel_sample_), so no neighbour's tile is read.
  bool stage_camera_skip_available() const override { return true; }
  // The delta texture of the evaluation is every texel's (the DRT pass does not run per tile).
  Status stage_catch_up_deltas(const StageWork&) override { return Status::success(); }
  Status stage_vector(const StageWork& work) override;
  Status stage_probes(const StageWork& work) override;
  Status stage_begin() override;
  void stage_end(bool ok) override;
  Status read_output(StageOutput output, std::span<float> out) override;
  Status stage_clutter_set(const DrtOperators* drt) override;
  Status stage_clutter_light(std::span<const float> clutter_ld,
                             std::span<const float> clutter_direct) override;
  Status stage_clutter_albedo(std::span<const float> rho_c) override;
  Status stage_clutter_c(ClutterCSource source, const ClutterFeedback& feedback) override;
  Status stage_deltas(const StageWork& work) override;
  Status stage_clutter_lightmap() override;
  void timer_begin(TimedStage stage) override;
  void timer_end(TimedStage stage) override;
  void timer_collect(BackendStageTimes& times) override;

 private:
  struct Target {  // one render target texture and its framebuffer
    GLuint texture = 0;
    GLuint framebuffer = 0;
    int width = 0, height = 0;
  };
  struct Signal3 {  // R, G, B planes of b or r (RGBA32UI), four modes per texel, one MRT framebuffer
    std::array<GLuint, 3> textures{};
    GLuint framebuffer = 0;
    int width = 0, height = 0;
  };
  struct VectorTarget {  // four OHLSH coefficient atlases, one MRT framebuffer
    std::array<GLuint, 4> textures{};
    GLuint framebuffer = 0;
    int width = 0, height = 0;
  };
  struct Program {
    GLuint id = 0;
    GLint u_bound = -1;  // feedback's per-frame uniform; everything else is set once
  };
  GlesLevelRuntime(const platform::GlFunctions& gl, const Level& level, const Dictionary& dict,
                   const GlesRuntimeOptions& options);
  Status build(const Level& level, const Dictionary& dict, bool gles_context,
               const GlesRuntimeOptions& options);
  struct Rect {
    int x = 0, y = 0, w = 0, h = 0;
  };
  struct Partial {                             // which passes run over their dirty_* items only
    bool b = false, r = false, atlas = false;  // atlas covers the probes too
  };
  // What the current evaluation does: its partial passes, whether ld is fed back (and its
  // largest value found on the GPU), the clutter's c source, and what it recomputes.
  struct Evaluation {
    Partial pass;
    bool feedback = false, ld_max_on_gpu = false, clutter_feedback = false;
    bool solved = false;  // stage_solve left r of its last application in r_
    ClutterFeedback clutter;
    std::size_t blocks_b = 0, slots_r = 0, blocks_redrawn = 0;
  };
  Status draw_feedback(float bound, float bound_scale);
  // The converged solve's operators packed and uploaded (at a cold solve: a new albedo), and
  // its programs compiled on first use.
  Status upload_reduced_operators(const ReducedFeedback& op);
  Status upload_reduced_clutter(const ReducedClutter& cl);
  Status build_reduced_programs();
  // Compiles kFullscreenVert with head + kCommon + fragment into out (recorded for the
  // destructor), binds its samplers to units in order and sets u_count when count >= 0. The
  // program is left in use for the caller's further uniforms.
  Status make_program(const char* name, const std::string& head, const char* fragment, Program& out,
                      std::initializer_list<const char*> samplers, int count = -1);
  Status check_texture_name(std::uint32_t texture, const char* who) const;
  // Scissor rects covering the linear-layout ranges [i * per, (i + 1) * per) of the flagged
  // items, consecutive items merged; appended to rects_ (cleared first).
  std::span<const Rect> linear_rects(std::span<const std::uint8_t> flags, int per);
  Status check(const char* what) const;
  void draw(const Program& program, GLuint framebuffer, int width, int height,
            std::initializer_list<GLuint> textures, std::span<const Rect> rects = {});
  Status read_target(GLuint framebuffer, int attachment, int width, int height, bool bits);
  Status read_signal3(const Signal3& s, int groups, std::size_t items, std::size_t modes,
                      std::span<float> out);

  const platform::GlFunctions& gl_;
  const Level* level_ = nullptr;
  // DRT: null without clutter. The atlas program with the delta is built on first use.
  std::unique_ptr<GlesDrt> drt_;
  std::string defines_;
  GLenum operator_format_ = 0, output_format_ = 0;
  const Dictionary* dict_ = nullptr;
  TargetFormat target_ = TargetFormat::float32;
  GlesRuntimeOptions options_;
  std::string description_;
  int groups_ = 0, r_groups_ = 0, n_max_ = 0, probe_rows_ = 0, b_chunks_ = 1, vector_rows_ = 0;
  bool has_probes_ = false, has_vector_ = false;

  // Operator and table textures (uploaded once).
  GLuint td_b_ = 0, ub_ = 0, ur_ = 0, t_ = 0, ubvol_ = 0, probe_response_ = 0, ub_vec_ = 0,
         vector_response_ = 0;
  GLuint block_info_ = 0, block_slots_ = 0, slot_info_ = 0, record_block_ = 0;
  GLuint texel_sample_ = 0, sample_info_ = 0, sample_slots_ = 0, sample_rows_ = 0;
  // Per-frame inputs (CPU uploads) and signals.
  GLuint ld_ = 0, ld_direct_ = 0, rho_ = 0;
  GLuint ld_source_ = 0;   // what the b pass reads: ld_, or update_from_texture's texture
  GLuint ld_sampler_ = 0;  // nearest, for the ld unit (the caller's texture's filters vary)
  int max_texture_size_ = 0;
  std::vector<GLuint> textures_;  // every texture created, for the destructor
  std::vector<GLuint> framebuffers_;
  std::vector<GLuint> programs_;
  Signal3 b_partial_, b_, r_partial_, r_;
  bool atlas_partial_ = false;  // the last atlas pass drew rects_ only (the vector pass follows it)
  Target atlas_, probes_, ld_feedback_;
  Target ld_max_rows_, ld_max_;
  Target probes_world_;                // world_probe_texture()
  GLuint sh_rotation_ = 0;             // the four quarter-turn SH9 rotations (R32F, 81 x 4)
  bool probes_world_current_ = false;  // ld_max.frag's two stages (multi_bounce_step_from_texture)
  GLuint feedback_source_ =
      0;  // what the feedback pass reads as ld_direct: ld_direct_, or the caller's texture
  VectorTarget vector_;
  // The converged solve (stage_solve): c = P b0, the two iterates, the last step's residual,
  // the packed P (or the plain iteration's A) and B_s (RGBA32F, created at the first solve).
  struct ReducedSolveGpu {
    Signal3 rhs;
    std::array<Signal3, 2> x;
    Target residual;
    GLuint block_matrices = 0, slot_matrices = 0;
    bool plain = false;  // the plain iteration (op.block_jacobi false): A, and c = b0
    Program rhs_program, apply_program, apply_plain_program, residual_program, copy_program;
    // With clutter (ReducedClutter): u = b0 + s sum w delta per step, its program, and the
    // tables (w, each block's reached samples, their level samples), RGBA32F / RGBA32I.
    Signal3 u;
    Program clutter_program;
    GLuint w = 0, block_samples = 0, sample_index = 0;
    int w_rows = 0;  // rows of w and sample_index as created
    GLint u_scale = -1;
    bool clutter = false;  // the operators uploaded have clutter terms
  } solve_;
  std::vector<float> solve_pack_;  // packing scratch of upload_reduced_operators
  GLuint vao_ = 0;
  Program prog_b_, prog_b_feedback_, prog_b_reduce_, prog_r_reduce_, prog_r_, prog_atlas_, prog_feedback_,
      prog_probes_, prog_vector_, prog_atlas_drt_, prog_vector_drt_, prog_probes_drt_, prog_ld_max_rows_,
      prog_ld_max_, prog_probes_world_;
  GLint u_bound_scale_ = -1;     // feedback.frag
  std::vector<float> readback_;  // 4 floats per texel of the largest target
  // Atlas tiles showing block i's samples: tile_rects_[block_tile_begin_[i] .. [i + 1]);
  // rects_ has capacity for every item so that no frame allocates.
  std::vector<std::uint32_t> block_tile_begin_;
  std::vector<Rect> tile_rects_;
  std::vector<Rect> rects_;
  Evaluation eval_;
  GlesSkipStats stats_;  // the evaluated updates (skip_stats adds the skipped ones)
  std::unique_ptr<platform::GpuTimer> timer_;
};

}  // namespace modrt::gles
