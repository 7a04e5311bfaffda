// SPDX-License-Identifier: MIT
// The built-level file (core/level_io.h): a saved level loads back field for field and
// evaluates to bit-identical lightmaps, and every kind of damage is refused with a message
// that names the part and problem.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "binary_test_support.h"
#include "level_fixtures.h"
#include "modrt/file_io.h"
#include "modrt/level_io.h"

namespace modrt {
namespace {

std::vector<std::byte> serialized(const Level& level) {
  Result<std::vector<std::byte>> bytes = serialize_level(level);
  EXPECT_TRUE(bytes.ok()) << bytes.status().to_string();
  return bytes.ok() ? bytes.value() : std::vector<std::byte>{};
}

using modrt::test::put_u32;
void reseal(std::vector<std::byte>& b) { modrt::test::reseal_sealed_file(b); }

constexpr std::size_t kAlbedoOffset = kLevelFileBlockAlbedoOffset;
constexpr std::size_t kBlockBytes = kLevelFileBlockBytes;

void expect_same_matrix(const Matrix& a, const Matrix& b, const std::string& what) {
  EXPECT_EQ(a.rows, b.rows) << what;
  EXPECT_EQ(a.cols, b.cols) << what;
  ASSERT_EQ(a.data.size(), b.data.size()) << what;
  if (a.data.empty()) return;  // memcmp must not see the null data() of an empty vector
  EXPECT_EQ(0, std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float))) << what;
}

void expect_same_level(const Level& a, const Level& b) {
  EXPECT_EQ(a.res, b.res);
  EXPECT_EQ(a.kb, b.kb);
  EXPECT_EQ(a.kr, b.kr);
  EXPECT_EQ(a.sample_count, b.sample_count);
  ASSERT_EQ(a.blocks.size(), b.blocks.size());
  for (std::size_t i = 0; i < a.blocks.size(); ++i) {
    const LevelBlock &x = a.blocks[i], &y = b.blocks[i];
    EXPECT_EQ(x.shape, y.shape);
    EXPECT_EQ(x.quarter_turns, y.quarter_turns);
    EXPECT_EQ(x.cell, y.cell);
    EXPECT_EQ(x.corners, y.corners);
    EXPECT_EQ(x.neighbour, y.neighbour);
    EXPECT_EQ(x.sample_offset, y.sample_offset);
    EXPECT_EQ(x.sample_count, y.sample_count);
    EXPECT_EQ(x.albedo, y.albedo);
  }
  ASSERT_EQ(a.slots.size(), b.slots.size());
  for (std::size_t s = 0; s < a.slots.size(); ++s) {
    EXPECT_EQ(a.slots[s].block, b.slots[s].block);
    EXPECT_EQ(a.slots[s].entry_face, b.slots[s].entry_face);
    EXPECT_EQ(a.slots[s].ur_row_to_sample, b.slots[s].ur_row_to_sample);
  }
  ASSERT_EQ(a.records.size(), b.records.size());
  for (std::size_t r = 0; r < a.records.size(); ++r) {
    EXPECT_EQ(a.records[r].source_block, b.records[r].source_block);
    EXPECT_EQ(a.records[r].slot, b.records[r].slot);
    expect_same_matrix(a.records[r].T, b.records[r].T, "record " + std::to_string(r));
  }
  for (std::size_t f = 0; f < std::size_t(kFaceCount); ++f) {
    expect_same_matrix(a.probe_response[f], b.probe_response[f], "probe_response");
    expect_same_matrix(a.vector_response[f], b.vector_response[f], "vector_response");
  }
  EXPECT_EQ(a.atlas.width, b.atlas.width);
  EXPECT_EQ(a.atlas.height, b.atlas.height);
  EXPECT_EQ(a.atlas.tile, b.atlas.tile);
  EXPECT_EQ(a.atlas.sample_texel, b.atlas.sample_texel);
  EXPECT_EQ(a.atlas.tile_origin_x, b.atlas.tile_origin_x);
  EXPECT_EQ(a.atlas.tile_origin_y, b.atlas.tile_origin_y);
  ASSERT_EQ(a.atlas.padding.size(), b.atlas.padding.size());
  for (std::size_t p = 0; p < a.atlas.padding.size(); ++p) {
    EXPECT_EQ(a.atlas.padding[p].dst, b.atlas.padding[p].dst);
    EXPECT_EQ(a.atlas.padding[p].src, b.atlas.padding[p].src);
  }
}

