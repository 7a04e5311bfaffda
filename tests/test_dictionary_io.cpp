// SPDX-License-Identifier: MIT
// The dictionary file format (core/include/modrt/dictionary_io.h), the file helpers
// (file_io.h) and settings/dictionary validation: round trips, hostile and corrupt files.
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <unistd.h>

#include "binary_test_support.h"
#include "modrt/dictionary.h"
#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"

namespace modrt {
namespace {

namespace fs = std::filesystem;

// --- a small synthetic dictionary ---

struct Rng {
  std::uint64_t state;
  explicit Rng(std::uint64_t seed) : state(seed * 0x9E3779B97F4A7C15ull + 1) {}
  std::uint64_t next() {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state;
  }
  // Magnitude in [0.01, 2], random sign: exactly representable range for float16 tests.
  float value() {
    const double u = double(next() >> 11) / double(1ull << 53);
    const float magnitude = float(0.01 + 1.99 * u);
    return (next() & 1u) ? magnitude : -magnitude;
  }
};

Matrix random_matrix(Rng& rng, std::uint32_t rows, std::uint32_t cols) {
  Matrix m(rows, cols);
  for (float& v : m.data) v = rng.value();
  return m;
}

DictionarySettings small_settings(bool interfaces = true) {
  DictionarySettings s;
  s.res = 2;
  s.kd = 4;
  s.kb = 3;
  s.probe_grid = 1;
  s.krlf = 4;
  s.kr = 2;
  s.lightfield_spatial = interfaces ? 3 : 0;
  return s;
}

Dictionary make_dictionary(bool interfaces = true) {
  Dictionary d;
  d.settings = small_settings(interfaces);
  Rng rng(42);
  const std::uint32_t kb = d.settings.kb, g = d.settings.probe_grid;
  for (int s = 0; s < kDictionaryShapeCount; ++s) {
    ShapeOperators op;
    op.face_mask = dictionary_shape_mask(s);
    const auto n = std::uint32_t(face_count(op.face_mask)) * d.settings.res * d.settings.res;
    op.Ub = random_matrix(rng, n, kb);
    op.Td_b = random_matrix(rng, kb, n);
    op.Limp = random_matrix(rng, n, kb);
    // Within the plausibility limits of operator_limits.h (prior scale sqrt(3)): columns of
    // Ub and Limp of L2 norm <= 1.3, and ||Ub_k|| ||Td_b,k|| = 1/2 per mode.
    for (float& v : op.Ub.data) v *= 0.125f;
    for (float& v : op.Limp.data) v *= 0.125f;
    for (std::uint32_t k = 0; k < kb; ++k) {
      double u = 0.0, t = 0.0;
      for (std::uint32_t r = 0; r < n; ++r) u += double(op.Ub(r, k)) * op.Ub(r, k);
      for (float v : op.Td_b.row(k)) t += double(v) * v;
      const float scale = float(0.5 / std::sqrt(u * t));
      for (std::uint32_t c = 0; c < n; ++c) op.Td_b(k, c) *= scale;
    }
    op.Ub_vec = random_matrix(rng, 4 * n, kb);
    op.Ubvol = random_matrix(rng, 9 * g * g * g, kb);
    for (std::uint32_t i = 0; i < d.settings.kd; ++i) op.sigma_M.push_back(std::abs(rng.value()));
    if (interfaces)
      for (int f = 0; f < kFaceCount; ++f)
        if (f != kFaceNegY && f != kFacePosY && !face_present(op.face_mask, f))
          op.Rb_rlf[std::size_t(f)] = random_matrix(rng, d.settings.krlf, kb);
    d.shapes.push_back(std::move(op));
  }
  if (interfaces) {
    const std::uint32_t krlf = d.settings.krlf, kr = d.settings.kr;
    d.interfaces.R_straight = random_matrix(rng, krlf, krlf);
    d.interfaces.R_left = random_matrix(rng, krlf, krlf);
    d.interfaces.R_right = random_matrix(rng, krlf, krlf);
    d.interfaces.Trlf_r = random_matrix(rng, kr, krlf);
    d.interfaces.Ur = random_matrix(rng, std::uint32_t(face_count(dictionary_shape_mask(1))) * 4, kr);
    d.interfaces.Urvol = random_matrix(rng, 9 * g * g * g, kr);
    d.interfaces.Ur_vec = random_matrix(rng, 4 * std::uint32_t(face_count(dictionary_shape_mask(1))) * 4, kr);
  }
  return d;
}

// Every matrix of a dictionary with a label, for comparisons.
std::vector<std::pair<std::string, const Matrix*>> all_matrices(const Dictionary& d) {
  std::vector<std::pair<std::string, const Matrix*>> out;
  for (std::size_t s = 0; s < d.shapes.size(); ++s) {
    const ShapeOperators& op = d.shapes[s];
    const std::string p = "shape " + std::to_string(s) + " ";
    out.push_back({p + "Ub", &op.Ub});
    out.push_back({p + "Td_b", &op.Td_b});
    out.push_back({p + "Limp", &op.Limp});
    out.push_back({p + "Ub_vec", &op.Ub_vec});
    out.push_back({p + "Ubvol", &op.Ubvol});
    for (int f = 0; f < kFaceCount; ++f)
      out.push_back({p + "Rb_rlf " + face_name(f), &op.Rb_rlf[std::size_t(f)]});
  }
  out.push_back({"R_straight", &d.interfaces.R_straight});
  out.push_back({"R_left", &d.interfaces.R_left});
  out.push_back({"R_right", &d.interfaces.R_right});
  out.push_back({"Trlf_r", &d.interfaces.Trlf_r});
  out.push_back({"Ur", &d.interfaces.Ur});
  out.push_back({"Urvol", &d.interfaces.Urvol});
  out.push_back({"Ur_vec", &d.interfaces.Ur_vec});
  return out;
}

void expect_bit_exact(const Dictionary& a, const Dictionary& b) {
  EXPECT_EQ(a.settings, b.settings);
  ASSERT_EQ(a.shapes.size(), b.shapes.size());
  const auto ma = all_matrices(a), mb = all_matrices(b);
  ASSERT_EQ(ma.size(), mb.size());
  for (std::size_t i = 0; i < ma.size(); ++i) {
    const Matrix& x = *ma[i].second;
    const Matrix& y = *mb[i].second;
    EXPECT_EQ(x.rows, y.rows) << ma[i].first;
    EXPECT_EQ(x.cols, y.cols) << ma[i].first;
    ASSERT_EQ(x.data.size(), y.data.size()) << ma[i].first;
    EXPECT_TRUE(x.data.empty() ||
                std::memcmp(x.data.data(), y.data.data(), x.data.size() * sizeof(float)) == 0)
        << ma[i].first;
  }
  for (std::size_t s = 0; s < a.shapes.size(); ++s) {
    EXPECT_EQ(a.shapes[s].face_mask, b.shapes[s].face_mask);
    ASSERT_EQ(a.shapes[s].sigma_M.size(), b.shapes[s].sigma_M.size());
    for (std::size_t i = 0; i < a.shapes[s].sigma_M.size(); ++i)
      EXPECT_EQ(std::bit_cast<std::uint32_t>(a.shapes[s].sigma_M[i]),
                std::bit_cast<std::uint32_t>(b.shapes[s].sigma_M[i]));
  }
}

// --- raw file surgery ---

using modrt::test::get_u32;
using modrt::test::get_u64;
using modrt::test::put_u32;
using modrt::test::put_u64;

constexpr std::size_t kSectionCountAt = 96, kTableCrcAt = 100, kHeaderCrcAt = 108;
std::size_t entry_at(std::size_t i) { return kDictionaryHeaderBytes + i * kDictionarySectionEntryBytes; }

std::size_t find_section(const std::vector<std::byte>& b, DictionarySectionKind kind, std::uint32_t shape) {
  const std::uint32_t count = get_u32(b, kSectionCountAt);
  for (std::size_t i = 0; i < count; ++i)
    if (get_u32(b, entry_at(i)) == std::uint32_t(kind) && get_u32(b, entry_at(i) + 4) == shape) return i;
  ADD_FAILURE() << "no section " << dictionary_section_name(std::uint32_t(kind)) << " for shape " << shape;
  return 0;
}

// Recomputes every checksum, so that a hand-made change reaches the later checks.
void reseal(std::vector<std::byte>& b) {
  const std::size_t count = get_u32(b, kSectionCountAt);
  for (std::size_t i = 0; i < count && entry_at(i + 1) <= b.size(); ++i) {
    const std::uint64_t off = get_u64(b, entry_at(i) + 24), size = get_u64(b, entry_at(i) + 32);
    if (off <= b.size() && size <= b.size() - off)
      put_u32(b, entry_at(i) + 40,
              crc32(std::span<const std::byte>(b).subspan(std::size_t(off), std::size_t(size))));
  }
  if (entry_at(count) <= b.size())
    put_u32(b, kTableCrcAt,
            crc32(std::span<const std::byte>(b).subspan(kDictionaryHeaderBytes,
                                                        count * kDictionarySectionEntryBytes)));
  put_u32(b, kHeaderCrcAt, crc32(std::span<const std::byte>(b).first(kHeaderCrcAt)));
}

std::vector<std::byte> serialized(const Dictionary& d, bool float16 = false) {
  DictionaryWriteOptions o;
  o.float16 = float16;
  Result<std::vector<std::byte>> r = serialize_dictionary(d, o);
  EXPECT_TRUE(r.ok()) << r.status().to_string();
  return r.ok() ? r.value() : std::vector<std::byte>{};
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A fresh directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("modrt_test_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
             std::to_string(long(::getpid())) + "_" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// --- DictionaryIo ---

TEST(DictionaryIo, Float32RoundTripIsBitExact) {
  const Dictionary d = make_dictionary();
  const std::vector<std::byte> bytes = serialized(d);
  Result<Dictionary> back = parse_dictionary(bytes, "mem");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  expect_bit_exact(d, back.value());

  TempDir dir;
  const std::string path = dir.file("dict.modrt");
  ASSERT_TRUE(save_dictionary(path, d).ok());
  Result<Dictionary> loaded = load_dictionary(path);
  ASSERT_TRUE(loaded.ok()) << loaded.status().to_string();
  expect_bit_exact(d, loaded.value());
  EXPECT_EQ(fs::file_size(path), bytes.size());
}

TEST(DictionaryIo, RoundTripWithoutInterfaceOperators) {
  const Dictionary d = make_dictionary(false);
  Result<Dictionary> back = parse_dictionary(serialized(d), "mem");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  expect_bit_exact(d, back.value());
  EXPECT_TRUE(back->interfaces.empty());
}

TEST(DictionaryIo, Float16RoundTripIsCloseAndSmaller) {
  const Dictionary d = make_dictionary();
  const std::vector<std::byte> f32 = serialized(d), f16 = serialized(d, true);
  std::size_t matrix_values = 0;
  for (const auto& [name, m] : all_matrices(d)) matrix_values += m->data.size();
  EXPECT_EQ(f32.size() - f16.size(), 2 * matrix_values);  // half the payload bytes, same table
  Result<Dictionary> back = parse_dictionary(f16, "mem16");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->settings, d.settings);
  const auto ma = all_matrices(d), mb = all_matrices(back.value());
  ASSERT_EQ(ma.size(), mb.size());
  for (std::size_t i = 0; i < ma.size(); ++i) {
    ASSERT_EQ(ma[i].second->data.size(), mb[i].second->data.size()) << ma[i].first;
    for (std::size_t k = 0; k < ma[i].second->data.size(); ++k) {
      const float x = ma[i].second->data[k], y = mb[i].second->data[k];
      ASSERT_LE(std::abs(x - y), 1e-3f * std::abs(x)) << ma[i].first << " [" << k << "]";
    }
  }
  // sigma_M stays float32.
  EXPECT_EQ(back->shapes[3].sigma_M, d.shapes[3].sigma_M);
}

TEST(DictionaryIo, Float16OverflowIsAnError) {
  Dictionary d = make_dictionary();
  // A mode with a tiny singular value: Ub's column small, Td_b's row large (plausible, see
  // operator_limits.h), beyond float16's 65504.
  for (std::uint32_t r = 0; r < d.shapes[2].Ub.rows; ++r) d.shapes[2].Ub(r, 1) *= 1e-6f;
  d.shapes[2].Td_b(1, 2) = 1e5f;
  DictionaryWriteOptions o;
  o.float16 = true;
  Result<std::vector<std::byte>> r = serialize_dictionary(d, o);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.status().message(), "shape 2 (corridor)")) << r.status().message();
  EXPECT_TRUE(contains(r.status().message(), "Td_b[1,2]")) << r.status().message();
  TempDir dir;
  EXPECT_FALSE(save_dictionary(dir.file("d.modrt"), d, o).ok());
  EXPECT_FALSE(fs::exists(dir.file("d.modrt")));
  EXPECT_TRUE(serialize_dictionary(d).ok());  // fine as float32
}

TEST(DictionaryIo, TruncationAtEveryOffsetFails) {
  const std::vector<std::byte> bytes = serialized(make_dictionary());
  ASSERT_GT(bytes.size(), kDictionaryHeaderBytes);
  // Every byte of header and table, then a dense set of payload offsets and the tail.
  const std::size_t table_end = entry_at(get_u32(bytes, kSectionCountAt));
  for (std::size_t size = 0; size < bytes.size();
       size += (size < table_end + 64 || size + 64 > bytes.size()) ? 1 : 5) {
    Result<Dictionary> r = parse_dictionary(std::span<const std::byte>(bytes).first(size), "cut");
    ASSERT_FALSE(r.ok()) << "loaded a file truncated to " << size << " bytes";
    ASSERT_TRUE(r.status().code() == ErrorCode::format_error) << size << ": " << r.status().to_string();
    ASSERT_TRUE(contains(r.status().message(), "cut: ")) << r.status().message();
  }
}

TEST(DictionaryIo, SingleByteFlipsAreDetected) {
  const std::vector<std::byte> bytes = serialized(make_dictionary());
  std::vector<std::byte> copy = bytes;
  // Every byte of the file, each with one bit flip; header and table bytes with two.
  const std::size_t table_end = entry_at(get_u32(bytes, kSectionCountAt));
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    for (unsigned mask : {0x01u << (i % 8), 0x80u}) {
      if (mask == 0x80u && i >= table_end) continue;
      copy[i] = bytes[i] ^ std::byte(mask);
      Result<Dictionary> r = parse_dictionary(copy, "flip");
      ASSERT_FALSE(r.ok()) << "byte " << i << " ^ " << mask << " went unnoticed";
      const ErrorCode c = r.status().code();
      ASSERT_TRUE(c == ErrorCode::checksum_mismatch || c == ErrorCode::format_error ||
                  (c == ErrorCode::version_mismatch && i >= 8 && i < 12))
          << "byte " << i << ": " << r.status().to_string();
      copy[i] = bytes[i];
    }
  }
}

