// SPDX-License-Identifier: MIT
#include "modrt/dictionary_io.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <tuple>

#include <glm/gtc/packing.hpp>

#include "modrt/file_io.h"

namespace modrt {
namespace {

constexpr std::size_t kHeaderCrcOffset = 108;
constexpr std::size_t kShapeCountOffset = 92;
constexpr std::uint32_t kMaxSectionsPerShape = 64;

// --- little-endian encoding, independent of the host byte order ---

void put_u32(std::vector<std::byte>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(std::byte((v >> (8 * i)) & 0xFFu));
}
void put_u64(std::vector<std::byte>& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(std::byte((v >> (8 * i)) & 0xFFu));
}
std::uint32_t get_u32(std::span<const std::byte> b, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v |= std::to_integer<std::uint32_t>(b[at + i]) << (8 * i);
  return v;
}
std::uint64_t get_u64(std::span<const std::byte> b, std::size_t at) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 8; ++i) v |= std::to_integer<std::uint64_t>(b[at + i]) << (8 * i);
  return v;
}

// --- section kinds ---

bool is_interface_kind(std::uint32_t kind) { return kind >= 17 && kind <= 22; }
bool is_shape_kind(std::uint32_t kind) { return (kind >= 1 && kind <= 6) || kind == 16; }

bool is_missing_side_face(int shape, int face) {
  return face != kFaceNegY && face != kFacePosY && !face_present(dictionary_shape_mask(shape), face);
}

std::string dims(std::uint64_t rows, std::uint64_t cols) {
  return std::to_string(rows) + "x" + std::to_string(cols);
}

std::string shape_label(std::uint32_t shape) {
  return "shape " + std::to_string(shape) + " (" + dictionary_shape_name(int(shape)) + ")";
}

// "Ub, shape 1 (dead_end)", "Rb_rlf -Z, shape 1 (dead_end)", "R_left, interfaces", "kind 99"
std::string section_label(std::uint32_t kind, std::uint32_t shape, std::uint32_t sub) {
  const char* name = dictionary_section_name(kind);
  if (!name) return "kind " + std::to_string(kind);
  std::string label = name;
  if (kind == std::uint32_t(DictionarySectionKind::Rb_rlf)) label += std::string(" ") + face_name(int(sub));
  if (is_interface_kind(kind)) return label + ", interfaces";
  if (shape < std::uint32_t(kDictionaryShapeCount)) return label + ", " + shape_label(shape);
  return label + ", shape " + std::to_string(shape);
}

std::uint64_t shape_samples(const DictionarySettings& s, int shape) {
  return std::uint64_t(face_count(dictionary_shape_mask(shape))) * s.res * s.res;
}

// Dimensions the settings imply for a section; for sigma_M, cols is the maximum length.
struct Dims {
  std::uint64_t rows, cols;
};
Dims expected_dims(const DictionarySettings& s, std::uint32_t kind, std::uint32_t shape) {
  const std::uint64_t kb = s.kb, g = s.probe_grid;
  const std::uint64_t n = shape < std::uint32_t(kDictionaryShapeCount) ? shape_samples(s, int(shape)) : 0;
  switch (DictionarySectionKind(kind)) {
    case DictionarySectionKind::Ub: return {n, kb};
    case DictionarySectionKind::Td_b: return {kb, n};
    case DictionarySectionKind::Limp: return {n, kb};
    case DictionarySectionKind::Ub_vec: return {4 * n, kb};
    case DictionarySectionKind::Ubvol: return {9 * g * g * g, kb};
    case DictionarySectionKind::sigma_M: return {1, n};
    case DictionarySectionKind::Rb_rlf: return {s.krlf, kb};
    case DictionarySectionKind::R_straight:
    case DictionarySectionKind::R_left:
    case DictionarySectionKind::R_right: return {s.krlf, s.krlf};
    case DictionarySectionKind::Trlf_r: return {s.kr, s.krlf};
    case DictionarySectionKind::Ur: return {shape_samples(s, 1), s.kr};
    case DictionarySectionKind::Urvol: return {9 * g * g * g, s.kr};
    case DictionarySectionKind::Ur_vec: return {4 * shape_samples(s, 1), s.kr};
  }
  return {0, 0};
}

