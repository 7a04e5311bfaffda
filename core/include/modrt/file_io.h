// modrt — small, careful file helpers shared by every file format (dictionary, levels).
//
// Nothing here throws: failures come back as a Status whose message names the path and
// the operating-system reason (strerror).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/status.h"

namespace modrt {

// Writes `bytes` to `path` atomically: the data goes to a temporary file in the same
// directory (path + ".tmp.<pid>.<counter>"), is flushed and fsync'ed, and the temporary
// is then renamed over `path` (POSIX rename is atomic), so readers see either the old or
// the new file, never a partial one. Missing parent directories are created. On failure
// the temporary file is removed and io_error is returned.
Status write_file_atomic(const std::string& path, std::span<const std::byte> bytes);

// Reads a whole file. Files larger than max_bytes are refused with resource_limit (the
// message gives both sizes) before anything is allocated; io_error when the file cannot
// be opened or read.
Result<std::vector<std::byte>> read_file(const std::string& path, std::uint64_t max_bytes);

// The size of the open file `fd` if it is a regular file; otherwise io_error
// "<path>: cannot read: a directory, not a regular file" (or a FIFO, device, socket). Every
// reader (read_file, read_file_prefix, the C API's file loaders) asks this first: a
// directory opens, and through stdio even reports a size of LONG_MAX.
Result<std::uint64_t> regular_file_size(int fd, const std::string& path);

// Reads at most the first `count` bytes of a file (fewer when the file is shorter);
// io_error when it cannot be opened or read.
Result<std::vector<std::byte>> read_file_prefix(const std::string& path, std::uint64_t count);

// IEEE 802.3 CRC-32 (reflected polynomial 0xEDB88320, initial value and final xor
// 0xFFFFFFFF), as used by zlib/PNG: crc32("123456789") == 0xCBF43926. `seed` is a previous
// result, to checksum data in pieces: crc32(b, crc32(a)) == crc32(a followed by b).
std::uint32_t crc32(std::span<const std::byte> bytes, std::uint32_t seed = 0);

}  // namespace modrt