TEST(DictionaryIo, PayloadFlipIsAChecksumMismatchNamingTheSection) {
  std::vector<std::byte> bytes = serialized(make_dictionary());
  const std::size_t i = find_section(bytes, DictionarySectionKind::Ub_vec, 4);
  bytes[std::size_t(get_u64(bytes, entry_at(i) + 24)) + 5] ^= std::byte(0x10);
  Result<Dictionary> r = parse_dictionary(bytes, "d.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::checksum_mismatch);
  EXPECT_TRUE(contains(r.status().message(),
                       "d.modrt: section " + std::to_string(i) + " (Ub_vec, shape 4 (t_junction))"))
      << r.status().message();
}

TEST(DictionaryIo, BadMagic) {
  std::vector<std::byte> bytes = serialized(make_dictionary());
  bytes[0] = std::byte('X');
  Result<Dictionary> r = parse_dictionary(bytes, "x.bin");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::format_error);
  EXPECT_EQ(r.status().message(), "x.bin: not a modrt dictionary (bad magic)");
  const std::string text =
      "hello, this is not a dictionary at all, but it is long enough to hold a header......"
      "..............................................................................";
  r = parse_dictionary(std::as_bytes(std::span<const char>(text.data(), text.size())), "t.txt");
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.status().message(), "bad magic"));
}