TEST(LevelFile, RoundTripIsExactAndEvaluatesBitIdentically) {
  for (const char* name : {"single", "corridor", "maze11"}) {
    SCOPED_TRACE(name);
    const test::TestLevel& t = test::test_level(name);
    const std::vector<std::byte> bytes = serialized(t.level);
    Result<Level> back = parse_level(bytes, name);
    ASSERT_TRUE(back.ok()) << back.status().to_string();
    expect_same_level(t.level, back.value());
    // Serialization is a function of the level: the same bytes again.
    EXPECT_EQ(bytes, serialized(back.value()));

    const test::LevelReference want = test::level_reference(t.level, t.ld);
    const test::LevelReference got = test::level_reference(back.value(), t.ld);
    ASSERT_EQ(want.atlas.size(), got.atlas.size());
    ASSERT_FALSE(want.atlas.empty());
    ASSERT_FALSE(want.probes.empty());
    EXPECT_EQ(0, std::memcmp(want.atlas.data(), got.atlas.data(), want.atlas.size() * sizeof(float)));
    EXPECT_EQ(0, std::memcmp(want.probes.data(), got.probes.data(), want.probes.size() * sizeof(float)));
    EXPECT_TRUE(check_level_operators(back.value(), test::small_test_dictionary()).ok());
  }
}

TEST(LevelFile, SaveAndLoadThroughAFile) {
  const test::TestLevel& t = test::test_level("corridor");
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "modrt_test_level_io";
  const std::string path = (dir / "corridor.modrtlevel").string();
  ASSERT_TRUE(save_level(path, t.level).ok());
  Result<Level> back = load_level(path);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  expect_same_level(t.level, back.value());
  // No temporary file is left next to it (write_file_atomic).
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) files += entry.is_regular_file();
  EXPECT_EQ(files, 1);
  std::filesystem::remove_all(dir);

  Result<Level> missing = load_level((dir / "missing.modrtlevel").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), ErrorCode::io_error);
  EXPECT_NE(missing.status().message().find("missing.modrtlevel"), std::string::npos);
}

struct Damage {
  const char* what;
  ErrorCode code;
  const char* message_part;
};

TEST(LevelFile, DamagedFilesAreRefusedWithNamedErrors) {
  const test::TestLevel& t = test::test_level("corridor");
  const std::vector<std::byte> good = serialized(t.level);
  auto expect_refused = [](const std::vector<std::byte>& bytes, ErrorCode code, const std::string& part) {
    Result<Level> r = parse_level(bytes, "asset.modrtlevel");
    ASSERT_FALSE(r.ok()) << "accepted a file that should fail with " << part;
    EXPECT_EQ(r.status().code(), code) << r.status().to_string();
    EXPECT_NE(r.status().message().find("asset.modrtlevel"), std::string::npos) << r.status().message();
    EXPECT_NE(r.status().message().find(part), std::string::npos) << r.status().message();
  };

  expect_refused({}, ErrorCode::format_error, "shorter than");
  std::vector<std::byte> b = good;
  b[0] = std::byte('X');
  expect_refused(b, ErrorCode::format_error, "bad magic");
  b = good;
  put_u32(b, 8, kLevelFileVersion + 1);
  reseal(b);
  expect_refused(b, ErrorCode::version_mismatch, "rebuild the level with modrt-level --save");
  // Version 1 (before per-face albedo) is refused by name, not decoded with a shifted layout.
  b = good;
  put_u32(b, 8, 1);
  reseal(b);
  expect_refused(b, ErrorCode::version_mismatch, "version 1 has no per-face albedo");
  b = good;
  put_u32(b, 8, 2);
  reseal(b);
  expect_refused(b, ErrorCode::version_mismatch, "version 2 has no shaped operators");
  b = good;
  b[20] ^= std::byte(1);  // kb, header checksum not updated
  expect_refused(b, ErrorCode::checksum_mismatch, "header checksum");
  b = good;
  b[kLevelFileHeaderBytes + 100] ^= std::byte(0x10);
  expect_refused(b, ErrorCode::checksum_mismatch, "body checksum");
  b = good;
  b.resize(b.size() - 3);
  expect_refused(b, ErrorCode::format_error, "truncated");

  // A huge block count behind valid checksums: refused before allocating.
  b = good;
  put_u32(b, 28, 0xFFFFFFF0u);
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "blocks");
  // One more block than the body holds: the decoder runs out of bytes and names the field.
  b = good;
  put_u32(b, 28, std::uint32_t(t.level.blocks.size() + 1));
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "");
  // kb disagreeing with the records' T.
  b = good;
  put_u32(b, 20, t.level.kb + 1);
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "not kr x kb");
  // Block 0's shape out of range.
  b = good;
  put_u32(b, kLevelFileHeaderBytes, 9);
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "block 0: shape 9");
  // The shaped operator count (once a reserved field: fuzz_level_file found a file that was
  // accepted with it set) past what the body holds.
  b = good;
  put_u32(b, 44, 0x540000u);
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "shaped operators");
  // Trailing bytes.
  b = good;
  b.insert(b.end(), 4, std::byte(0));
  const std::uint64_t body = b.size() - kLevelFileHeaderBytes;
  put_u32(b, 48, std::uint32_t(body));
  put_u32(b, 52, std::uint32_t(body >> 32));
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "trailing bytes");
}

