// SPDX-License-Identifier: MIT
// The DRT operator file (drt_io.h).
#include "modrt/drt_io.h"

#include <cmath>
#include <cstring>

#include "binary_io.h"
#include "modrt/file_io.h"

namespace modrt {
namespace {

using binary::header_u32;
using binary::Reader;
using binary::Writer;

constexpr std::size_t kHeaderCrcOffset = 60;

// Every stored operator of an object, in file order: the one list that both the writer and
// the reader walk, so the two cannot disagree.
template <class Object, class Visitor>
void visit_fields(Object& o, Visitor&& v) {
  v("dUb_sample", o.dUb_sample);
  v("dUb_block", o.dUb_block);
  v("dUb", o.dUb);
  v("Td_c", o.Td_c);
  v("dUc_sample", o.dUc_sample);
  v("dUc", o.dUc);
  v("Cb_blocks", o.Cb_blocks);
  v("Uc", o.Uc);
  v("Vc", o.Vc);
  v("Cb_sigma", o.Cb_sigma);
  v("Cb_truncation_error", o.Cb_truncation_error);
  v("Cc_objects", o.Cc_objects);
  v("Cc", o.Cc);
  v("dUb_vec_sample", o.dUb_vec_sample);
  v("dUb_vec_block", o.dUb_vec_block);
  v("dUb_vec", o.dUb_vec);
  v("dUc_vec_sample", o.dUc_vec_sample);
  v("dUc_vec", o.dUc_vec);
  v("Udyn_probe", o.Udyn_probe);
  v("Udyn_block", o.Udyn_block);
  v("Udyn", o.Udyn);
  v("Udyn_c_probe", o.Udyn_c_probe);
  v("Udyn_c", o.Udyn_c);
  v("Cb_vec_blocks", o.Cb_vec_blocks);
  v("Uc_vec", o.Uc_vec);
  v("Vc_vec", o.Vc_vec);
  v("Cb_vec_truncation_error", o.Cb_vec_truncation_error);
  v("Cc_vec_objects", o.Cc_vec_objects);
  v("Cc_vec", o.Cc_vec);
  v("texel_position", o.texel_position);  // since version 2
  v("texel_normal", o.texel_normal);
}

bool finite(float v) { return std::isfinite(v); }
bool finite(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}
bool finite(const Matrix& m) { return finite(m.data); }
bool finite(const std::vector<std::uint32_t>&) { return true; }

struct FieldWriter {
  Writer& out;
  void operator()(const char*, const std::vector<std::uint32_t>& v) const {
    out.u32(std::uint32_t(v.size()));
    for (std::uint32_t x : v) out.u32(x);
  }
  void operator()(const char*, const std::vector<float>& v) const {
    out.u32(std::uint32_t(v.size()));
    for (float x : v) out.f32(x);
  }
  void operator()(const char*, const Matrix& m) const { out.matrix(m); }
  void operator()(const char*, float v) const { out.f32(v); }
};

struct FieldReader {
  Reader& in;
  const std::string& object;
  void operator()(const char* name, std::vector<std::uint32_t>& v) const {
    const std::string field = object + " " + name;
    const std::uint32_t n = in.u32(field + " count");
    if (!in.fits(field, n, 4)) return;
    v.resize(n);
    for (std::uint32_t& x : v) x = in.u32(field);
  }
  void operator()(const char* name, std::vector<float>& v) const {
    const std::string field = object + " " + name;
    const std::uint32_t n = in.u32(field + " count");
    if (!in.fits(field, n, 4)) return;
    v.resize(n);
    for (float& x : v) x = in.f32(field);
  }
  void operator()(const char* name, Matrix& m) const { m = in.matrix(object + " " + name); }
  void operator()(const char* name, float& v) const { v = in.f32(object + " " + name); }
};

// The first field of `drt` holding NaN or Inf, as "object i field", or "".
std::string first_non_finite(const DrtOperators& drt) {
  for (std::size_t i = 0; i < drt.objects.size(); ++i) {
    std::string bad;
    visit_fields(drt.objects[i], [&](const char* name, const auto& field) {
      if (bad.empty() && !finite(field)) bad = "object " + std::to_string(i) + " " + name;
    });
    if (!bad.empty()) return bad;
  }
  return {};
}

}  // namespace

Result<std::vector<std::byte>> serialize_drt(const DrtOperators& drt) {
  if (const std::string bad = first_non_finite(drt); !bad.empty())
    return Status::error(ErrorCode::non_finite, "DRT operators: " + bad + " has NaN or Inf");
  Writer body;
  for (const DrtObjectOperators& o : drt.objects) {
    body.u32(o.texel_count);
    body.u32(o.face_count);
    visit_fields(o, FieldWriter{body});
  }
  const std::uint64_t file_bytes = kDrtFileHeaderBytes + body.bytes.size();
  if (file_bytes > kMaxDrtFileBytes)
    return Status::error(ErrorCode::resource_limit,
                         "DRT operators: the file would be " + std::to_string(file_bytes) +
                             " bytes, more than the limit of " + std::to_string(kMaxDrtFileBytes));
  Writer out;
  out.bytes.reserve(file_bytes);
  for (char c : kDrtFileMagic) out.bytes.push_back(std::byte(c));
  out.u32(kDrtFileVersion);
  out.u32(std::uint32_t(kDrtFileHeaderBytes));
  out.u32(drt.kb);
  out.u32(std::uint32_t(drt.objects.size()));
  out.u32(drt.probes_per_block);
  out.u32(drt.level_blocks);
  out.u32(drt.level_samples);
  for (int i = 0; i < 3; ++i) out.u32(0);
  out.u64(body.bytes.size());
  out.u32(crc32(body.bytes));
  out.u32(crc32(std::span<const std::byte>(out.bytes).first(kHeaderCrcOffset)));
  out.bytes.insert(out.bytes.end(), body.bytes.begin(), body.bytes.end());
  return std::move(out.bytes);
}

Status save_drt(const std::string& path, const DrtOperators& drt) {
  Result<std::vector<std::byte>> bytes = serialize_drt(drt);
  if (!bytes.ok()) return Status::error(bytes.status().code(), path + ": " + bytes.status().message());
  return write_file_atomic(path, bytes.value());
}

Result<DrtOperators> parse_drt(std::span<const std::byte> bytes, const std::string& what) {
  auto error = [&](ErrorCode code, const std::string& problem) {
    return Status::error(code, what + ": " + problem);
  };
  if (bytes.size() < kDrtFileHeaderBytes)
    return error(ErrorCode::format_error, "file is " + std::to_string(bytes.size()) +
                                              " bytes, shorter than the " +
                                              std::to_string(kDrtFileHeaderBytes) + "-byte header");
  if (std::memcmp(bytes.data(), kDrtFileMagic, sizeof kDrtFileMagic) != 0)
    return error(ErrorCode::format_error, "not a modrt DRT operator file (bad magic; expected \"MODRTDRT\")");
  if (const std::uint32_t version = header_u32(bytes, 8); version != kDrtFileVersion)
    return error(ErrorCode::version_mismatch,
                 "format version " + std::to_string(version) + ", this build reads " +
                     std::to_string(kDrtFileVersion) +
                     ": rebuild the clutter operators (modrt-demo --save-clutter)");
  if (header_u32(bytes, 12) != kDrtFileHeaderBytes)
    return error(ErrorCode::format_error, "header size " + std::to_string(header_u32(bytes, 12)) +
                                              " is not " + std::to_string(kDrtFileHeaderBytes));
  if (crc32(bytes.first(kHeaderCrcOffset)) != header_u32(bytes, kHeaderCrcOffset))
    return error(ErrorCode::checksum_mismatch, "header checksum mismatch");
  for (std::size_t at = 36; at < 48; at += 4)
    if (header_u32(bytes, at) != 0)
      return error(ErrorCode::format_error, "header field at offset " + std::to_string(at) +
                                                " (reserved) is " + std::to_string(header_u32(bytes, at)) +
                                                ", not 0");
  const std::uint64_t body_bytes =
      std::uint64_t(header_u32(bytes, 48)) | (std::uint64_t(header_u32(bytes, 52)) << 32);
  if (body_bytes != bytes.size() - kDrtFileHeaderBytes)
    return error(ErrorCode::format_error,
                 "header says the body is " + std::to_string(body_bytes) + " bytes, the file holds " +
                     std::to_string(bytes.size() - kDrtFileHeaderBytes) + " (truncated?)");
  const std::span<const std::byte> body = bytes.subspan(kDrtFileHeaderBytes);
  if (crc32(body) != header_u32(bytes, 56))
    return error(ErrorCode::checksum_mismatch, "body checksum mismatch");

  DrtOperators drt;
  drt.kb = header_u32(bytes, 16);
  const std::uint32_t objects = header_u32(bytes, 20);
  drt.probes_per_block = header_u32(bytes, 24);
  drt.level_blocks = header_u32(bytes, 28);
  drt.level_samples = header_u32(bytes, 32);
  Reader in(body, what);
  // A lower bound on an object's bytes: two counts and at least 4 bytes per field (29).
  if (in.fits("objects", objects, 8 + 4 * 29)) drt.objects.resize(objects);
  for (std::uint32_t i = 0; i < objects && in.ok(); ++i) {
    DrtObjectOperators& o = drt.objects[i];
    const std::string name = "object " + std::to_string(i);
    o.texel_count = in.u32(name + " texel_count");
    o.face_count = in.u32(name + " face_count");
    visit_fields(o, FieldReader{in, name});
  }
  if (!in.ok()) return in.status();
  if (in.left() != 0)
    return error(ErrorCode::format_error,
                 std::to_string(in.left()) + " trailing bytes after the last object");
  if (const std::string bad = first_non_finite(drt); !bad.empty())
    return error(ErrorCode::non_finite, bad + " has NaN or Inf");
  return drt;
}

Result<DrtOperators> load_drt(const std::string& path) {
  Result<std::vector<std::byte>> bytes = read_file(path, kMaxDrtFileBytes);
  if (!bytes.ok()) return bytes.status();
  return parse_drt(bytes.value(), path);
}

}  // namespace modrt
