// SPDX-License-Identifier: MIT
// The 64-byte sealed header that the level file (level_io.h) and the DRT operator file
// (drt_io.h) share, written and checked in one place. Internal to core.
//
//   0 magic[8] | 8 version | 12 header bytes (64) | 16..44 eight u32 fields of the format (the
//   unused ones reserved, 0) | 48 body bytes (u64) | 56 CRC-32 of the body | 60 CRC-32 of bytes 0..59
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/status.h"

namespace modrt::binary {

inline constexpr std::size_t kSealedHeaderBytes = 64;
inline constexpr std::size_t kSealedHeaderFields = 8;
using SealedFields = std::array<std::uint32_t, kSealedHeaderFields>;

struct SealedFormat {
  const char* magic = "";   // 8 characters
  const char* kind = "";    // "modrt level file": "not a <kind> (bad magic ...)"
  const char* writer = "";  // "level": "<writer>: the file would be N bytes ..."
  std::uint32_t version = 0;
  std::size_t fields = 0;  // fields the format uses; those after them must be 0
  std::uint64_t max_file_bytes = 0;
  const char* rebuild = "";  // the remedy a version mismatch names
  // Extra words for an old version (" (version 1 has no per-face albedo)"); may be null.
  const char* (*version_note)(std::uint32_t version) = nullptr;
};

// Header + body, the header's fields, sizes and checksums filled in. Fails (resource_limit)
// when the file would exceed format.max_file_bytes.
Result<std::vector<std::byte>> seal(const SealedFormat& format, const SealedFields& fields,
                                    std::span<const std::byte> body);

// Checks, in this order, the size, magic, version, header size, header CRC, reserved fields,
// body size and body CRC of `bytes`; every error begins with `what`. Returns the body and
// fills `fields`.
Result<std::span<const std::byte>> open_sealed(const SealedFormat& format, std::span<const std::byte> bytes,
                                               const std::string& what, SealedFields& fields);

}  // namespace modrt::binary