// --- writing ---

struct PlannedSection {
  std::uint32_t kind, shape, sub;
  const Matrix* matrix = nullptr;              // or
  const std::vector<float>* vector = nullptr;  // sigma_M
  bool float16 = false;
};

std::vector<PlannedSection> plan_sections(const Dictionary& dict, bool float16) {
  std::vector<PlannedSection> plan;
  auto add = [&](DictionarySectionKind kind, std::uint32_t shape, std::uint32_t sub, const Matrix& m) {
    plan.push_back({std::uint32_t(kind), shape, sub, &m, nullptr, float16});
  };
  for (std::uint32_t s = 0; s < dict.shapes.size(); ++s) {
    const ShapeOperators& op = dict.shapes[s];
    add(DictionarySectionKind::Ub, s, 0, op.Ub);
    add(DictionarySectionKind::Td_b, s, 0, op.Td_b);
    add(DictionarySectionKind::Limp, s, 0, op.Limp);
    add(DictionarySectionKind::Ub_vec, s, 0, op.Ub_vec);
    add(DictionarySectionKind::Ubvol, s, 0, op.Ubvol);
    plan.push_back({std::uint32_t(DictionarySectionKind::sigma_M), s, 0, nullptr, &op.sigma_M, false});
    if (dict.settings.lightfield_spatial > 0)
      for (int f = 0; f < kFaceCount; ++f)
        if (is_missing_side_face(int(s), f))
          add(DictionarySectionKind::Rb_rlf, s, std::uint32_t(f), op.Rb_rlf[std::size_t(f)]);
  }
  if (dict.settings.lightfield_spatial > 0) {
    const InterfaceOperators& io = dict.interfaces;
    add(DictionarySectionKind::R_straight, kNoShape, 0, io.R_straight);
    add(DictionarySectionKind::R_left, kNoShape, 0, io.R_left);
    add(DictionarySectionKind::R_right, kNoShape, 0, io.R_right);
    add(DictionarySectionKind::Trlf_r, kNoShape, 0, io.Trlf_r);
    add(DictionarySectionKind::Ur, kNoShape, 0, io.Ur);
    add(DictionarySectionKind::Urvol, kNoShape, 0, io.Urvol);
    add(DictionarySectionKind::Ur_vec, kNoShape, 0, io.Ur_vec);
  }
  return plan;
}

void put_settings(std::vector<std::byte>& out, const DictionarySettings& s) {
  put_u32(out, s.res);
  put_u32(out, s.kd);
  put_u32(out, s.kb);
  put_u32(out, s.rays);
  put_u32(out, s.enrichment_iterations);
  put_u32(out, s.prior_grid);
  put_u32(out, s.light_samples);
  put_u32(out, std::bit_cast<std::uint32_t>(s.light_radius));
  put_u32(out, s.sh_rays);
  put_u32(out, s.probe_grid);
  put_u64(out, s.seed);
  put_u32(out, s.lightfield_spatial);
  put_u32(out, s.lightfield_directional);
  put_u32(out, s.lightfield_supersample);
  put_u32(out, s.krlf);
  put_u32(out, s.kr);
  put_u32(out, s.interface_enrichment_iterations);
  put_u32(out, s.response_rays);
}

DictionarySettings get_settings(std::span<const std::byte> b) {
  DictionarySettings s;
  s.res = get_u32(b, 16);
  s.kd = get_u32(b, 20);
  s.kb = get_u32(b, 24);
  s.rays = get_u32(b, 28);
  s.enrichment_iterations = get_u32(b, 32);
  s.prior_grid = get_u32(b, 36);
  s.light_samples = get_u32(b, 40);
  s.light_radius = std::bit_cast<float>(get_u32(b, 44));
  s.sh_rays = get_u32(b, 48);
  s.probe_grid = get_u32(b, 52);
  s.seed = get_u64(b, 56);
  s.lightfield_spatial = get_u32(b, 64);
  s.lightfield_directional = get_u32(b, 68);
  s.lightfield_supersample = get_u32(b, 72);
  s.krlf = get_u32(b, 76);
  s.kr = get_u32(b, 80);
  s.interface_enrichment_iterations = get_u32(b, 84);
  s.response_rays = get_u32(b, 88);
  return s;
}

