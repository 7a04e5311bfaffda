// SPDX-License-Identifier: MIT
// modrt — the run-time backend interface (architecture.md §5): what the CPU (modrt::cpu) and OpenGL ES
// (modrt::gles) backends both implement, so a caller swaps them by a flag.
//
// A backend evaluates one built level every frame: ld (or ld_direct plus multi-bounce
// feedback) -> b -> r -> lightmap -> padded atlas (-> volume probes, vector irradiance). Results stay inside
// the backend (CPU memory or GL textures); the read_* calls copy them out in core's layouts
// (level_runtime.h), which is what conformance tests and CPU-side consumers use. A GPU
// backend's read_* wait for the GPU, so a renderer samples its textures instead.
//
// Errors: every call returns a Status and never throws. A failed update leaves the previous
// results in place.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "modrt/drt.h"
#include "modrt/feedback_policy.h"
#include "modrt/level_runtime.h"
#include "modrt/reduced_feedback.h"
#include "modrt/status.h"

namespace modrt {

// Every kind has one entry in the creator table (modrt/backends.h, create_backend), which a
// static_assert checks against `count`. reference: core's scalar reference (reference_backend.h).
enum class BackendKind { cpu, gles, reference, count };
const char* backend_kind_name(BackendKind kind);  // "cpu", "gles", "reference"; "unknown" otherwise

// The results a renderer samples, as GPU textures where the backend keeps them there.
enum class BackendOutput {
  atlas,    // the padded lightmap atlas (RGB in .rgb)
  vector0,  // vector irradiance, OHLSH coefficient 0 .. 3, laid out as the atlas
  vector1,
  vector2,
  vector3,
  clutter_atlas,  // DRT: the clutter lightmap atlas
  count
};

// Time of each stage of the last update() or multi_bounce_step(), nanoseconds, when the
// backend measures them (GLES with timing on: GPU timer queries where available); 0 otherwise.
struct BackendStageTimes {
  std::uint64_t upload = 0, feedback = 0, b = 0, r = 0, atlas = 0, probes = 0, vector = 0;
  std::uint64_t drt = 0, clutter = 0;  // c + delta passes, clutter atlas passes (with clutter only)
  // b, r and the lightmap together, for a backend that runs them as one fused stage (cpu);
  // 0 where b and r are timed apart.
  std::uint64_t lightmap = 0;
};

// What the evaluations since the backend's creation computed and kept, one count per
// evaluation (one update(), update_from_texture() or multi_bounce_step() that succeeded):
// computed + kept = evaluations x the level's blocks (slots). Exact skipping (error bound 0)
// keeps what an unchanged input reaches (modrt_skip_stats); a feedback step changes every
// block's ld, so it computes everything.
struct BackendEvaluationStats {
  std::uint64_t evaluations = 0;
  std::uint64_t evaluations_skipped = 0;               // the input was identical to the last one: nothing ran
  std::uint64_t blocks_computed = 0, blocks_kept = 0;  // b_i = Td_b ld_i (a block whose ld is 0: computed)
  std::uint64_t slots_computed = 0, slots_kept = 0;    // r_s = Tb->r b
  std::uint64_t tiles_written = 0, tiles_kept = 0;     // the block's atlas tiles
  // The camera skip (set_visible_blocks): computed + kept + hidden = evaluations x blocks, where
  // tiles_hidden counts the changed tiles of blocks outside the visible set (not written then).
  // tiles_caught_up: tiles written late, when their block became visible (or before a
  // feedback step read them), not counted in the sum.
  std::uint64_t tiles_hidden = 0, tiles_caught_up = 0;
  // Blocks whose probes an evaluation computed, and those computed later, when read or when
  // their block came into view (the camera skip); without it every changed block's are computed.
  std::uint64_t probe_blocks_computed = 0, probe_blocks_caught_up = 0;
};

// The converged multi-bounce of a backend (update_converged, reduced_feedback.h).
struct ConvergedStats {
  ReducedSolveReport last;       // the last converged update's solve
  double spectral_radius = 0.0;  // of M (before damping), reduced_feedback.h
  float damping = 1.0f;
  double contraction = 0.0;  // of the iteration in use
  bool block_jacobi = true;
  std::uint64_t build_ns = 0;                // the last build of the reduced operators
  std::uint64_t solves = 0, iterations = 0;  // converged updates, and their applications of M
  std::uint64_t blocks_applied = 0;          // their blocks_applied (ReducedSolveReport)
};

// The size of a texture in texels.
struct TextureSize {
  int width = 0, height = 0;
};

class Backend {
 public:
  virtual ~Backend() = default;

