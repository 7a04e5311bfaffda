// SPDX-License-Identifier: MIT
// modrt — the DRT operator file (.modrtdrt): one versioned, checksummed binary file holding
// the clutter operators of a level (DrtOperators, drt.h), built offline (precompute's
// DrtBuilder, written by modrt-demo --save-clutter) so that an app loads them without the
// precompute library, from a path or a memory buffer. This comment is the contract.
//
// ## Layout (format version 4)
//
// Little-endian; floats are IEEE-754 binary32 stored by their bit pattern as a u32.
//
// Header (kDrtFileHeaderBytes = 64 bytes):
//   off  type     field
//     0  u8[8]    magic "MODRTDRT"
//     8  u32      format version (kDrtFileVersion)
//    12  u32      header byte size (64)
//    16  u32      kb
//    20  u32      object count
//    24  u32      probes_per_block
//    28  u32      level_blocks (since version 2; 0: not recorded)
//    32  u32      level_samples (since version 2)
//    36  u32[3]   reserved, 0
//    48  u64      body byte size (the rest of the file)
//    56  u32      CRC-32 of the body
//    60  u32      CRC-32 of header bytes [0, 60)
//
// Body: per object, u32 texel_count, u32 face_count, u32 cell_res (since version 3; 0: no
// texel cells), then the operators of
// DrtObjectOperators in the order of its declaration (drt_io.cpp, visit_fields): an index
// list is u32 n, u32[n]; a float list u32 n, f32[n]; a matrix u32 rows, u32 cols,
// f32[rows * cols] (row-major); a scalar one f32.
//
// A reader checks, in order: size >= header, magic, version (version_mismatch), header size,
// reserved fields, header CRC, body size, body CRC (checksum_mismatch), then every field while
// decoding (format_error naming the object and field; counts are checked against the bytes
// left before anything is allocated), no trailing bytes, finite values (non_finite). Whether
// the operators fit a level (sizes, sample and block indices, kb) is check_drt_operators
// (drt.h), which every backend's set_clutter runs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/drt.h"
#include "modrt/status.h"

namespace modrt {

// 2: the texels' positions and normals (DrtObjectOperators::texel_position, texel_normal).
// 3: the texels' lightmap cells (cell_res, texel_cell).
// 4: the real-radiance gather (Gs, Gt, H_sample, Hs, Ht: each sparse row set as three lists,
//    start, index, weight).
inline constexpr std::uint32_t kDrtFileVersion = 4;
inline constexpr char kDrtFileMagic[8] = {'M', 'O', 'D', 'R', 'T', 'D', 'R', 'T'};
inline constexpr std::size_t kDrtFileHeaderBytes = 64;
// load_drt refuses larger files; serialize_drt refuses to produce them.
inline constexpr std::uint64_t kMaxDrtFileBytes = std::uint64_t(1) << 30;  // 1 GiB

// The whole file in memory. Fails (non_finite) on NaN or Inf in an operator.
Result<std::vector<std::byte>> serialize_drt(const DrtOperators& drt);
// Serializes and writes atomically (write_file_atomic). Messages start with path.
Status save_drt(const std::string& path, const DrtOperators& drt);
// Parses and validates a file image; `what` (the path or asset name) starts every message.
Result<DrtOperators> parse_drt(std::span<const std::byte> bytes, const std::string& what);
// read_file (at most kMaxDrtFileBytes) + parse_drt(bytes, path).
Result<DrtOperators> load_drt(const std::string& path);

}  // namespace modrt