// Appends the payload of one section.
Status put_payload(std::vector<std::byte>& out, const PlannedSection& p, const std::string& what) {
  const float* values = p.matrix ? p.matrix->data.data() : p.vector->data();
  const std::size_t count = p.matrix ? p.matrix->data.size() : p.vector->size();
  if (!p.float16) {
    for (std::size_t i = 0; i < count; ++i) put_u32(out, std::bit_cast<std::uint32_t>(values[i]));
    return Status::success();
  }
  for (std::size_t i = 0; i < count; ++i) {
    const glm::uint16 h = glm::packHalf1x16(values[i]);
    if (!std::isfinite(glm::unpackHalf1x16(h))) {
      char value[32];
      std::snprintf(value, sizeof value, "%g", double(values[i]));
      const std::uint32_t cols = p.matrix->cols;
      const std::string where = is_interface_kind(p.kind) ? "interfaces" : shape_label(p.shape);
      std::string name = dictionary_section_name(p.kind);
      if (p.kind == std::uint32_t(DictionarySectionKind::Rb_rlf))
        name += std::string("(") + face_name(int(p.sub)) + ")";
      return Status::error(ErrorCode::invalid_argument,
                           what + ": " + where + ": " + name + "[" + std::to_string(i / cols) + "," +
                               std::to_string(i % cols) + "] = " + value +
                               " does not fit float16 (max 65504): save as float32");
    }
    out.push_back(std::byte(h & 0xFFu));
    out.push_back(std::byte(h >> 8));
  }
  return Status::success();
}

Result<std::vector<std::byte>> serialize_impl(const Dictionary& dict, const DictionaryWriteOptions& options,
                                              const std::string& what) {
  if (Status s = validate_dictionary(dict, what); !s.ok()) return s;
  const std::vector<PlannedSection> plan = plan_sections(dict, options.float16);

  // Sizes first, so that an oversized dictionary is refused before anything is built.
  const std::uint64_t table_end = kDictionaryHeaderBytes + plan.size() * kDictionarySectionEntryBytes;
  std::uint64_t total = table_end;
  std::vector<std::uint64_t> sizes;
  for (const PlannedSection& p : plan) {
    const std::uint64_t count = p.matrix ? p.matrix->data.size() : p.vector->size();
    sizes.push_back(count * (p.float16 ? 2 : 4));
    total += sizes.back();
  }
  if (total > kMaxDictionaryFileBytes)
    return Status::error(ErrorCode::resource_limit, what + ": the dictionary file would be " +
                                                        std::to_string(total) +
                                                        " bytes, more than the limit of " +
                                                        std::to_string(kMaxDictionaryFileBytes) + " bytes");

  std::vector<std::byte> out;
  out.reserve(std::size_t(total));
  out.resize(std::size_t(table_end));
  std::vector<std::uint32_t> crcs;
  for (const PlannedSection& p : plan) {
    const std::size_t start = out.size();
    if (Status s = put_payload(out, p, what); !s.ok()) return s;
    crcs.push_back(crc32(std::span<const std::byte>(out).subspan(start)));
  }

  std::vector<std::byte> table;
  std::uint64_t offset = table_end;
  for (std::size_t i = 0; i < plan.size(); ++i) {
    const PlannedSection& p = plan[i];
    put_u32(table, p.kind);
    put_u32(table, p.shape);
    put_u32(table, p.matrix ? p.matrix->rows : 1u);
    put_u32(table, p.matrix ? p.matrix->cols : std::uint32_t(p.vector->size()));
    put_u32(table,
            std::uint32_t(p.float16 ? DictionaryElementType::float16 : DictionaryElementType::float32));
    put_u32(table, p.sub);
    put_u64(table, offset);
    put_u64(table, sizes[i]);
    put_u32(table, crcs[i]);
    put_u32(table, 0);
    offset += sizes[i];
  }

  std::vector<std::byte> header;
  for (char c : kDictionaryMagic) header.push_back(std::byte(c));
  put_u32(header, kDictionaryFormatVersion);
  put_u32(header, std::uint32_t(kDictionaryHeaderBytes));
  put_settings(header, dict.settings);
  put_u32(header, std::uint32_t(dict.shapes.size()));
  put_u32(header, std::uint32_t(plan.size()));
  put_u32(header, crc32(table));
  put_u32(header, 0);
  put_u32(header, crc32(header));

  std::copy(header.begin(), header.end(), out.begin());
  std::copy(table.begin(), table.end(), out.begin() + std::ptrdiff_t(kDictionaryHeaderBytes));
  return out;
}

