// SPDX-License-Identifier: MIT
// modrt precompute — the DRT build state file (.modrtdrtstate): a DrtBuildState (drt_build.h)
// kept across program starts, so that after one clutter object moved the next start re-traces
// only what the move changes (DrtBuilder::rebuild_object) instead of building every object's
// operators again (drt_cache.h keeps one next to the operators). This comment is the contract.
//
// ## Layout (format version 1)
//
// Little-endian; doubles are IEEE-754 binary64 and floats binary32, stored by their bit
// patterns. The 64-byte header is that of the level and DRT operator files (core's sealed
// header: magic "MODRTDBS", format version, header size 64, eight u32 fields, u64 body size,
// CRC-32 of the body, CRC-32 of header bytes [0, 60)); its fields:
//   16 level samples   20 level blocks   24 kb   28 object count
//   32 probes per block (the dictionary's probe_grid^3 with the probe pass, else 0)
//   36 scene key, low 32 bits   40 high 32 bits (the caller's tag, drt_cache.h's scene key)
//   44 reserved, 0
//
// Body, in this order (a list is u32 n, then its n items):
//   settings: u32 rays, u32 max_clutter_rays, u32 cb_modes, u32 clutter_prior_modes,
//     u32 clutter_prior_grid, u32 flags (1 inpaint, 2 cull, 4 vector, 8 probes,
//     16 sample_gather, 32 gather), f64 drop_tolerance, u64 seed
//   objects, each: u32 kind (0 box, 1 mesh), u32 block, f64[3] box centre, f64[3] half
//     extent, f64[9] rotation (column by column), u32 lit faces, f64[3] albedo, u32 res; a
//     mesh then: positions (f64[3] each), lightmap UVs (f64[2] each), indices (u32 each).
//     A mesh's atlas and charts are not stored: the loader makes them again from these and
//     res (make_mesh_clutter), and the box and faces stored are put back, so that the object
//     is the one the build saw, field for field.
//   scene pass: a list of sample results (one per level sample; none without objects)
//   vector scene pass: a list of sample results (one per sample with the vector pass, else none)
//   probe pass: a list of sample results (level blocks x probes per block with the probe pass)
//   clutter pass: per object, a list of texel results (one per texel of the object)
//   vector clutter pass: u32 1 and per object a list of texel results, or u32 0 (no vector pass)
// A sample result: u32 state (0 culled, 1 traced, 2 inside), i32 inside_of (the object
//   containing it when inside, else -1), then a list of object rows, each: u32 object, a
//   list of (u32 block, f64[W kb] row) (W = 1 for the scene pass, 4 vector, 9 probes), a
//   list of f64 (dUc), a list of (u32 sample, f32 weight), a list of (u64 key, f32 weight)
//   (key: object << 32 | texel).
// A texel result: a list of (u32 block, f64[W kb] row) (Cb's Limp sums), a list of
//   (u32 sample, f32 weight), a list of (u64 key, f32 weight), a list of (u64 key, f64
//   weight) (Cc: object << 32 | entry of its c, W entries per entry of c).
//
// A reader checks, in order: the sealed header (size, magic, version, header size and CRC,
// reserved field, body size and CRC), then while decoding every count against the bytes left
// before allocating, the settings (validate_drt_build_settings), each object (kind, block below
// the level's, finite box with positive extents and an orthonormal rotation, lit faces, albedo
// in [0, 1], res in [1, kMaxClutterCellRes]; a mesh rasterized again), every list's length
// against the level, the passes the settings ask for and the objects' texel counts, finite
// values, then every index the operators' assembly follows (drt_state.h check_state_rows:
// objects, blocks, samples, texels, entries of c, row lengths) and no trailing bytes. Errors
// name the file, the part ("object 2", "scene pass sample 17") and the problem
// (format_error; version_mismatch; checksum_mismatch; non_finite). Whether a state fits a
// level, a dictionary and settings is rebuild_object's check.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/precompute/drt_build.h"
#include "modrt/status.h"

namespace modrt::precompute {

inline constexpr std::uint32_t kDrtStateFileVersion = 1;
inline constexpr char kDrtStateFileMagic[8] = {'M', 'O', 'D', 'R', 'T', 'D', 'B', 'S'};
inline constexpr std::size_t kDrtStateFileHeaderBytes = 64;
// load_drt_build_state refuses larger files; serialize_drt_build_state refuses to make them.
inline constexpr std::uint64_t kMaxDrtStateFileBytes = std::uint64_t(1) << 32;  // 4 GiB

struct LoadedDrtBuildState {
  DrtBuildState state;
  std::uint64_t scene_key = 0;  // as given to serialize_drt_build_state
};

// The whole file in memory; `scene_key` is stored as given. Fails (invalid_argument) on an
// empty state or a mesh object whose atlas res is not its res, (non_finite) on NaN or Inf.
Result<std::vector<std::byte>> serialize_drt_build_state(const DrtBuildState& state,
                                                         std::uint64_t scene_key = 0);
// Serializes and writes atomically (write_file_atomic). Messages start with path.
Status save_drt_build_state(const std::string& path, const DrtBuildState& state, std::uint64_t scene_key = 0);
// Parses and checks a file image; `what` (the path) starts every message.
Result<LoadedDrtBuildState> parse_drt_build_state(std::span<const std::byte> bytes, const std::string& what);
// read_file (at most kMaxDrtStateFileBytes) + parse_drt_build_state(bytes, path).
Result<LoadedDrtBuildState> load_drt_build_state(const std::string& path);

}  // namespace modrt::precompute