TEST(DictionaryIo, WrongVersionAsksForARebake) {
  std::vector<std::byte> bytes = serialized(make_dictionary());
  put_u32(bytes, 8, kDictionaryFormatVersion + 1);
  reseal(bytes);
  Result<Dictionary> r = parse_dictionary(bytes, "old.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::version_mismatch);
  EXPECT_TRUE(contains(r.status().message(), "re-bake")) << r.status().message();
  EXPECT_TRUE(contains(r.status().message(), "written by format version 3, this build reads version 2"))
      << r.status().message();
  TempDir dir;
  ASSERT_TRUE(write_file_atomic(dir.file("old.modrt"), bytes).ok());
  Result<DictionarySettings> peek = peek_dictionary_settings(dir.file("old.modrt"));
  ASSERT_FALSE(peek.ok());
  EXPECT_EQ(peek.status().code(), ErrorCode::version_mismatch);
}

TEST(DictionaryIo, OversizedSectionSize) {
  std::vector<std::byte> bytes = serialized(make_dictionary());
  const std::size_t i = find_section(bytes, DictionarySectionKind::Td_b, 1);
  put_u64(bytes, entry_at(i) + 32, std::uint64_t(1) << 40);
  reseal(bytes);
  Result<Dictionary> r = parse_dictionary(bytes, "big.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::format_error);
  EXPECT_TRUE(contains(r.status().message(),
                       "big.modrt: section " + std::to_string(i) + " (Td_b, shape 1 (dead_end))"))
      << r.status().message();
  EXPECT_TRUE(contains(r.status().message(), "byte size")) << r.status().message();
}

TEST(DictionaryIo, OffsetPastTheEnd) {
  std::vector<std::byte> bytes = serialized(make_dictionary());
  const std::size_t i = find_section(bytes, DictionarySectionKind::Ubvol, 5);
  put_u64(bytes, entry_at(i) + 24, bytes.size() + 16);
  reseal(bytes);
  Result<Dictionary> r = parse_dictionary(bytes, "off.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::format_error);
  EXPECT_TRUE(contains(r.status().message(), "section " + std::to_string(i) + " (Ubvol, shape 5 (crossing))"))
      << r.status().message();
  EXPECT_TRUE(contains(r.status().message(), "outside")) << r.status().message();
  // An offset that overflows offset + size.
  put_u64(bytes, entry_at(i) + 24, ~std::uint64_t(0) - 4);
  reseal(bytes);
  r = parse_dictionary(bytes, "off.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.status().message(), "outside")) << r.status().message();
}

TEST(DictionaryIo, RowsTimesColsOverflowing32Bits) {
  std::vector<std::byte> bytes = serialized(make_dictionary());
  const std::size_t i = find_section(bytes, DictionarySectionKind::Ub, 0);
  put_u32(bytes, entry_at(i) + 8, 0x10000u);
  put_u32(bytes, entry_at(i) + 12, 0x10001u);
  put_u64(bytes, entry_at(i) + 32, std::uint64_t(0x10000u) * 0x10001u * 4);
  reseal(bytes);
  Result<Dictionary> r = parse_dictionary(bytes, "dims.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::format_error);
  EXPECT_TRUE(contains(r.status().message(), "section " + std::to_string(i) +
                                                 " (Ub, shape 0 (closed)): is 65536x65537, expected 24x3"))
      << r.status().message();
  // Byte size consistent with 32-bit wrapped rows*cols: still refused.
  put_u32(bytes, entry_at(i) + 8, 0x10000u);
  put_u32(bytes, entry_at(i) + 12, 0x10000u);
  put_u64(bytes, entry_at(i) + 32, 0);
  reseal(bytes);
  EXPECT_FALSE(parse_dictionary(bytes, "dims.modrt").ok());
}

TEST(DictionaryIo, UnknownKindsDuplicatesAndMissingSections) {
  const std::vector<std::byte> good = serialized(make_dictionary());
  for (std::uint32_t kind : {7u, 24u, 99u, 0u}) {
    std::vector<std::byte> bytes = good;
    put_u32(bytes, entry_at(3), kind);
    reseal(bytes);
    Result<Dictionary> r = parse_dictionary(bytes, "k.modrt");
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), ErrorCode::format_error);
    EXPECT_TRUE(contains(r.status().message(), "unknown section kind " + std::to_string(kind)))
        << r.status().message();
  }
  {  // Limp relabelled as a second Ub (same dimensions).
    std::vector<std::byte> bytes = good;
    const std::size_t i = find_section(bytes, DictionarySectionKind::Limp, 2);
    put_u32(bytes, entry_at(i), std::uint32_t(DictionarySectionKind::Ub));
    reseal(bytes);
    Result<Dictionary> r = parse_dictionary(bytes, "dup.modrt");
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(contains(r.status().message(), "duplicate")) << r.status().message();
    EXPECT_TRUE(contains(r.status().message(), "Ub, shape 2 (corridor)")) << r.status().message();
  }
  {  // Table shortened by one entry: the last section (Ur_vec) is missing.
    std::vector<std::byte> bytes = good;
    put_u32(bytes, kSectionCountAt, get_u32(bytes, kSectionCountAt) - 1);
    reseal(bytes);
    Result<Dictionary> r = parse_dictionary(bytes, "short.modrt");
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), ErrorCode::format_error);
    EXPECT_TRUE(contains(r.status().message(), "missing section Ur")) << r.status().message();
  }
  {  // Hostile section count.
    std::vector<std::byte> bytes = good;
    put_u32(bytes, kSectionCountAt, 0xFFFFFFFFu);
    reseal(bytes);
    Result<Dictionary> r = parse_dictionary(bytes, "many.modrt");
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(contains(r.status().message(), "section count")) << r.status().message();
  }
  {  // Sections are found through the table, not by order: swapping two entries is fine.
    std::vector<std::byte> bytes = good;
    std::vector<std::byte> tmp(bytes.begin() + std::ptrdiff_t(entry_at(0)),
                               bytes.begin() + std::ptrdiff_t(entry_at(1)));
    std::copy(bytes.begin() + std::ptrdiff_t(entry_at(5)), bytes.begin() + std::ptrdiff_t(entry_at(6)),
              bytes.begin() + std::ptrdiff_t(entry_at(0)));
    std::copy(tmp.begin(), tmp.end(), bytes.begin() + std::ptrdiff_t(entry_at(5)));
    reseal(bytes);
    Result<Dictionary> r = parse_dictionary(bytes, "swapped.modrt");
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_bit_exact(make_dictionary(), r.value());
  }
}

TEST(DictionaryIo, InvalidSettingsInTheHeader) {
  std::vector<std::byte> bytes = serialized(make_dictionary());
  put_u32(bytes, 16, 0);  // settings.res
  reseal(bytes);
  Result<Dictionary> r = parse_dictionary(bytes, "res0.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::format_error);
  EXPECT_TRUE(contains(r.status().message(), "res0.modrt: header: settings.res = 0")) << r.status().message();
}

TEST(DictionaryIo, NanIsRefusedOnSaveAndOnLoad) {
  Dictionary d = make_dictionary();
  d.shapes[2].Td_b(1, 5) = std::numeric_limits<float>::quiet_NaN();
  TempDir dir;
  const Status s = save_dictionary(dir.file("nan.modrt"), d);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_TRUE(contains(s.message(), "shape 2 (corridor): Td_b[1,5] is NaN")) << s.message();
  EXPECT_FALSE(fs::exists(dir.file("nan.modrt")));

  // Hand-made: a NaN in a payload with valid checksums.
  std::vector<std::byte> bytes = serialized(make_dictionary());
  const std::size_t i = find_section(bytes, DictionarySectionKind::Td_b, 2);
  const std::size_t cols = get_u32(bytes, entry_at(i) + 12);
  put_u32(bytes, std::size_t(get_u64(bytes, entry_at(i) + 24)) + 4 * (1 * cols + 5), 0x7FC00000u);
  reseal(bytes);
  ASSERT_TRUE(write_file_atomic(dir.file("nan.modrt"), bytes).ok());
  Result<Dictionary> r = load_dictionary(dir.file("nan.modrt"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::non_finite);
  EXPECT_EQ(r.status().message(), dir.file("nan.modrt") + ": shape 2 (corridor): Td_b[1,5] is NaN");

  // A float16 infinity is caught the same way.
  bytes = serialized(make_dictionary(), true);
  const std::size_t j = find_section(bytes, DictionarySectionKind::R_left, kNoShape);
  const std::size_t at = std::size_t(get_u64(bytes, entry_at(j) + 24));
  bytes[at] = std::byte(0x00);
  bytes[at + 1] = std::byte(0xFC);  // -Inf in binary16
  reseal(bytes);
  r = parse_dictionary(bytes, "h.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::non_finite);
  EXPECT_EQ(r.status().message(), "h.modrt: interfaces: R_left[0,0] is -Inf");
}

TEST(DictionaryIo, LoadErrorsStartWithThePath) {
  TempDir dir;
  const std::string path = dir.file("missing.modrt");
  Result<Dictionary> r = load_dictionary(path);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::io_error);
  EXPECT_EQ(r.status().message().rfind(path, 0), 0u) << r.status().message();

  std::vector<std::byte> bytes = serialized(make_dictionary());
  bytes.resize(bytes.size() / 2);
  ASSERT_TRUE(write_file_atomic(dir.file("half.modrt"), bytes).ok());
  r = load_dictionary(dir.file("half.modrt"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().message().rfind(dir.file("half.modrt") + ": section ", 0), 0u) << r.status().message();
}

TEST(DictionaryIo, PeekReturnsTheSettings) {
  TempDir dir;
  const Dictionary d = make_dictionary();
  const std::string path = dir.file("peek.modrt");
  ASSERT_TRUE(save_dictionary(path, d).ok());
  Result<DictionarySettings> s = peek_dictionary_settings(path);
  ASSERT_TRUE(s.ok()) << s.status().to_string();
  EXPECT_EQ(s.value(), d.settings);

  std::vector<std::byte> bytes = serialized(d);
  bytes.resize(kDictionaryHeaderBytes - 1);
  ASSERT_TRUE(write_file_atomic(path, bytes).ok());
  s = peek_dictionary_settings(path);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), ErrorCode::format_error);
  EXPECT_FALSE(peek_dictionary_settings(dir.file("nothing")).ok());
}

TEST(DictionaryIo, SaveRefusesAnInvalidDictionary) {
  Dictionary d = make_dictionary();
  d.shapes[2].Ub = Matrix(16, 2);
  Result<std::vector<std::byte>> r = serialize_dictionary(d);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().message(), "dictionary: shape 2 (corridor): Ub is 16x2, expected 16x3");
  d = make_dictionary();
  d.shapes.pop_back();
  EXPECT_FALSE(serialize_dictionary(d).ok());
}

// --- FileIo ---

TEST(FileIo, Crc32CheckValue) {
  const char* check = "123456789";
  const auto bytes = std::as_bytes(std::span<const char>(check, 9));
  EXPECT_EQ(crc32(bytes), 0xCBF43926u);
  EXPECT_EQ(crc32(bytes.subspan(4), crc32(bytes.first(4))), 0xCBF43926u);
  EXPECT_EQ(crc32({}), 0u);
}

// Eight bytes at a time (slicing-by-8) against the bitwise definition, on every length from 0
// to 40 at every start offset 0..7 (the tail and the alignment paths) and in pieces.
TEST(FileIo, Crc32OfAnySliceIsTheBitwiseCrc) {
  std::vector<std::byte> data(48);
  std::uint32_t x = 12345;
  for (std::byte& b : data) b = std::byte((x = x * 1103515245u + 12345u) >> 24);
  auto bitwise = [](std::span<const std::byte> bytes) {
    std::uint32_t c = 0xFFFFFFFFu;
    for (std::byte b : bytes) {
      c ^= std::to_integer<std::uint32_t>(b);
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    }
    return c ^ 0xFFFFFFFFu;
  };
  const std::span<const std::byte> all(data);
  for (std::size_t at = 0; at < 8; ++at)
    for (std::size_t n = 0; at + n <= 40; ++n) {
      const std::span<const std::byte> slice = all.subspan(at, n);
      ASSERT_EQ(crc32(slice), bitwise(slice)) << "offset " << at << ", " << n << " bytes";
      ASSERT_EQ(crc32(slice.subspan(n / 3), crc32(slice.first(n / 3))), bitwise(slice));
    }
}

TEST(FileIo, AtomicWriteLeavesNoTemporaryFiles) {
  TempDir dir;
  ASSERT_TRUE(save_dictionary(dir.file("a.modrt"), make_dictionary()).ok());
  ASSERT_TRUE(save_dictionary(dir.file("a.modrt"), make_dictionary(false)).ok());  // overwrite
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir.path())) names.push_back(e.path().filename().string());
  ASSERT_EQ(names.size(), 1u);
  EXPECT_EQ(names[0], "a.modrt");
  Result<Dictionary> r = load_dictionary(dir.file("a.modrt"));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->settings.lightfield_spatial, 0u);
}

