// SPDX-License-Identifier: MIT
#include "modrt/precompute/matrix_file.h"

#include <bit>
#include <cmath>
#include <cstring>

#include "modrt/file_io.h"

namespace modrt::precompute {
namespace {

static_assert(std::endian::native == std::endian::little, "matrix files are little-endian");
constexpr char kMagic[8] = {'M', 'O', 'D', 'R', 'T', 'M', 'X', 'F'};

void put(std::vector<std::byte>& out, const void* data, std::size_t bytes) {
  const auto* p = static_cast<const std::byte*>(data);
  out.insert(out.end(), p, p + bytes);
}
void put_u32(std::vector<std::byte>& out, std::uint32_t v) { put(out, &v, 4); }

// Bounds-checked reads over the file's bytes; `ok` turns false at the first overrun.
struct Reader {
  std::span<const std::byte> bytes;
  std::size_t at = 0;
  bool ok = true;
  bool take(void* out, std::size_t n) {
    if (!ok || n > bytes.size() - at) return ok = false;
    std::memcpy(out, bytes.data() + at, n);
    at += n;
    return true;
  }
  std::uint32_t u32() {
    std::uint32_t v = 0;
    take(&v, 4);
    return v;
  }
  std::string text() {
    const std::uint32_t n = u32();
    if (!ok || n > bytes.size() - at) {
      ok = false;
      return {};
    }
    std::string s(reinterpret_cast<const char*>(bytes.data() + at), n);
    at += n;
    return s;
  }
};

}  // namespace

Status save_matrix_file(const std::string& path, const std::string& tag,
                        std::span<const MatrixRef> matrices) {
  std::uint64_t total = 8 + 4 + 4 + tag.size() + 4 + 4;
  for (const MatrixRef& m : matrices) total += 12 + m.name.size() + 4ull * m.matrix->data.size();
  if (total > kMaxMatrixFileBytes)
    return Status::error(ErrorCode::resource_limit, path + ": the matrix file would be " +
                                                        std::to_string(total) + " bytes, over the limit of " +
                                                        std::to_string(kMaxMatrixFileBytes));
  std::vector<std::byte> out;
  out.reserve(std::size_t(total));
  put(out, kMagic, 8);
  put_u32(out, kMatrixFileVersion);
  put_u32(out, std::uint32_t(tag.size()));
  put(out, tag.data(), tag.size());
  put_u32(out, std::uint32_t(matrices.size()));
  for (const MatrixRef& m : matrices) {
    put_u32(out, std::uint32_t(m.name.size()));
    put(out, m.name.data(), m.name.size());
    put_u32(out, m.matrix->rows);
    put_u32(out, m.matrix->cols);
    put(out, m.matrix->data.data(), 4 * m.matrix->data.size());
  }
  put_u32(out, crc32(out));
  return write_file_atomic(path, out);
}

Result<std::vector<NamedMatrix>> load_matrix_file(const std::string& path, const std::string& expected_tag) {
  Result<std::vector<std::byte>> file = read_file(path, kMaxMatrixFileBytes);
  if (!file.ok()) return file.status();
  const std::span<const std::byte> bytes = file.value();
  auto bad = [&](ErrorCode code, const std::string& why) { return Status::error(code, path + ": " + why); };
  if (bytes.size() < 8 + 4 + 4 || std::memcmp(bytes.data(), kMagic, 8) != 0)
    return bad(ErrorCode::format_error, "not a modrt matrix file (bad magic or shorter than its header)");
  Reader in{bytes.first(bytes.size() - 4), 8};
  if (const std::uint32_t version = in.u32(); version != kMatrixFileVersion)
    return bad(ErrorCode::version_mismatch, "matrix file version " + std::to_string(version) + ", expected " +
                                                std::to_string(kMatrixFileVersion) + ": rebuild it");
  std::uint32_t stored_crc = 0;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  if (crc32(bytes.first(bytes.size() - 4)) != stored_crc)
    return bad(ErrorCode::checksum_mismatch, "checksum mismatch (a truncated or damaged file)");
  const std::string tag = in.text();
  if (!in.ok) return bad(ErrorCode::format_error, "truncated tag");
  if (tag != expected_tag)
    return bad(ErrorCode::format_error, "holds '" + tag + "', expected '" + expected_tag + "'");
  const std::uint32_t count = in.u32();
  std::vector<NamedMatrix> out;
  for (std::uint32_t i = 0; in.ok && i < count; ++i) {
    NamedMatrix m;
    m.name = in.text();
    const std::uint32_t rows = in.u32(), cols = in.u32();
    const std::uint64_t values = std::uint64_t(rows) * cols;
    if (!in.ok || values > (in.bytes.size() - in.at) / 4)
      return bad(ErrorCode::format_error, "matrix " + std::to_string(i) + " '" + m.name +
                                              "': truncated or sizes inconsistent with the file");
    m.matrix = Matrix(rows, cols);
    in.take(m.matrix.data.data(), 4 * std::size_t(values));
    for (float v : m.matrix.data)
      if (!std::isfinite(v)) return bad(ErrorCode::non_finite, "matrix '" + m.name + "' holds NaN or Inf");
    out.push_back(std::move(m));
  }
  if (!in.ok) return bad(ErrorCode::format_error, "truncated matrix table");
  if (in.at != in.bytes.size()) return bad(ErrorCode::format_error, "trailing bytes after the last matrix");
  return out;
}

}  // namespace modrt::precompute
