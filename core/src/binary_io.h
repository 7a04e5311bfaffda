// SPDX-License-Identifier: MIT
// modrt — the little-endian writer and the bounds-checked reader of the binary files that
// hold a Level (level_io.cpp) and DRT operators (drt_io.cpp). Internal to core.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/status.h"

namespace modrt::binary {

inline constexpr std::uint32_t kMaxMatrixDimension = 1u << 24;

// --- writing: little-endian, independent of the host byte order ---

class Writer {
 public:
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes.push_back(std::byte((v >> (8 * i)) & 0xFFu));
  }
  void i32(std::int32_t v) { u32(std::uint32_t(v)); }
  void u64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) bytes.push_back(std::byte((v >> (8 * i)) & 0xFFu));
  }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  void matrix(const Matrix& m) {
    u32(m.rows);
    u32(m.cols);
    for (float v : m.data) f32(v);
  }
  std::vector<std::byte> bytes;
};

// --- reading: every read is bounds-checked; the first failure sticks and names the field ---

class Reader {
 public:
  Reader(std::span<const std::byte> bytes, const std::string& what) : bytes_(bytes), what_(what) {}

  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }
  std::size_t left() const { return bytes_.size() - at_; }

  void fail(const std::string& field, const std::string& problem) {
    if (status_.ok()) status_ = Status::error(ErrorCode::format_error, what_ + ": " + field + ": " + problem);
  }
  // Whether `count` items of `item_bytes` each still fit; a failure names the field.
  bool fits(const std::string& field, std::uint64_t count, std::uint64_t item_bytes) {
    if (!ok()) return false;
    if (item_bytes != 0 && count > left() / item_bytes) {
      fail(field, "count " + std::to_string(count) + " needs more bytes than the " + std::to_string(left()) +
                      " left in the file (truncated or corrupt)");
      return false;
    }
    return true;
  }

  std::uint32_t u32(const std::string& field) {
    if (!fits(field, 1, 4)) return 0;
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v |= std::to_integer<std::uint32_t>(bytes_[at_ + i]) << (8 * i);
    at_ += 4;
    return v;
  }
  std::int32_t i32(const std::string& field) { return std::int32_t(u32(field)); }
  // The next n bytes, for a decoder that reads a run of values at once (empty, and the reader
  // failed naming the field, when fewer are left).
  std::span<const std::byte> take(const std::string& field, std::size_t n) {
    if (!fits(field, n, 1)) return {};
    const std::span<const std::byte> out = bytes_.subspan(at_, n);
    at_ += n;
    return out;
  }
  std::uint64_t u64(const std::string& field) {
    const std::uint64_t lo = u32(field), hi = u32(field);
    return lo | (hi << 32);
  }
  float f32(const std::string& field) { return std::bit_cast<float>(u32(field)); }
  double f64(const std::string& field) { return std::bit_cast<double>(u64(field)); }

  Matrix matrix(const std::string& field) {
    const std::uint32_t rows = u32(field + " rows"), cols = u32(field + " cols");
    if (!ok()) return {};
    if (rows > kMaxMatrixDimension || cols > kMaxMatrixDimension) {
      fail(field, "dimensions " + std::to_string(rows) + "x" + std::to_string(cols) + " are out of range");
      return {};
    }
    if ((rows == 0) != (cols == 0)) {
      fail(field, "dimensions " + std::to_string(rows) + "x" + std::to_string(cols) + " are inconsistent");
      return {};
    }
    if (!fits(field + " values", std::uint64_t(rows) * cols, 4)) return {};
    Matrix m(rows, cols);
    for (float& v : m.data) v = f32(field);
    return m;
  }

 private:
  std::span<const std::byte> bytes_;
  std::string what_;
  std::size_t at_ = 0;
  Status status_;
};

// The u32 at byte `at` of a header already known to be long enough.
inline std::uint32_t header_u32(std::span<const std::byte> b, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v |= std::to_integer<std::uint32_t>(b[at + i]) << (8 * i);
  return v;
}

}  // namespace modrt::binary
