// SPDX-License-Identifier: MIT
// modrt — the dictionary file: one versioned, checksummed binary file holding the
// settings and every operator of a Dictionary (dictionary.h). It is written by modrt-bake
// and by the dictionary cache, and read by every runtime. This comment is the contract.
//
// ## Layout (format version 2)
//
// All integers are little-endian, floats are IEEE-754 binary32 stored by their bit
// pattern as a u32. Offsets are from the start of the file.
//
// Header (kDictionaryHeaderBytes = 112 bytes):
//   off  type     field
//     0  u8[8]    magic "MODRTDIC" (no terminator)
//     8  u32      format version (kDictionaryFormatVersion)
//    12  u32      header byte size (112 for versions 1 and 2; the section table starts here)
//    16  u32      settings.res
//    20  u32      settings.kd
//    24  u32      settings.kb
//    28  u32      settings.rays
//    32  u32      settings.enrichment_iterations
//    36  u32      settings.prior_grid
//    40  u32      settings.light_samples
//    44  f32      settings.light_radius
//    48  u32      settings.sh_rays
//    52  u32      settings.probe_grid
//    56  u64      settings.seed
//    64  u32      settings.lightfield_spatial
//    68  u32      settings.lightfield_directional
//    72  u32      settings.lightfield_supersample
//    76  u32      settings.krlf
//    80  u32      settings.kr
//    84  u32      settings.interface_enrichment_iterations
//    88  u32      settings.response_rays
//    92  u32      shape count (kDictionaryShapeCount = 6)
//    96  u32      section count (1 .. 64 * shape count)
//   100  u32      CRC-32 of the section table (section count * 48 bytes)
//   104  u32      reserved, 0
//   108  u32      CRC-32 of header bytes [0, 108)
//
// Section table (starts at the header byte size; kDictionarySectionEntryBytes = 48 bytes
// per entry):
//   off  type     field
//     0  u32      kind (DictionarySectionKind)
//     4  u32      shape index 0..5 (dictionary order, cube.h) for per-shape kinds;
//                 kNoShape (0xFFFFFFFF) for the dictionary-wide interface operators
//     8  u32      rows
//    12  u32      cols
//    16  u32      element type: 0 = float32, 1 = float16 (IEEE binary16)
//    20  u32      sub-index: for Rb_rlf the missing side face (cube.h face index);
//                 0 for every other kind
//    24  u64      payload byte offset
//    32  u64      payload byte size (= rows * cols * element size)
//    40  u32      CRC-32 of the payload bytes
//    44  u32      pad, 0
//
// Payloads: each section's matrix, row-major, rows * cols elements of the element type.
// sigma_M is stored as one row (rows = 1, cols = its length, possibly 0). The writer
// places the payloads contiguously after the table in table order (shape 0..5: Ub, Td_b,
// Limp, Ub_vec, Ubvol, sigma_M, Rb_rlf per missing side face in ascending face order; then
// R_straight, R_left, R_right, Trlf_r, Ur, Urvol, Ur_vec); readers must locate sections only through the
// table. Payloads lie after the table, inside the file.
//
// Required sections: every per-shape kind 1..6 for each of the 6 shapes; when
// settings.lightfield_spatial > 0 also Rb_rlf for every missing side face of every shape
// and the seven interface operators (kinds 17..23); when it is 0, no interface sections.
// Matrix sizes are implied by the settings (dictionary.h, validate_dictionary), with
// n = face_count(shape mask) * res^2: Ub n x kb, Td_b kb x n, Limp n x kb, Ub_vec 4n x kb,
// Ubvol 9 g^3 x kb (g = probe_grid), sigma_M 1 x (<= n), Rb_rlf krlf x kb,
// R_* krlf x krlf, Trlf_r kr x krlf, Ur n(dead end) x kr, Urvol 9 g^3 x kr, Ur_vec 4n(dead end) x kr.
//
// Version history: version 1 had no Ur_vec; its files are refused (version_mismatch: re-bake).
//
// Float16 (DictionaryWriteOptions::float16) stores every matrix as binary16 except
// sigma_M, which is always float32. A value outside the float16 range is a save error,
// never a silent Inf.
//
// CRC-32 is IEEE (file_io.h crc32). A reader checks, in order: size >= header, magic,
// version (version_mismatch), header size, header CRC, settings (validate_settings), shape
// count, section count and table bounds, table CRC, then each section (kind, shape,
// sub-index, element type, dimensions against the settings, byte size, bounds, payload
// CRC), duplicates, missing sections, no trailing bytes after the last section's payload
// (the rule of level files too), and finally the decoded values (validate_dictionary: no
// NaN/Inf, and every operator within the plausibility limits of operator_limits.h).
// Nothing is allocated from an unchecked size.
//
// Error codes: format_error (malformed), version_mismatch (other format version: re-bake),
// checksum_mismatch (a CRC differs), non_finite (NaN/Inf values), invalid_argument (an operator
// above its limit), io_error, resource_limit
// (file larger than kMaxDictionaryFileBytes). Messages start with the file name (the
// `what` of parse_dictionary) and name the section, shape and problem.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/status.h"