TEST(FileIo, CreatesMissingDirectories) {
  TempDir dir;
  const std::string path = (dir.path() / "x" / "y" / "z" / "d.modrt").string();
  ASSERT_TRUE(save_dictionary(path, make_dictionary()).ok());
  EXPECT_TRUE(load_dictionary(path).ok());
}

TEST(FileIo, UnwritablePathIsAnIoError) {
  const Status s = save_dictionary("/proc/forbidden/x", make_dictionary());
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), ErrorCode::io_error);
  EXPECT_TRUE(contains(s.message(), "/proc/forbidden")) << s.message();
  const std::byte one{1};
  EXPECT_EQ(write_file_atomic("/proc/forbidden/y", std::span<const std::byte>(&one, 1)).code(),
            ErrorCode::io_error);
}

// Issue 18 item 11: one rule with level files: bytes after the last section are refused.
TEST(DictionaryIo, TrailingBytesAreRefused) {
  std::vector<std::byte> bytes = serialized(make_dictionary());
  ASSERT_TRUE(parse_dictionary(bytes, "exact").ok());
  bytes.push_back(std::byte{0});
  Result<Dictionary> r = parse_dictionary(bytes, "appended.modrt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::format_error);
  EXPECT_TRUE(contains(r.status().message(), "appended.modrt: 1 trailing bytes after the last section"))
      << r.status().message();
  bytes.resize(bytes.size() + 4095);  // resealing does not help: no section covers them
  reseal(bytes);
  EXPECT_TRUE(contains(parse_dictionary(bytes, "x").status().message(), "4096 trailing bytes"));
}

// Issue 18 items 5 and 11 on the synthetic dictionary: FLT_MAX and 1e6 poked into an
// operator with the checksums resealed are refused naming it (test_operator_limits.cpp does
// the same on real baked files).
TEST(DictionaryIo, PokedOperatorIsRefusedNamingIt) {
  const std::vector<std::byte> clean = serialized(make_dictionary());
  for (const float value : {std::numeric_limits<float>::max(), 1e6f}) {
    std::vector<std::byte> bytes = clean;
    const std::size_t e = entry_at(find_section(bytes, DictionarySectionKind::Ubvol, 3));
    put_u32(bytes, std::size_t(get_u64(bytes, e + 24)) + 4 * 2, std::bit_cast<std::uint32_t>(value));
    reseal(bytes);
    Result<Dictionary> r = parse_dictionary(bytes, "poked.modrt");
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), ErrorCode::invalid_argument);
    EXPECT_TRUE(contains(r.status().message(), "poked.modrt: shape 3 (corner): Ubvol[0,2]: |Ubvol| = "))
        << r.status().message();
    EXPECT_TRUE(contains(r.status().message(), "above the limit")) << r.status().message();
  }
}