// --- reading ---

Status format_error(const std::string& what, const std::string& message) {
  return Status::error(ErrorCode::format_error, what + ": " + message);
}

struct Header {
  DictionarySettings settings;
  std::uint32_t shape_count = 0;
  std::uint32_t section_count = 0;
  std::uint32_t table_crc = 0;
};

// Checks everything the header alone can tell: needs the first kDictionaryHeaderBytes.
Result<Header> parse_header(std::span<const std::byte> b, const std::string& what) {
  if (b.size() < 16)
    return format_error(what, "file is " + std::to_string(b.size()) + " bytes, shorter than the " +
                                  std::to_string(kDictionaryHeaderBytes) +
                                  "-byte dictionary header (truncated?)");
  if (std::memcmp(b.data(), kDictionaryMagic, sizeof kDictionaryMagic) != 0)
    return format_error(what, "not a modrt dictionary (bad magic)");
  const std::uint32_t version = get_u32(b, 8);
  if (version != kDictionaryFormatVersion)
    return Status::error(ErrorCode::version_mismatch,
                         what + ": written by format version " + std::to_string(version) +
                             ", this build reads version " + std::to_string(kDictionaryFormatVersion) +
                             ": re-bake the dictionary with modrt-bake");
  const std::uint32_t header_size = get_u32(b, 12);
  if (header_size != kDictionaryHeaderBytes)
    return format_error(what, "header size " + std::to_string(header_size) + ", expected " +
                                  std::to_string(kDictionaryHeaderBytes) + " for format version " +
                                  std::to_string(version));
  if (b.size() < kDictionaryHeaderBytes)
    return format_error(what, "file is " + std::to_string(b.size()) + " bytes, shorter than the " +
                                  std::to_string(kDictionaryHeaderBytes) +
                                  "-byte dictionary header (truncated?)");
  const std::uint32_t stored_crc = get_u32(b, kHeaderCrcOffset);
  const std::uint32_t actual_crc = crc32(b.first(kHeaderCrcOffset));
  if (stored_crc != actual_crc)
    return Status::error(ErrorCode::checksum_mismatch,
                         what + ": header checksum mismatch (stored " + std::to_string(stored_crc) +
                             ", computed " + std::to_string(actual_crc) + "): the file is corrupt");
  if (get_u32(b, 104) != 0) return format_error(what, "header: reserved field is not 0");
  Header h;
  h.settings = get_settings(b);
  if (Status s = validate_settings(h.settings); !s.ok()) return format_error(what, "header: " + s.message());
  h.shape_count = get_u32(b, kShapeCountOffset);
  if (h.shape_count != std::uint32_t(kDictionaryShapeCount))
    return format_error(what, "header: " + std::to_string(h.shape_count) + " shapes, expected " +
                                  std::to_string(kDictionaryShapeCount));
  h.section_count = get_u32(b, 96);
  h.table_crc = get_u32(b, 100);
  if (h.section_count < 1 || h.section_count > kMaxSectionsPerShape * h.shape_count)
    return format_error(what, "header: section count " + std::to_string(h.section_count) + " is not in [1, " +
                                  std::to_string(kMaxSectionsPerShape * h.shape_count) + "]");
  return h;
}

struct Entry {
  std::uint32_t kind, shape, rows, cols, type, sub;
  std::uint64_t offset, size;
  std::uint32_t crc, pad;
};

Entry get_entry(std::span<const std::byte> b, std::size_t at) {
  Entry e;
  e.kind = get_u32(b, at);
  e.shape = get_u32(b, at + 4);
  e.rows = get_u32(b, at + 8);
  e.cols = get_u32(b, at + 12);
  e.type = get_u32(b, at + 16);
  e.sub = get_u32(b, at + 20);
  e.offset = get_u64(b, at + 24);
  e.size = get_u64(b, at + 32);
  e.crc = get_u32(b, at + 40);
  e.pad = get_u32(b, at + 44);
  return e;
}

