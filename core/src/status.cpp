// SPDX-License-Identifier: MIT
#include "modrt/status.h"

namespace modrt {

const char* error_code_name(ErrorCode code) {
  switch (code) {
    case ErrorCode::ok: return "ok";
    case ErrorCode::invalid_argument: return "invalid_argument";
    case ErrorCode::io_error: return "io_error";
    case ErrorCode::format_error: return "format_error";
    case ErrorCode::version_mismatch: return "version_mismatch";
    case ErrorCode::checksum_mismatch: return "checksum_mismatch";
    case ErrorCode::non_finite: return "non_finite";
    case ErrorCode::resource_limit: return "resource_limit";
    case ErrorCode::internal_error: return "internal_error";
  }
  return "unknown_error";
}

std::string Status::to_string() const {
  if (ok()) return "ok";
  return std::string(error_code_name(code_)) + ": " + message_;
}

}  // namespace modrt