TEST(FileIo, ReadFileEnforcesTheLimit) {
  TempDir dir;
  const std::vector<std::byte> data(1000, std::byte{7});
  ASSERT_TRUE(write_file_atomic(dir.file("f"), data).ok());
  Result<std::vector<std::byte>> r = read_file(dir.file("f"), 1000);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r.value(), data);
  r = read_file(dir.file("f"), 999);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::resource_limit);
  EXPECT_TRUE(contains(r.status().message(), "1000")) << r.status().message();
  EXPECT_TRUE(contains(r.status().message(), "999")) << r.status().message();
  EXPECT_EQ(read_file(dir.file("nope"), 10).status().code(), ErrorCode::io_error);
  EXPECT_EQ(read_file(dir.path().string(), 10).status().code(), ErrorCode::io_error);
  // Issue 18 item 11: a directory is named as such (never a size of LONG_MAX).
  for (const Status& s :
       {read_file(dir.path().string(), 10).status(), load_dictionary(dir.path().string()).status(),
        read_file_prefix(dir.path().string(), 10).status()})
    EXPECT_TRUE(contains(s.message(), dir.path().string() + ": cannot read: a directory, not a regular file"))
        << s.message();
  Result<std::vector<std::byte>> prefix = read_file_prefix(dir.file("f"), 10);
  ASSERT_TRUE(prefix.ok());
  EXPECT_EQ(prefix->size(), 10u);
}

