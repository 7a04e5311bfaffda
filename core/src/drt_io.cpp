// SPDX-License-Identifier: MIT
// The DRT operator file (drt_io.h).
#include "modrt/drt_io.h"

#include <cmath>
#include <cstring>

#include "binary_io.h"
#include "modrt/file_io.h"
#include "sealed_file.h"

namespace modrt {
namespace {

using binary::Reader;
using binary::Writer;

static_assert(kDrtFileHeaderBytes == binary::kSealedHeaderBytes);

// Fields: kb, objects, probes per block, level blocks, level samples; offsets 36..44 reserved.
binary::SealedFormat drt_file_format() {
  binary::SealedFormat f;
  f.magic = kDrtFileMagic;
  f.kind = "modrt DRT operator file";
  f.writer = "DRT operators";
  f.version = kDrtFileVersion;
  f.fields = 5;
  f.max_file_bytes = kMaxDrtFileBytes;
  f.rebuild = "rebuild the clutter operators (modrt-demo --save-clutter)";
  return f;
}

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
  v("texel_cell", o.texel_cell);  // since version 3
  v("Gs_start", o.Gs.start);      // since version 4: the real-radiance gather
  v("Gs_index", o.Gs.index);
  v("Gs_weight", o.Gs.weight);
  v("Gt_start", o.Gt.start);
  v("Gt_index", o.Gt.index);
  v("Gt_weight", o.Gt.weight);
  v("H_sample", o.H_sample);
  v("Hs_start", o.Hs.start);
  v("Hs_index", o.Hs.index);
  v("Hs_weight", o.Hs.weight);
  v("Ht_start", o.Ht.start);
  v("Ht_index", o.Ht.index);
  v("Ht_weight", o.Ht.weight);
}

// How many fields visit_fields walks (the per-object lower bound on bytes).
std::size_t field_count() {
  DrtObjectOperators o;
  std::size_t n = 0;
  visit_fields(o, [&](const char*, const auto&) { ++n; });
  return n;
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
    body.u32(o.cell_res);  // since version 3
    visit_fields(o, FieldWriter{body});
  }
  return binary::seal(drt_file_format(),
                      {drt.kb, std::uint32_t(drt.objects.size()), drt.probes_per_block, drt.level_blocks,
                       drt.level_samples, 0, 0, 0},
                      body.bytes);
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
  binary::SealedFields header{};
  const Result<std::span<const std::byte>> sealed =
      binary::open_sealed(drt_file_format(), bytes, what, header);
  if (!sealed.ok()) return sealed.status();
  const std::span<const std::byte> body = sealed.value();

  DrtOperators drt;
  drt.kb = header[0];
  const std::uint32_t objects = header[1];
  drt.probes_per_block = header[2];
  drt.level_blocks = header[3];
  drt.level_samples = header[4];
  Reader in(body, what);
  // A lower bound on an object's bytes: three counts and at least 4 bytes per field.
  if (in.fits("objects", objects, 12 + 4 * field_count())) drt.objects.resize(objects);
  for (std::uint32_t i = 0; i < objects && in.ok(); ++i) {
    DrtObjectOperators& o = drt.objects[i];
    const std::string name = "object " + std::to_string(i);
    o.texel_count = in.u32(name + " texel_count");
    o.face_count = in.u32(name + " face_count");
    o.cell_res = in.u32(name + " cell_res");
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