  virtual BackendKind kind() const = 0;
  // Human-readable configuration, e.g. "cpu avx2" or "gles float32 targets, float32 operators".
  virtual const char* description() const = 0;
  // Sizes of ld, lightmap, atlas and probes for this level (level_buffer_sizes).
  virtual const LevelBufferSizes& sizes() const = 0;

  // Steps 2–6 (and 9 when the backend computes probes): b = Td_b ld, r = Tb->r b,
  // lightmap = Ub b + Ur r, atlas with padding. Rejects NaN, Inf and negative ld (the
  // message names sample and channel); then nothing changes.
  virtual Status update(std::span<const float> ld) = 0;

  // Multi-bounce feedback (architecture.md §2, core's apply_feedback): set_albedo() validates and
  // stores albedo (3 x samples) clamped to max_albedo < 1; multi_bounce_step() runs one
  // feedback iteration on the previous update's lightmap, ld = ld_direct + rho *
  // min(max(lightmap, 0), max(ld_direct) / (1 - max rho)), then update(ld). k steps after
  // update(ld_direct) equal level_multi_bounce after k iterations.
  virtual Status set_albedo(std::span<const float> albedo, float max_albedo = kDefaultMaxAlbedo) = 0;
  virtual Status multi_bounce_step(std::span<const float> ld_direct) = 0;

  // Converged multi-bounce in the reduced space (reduced_feedback.h, issue 20): b0 = Td_b
  // ld_direct, b* = (I - s M)^-1 b0 by ReducedSolver warm-started from the last converged
  // update's b*, then r, the lightmap, atlas, probes and vector irradiance once from b*. Needs
  // set_albedo; the reduced operators are built at the first converged update after it
  // (converged_stats().build_ns: that update allocates). Not converging within
  // settings.max_iterations is reported in converged_stats(), not an error. Refused
  // (invalid_argument) by a backend without a reduced solve (none today). With clutter
  // the solve includes the clutter's c (its light fed back with set_clutter_albedo's albedo, DRT
  // deltas in the feedback: drt_converged_bounce); set_clutter / set_clutter_albedo rebuild it.
  // With clutter operators that gather the real radiance the solve leaves the clutter out and
  // kGatherConvergedSteps multi_bounce_step()s with it follow (drt.h, drt_converged_bounce).
  // GLES solves on the GPU from b0 with an a-priori iteration count (staged_backend.h).
  virtual Status update_converged(std::span<const float> ld_direct,
                                  const ReducedSolveSettings& settings = {}) {
    (void)ld_direct, (void)settings;
    return Status::error(ErrorCode::invalid_argument, std::string(backend_kind_name(kind())) +
                                                          ": no converged solve: use multi_bounce_step()");
  }
  // The same with ld_direct from a GL texture (as update_from_texture reads it; nothing is read
  // back). Refused where update_from_texture or update_converged is.
  virtual Status update_converged_from_texture(std::uint32_t ld_texture,
                                               const ReducedSolveSettings& settings = {}) {
    (void)ld_texture, (void)settings;
    return Status::error(ErrorCode::invalid_argument,
                         std::string(backend_kind_name(kind())) + ": no converged solve from a texture");
  }
  virtual ConvergedStats converged_stats() const { return {}; }
  // Whether update_converged can run (a backend with a reduced solve).
  virtual bool converged_available() const { return false; }

  // Skip what the camera cannot see (issue 20): visible[i] != 0 marks block i potentially
  // visible (level_visible_blocks, or the renderer's own visibility set); empty: every block
  // (the default). b and r are still computed for every block (they carry light), but a
  // block's lightmap tile and its atlas rectangles (and vector atlases on a GPU) are written
  // only while it is visible, and of its open-face neighbours what its padding reads (the CPU
  // backend: those samples only; the reference: their whole tiles).
  // A block that becomes visible has its tiles produced by this call, from the b and r on
  // hand, so that the outputs of every visible block equal the full path's bit for bit; a
  // feedback step first produces every hidden tile (it reads the whole lightmap). The hidden
  // blocks' texels in read_lightmap / read_atlas are not current (an earlier frame's, and
  // with clutter this frame's deltas over them). The probes of a hidden block (CPU and
  // reference backends, without clutter; GLES computes every block's) are computed when they
  // are read (read_probes, read_block_probes) or the block comes into view, so every probe
  // read equals the full path's. Refused (nothing changes) for a wrong size, and by a
  // backend without it.
  virtual Status set_visible_blocks(std::span<const std::uint8_t> visible) {
    (void)visible;
    return Status::error(ErrorCode::invalid_argument,
                         std::string(backend_kind_name(kind())) + ": no camera skip in this backend");
  }