TEST(LevelFile, NonFiniteValuesAreRefusedOnWriteAndRead) {
  Level level = test::test_level("corridor").level;
  ASSERT_FALSE(level.records.empty());
  const float good_value = level.records[0].T.data[0];
  level.records[0].T.data[0] = std::nanf("");
  Result<std::vector<std::byte>> written = serialize_level(level);
  ASSERT_FALSE(written.ok());
  EXPECT_EQ(written.status().code(), ErrorCode::non_finite);
  EXPECT_NE(written.status().message().find("record 0"), std::string::npos);

  // The same NaN smuggled into a file with valid checksums.
  level.records[0].T.data[0] = good_value;
  std::vector<std::byte> b = serialized(level);
  // Record 0's first value: after the blocks (kBlockBytes each), the slots (12 bytes plus
  // their row maps) and the record's source block, slot, rows and cols.
  std::size_t at = kLevelFileHeaderBytes + level.blocks.size() * kBlockBytes;
  for (const ResponseSlot& slot : level.slots) at += 12 + 4 * slot.ur_row_to_sample.size();
  at += 16;
  ASSERT_LT(at + 4, b.size());
  std::uint32_t stored = 0;
  for (int k = 0; k < 4; ++k) stored |= std::to_integer<std::uint32_t>(b[at + std::size_t(k)]) << (8 * k);
  ASSERT_EQ(stored, std::bit_cast<std::uint32_t>(good_value));
  put_u32(b, at, 0x7FC00000u);
  reseal(b);
  Result<Level> r = parse_level(b, "nan.modrtlevel");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::non_finite) << r.status().to_string();
}

TEST(LevelFile, PerFaceAlbedoRoundTripsAndIsChecked) {
  // The authored per-face albedo (level JSON) is what a loaded level reflects with: corridor's
  // red and green walls survive the file, and every sample of a face carries its face's albedo.
  const test::TestLevel& t = test::test_level("corridor");
  Result<Level> back = parse_level(serialized(t.level), "corridor.modrtlevel");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(level_sample_albedo(back.value()), t.albedo);
  bool coloured = false;
  for (const LevelBlock& blk : back->blocks)
    for (const glm::vec3& a : blk.albedo) coloured = coloured || a.r != a.g;
  EXPECT_TRUE(coloured) << "corridor's coloured walls were lost";

  // Out of [0, 1] or not finite: refused on write and on read, naming block, face and channel.
  Level bad = t.level;
  bad.blocks[1].albedo[3].g = 1.5f;
  Result<std::vector<std::byte>> written = serialize_level(bad);
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.status().message().find("block 1: albedo of face 3 channel 1 is 1.5"), std::string::npos)
      << written.status().message();
  std::vector<std::byte> b = serialized(t.level);
  put_u32(b, kLevelFileHeaderBytes + kAlbedoOffset + 4 * 2, 0x7F800000u);  // block 0, face 0, blue: +Inf
  reseal(b);
  Result<Level> r = parse_level(b, "inf.modrtlevel");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::non_finite) << r.status().to_string();
  EXPECT_NE(r.status().message().find("block 0: albedo of face 0 channel 2"), std::string::npos)
      << r.status().message();
  put_u32(b, kLevelFileHeaderBytes + kAlbedoOffset + 4 * 2, std::bit_cast<std::uint32_t>(-0.25f));
  reseal(b);
  r = parse_level(b, "negative.modrtlevel");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), ErrorCode::format_error) << r.status().to_string();
}

}  // namespace
}  // namespace modrt