// Checks one table entry against the settings and the file; nothing is allocated.
Status check_entry(const Entry& e, std::size_t index, const Header& h, std::span<const std::byte> bytes,
                   std::uint64_t payload_start, const std::string& what) {
  const std::string where =
      what + ": section " + std::to_string(index) + " (" + section_label(e.kind, e.shape, e.sub) + "): ";
  if (!dictionary_section_name(e.kind))
    return Status::error(ErrorCode::format_error, where + "unknown section kind " + std::to_string(e.kind));
  if (is_shape_kind(e.kind) && e.shape >= std::uint32_t(kDictionaryShapeCount))
    return Status::error(ErrorCode::format_error, where + "shape index " + std::to_string(e.shape) +
                                                      " is not in [0, " +
                                                      std::to_string(kDictionaryShapeCount - 1) + "]");
  if (is_interface_kind(e.kind) && e.shape != kNoShape)
    return Status::error(ErrorCode::format_error, where + "shape index " + std::to_string(e.shape) +
                                                      ", expected 0xFFFFFFFF (dictionary-wide)");
  if (e.kind == std::uint32_t(DictionarySectionKind::Rb_rlf)) {
    if (e.sub >= std::uint32_t(kFaceCount) || !is_missing_side_face(int(e.shape), int(e.sub)))
      return Status::error(
          ErrorCode::format_error,
          where + "face " + std::to_string(e.sub) + " is not a missing side face of " + shape_label(e.shape));
  } else if (e.sub != 0) {
    return Status::error(ErrorCode::format_error,
                         where + "sub-index " + std::to_string(e.sub) + ", expected 0");
  }
  if ((e.kind == std::uint32_t(DictionarySectionKind::Rb_rlf) || is_interface_kind(e.kind)) &&
      h.settings.lightfield_spatial == 0)
    return Status::error(ErrorCode::format_error,
                         where + "interface operator in a dictionary with settings.lightfield_spatial = 0");
  if (e.type != std::uint32_t(DictionaryElementType::float32) &&
      e.type != std::uint32_t(DictionaryElementType::float16))
    return Status::error(ErrorCode::format_error, where + "unknown element type " + std::to_string(e.type));
  if (e.pad != 0) return Status::error(ErrorCode::format_error, where + "pad field is not 0");

  const Dims want = expected_dims(h.settings, e.kind, e.shape);
  if (e.kind == std::uint32_t(DictionarySectionKind::sigma_M)) {
    if (e.rows != 1 || e.cols > want.cols)
      return Status::error(
          ErrorCode::format_error,
          where + "is " + dims(e.rows, e.cols) + ", expected 1x(at most " + std::to_string(want.cols) + ")");
  } else if (e.rows != want.rows || e.cols != want.cols) {
    return Status::error(ErrorCode::format_error,
                         where + "is " + dims(e.rows, e.cols) + ", expected " + dims(want.rows, want.cols));
  }
  // rows, cols < 2^32: their product fits in 64 bits, times 4 only if below 2^62.
  const std::uint64_t count = std::uint64_t(e.rows) * e.cols;
  const std::uint64_t elem = e.type == std::uint32_t(DictionaryElementType::float16) ? 2 : 4;
  if (count > (UINT64_MAX / 4) || count * elem != e.size)
    return Status::error(ErrorCode::format_error, where + "byte size " + std::to_string(e.size) +
                                                      ", expected " + dims(e.rows, e.cols) + " x " +
                                                      std::to_string(elem) + " bytes");
  if (e.offset < payload_start || e.offset > bytes.size() || e.size > bytes.size() - e.offset)
    return Status::error(ErrorCode::format_error,
                         where + "payload [" + std::to_string(e.offset) + ", +" + std::to_string(e.size) +
                             ") is outside the file's payload area [" + std::to_string(payload_start) + ", " +
                             std::to_string(bytes.size()) + ") (truncated?)");
  const std::uint32_t actual = crc32(bytes.subspan(std::size_t(e.offset), std::size_t(e.size)));
  if (actual != e.crc)
    return Status::error(ErrorCode::checksum_mismatch, where + "payload checksum mismatch (stored " +
                                                           std::to_string(e.crc) + ", computed " +
                                                           std::to_string(actual) + "): the file is corrupt");
  return Status::success();
}

