// SPDX-License-Identifier: MIT
#include "modrt/file_io.h"

#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <limits>
#include <system_error>

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

namespace modrt {
namespace {

std::string os_error(int err) { return std::strerror(err); }

Status io_error(const std::string& path, const std::string& what, int err) {
  return Status::error(ErrorCode::io_error, path + ": " + what + ": " + os_error(err));
}

// Closes a file descriptor on scope exit unless released.
class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }
  // Closes now and reports the error of close(2) (0 on success).
  int close_now() {
    const int fd = fd_;
    fd_ = -1;
    return (fd >= 0 && ::close(fd) != 0) ? errno : 0;
  }

 private:
  int fd_;
};

Status write_all(int fd, std::span<const std::byte> bytes, const std::string& tmp) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const std::size_t chunk = std::min<std::size_t>(bytes.size() - done, std::size_t(1) << 30);
    const ssize_t n = ::write(fd, bytes.data() + done, chunk);
    if (n < 0) {
      if (errno == EINTR) continue;
      return io_error(tmp, "write failed", errno);
    }
    if (n == 0) return Status::error(ErrorCode::io_error, tmp + ": write failed: no progress");
    done += std::size_t(n);
  }
  return Status::success();
}

// Reads until `limit` bytes or end of file; appends to `out`.
Status read_up_to(int fd, std::uint64_t limit, std::vector<std::byte>& out, const std::string& path) {
  std::array<std::byte, 1 << 16> buffer;
  while (out.size() < limit) {
    const std::uint64_t want = std::min<std::uint64_t>(buffer.size(), limit - out.size());
    const ssize_t n = ::read(fd, buffer.data(), std::size_t(want));
    if (n < 0) {
      if (errno == EINTR) continue;
      return io_error(path, "read failed", errno);
    }
    if (n == 0) break;
    out.insert(out.end(), buffer.begin(), buffer.begin() + n);
  }
  return Status::success();
}

Result<int> open_for_reading(const std::string& path, struct stat& st) {
  int fd;
  do {
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) return io_error(path, "cannot open for reading", errno);
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    return io_error(path, "cannot stat", err);
  }
  if (Result<std::uint64_t> size = regular_file_size(fd, path); !size.ok()) {
    ::close(fd);
    return size.status();
  }
  return fd;
}

// path + ".tmp.<pid>.<counter>": unique per process and call; the pid lets
// remove_stale_temporaries tell a dead writer's leftovers from a save in progress.
std::string temporary_name(const std::string& path) {
  static std::atomic<std::uint64_t> counter{0};
  return path + ".tmp." + std::to_string(long(::getpid())) + "." + std::to_string(counter++);
}

// The writer's pid of a temporary named "<file>.tmp.<pid>.<n>" (file = the part before), or
// 0 when `name` is not one.
long temporary_owner(const std::string& name, std::string& file) {
  const std::size_t dot = name.rfind('.');
  if (dot == std::string::npos || dot + 1 == name.size()) return 0;
  const std::size_t pid_dot = dot == 0 ? std::string::npos : name.rfind('.', dot - 1);
  if (pid_dot == std::string::npos || pid_dot + 1 == dot || pid_dot < 4) return 0;
  if (name.compare(pid_dot - 4, 4, ".tmp") != 0) return 0;
  auto digits = [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i)
      if (name[i] < '0' || name[i] > '9') return false;
    return e > b && e - b <= 18;
  };
  if (!digits(dot + 1, name.size()) || !digits(pid_dot + 1, dot)) return 0;
  file = name.substr(0, pid_dot - 4);
  return std::stol(name.substr(pid_dot + 1, dot - pid_dot - 1));
}

bool process_alive(long pid) {
  if (pid <= 0 || pid > long(std::numeric_limits<pid_t>::max())) return false;
  return ::kill(pid_t(pid), 0) == 0 || errno != ESRCH;  // EPERM: alive, another user's
}