namespace modrt {

inline constexpr std::uint32_t kDictionaryFormatVersion = 2;
inline constexpr char kDictionaryMagic[8] = {'M', 'O', 'D', 'R', 'T', 'D', 'I', 'C'};
inline constexpr std::size_t kDictionaryHeaderBytes = 112;
inline constexpr std::size_t kDictionarySectionEntryBytes = 48;
inline constexpr std::uint32_t kNoShape = 0xFFFFFFFFu;
// load_dictionary refuses larger files; serialize_dictionary refuses to produce them.
inline constexpr std::uint64_t kMaxDictionaryFileBytes = std::uint64_t(2) << 30;  // 2 GiB

// Section kinds. 1..15 are per-shape operators (7..15 reserved); 16..31 interface
// operators (MRT §5; 24..31 reserved, e.g. Hrlf). A kind this build does not know is
// an error ("unknown section kind K"): new kinds come with a new format version.
enum class DictionarySectionKind : std::uint32_t {
  Ub = 1,
  Td_b = 2,
  Limp = 3,
  Ub_vec = 4,
  Ubvol = 5,
  sigma_M = 6,
  Rb_rlf = 16,      // per shape and missing side face (sub-index = face)
  R_straight = 17,  // dictionary-wide (shape index = kNoShape)
  R_left = 18,
  R_right = 19,
  Trlf_r = 20,
  Ur = 21,
  Urvol = 22,   // probe response, 9 g^3 x kr
  Ur_vec = 23,  // OHLSH vector irradiance response, 4n(dead end) x kr (since version 2)
};
// "Ub", "Rb_rlf", ...; nullptr for an unknown kind.
const char* dictionary_section_name(std::uint32_t kind);

enum class DictionaryElementType : std::uint32_t { float32 = 0, float16 = 1 };

struct DictionaryWriteOptions {
  bool float16 = false;  // store matrices as IEEE half (sigma_M stays float32)
};

// The whole file in memory. Validates the dictionary first (validate_dictionary).
Result<std::vector<std::byte>> serialize_dictionary(const Dictionary& dict,
                                                    const DictionaryWriteOptions& options = {});

// Validates, serializes and writes atomically (write_file_atomic). Messages start with path.
Status save_dictionary(const std::string& path, const Dictionary& dict,
                       const DictionaryWriteOptions& options = {});

// Parses and fully validates a dictionary file image; `what` (e.g. the path) starts
// every message. Never trusts a size before checking it against the file and settings.
Result<Dictionary> parse_dictionary(std::span<const std::byte> bytes, const std::string& what);

// read_file (at most kMaxDictionaryFileBytes) + parse_dictionary(bytes, path).
Result<Dictionary> load_dictionary(const std::string& path);

// Reads and validates the header only (magic, version, header CRC, settings): whether a
// cache file matches requested settings, without reading its payload.
Result<DictionarySettings> peek_dictionary_settings(const std::string& path);

}  // namespace modrt
