// SPDX-License-Identifier: MIT
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

// Whether write_file_atomic(path, ...) can succeed, checked before expensive work (a bake,
// a level build) rather than after it: `path` must not be a directory, its parent directory
// is created when missing (as write_file_atomic would) and must be a directory in which a
// file can be created (a probe temporary is created and removed: this sees permissions,
// read-only file systems and ACLs alike). io_error naming the path and the reason.
Status check_writable_file(const std::string& path);
// The same for a directory that files will be written into (created when missing).
Status check_writable_directory(const std::string& dir);

// Removes the temporaries that write_file_atomic left next to files in `dir` when its
// process died before renaming (a kill during a save): names "<file>.tmp.<pid>.<n>" whose
// pid is no longer alive (kill(pid, 0) fails with ESRCH). A live pid's temporaries are kept
// (a save in progress). `file_name` non-empty limits it to that file's temporaries. Returns
// the number removed; errors are ignored (a temporary that cannot be removed stays).
std::size_t remove_stale_temporaries(const std::string& dir, const std::string& file_name = {});

// An exclusive advisory lock (flock(2)) on a lock file, held until destruction. flock
// belongs to the open file description, so two threads or two processes that each acquire
// it exclude each other; the kernel releases it when the holder dies. The lock file is
// created when missing and left in place (removing it would race with the next locker).
class FileLock {
 public:
  // Blocks until the lock is held; io_error when the lock file cannot be opened.
  static Result<FileLock> acquire(const std::string& lock_path);
  FileLock(FileLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  FileLock& operator=(FileLock&& other) noexcept;
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  ~FileLock();

 private:
  explicit FileLock(int fd) : fd_(fd) {}
  int fd_ = -1;
};

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
