// SPDX-License-Identifier: MIT
#include "sealed_file.h"

#include <cstring>

#include "binary_io.h"
#include "modrt/file_io.h"

namespace modrt::binary {
namespace {

constexpr std::size_t kFieldsOffset = 16, kBodyBytesOffset = 48, kBodyCrcOffset = 56, kHeaderCrcOffset = 60;
static_assert(kFieldsOffset + 4 * kSealedHeaderFields == kBodyBytesOffset);
static_assert(kHeaderCrcOffset + 4 == kSealedHeaderBytes);

}  // namespace

Result<std::vector<std::byte>> seal(const SealedFormat& format, const SealedFields& fields,
                                    std::span<const std::byte> body) {
  const std::uint64_t file_bytes = kSealedHeaderBytes + std::uint64_t(body.size());
  if (file_bytes > format.max_file_bytes)
    return Status::error(ErrorCode::resource_limit,
                         std::string(format.writer) + ": the file would be " + std::to_string(file_bytes) +
                             " bytes, more than the limit of " + std::to_string(format.max_file_bytes));
  Writer out;
  out.bytes.reserve(std::size_t(file_bytes));
  for (std::size_t i = 0; i < 8; ++i) out.bytes.push_back(std::byte(format.magic[i]));
  out.u32(format.version);
  out.u32(std::uint32_t(kSealedHeaderBytes));
  for (std::uint32_t f : fields) out.u32(f);
  out.u64(body.size());
  out.u32(crc32(body));
  out.u32(crc32(std::span<const std::byte>(out.bytes).first(kHeaderCrcOffset)));
  out.bytes.insert(out.bytes.end(), body.begin(), body.end());
  return std::move(out.bytes);
}

Result<std::span<const std::byte>> open_sealed(const SealedFormat& format, std::span<const std::byte> bytes,
                                               const std::string& what, SealedFields& fields) {
  auto error = [&](ErrorCode code, const std::string& problem) {
    return Status::error(code, what + ": " + problem);
  };
  if (bytes.size() < kSealedHeaderBytes)
    return error(ErrorCode::format_error, "file is " + std::to_string(bytes.size()) +
                                              " bytes, shorter than the " +
                                              std::to_string(kSealedHeaderBytes) + "-byte header");
  if (std::memcmp(bytes.data(), format.magic, 8) != 0)
    return error(ErrorCode::format_error, std::string("not a ") + format.kind + " (bad magic; expected \"" +
                                              std::string(format.magic, 8) + "\")");
  if (const std::uint32_t version = header_u32(bytes, 8); version != format.version)
    return error(ErrorCode::version_mismatch, "format version " + std::to_string(version) +
                                                  ", this build reads " + std::to_string(format.version) +
                                                  (format.version_note ? format.version_note(version) : "") +
                                                  ": " + format.rebuild);
  if (header_u32(bytes, 12) != kSealedHeaderBytes)
    return error(ErrorCode::format_error, "header size " + std::to_string(header_u32(bytes, 12)) +
                                              " is not " + std::to_string(kSealedHeaderBytes));
  if (crc32(bytes.first(kHeaderCrcOffset)) != header_u32(bytes, kHeaderCrcOffset))
    return error(ErrorCode::checksum_mismatch, "header checksum mismatch");
  for (std::size_t i = 0; i < kSealedHeaderFields; ++i) {
    const std::size_t at = kFieldsOffset + 4 * i;
    fields[i] = header_u32(bytes, at);
    // One encoding per file: a reserved field must be what the writer writes.
    if (i >= format.fields && fields[i] != 0)
      return error(ErrorCode::format_error, "header field at offset " + std::to_string(at) +
                                                " (reserved) is " + std::to_string(fields[i]) + ", not 0");
  }
  const std::uint64_t body_bytes = std::uint64_t(header_u32(bytes, kBodyBytesOffset)) |
                                   (std::uint64_t(header_u32(bytes, kBodyBytesOffset + 4)) << 32);
  if (body_bytes != bytes.size() - kSealedHeaderBytes)
    return error(ErrorCode::format_error,
                 "header says the body is " + std::to_string(body_bytes) + " bytes, the file holds " +
                     std::to_string(bytes.size() - kSealedHeaderBytes) + " (truncated?)");
  const std::span<const std::byte> body = bytes.subspan(kSealedHeaderBytes);
  if (crc32(body) != header_u32(bytes, kBodyCrcOffset))
    return error(ErrorCode::checksum_mismatch, "body checksum mismatch");
  return body;
}

}  // namespace modrt::binary
