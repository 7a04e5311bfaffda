// SPDX-License-Identifier: MIT
// modrt — error reporting shared by every layer.
//
// The runtime never throws across its API: functions that can fail on untrusted input
// (files, caller-provided light signals, settings) return a Status, or a Result<T> that
// carries either a value or a Status. Messages name the file, field and problem so that
// a user can act on them without a debugger.
#pragma once

#include <optional>
#include <string>
#include <utility>

namespace modrt {

enum class ErrorCode {
  ok = 0,
  invalid_argument,   // a caller-provided value is out of range (res 0, zero rays, NaN ld)
  io_error,           // a file could not be opened, read, written or renamed
  format_error,       // a file is malformed: bad magic, truncated, sizes inconsistent
  version_mismatch,   // a file was written by another format version: re-bake
  checksum_mismatch,  // a section's bytes do not match its stored checksum
  non_finite,         // NaN or Inf where only finite values are allowed
  resource_limit,     // a request would exceed a configured memory or size budget
  internal_error,     // a library below us failed (Embree device, SVD did not converge)
};

const char* error_code_name(ErrorCode code);

class Status {
 public:
  Status() = default;
  static Status success() { return Status(); }
  static Status error(ErrorCode code, std::string message) {
    Status s;
    s.code_ = code;
    s.message_ = std::move(message);
    return s;
  }

  bool ok() const { return code_ == ErrorCode::ok; }
  explicit operator bool() const { return ok(); }
  ErrorCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // "format_error: dict.modrt: section 3 (Ub, shape 1): checksum mismatch"
  std::string to_string() const;

 private:
  ErrorCode code_ = ErrorCode::ok;
  std::string message_;
};

// A value or the Status explaining why there is none.
template <class T>
class Result {
 public:
  Result(T value) : value_(std::move(value)) {}          // NOLINT: implicit by design
  Result(Status status) : status_(std::move(status)) {}  // NOLINT: implicit by design

  bool ok() const { return value_.has_value(); }
  explicit operator bool() const { return ok(); }
  const Status& status() const { return status_; }
  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }

 private:
  std::optional<T> value_;
  Status status_;
};

}  // namespace modrt
