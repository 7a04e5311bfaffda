// SPDX-License-Identifier: MIT
// modrt — the scalar reference runtime for a whole level (architecture.md §5, MRT §7.3 steps 2–6, 8).
//
// Level-wide signals are RGB-interleaved and concatenate the blocks (level.h):
//   ld, lightmap, albedo: 3 * level.sample_count
//   b: 3 * kb per block (block i at 3 * kb * i; its first 3 * block_kb are its modes, the
//      rest zero: level.h)
//   r: 3 * kr per response slot
#pragma once

#include <span>

#include "modrt/level.h"
#include "modrt/level_dirty.h"
#include "modrt/reference_runtime.h"

namespace modrt {

// Sizes of the per-frame buffers a caller allocates once.
struct LevelBufferSizes {
  std::size_t ld = 0, b = 0, r = 0, lightmap = 0, atlas = 0, probes = 0;
  std::size_t vector_lightmap = 0;  // 12 per sample: 4 OHLSH coefficients x RGB
};
LevelBufferSizes level_buffer_sizes(const Level& level, const Dictionary& dict);

// Checks that the level was built against this dictionary (res, kb, kr, shapes).
Status check_level_matches(const Level& level, const Dictionary& dict);
// check_level_matches, then every operator size, index and offset a runtime relies on
// (shapes, Td_b / Ub / Ubvol sizes, contiguous sample offsets, slots, records, atlas).
// Backends call it once at creation so that per-frame code can index without checks.
Status check_level_operators(const Level& level, const Dictionary& dict);

// Step 2: b = Td_b ld per block. Validates ld.
Status level_compute_b(const Level& level, const Dictionary& dict, std::span<const float> ld,
                       std::span<float> b);
// Step 4: r = Tb->r b (records summed per slot).
void level_compute_r(const Level& level, std::span<const float> b, std::span<float> r);
// Steps 3 and 5: lightmap = Ub b + Ur r (rotated onto each slot's entry face).
void level_compute_lightmap(const Level& level, const Dictionary& dict, std::span<const float> b,
                            std::span<const float> r, std::span<float> lightmap);
// Steps 2–5 in one call.
Status level_evaluate(const Level& level, const Dictionary& dict, std::span<const float> ld,
                      std::span<float> b, std::span<float> r, std::span<float> lightmap);
// The same with the level's transport graph built once by the caller (level_dependencies):
// allocates nothing (the overload above builds the graph on every call).
Status level_evaluate(const Level& level, const Dictionary& dict, const LevelDependencies& deps,
                      std::span<const float> ld, std::span<float> b, std::span<float> r,
                      std::span<float> lightmap);

// The same steps one item at a time (the reference backend's stages): the whole-level calls
// above loop over these, so recomputing only the dirty items (level_dirty.h) gives the same
// bits. No checks: ld must be validated and the level checked (check_level_operators).
//   b_i = Td_b ld_i (block i)
void level_compute_block_b(const Level& level, const Dictionary& dict, std::span<const float> ld,
                           std::size_t block, std::span<float> b);
//   r_s = sum of T b_source over the records of slot s, in record order
void level_compute_slot_r(const Level& level, const LevelDependencies& deps, std::span<const float> b,
                          std::size_t slot, std::span<float> r);
//   block i's tile of the lightmap: clamp(Ub b_i + Ur r_s of every slot s entering i, in slot order)
void level_compute_tile(const Level& level, const Dictionary& dict, const LevelDependencies& deps,
                        std::span<const float> b, std::span<const float> r, std::size_t block,
                        std::span<float> lightmap);
//   block i's probes: Ubvol b_i + the probe response to every slot entering i, in slot order
void level_compute_block_probes(const Level& level, const Dictionary& dict, const LevelDependencies& deps,
                                std::span<const float> b, std::span<const float> r, std::size_t block,
                                std::span<float> probes);

// Multi-bounce feedback for a level, as multi_bounce() for one block (same clamps). This is
// the oracle: it iterates to convergence and allocates its scratch per call. Per-frame code
// uses modrt::cpu::CpuLevelRuntime::multi_bounce_step (one iteration, no allocation).
Result<MultiBounceReport> level_multi_bounce(const Level& level, const Dictionary& dict,
                                             std::span<const float> ld_direct, std::span<const float> albedo,
                                             const MultiBounceSettings& settings, std::span<float> b,
                                             std::span<float> r, std::span<float> lightmap);

// Step 6: writes the lightmap into the padded atlas (3 * width * height floats) and fills
// the padding from the records. Texels not covered by any tile are zero.
void level_fill_atlas(const Level& level, std::span<const float> lightmap, std::span<float> atlas);

// Step 8: volume probes (radiance SH9, 9 g^3 per block, canonical block frame): Ubvol b
// for light from the block itself plus the probe response to every slot's r.
void level_compute_probes(const Level& level, const Dictionary& dict, std::span<const float> b,
                          std::span<const float> r, std::span<float> probes);

// Step 9, vector irradiance (MRT §6.4): OHLSH E/pi per sample in its face frame (sh.h),
// from the b and r of level_evaluate: Ub_vec b per block plus every slot's turned
// Ur_vec r (Level::vector_response). Layout: vector_lightmap[3 (4 s + i) + c] = coefficient
// i of sample s, channel c (sizes().vector_lightmap floats). ohlsh_eval of a sample's four
// coefficients at its face normal (0, 0, 1) approximates the scalar lightmap there; a
// normal map's normal gives the bumped irradiance. Fails (invalid_argument) when the
// dictionary or level has no vector operators of the expected sizes, or on wrong sizes.
Status level_compute_vector_irradiance(const Level& level, const Dictionary& dict, std::span<const float> b,
                                       std::span<const float> r, std::span<float> vector_lightmap);
// Whether the level and dictionary carry the vector operators level_compute_vector_irradiance
// needs (Ub_vec per shape, the turned Ur_vec per used entry face); the error names the block
// or slot without them. Backends ask once at creation.
Status check_level_vector_operators(const Level& level, const Dictionary& dict);

}  // namespace modrt