void decode(std::span<const std::byte> bytes, const Entry& e, float* out) {
  const std::size_t count = std::size_t(std::uint64_t(e.rows) * e.cols);
  const std::byte* p = bytes.data() + e.offset;
  if (e.type == std::uint32_t(DictionaryElementType::float16)) {
    for (std::size_t i = 0; i < count; ++i) {
      const auto h =
          glm::uint16(std::to_integer<unsigned>(p[2 * i]) | (std::to_integer<unsigned>(p[2 * i + 1]) << 8));
      out[i] = glm::unpackHalf1x16(h);
    }
  } else if constexpr (std::endian::native == std::endian::little) {
    if (count > 0) std::memcpy(out, p, count * sizeof(float));
  } else {
    for (std::size_t i = 0; i < count; ++i)
      out[i] = std::bit_cast<float>(get_u32(bytes, std::size_t(e.offset) + 4 * i));
  }
}

Matrix decode_matrix(std::span<const std::byte> bytes, const Entry& e) {
  Matrix m(e.rows, e.cols);
  decode(bytes, e, m.data.data());
  return m;
}

}  // namespace

const char* dictionary_section_name(std::uint32_t kind) {
  switch (kind) {
    case 1: return "Ub";
    case 2: return "Td_b";
    case 3: return "Limp";
    case 4: return "Ub_vec";
    case 5: return "Ubvol";
    case 6: return "sigma_M";
    case 16: return "Rb_rlf";
    case 17: return "R_straight";
    case 18: return "R_left";
    case 19: return "R_right";
    case 20: return "Trlf_r";
    case 21: return "Ur";
    case 22: return "Urvol";
    case 23: return "Ur_vec";
    default: return nullptr;
  }
}

Result<std::vector<std::byte>> serialize_dictionary(const Dictionary& dict,
                                                    const DictionaryWriteOptions& options) {
  return serialize_impl(dict, options, "dictionary");
}

Status save_dictionary(const std::string& path, const Dictionary& dict,
                       const DictionaryWriteOptions& options) {
  Result<std::vector<std::byte>> bytes = serialize_impl(dict, options, path);
  if (!bytes.ok()) return bytes.status();
  return write_file_atomic(path, bytes.value());
}