  // Copies of the last update's results (sizes().lightmap, .atlas, .probes floats, RGB
  // interleaved). read_probes fails when the level or backend has no probes.
  virtual Status read_lightmap(std::span<float> lightmap) = 0;
  virtual Status read_atlas(std::span<float> atlas) = 0;
  virtual Status read_probes(std::span<float> probes) = 0;
  // The probes of block `block` only (sizes().probes / blocks floats, read_probes' slice of it):
  // with the camera skip, the one hidden block's probes are computed, not every one's.
  virtual Status read_block_probes(std::size_t block, std::span<float> probes) = 0;
  // Vector irradiance (MRT §6.4, level_compute_vector_irradiance's layout, sizes().vector_lightmap
  // floats): four OHLSH coefficients x RGB per sample, for normal-mapped surfaces. Fails when
  // the dictionary has no vector operators or the backend was created without them.
  virtual Status read_vector_lightmap(std::span<float> vector_lightmap) = 0;

  // The GL texture name (GL_TEXTURE_2D) holding `output` after the last update, for a renderer
  // to sample without a copy; 0 when the backend keeps it in CPU memory (read it with the
  // read_* calls) or does not compute it. Its format: the backend's description.
  virtual std::uint32_t output_texture(BackendOutput output) const {
    (void)output;
    return 0;
  }
  // Where the backend keeps `output` in CPU memory (the atlas of modrt::cpu), for a renderer to
  // upload without a copy; empty when it keeps it on the GPU (output_texture) or does not have it.
  virtual std::span<const float> output_data(BackendOutput output) const {
    (void)output;
    return {};
  }
  // The format of every output_texture: 0 RGBA32F, 1 RGBA16F, 2 RGBA32UI holding float bits (fetch
  // it with texelFetch) — modrt.h's format codes; -1 for a backend without textures.
  virtual int output_texture_format() const { return -1; }
  // The probe volume of the last update in the world frame as a GL texture, for a renderer to
  // sample on the GPU: texel i = (block g^3 + probe) 9 + k at (i % 2048, i / 2048), radiance
  // SH9 coefficient k in .rgb, each block's canonical-frame probes turned by its quarter turns
  // (sh9_quarter_turn_rotation); one GPU pass on the first request after an update, nothing
  // read back. Backends without GL textures or probes fail (invalid_argument).
  virtual Result<std::uint32_t> world_probe_texture() {
    return Status::error(
        ErrorCode::invalid_argument,
        std::string(backend_kind_name(kind())) + ": no GL textures: read the probes with read_probes");
  }

  // The stage times of the last evaluation (all 0 unless timing is on).
  virtual const BackendStageTimes& stage_times() const {
    static const BackendStageTimes none;
    return none;
  }
  // Measure stage_times() from the next evaluation on (GLES: a glFinish per pass or GPU timer
  // queries; cpu: the steady clock around each stage). Off by default.
  virtual void set_timing(bool on) { (void)on; }
  virtual BackendEvaluationStats evaluation_stats() const = 0;
  // Counts a frame the caller skipped whole (its input repeated the last frame's exactly, so
  // every result stands) as an evaluation that kept every block, slot and tile: the frame
  // pipeline's skip of a repeated multi-bounce frame, so computed + kept stays evaluations x blocks.
  virtual void count_frame_kept() = 0;

  // GPU-resident ld (architecture.md §5 step 1 on the GPU): as update(), with ld read from a GL
  // texture (GL_TEXTURE_2D) the caller rendered, sample s at texel (s % width, s / width) of
  // ld_texture_size(), RGB in .rgb, a float format. Nothing is read back, so the values are not
  // validated on the CPU: NaN and negative texels read as 0, and values clamp at
  // kMaxLightValue. Backends that keep ld in CPU memory refuse it (invalid_argument).
  virtual Status update_from_texture(std::uint32_t ld_texture) {
    (void)ld_texture;
    return Status::error(ErrorCode::invalid_argument,
                         std::string(backend_kind_name(kind())) + ": ld comes from CPU memory: use update()");
  }
  virtual TextureSize ld_texture_size() const { return {}; }  // {0, 0} without update_from_texture
  // multi_bounce_step with ld_direct from the texture update_from_texture read, and the bound
  // found on the GPU (no readback; the fed-back light clamps at kMaxLightValue).
  virtual Status multi_bounce_step_from_texture(std::uint32_t ld_texture) {
    (void)ld_texture;
    return Status::error(
        ErrorCode::invalid_argument,
        std::string(backend_kind_name(kind())) + ": ld comes from CPU memory: use multi_bounce_step()");
  }

