// SPDX-License-Identifier: MIT
// modrt — the built-level file (.modrtlevel): one versioned, checksummed binary file
// holding a Level (level.h), so that an app ships a level built offline by modrt-level and
// loads it without the precompute library. Read from a path or from a memory buffer (an
// app bundle's asset). This comment is the contract.
//
// ## Layout (format version 3; version 1 had no per-face albedo, version 2 no shaped
// operators; both are refused)
//
// All integers are little-endian; floats are IEEE-754 binary32 stored by their bit pattern
// as a u32, doubles binary64 as a u64. Offsets are from the start of the file.
//
// Header (kLevelFileHeaderBytes = 64 bytes):
//   off  type     field
//     0  u8[8]    magic "MODRTLVL"
//     8  u32      format version (kLevelFileVersion)
//    12  u32      header byte size (64)
//    16  u32      res
//    20  u32      kb (b's stride: the most modes of any operator set, level.h)
//    24  u32      kr
//    28  u32      block count
//    32  u32      sample count
//    36  u32      slot count
//    40  u32      record count
//    44  u32      shaped operator set count (Level::shaped)
//    48  u64      body byte size (the rest of the file)
//    56  u32      CRC-32 of the body
//    60  u32      CRC-32 of header bytes [0, 60)
//
// Body, in this order (every count below is checked against the bytes left before it is
// used to allocate):
//   blocks      per block: i32 shape, i32 quarter_turns, i32 cell[3], f64 corners[8][3],
//               i32 neighbour[6], u32 sample_offset, u32 sample_count,
//               f32 albedo[6][3] (per canonical face, linear RGB in [0, 1])
//   slots       per slot: u32 block, i32 entry_face, u32 n, i32 ur_row_to_sample[n]
//   records     per record: u32 source_block, u32 slot, u32 rows, u32 cols, f32 T[rows*cols]
//               (kr x the source block's modes: its shaped set's, else the dictionary's)
//   probe_response[6], then vector_response[6]: u32 rows, u32 cols, f32 values[rows*cols]
//   atlas       i32 width, i32 height, i32 tile, u32 n, u32 sample_texel[n],
//               u32 has_tiles (0 or 1), when 1 per block: i32 tile_origin_x[6],
//               i32 tile_origin_y[6]; u32 padding count p, (u32 dst, u32 src)[p]
//   shaped      per set: i32 shape, f32 extent[3], then Ub, Td_b, Limp, Ub_vec, Ubvol each
//               as u32 rows, u32 cols, f32 values (the set's own modes, Ub's columns, in
//               [1, kb]: a long box keeps more than a cube); when the count is > 0, per block i32
//               shaped (-1: the dictionary shape's operators). Rb_rlf is not stored: only
//               the level build uses it.
//
// A reader checks, in order: size >= header, magic, version (version_mismatch), header
// size, header CRC, body size, body CRC (checksum_mismatch), then every field while
// decoding (format_error: the message names the part, index and field), no trailing
// bytes, finite values (non_finite), and finally the Level's own consistency (sample
// offsets contiguous, indices in range, records sorted by slot, atlas texels inside the
// atlas). Matching against a dictionary is check_level_operators (level_runtime.h), which
// every backend runs at creation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/level.h"
#include "modrt/status.h"

namespace modrt {

inline constexpr std::uint32_t kLevelFileVersion = 3;
inline constexpr char kLevelFileMagic[8] = {'M', 'O', 'D', 'R', 'T', 'L', 'V', 'L'};
inline constexpr std::size_t kLevelFileHeaderBytes = 64;
// Bytes of one encoded block (the body's first part), and where its albedo starts in it.
inline constexpr std::size_t kLevelFileBlockAlbedoOffset = 4 * 5 + 8 * 24 + 4 * 6 + 8;
inline constexpr std::size_t kLevelFileBlockBytes = kLevelFileBlockAlbedoOffset + 4 * 3 * 6;
// load_level refuses larger files; serialize_level refuses to produce them.
inline constexpr std::uint64_t kMaxLevelFileBytes = std::uint64_t(1) << 30;  // 1 GiB

// The whole file in memory. Fails (invalid_argument) on a Level that is not
// self-consistent or holds NaN/Inf.
Result<std::vector<std::byte>> serialize_level(const Level& level);

// Serializes and writes atomically (write_file_atomic). Messages start with path.
Status save_level(const std::string& path, const Level& level);

// Parses and fully validates a level file image; `what` (e.g. the path or asset name)
// starts every message. Never allocates from a size it has not checked.
Result<Level> parse_level(std::span<const std::byte> bytes, const std::string& what);

// read_file (at most kMaxLevelFileBytes) + parse_level(bytes, path).
Result<Level> load_level(const std::string& path);

}  // namespace modrt