Result<Dictionary> parse_dictionary(std::span<const std::byte> bytes, const std::string& what) {
  Result<Header> header = parse_header(bytes, what);
  if (!header.ok()) return header.status();
  const Header& h = header.value();

  const std::uint64_t table_bytes = std::uint64_t(h.section_count) * kDictionarySectionEntryBytes;
  const std::uint64_t payload_start = kDictionaryHeaderBytes + table_bytes;
  if (payload_start > bytes.size())
    return format_error(what, "section table of " + std::to_string(h.section_count) +
                                  " entries ends at byte " + std::to_string(payload_start) +
                                  ", past the end of the " + std::to_string(bytes.size()) +
                                  "-byte file (truncated?)");
  const std::span<const std::byte> table = bytes.subspan(kDictionaryHeaderBytes, std::size_t(table_bytes));
  if (const std::uint32_t actual = crc32(table); actual != h.table_crc)
    return Status::error(ErrorCode::checksum_mismatch, what + ": section table checksum mismatch (stored " +
                                                           std::to_string(h.table_crc) + ", computed " +
                                                           std::to_string(actual) + "): the file is corrupt");

  // Validate every entry and index them by (kind, shape, sub-index).
  std::map<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>, Entry> found;
  std::uint64_t payload_end = payload_start;
  for (std::size_t i = 0; i < h.section_count; ++i) {
    const Entry e = get_entry(bytes, kDictionaryHeaderBytes + i * kDictionarySectionEntryBytes);
    if (Status s = check_entry(e, i, h, bytes, payload_start, what); !s.ok()) return s;
    if (!found.emplace(std::make_tuple(e.kind, e.shape, e.sub), e).second)
      return format_error(what, "section " + std::to_string(i) + " (" +
                                    section_label(e.kind, e.shape, e.sub) + "): duplicate section");
    payload_end = std::max(payload_end, e.offset + e.size);  // check_entry: inside the file
  }

  auto require = [&](DictionarySectionKind kind, std::uint32_t shape, std::uint32_t sub) -> Result<Entry> {
    const auto it = found.find(std::make_tuple(std::uint32_t(kind), shape, sub));
    if (it == found.end())
      return format_error(what, "missing section " + section_label(std::uint32_t(kind), shape, sub));
    return it->second;
  };

  Dictionary dict;
  dict.settings = h.settings;
  dict.shapes.resize(std::size_t(kDictionaryShapeCount));
  const bool with_interfaces = h.settings.lightfield_spatial > 0;
  try {
    for (std::uint32_t s = 0; s < std::uint32_t(kDictionaryShapeCount); ++s) {
      ShapeOperators& op = dict.shapes[s];
      op.face_mask = dictionary_shape_mask(int(s));
      const std::pair<DictionarySectionKind, Matrix*> matrices[] = {
          {DictionarySectionKind::Ub, &op.Ub},       {DictionarySectionKind::Td_b, &op.Td_b},
          {DictionarySectionKind::Limp, &op.Limp},   {DictionarySectionKind::Ub_vec, &op.Ub_vec},
          {DictionarySectionKind::Ubvol, &op.Ubvol},
      };
      for (const auto& [kind, target] : matrices) {
        Result<Entry> e = require(kind, s, 0);
        if (!e.ok()) return e.status();
        *target = decode_matrix(bytes, e.value());
      }
      Result<Entry> sigma = require(DictionarySectionKind::sigma_M, s, 0);
      if (!sigma.ok()) return sigma.status();
      op.sigma_M.resize(sigma->cols);
      decode(bytes, sigma.value(), op.sigma_M.data());
      if (with_interfaces)
        for (int f = 0; f < kFaceCount; ++f) {
          if (!is_missing_side_face(int(s), f)) continue;
          Result<Entry> e = require(DictionarySectionKind::Rb_rlf, s, std::uint32_t(f));
          if (!e.ok()) return e.status();
          op.Rb_rlf[std::size_t(f)] = decode_matrix(bytes, e.value());
        }
    }
    if (with_interfaces) {
      InterfaceOperators& io = dict.interfaces;
      const std::pair<DictionarySectionKind, Matrix*> matrices[] = {
          {DictionarySectionKind::R_straight, &io.R_straight},
          {DictionarySectionKind::R_left, &io.R_left},
          {DictionarySectionKind::R_right, &io.R_right},
          {DictionarySectionKind::Trlf_r, &io.Trlf_r},
          {DictionarySectionKind::Ur, &io.Ur},
          {DictionarySectionKind::Urvol, &io.Urvol},
          {DictionarySectionKind::Ur_vec, &io.Ur_vec},
      };
      for (const auto& [kind, target] : matrices) {
        Result<Entry> e = require(kind, kNoShape, 0);
        if (!e.ok()) return e.status();
        *target = decode_matrix(bytes, e.value());
      }
    }
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::resource_limit, what + ": out of memory while decoding the dictionary");
  }
  // One rule with level files: nothing may follow the data (appended bytes are damage or a
  // concatenation, never part of the format).
  if (payload_end != bytes.size())
    return format_error(what, std::to_string(bytes.size() - payload_end) +
                                  " trailing bytes after the last section (it ends at byte " +
                                  std::to_string(payload_end) + " of " + std::to_string(bytes.size()) + ")");
  // Sizes were checked above; this finds NaN/Inf (e.g. float16 infinities).
  if (Status s = validate_dictionary(dict, what); !s.ok()) return s;
  return dict;
}

Result<Dictionary> load_dictionary(const std::string& path) {
  Result<std::vector<std::byte>> bytes = read_file(path, kMaxDictionaryFileBytes);
  if (!bytes.ok()) return bytes.status();
  return parse_dictionary(bytes.value(), path);
}

Result<DictionarySettings> peek_dictionary_settings(const std::string& path) {
  Result<std::vector<std::byte>> bytes = read_file_prefix(path, kDictionaryHeaderBytes);
  if (!bytes.ok()) return bytes.status();
  Result<Header> header = parse_header(bytes.value(), path);
  if (!header.ok()) return header.status();
  return header->settings;
}

}  // namespace modrt