// --- DictionarySettingsValidation ---

TEST(DictionarySettingsValidation, DefaultsAreValid) {
  EXPECT_TRUE(validate_settings(DictionarySettings{}).ok())
      << validate_settings(DictionarySettings{}).to_string();
  EXPECT_TRUE(validate_settings(small_settings()).ok());
}

TEST(DictionarySettingsValidation, BadValuesNameTheField) {
  auto expect_bad = [](DictionarySettings s, const std::string& field) {
    const Status st = validate_settings(s);
    ASSERT_FALSE(st.ok()) << field;
    EXPECT_EQ(st.code(), ErrorCode::invalid_argument) << field;
    EXPECT_TRUE(contains(st.message(), "settings." + field + " = ")) << st.message();
  };
  DictionarySettings s;
  s.res = 0;
  expect_bad(s, "res");
  EXPECT_EQ(validate_settings(s).message(), "settings.res = 0: must be in [1, 256]");
  s = {};
  s.res = 257;
  expect_bad(s, "res");
  s = {};
  s.rays = 0;
  expect_bad(s, "rays");
  s = {};
  s.kb = s.kd + 1;
  expect_bad(s, "kb");
  s = {};
  s.kd = 0;
  expect_bad(s, "kd");
  s = {};
  s.light_radius = std::numeric_limits<float>::quiet_NaN();
  expect_bad(s, "light_radius");
  s = {};
  s.light_radius = 0.5f;
  expect_bad(s, "light_radius");
  s = {};
  s.probe_grid = 33;
  expect_bad(s, "probe_grid");
  s = {};
  s.enrichment_iterations = 17;
  expect_bad(s, "enrichment_iterations");
  s = {};
  s.sh_rays = 0;
  expect_bad(s, "sh_rays");
  s = {};
  s.rays = kMaxSettingsRays + 1;  // issue 18: every count has an upper bound
  expect_bad(s, "rays");
  s = {};
  s.sh_rays = 4294967295u;
  expect_bad(s, "sh_rays");
  s = {};
  s.prior_grid = kMaxSettingsPriorGrid + 1;
  expect_bad(s, "prior_grid");
  s = {};
  s.light_samples = kMaxSettingsLightSamples + 1;
  expect_bad(s, "light_samples");
  s = {};
  s.kd = kMaxSettingsModes + 1;
  s.kb = 1;
  expect_bad(s, "kd");
  s = {};
  s.response_rays = kMaxSettingsRays + 1;
  expect_bad(s, "response_rays");
  s = {};
  s.krlf = 0;
  expect_bad(s, "krlf");
  s.lightfield_spatial = 0;  // interface settings are unused then
  EXPECT_TRUE(validate_settings(s).ok());
}