  // DRT (architecture.md §6, docs/drt.md "Runtime in the backends"): clutter inside the level's blocks.
  // set_clutter() checks the operators against the level (check_drt_operators) and borrows
  // them until the next set_clutter() or the backend's end; nullptr or empty operators remove
  // the clutter, and a backend without clutter (the default) runs no DRT work and allocates
  // nothing for it. With clutter, every update() and multi_bounce_step() also computes
  //   c = Td_c clutter_ld, lightmap += dUb b + dUc c (atlas and padding included),
  //   clutter lightmap = Cb b + Cc c + clutter_direct (Cc: clutter-to-clutter light, drt.h),
  // and the multi-bounce feedback reads the lightmap with the delta (core's drt_multi_bounce;
  // with set_clutter_albedo it feeds the clutter's indirect light back through c too). When the operators
  // carry them (DrtBuildSettings::vector / probes) and the backend renders them, the vector irradiance gets
  // dUb_vec b + dUc_vec c (drt_apply_vector) and the probes Udyn b + Udyn_c c (drt_apply_probes).
  virtual Status set_clutter(const DrtOperators* drt) = 0;
  // The clutter's light for the following updates (3 floats per clutter texel, clutter_sizes()
  // .clutter_ld): clutter_ld is what Td_c reads (drt_compute_c), clutter_direct what the clutter
  // lightmap adds (empty: nothing). Zero until set. Rejects NaN, Inf, negative values and
  // wrong sizes; then nothing changes. Takes effect at the next update().
  virtual Status set_clutter_light(std::span<const float> clutter_ld,
                                   std::span<const float> clutter_direct) = 0;
  // The clutter's albedo (3 floats per clutter texel, clamped to max_albedo < 1) for
  // multi-bounce: each multi_bounce_step() then first feeds the clutter's indirect light of
  // the previous evaluation back, c = Td_c drt_clutter_feedback(clutter_ld, rho_c, Cb b + Cc c,
  // drt_feedback_bound(...)), as core's drt_multi_bounce with clutter_albedo; update() starts
  // again from c = Td_c clutter_ld. Empty: no clutter feedback (the default; also after
  // set_clutter). Rejects NaN, Inf, negative values and wrong sizes; then nothing changes.
  virtual Status set_clutter_albedo(std::span<const float> clutter_albedo,
                                    float max_albedo = kDefaultMaxAlbedo) = 0;
  // drt_buffer_sizes of the current clutter (all zero without).
  virtual const DrtBufferSizes& clutter_sizes() const = 0;
  // The clutter atlas (output_texture(BackendOutput::clutter_atlas)): its size, and where
  // texel t of object k lies in it; {0, 0} and {-1, -1} for a backend without one.
  virtual TextureSize clutter_atlas_size() const { return {}; }
  virtual std::array<int, 2> clutter_atlas_texel(std::size_t object, std::uint32_t t) const {
    (void)object, (void)t;
    return {-1, -1};
  }
  // The clutter's vector irradiance of the last update (clutter_sizes().clutter_vector_lightmap
  // floats, core's drt_clutter_vector_lightmap layout: OHLSH E/pi in each clutter texel's
  // frame, for normal-mapped clutter; zeros for objects built without vector operators).
  // Computed on request from the last update's b and c. Fails without clutter.
  virtual Status read_clutter_vector_lightmap(std::span<float> clutter_vector_lightmap) = 0;
  // The clutter lightmap of the last update (clutter_sizes().clutter_lightmap floats, core's
  // drt_clutter_lightmap layout). Fails without clutter.
  virtual Status read_clutter_lightmap(std::span<float> clutter_lightmap) = 0;

 protected:
  Backend() = default;
  Backend(const Backend&) = default;
  Backend& operator=(const Backend&) = default;
};

}  // namespace modrt
