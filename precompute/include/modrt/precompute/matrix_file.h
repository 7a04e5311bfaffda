// SPDX-License-Identifier: MIT
// modrt precompute — a checksummed file of named float matrices, for what the level build
// keeps between runs but no run time reads: the dictionary's interface basis Hrlf and the
// interface operators of shaped blocks (shaped_interfaces.h).
//
//   0 magic "MODRTMXF" | 8 version (u32) | 12 tag: u32 length, bytes | count (u32) | per
//   matrix: u32 name length, name, u32 rows, u32 cols, rows x cols float32 row-major |
//   CRC-32 (file_io.h) of every byte before it.
//
// All integers and floats little-endian. The tag says what the file holds and for which
// dictionary; a reader asks for the tag it expects, so a renamed or stale file is refused.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/status.h"

namespace modrt::precompute {

inline constexpr std::uint32_t kMatrixFileVersion = 1;
inline constexpr std::uint64_t kMaxMatrixFileBytes = std::uint64_t(2) << 30;

struct MatrixRef {
  std::string name;
  const Matrix* matrix = nullptr;
};
struct NamedMatrix {
  std::string name;
  Matrix matrix;
};

// Written atomically (write_file_atomic). resource_limit past kMaxMatrixFileBytes.
Status save_matrix_file(const std::string& path, const std::string& tag, std::span<const MatrixRef> matrices);

// Every error names the path and the problem: io_error (cannot read), the file is bad (bad
// magic, truncated or inconsistent sizes, another tag: format_error; another version:
// version_mismatch; checksum_mismatch), non_finite (a
// NaN or Inf entry, naming the matrix).
Result<std::vector<NamedMatrix>> load_matrix_file(const std::string& path, const std::string& expected_tag);

}  // namespace modrt::precompute