// Whether files can be created in `dir` (created when missing). Messages name the
// directory; `prefix` (the file to be written, or empty) goes in front.
Status check_directory_writable(const std::string& prefix, const std::filesystem::path& dir) {
  const std::string lead = prefix.empty() ? std::string() : prefix + ": ";
  std::error_code ec;
  const std::filesystem::path d = dir.empty() ? std::filesystem::path(".") : dir;
  if (std::filesystem::exists(d, ec) && !std::filesystem::is_directory(d, ec))
    return Status::error(ErrorCode::io_error, lead + d.string() + " is not a directory");
  std::filesystem::create_directories(d, ec);
  if (ec)
    return Status::error(ErrorCode::io_error,
                         lead + "cannot create directory " + d.string() + ": " + ec.message());
  const std::string probe = temporary_name((d / ".modrt-write-probe").string());
  int fd;
  do {
    fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    const int err = errno;
    return Status::error(ErrorCode::io_error,
                         lead + "cannot create files in directory " + d.string() + ": " + os_error(err));
  }
  ::close(fd);
  ::unlink(probe.c_str());
  return Status::success();
}

// Slicing-by-8 (Intel's, as zlib's crc32 uses a variant of it): entries[k][b] is the CRC of
// byte b followed by k zero bytes, so that eight bytes take eight lookups and no byte-serial
// dependency; the bytes are read one by one, independent of the host byte order.
struct CrcTable {
  std::array<std::array<std::uint32_t, 256>, 8> entries{};
  CrcTable() {
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
      entries[0][i] = c;
    }
    for (std::size_t k = 1; k < 8; ++k)
      for (std::size_t i = 0; i < 256; ++i)
        entries[k][i] = (entries[k - 1][i] >> 8) ^ entries[0][entries[k - 1][i] & 0xFFu];
  }
};

}  // namespace

Status write_file_atomic(const std::string& path, std::span<const std::byte> bytes) {
  if (path.empty()) return Status::error(ErrorCode::io_error, "write_file_atomic: empty path");
  const std::filesystem::path target(path);
  if (target.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(target.parent_path(), ec);
    if (ec)
      return Status::error(ErrorCode::io_error, path + ": cannot create directory " +
                                                    target.parent_path().string() + ": " + ec.message());
  }

  remove_stale_temporaries(target.has_parent_path() ? target.parent_path().string() : std::string("."),
                           target.filename().string());
  const std::string tmp = temporary_name(path);
  int raw;
  do {
    raw = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_TRUNC | O_CLOEXEC, 0644);
  } while (raw < 0 && errno == EINTR);
  if (raw < 0) return io_error(tmp, "cannot create temporary file", errno);
  Fd fd(raw);

  auto fail = [&](Status s) {
    fd.close_now();
    ::unlink(tmp.c_str());
    return s;
  };
  if (Status s = write_all(fd.get(), bytes, tmp); !s.ok()) return fail(std::move(s));
  if (::fsync(fd.get()) != 0) return fail(io_error(tmp, "fsync failed", errno));
  if (const int err = fd.close_now(); err != 0) return fail(io_error(tmp, "close failed", err));
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return io_error(path, "cannot rename " + tmp + " over it", err);
  }
  // Make the rename itself durable; failure here does not undo a completed write.
  const std::string dir = target.has_parent_path() ? target.parent_path().string() : std::string(".");
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    (void)::fsync(dfd);
    ::close(dfd);
  }
  return Status::success();
}

Result<std::uint64_t> regular_file_size(int fd, const std::string& path) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return io_error(path, "cannot stat", errno);
  if (S_ISREG(st.st_mode)) return std::uint64_t(st.st_size);
  const char* kind = S_ISDIR(st.st_mode)    ? "a directory"
                     : S_ISFIFO(st.st_mode) ? "a FIFO"
                     : S_ISCHR(st.st_mode)  ? "a character device"
                     : S_ISBLK(st.st_mode)  ? "a block device"
                     : S_ISSOCK(st.st_mode) ? "a socket"
                                            : "a special file";
  return Status::error(ErrorCode::io_error, path + ": cannot read: " + kind + ", not a regular file");
}

Status check_writable_file(const std::string& path) {
  if (path.empty()) return Status::error(ErrorCode::io_error, "output path is empty");
  const std::filesystem::path target(path);
  std::error_code ec;
  if (std::filesystem::is_directory(target, ec))
    return Status::error(ErrorCode::io_error, path + ": cannot write: is a directory");
  return check_directory_writable(path, target.parent_path());
}

