// SPDX-License-Identifier: MIT
// Byte-level edits of the binary files (level, DRT operators, dictionary) for the tests and the
// fuzz harnesses: little-endian u32/u64 at a byte offset, and resealing a level or DRT file
// (core's 64-byte sealed header, core/src/sealed_file.h) after a change, so that a damaged
// field reaches the decoder's later checks. Needs no test framework.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "modrt/file_io.h"

namespace modrt::test {

inline std::uint32_t get_u32(std::span<const std::byte> b, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v |= std::to_integer<std::uint32_t>(b[at + i]) << (8 * i);
  return v;
}
inline std::uint64_t get_u64(std::span<const std::byte> b, std::size_t at) {
  return std::uint64_t(get_u32(b, at)) | (std::uint64_t(get_u32(b, at + 4)) << 32);
}
inline void put_u32(std::vector<std::byte>& b, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i) b[at + i] = std::byte((v >> (8 * i)) & 0xFFu);
}
inline void put_u64(std::vector<std::byte>& b, std::size_t at, std::uint64_t v) {
  put_u32(b, at, std::uint32_t(v));
  put_u32(b, at + 4, std::uint32_t(v >> 32));
}

// A level or DRT file: the body's CRC (offset 56) and then the header's (60, over bytes 0..59).
inline constexpr std::size_t kSealedHeaderBytes = 64;
// The body size field (offset 48, u64) set to what the file holds.
inline void put_sealed_body_size(std::vector<std::byte>& b) {
  const std::uint64_t body = b.size() - kSealedHeaderBytes;
  put_u64(b, 48, body);
}
inline void reseal_sealed_file(std::vector<std::byte>& b) {
  put_u32(b, 56, crc32(std::span<const std::byte>(b).subspan(kSealedHeaderBytes)));
  put_u32(b, 60, crc32(std::span<const std::byte>(b).first(60)));
}

}  // namespace modrt::test