TEST(DictionarySettingsValidation, DictionaryShapesAndInterfaces) {
  Dictionary d = make_dictionary();
  EXPECT_TRUE(validate_dictionary(d, "d").ok());
  d.shapes[1].face_mask = kAllFaces;
  EXPECT_FALSE(validate_dictionary(d, "d").ok());
  d = make_dictionary();
  d.shapes[1].Rb_rlf[kFaceNegZ] = Matrix();
  Status s = validate_dictionary(d, "d");
  EXPECT_EQ(s.message(), "d: shape 1 (dead_end): Rb_rlf(-Z) is 0x0, expected 4x3");
  d = make_dictionary();
  d.interfaces = {};
  s = validate_dictionary(d, "d");
  EXPECT_EQ(s.message(), "d: interfaces: R_straight is 0x0, expected 4x4");
  d = make_dictionary();
  d.shapes[0].sigma_M.assign(25, 1.0f);  // n = 24
  EXPECT_FALSE(validate_dictionary(d, "d").ok());
  d = make_dictionary(false);
  d.shapes[0].Ubvol.data[3] = std::numeric_limits<float>::infinity();
  s = validate_dictionary(d, "d");
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_EQ(s.message(), "d: shape 0 (closed): Ubvol[1,0] is +Inf");
}

}  // namespace
}  // namespace modrt