Status check_writable_directory(const std::string& dir) {
  if (dir.empty()) return Status::error(ErrorCode::io_error, "output directory is empty");
  return check_directory_writable({}, std::filesystem::path(dir));
}

std::size_t remove_stale_temporaries(const std::string& dir, const std::string& file_name) {
  std::error_code ec;
  std::filesystem::directory_iterator it(dir.empty() ? std::string(".") : dir, ec), end;
  std::size_t removed = 0;
  for (; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::string file;
    const long pid = temporary_owner(name, file);
    if (pid == 0 || (!file_name.empty() && file != file_name) || process_alive(pid)) continue;
    std::error_code type_ec;
    if (!it->is_regular_file(type_ec)) continue;
    if (::unlink(it->path().c_str()) == 0) ++removed;
  }
  return removed;
}

Result<FileLock> FileLock::acquire(const std::string& lock_path) {
  int fd;
  do {
    fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) return io_error(lock_path, "cannot open lock file", errno);
  int rc;
  do {
    rc = ::flock(fd, LOCK_EX);
  } while (rc != 0 && errno == EINTR);
  if (rc != 0) {
    const int err = errno;
    ::close(fd);
    return io_error(lock_path, "cannot lock", err);
  }
  return FileLock(fd);
}

FileLock& FileLock::operator=(FileLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

FileLock::~FileLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the last descriptor of the description releases the lock
}

Result<std::vector<std::byte>> read_file(const std::string& path, std::uint64_t max_bytes) {
  struct stat st {};
  Result<int> opened = open_for_reading(path, st);
  if (!opened.ok()) return opened.status();
  Fd fd(opened.value());
  std::vector<std::byte> out;
  const std::uint64_t size = std::uint64_t(st.st_size);  // a regular file (open_for_reading)
  if (size > max_bytes)
    return Status::error(ErrorCode::resource_limit, path + ": file is " + std::to_string(size) +
                                                        " bytes, larger than the limit of " +
                                                        std::to_string(max_bytes) + " bytes");
  out.reserve(std::size_t(size));
  // Read one byte past the limit to notice files that grew since the stat.
  const std::uint64_t limit = max_bytes == UINT64_MAX ? max_bytes : max_bytes + 1;
  if (Status s = read_up_to(fd.get(), limit, out, path); !s.ok()) return s;
  if (out.size() > max_bytes)
    return Status::error(ErrorCode::resource_limit,
                         path + ": file is more than " + std::to_string(max_bytes) +
                             " bytes, larger than the limit of " + std::to_string(max_bytes) + " bytes");
  return out;
}

Result<std::vector<std::byte>> read_file_prefix(const std::string& path, std::uint64_t count) {
  struct stat st {};
  Result<int> opened = open_for_reading(path, st);
  if (!opened.ok()) return opened.status();
  Fd fd(opened.value());
  std::vector<std::byte> out;
  if (Status s = read_up_to(fd.get(), count, out, path); !s.ok()) return s;
  return out;
}

std::uint32_t crc32(std::span<const std::byte> bytes, std::uint32_t seed) {
  static const CrcTable table;
  const auto& t = table.entries;
  auto word = [](const std::byte* p) {
    return std::to_integer<std::uint32_t>(p[0]) | (std::to_integer<std::uint32_t>(p[1]) << 8) |
           (std::to_integer<std::uint32_t>(p[2]) << 16) | (std::to_integer<std::uint32_t>(p[3]) << 24);
  };
  std::uint32_t c = seed ^ 0xFFFFFFFFu;
  const std::byte* p = bytes.data();
  std::size_t n = bytes.size();
  for (; n >= 8; p += 8, n -= 8) {
    const std::uint32_t lo = c ^ word(p), hi = word(p + 4);
    c = t[7][lo & 0xFFu] ^ t[6][(lo >> 8) & 0xFFu] ^ t[5][(lo >> 16) & 0xFFu] ^ t[4][lo >> 24] ^
        t[3][hi & 0xFFu] ^ t[2][(hi >> 8) & 0xFFu] ^ t[1][(hi >> 16) & 0xFFu] ^ t[0][hi >> 24];
  }
  for (; n > 0; ++p, --n) c = t[0][(c ^ std::to_integer<std::uint32_t>(*p)) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

}  // namespace modrt
