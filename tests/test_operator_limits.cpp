// SPDX-License-Identifier: MIT
// Plausibility limits of baked operators (core operator_limits.h, issue 18 item 5): the real
// baked dictionaries and levels are within them (the measured maxima are printed; they are
// docs/robustness.md's table), and a file with valid checksums but FLT_MAX or a plausible-
// looking 1e6 poked into an operator is refused by the loader, naming the operator.
#include <gtest/gtest.h>

#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "binary_test_support.h"
#include "level_fixtures.h"
#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"
#include "modrt/level_io.h"
#include "modrt/level_runtime.h"
#include "modrt/operator_limits.h"

namespace modrt {
namespace {

std::string corpus(const std::string& name) { return std::string(MODRT_CORPUS_DIR) + "/" + name; }

using modrt::test::get_u32;
using modrt::test::get_u64;
using modrt::test::put_u32;

// Recomputes every CRC of a dictionary image: each section's, the table's, the header's.
void reseal_dictionary(std::vector<std::byte>& bytes) {
  const std::uint32_t sections = get_u32(bytes, 96);
  for (std::uint32_t i = 0; i < sections; ++i) {
    const std::size_t e = kDictionaryHeaderBytes + i * kDictionarySectionEntryBytes;
    const std::uint64_t offset = get_u64(bytes, e + 24), size = get_u64(bytes, e + 32);
    put_u32(bytes, e + 40, crc32(std::span<const std::byte>(bytes).subspan(offset, size)));
  }
  put_u32(bytes, 100,
          crc32(std::span<const std::byte>(bytes).subspan(kDictionaryHeaderBytes,
                                                          sections * kDictionarySectionEntryBytes)));
  put_u32(bytes, 108, crc32(std::span<const std::byte>(bytes).first(108)));
}

// Same for a level image (fuzz_level_file.cpp's reseal).
void reseal_level(std::vector<std::byte>& bytes) {
  put_u32(bytes, 56, crc32(std::span<const std::byte>(bytes).subspan(kLevelFileHeaderBytes)));
  put_u32(bytes, 60, crc32(std::span<const std::byte>(bytes).first(60)));
}

// Byte offset of entry `index` of section (kind, shape) in a float32 dictionary image.
std::size_t section_value_offset(const std::vector<std::byte>& bytes, DictionarySectionKind kind,
                                 std::uint32_t shape, std::size_t index) {
  const std::uint32_t sections = get_u32(bytes, 96);
  for (std::uint32_t i = 0; i < sections; ++i) {
    const std::size_t e = kDictionaryHeaderBytes + i * kDictionarySectionEntryBytes;
    if (get_u32(bytes, e) == std::uint32_t(kind) && get_u32(bytes, e + 4) == shape)
      return std::size_t(get_u64(bytes, e + 24)) + 4 * index;
  }
  ADD_FAILURE() << "no section " << dictionary_section_name(std::uint32_t(kind));
  return 0;
}

std::vector<std::byte> read_bytes(const std::string& path) {
  Result<std::vector<std::byte>> b = read_file(path, kMaxDictionaryFileBytes);
  EXPECT_TRUE(b.ok()) << b.status().to_string();
  return b.ok() ? b.value() : std::vector<std::byte>{};
}

// Largest value / limit per (operator, measure) over every shape, for the report.
void report(const std::string& name, const std::vector<OperatorMeasure>& measures,
            std::map<std::string, std::pair<double, double>>& worst) {
  for (const OperatorMeasure& m : measures) {
    EXPECT_LE(m.value, m.limit) << name << ": " << m.where << ": " << m.what;
    std::string key = m.what;
    if (m.where.rfind("interfaces", 0) == 0 || m.where.rfind("entry face", 0) == 0)
      key = m.where.substr(0, 12) + " " + key;
    auto& w = worst[key];
    if (m.value / m.limit > w.first / std::max(w.second, 1e-300) || w.second == 0.0) w = {m.value, m.limit};
  }
}

TEST(OperatorLimits, BakedDictionariesAndLevelsAreWithinTheLimits) {
  struct Named {
    std::string name;
    Dictionary dict;
  };
  std::vector<Named> dicts;
  dicts.push_back({"small test dictionary (res 8)", test::small_test_dictionary()});
  for (const char* file : {"tiny_interfaces.modrt", "tiny_no_interfaces.modrt", "tiny_float16.modrt"}) {
    Result<Dictionary> d = load_dictionary(corpus(std::string("dictionary/") + file));
    ASSERT_TRUE(d.ok()) << d.status().to_string();
    dicts.push_back({file, std::move(d).value()});
  }
  for (const Named& d : dicts) {
    std::map<std::string, std::pair<double, double>> worst;
    report(d.name, measure_dictionary_operators(d.dict), worst);
    std::printf("%s (prior scale %.4g):\n", d.name.c_str(), prior_scale(d.dict.settings));
    for (const auto& [what, w] : worst)
      std::printf("  %-40s max %-12.4g limit %-10.4g (%.3f of it)\n", what.c_str(), w.first, w.second,
                  w.first / w.second);
  }
  // Levels: their own operators and the ld -> output gain with their dictionary.
  std::vector<std::pair<std::string, std::pair<const Level*, const Dictionary*>>> levels;
  for (const test::TestLevel& t : test::test_levels())
    levels.push_back({t.name + " (small test dictionary)", {&t.level, &test::small_test_dictionary()}});
  std::vector<Level> corpus_levels;
  for (const char* file : {"corridor.modrtlevel", "l_corner.modrtlevel", "maze11.modrtlevel"}) {
    Result<Level> l = load_level(corpus(std::string("level_file/") + file));
    ASSERT_TRUE(l.ok()) << l.status().to_string();
    corpus_levels.push_back(std::move(l).value());
  }
  for (std::size_t i = 0; i < corpus_levels.size(); ++i)
    levels.push_back({std::string("corpus level ") + std::to_string(i) + " (tiny_interfaces)",
                      {&corpus_levels[i], &dicts[1].dict}});
  for (const auto& [name, p] : levels) {
    ASSERT_TRUE(check_level_operators(*p.first, *p.second).ok()) << name;
    std::map<std::string, std::pair<double, double>> worst;
    report(name, measure_level_operators(*p.first), worst);
    report(name, measure_level_gain(*p.first, *p.second), worst);
    std::printf("%s:\n", name.c_str());
    for (const auto& [what, w] : worst)
      std::printf("  %-40s max %-12.4g limit %-10.4g (%.3g of it)\n", what.c_str(), w.first, w.second,
                  w.first / w.second);
  }
}

// FLT_MAX and 1e6 poked into operators of a real dictionary, CRCs resealed: refused, naming
// the shape and operator.
TEST(OperatorLimits, PokedDictionaryOperatorIsRefusedNamingIt) {
  const std::vector<std::byte> clean = read_bytes(corpus("dictionary/tiny_interfaces.modrt"));
  ASSERT_TRUE(parse_dictionary(clean, "clean").ok());
  struct Case {
    DictionarySectionKind kind;
    std::uint32_t shape;
    float value;
    const char* expect;
  };
  const Case cases[] = {
      {DictionarySectionKind::Td_b, 1, FLT_MAX, "shape 1 (dead_end): Ub column 0 x Td_b row 0"},
      {DictionarySectionKind::Td_b, 1, 1e6f, "shape 1 (dead_end): Ub column 0 x Td_b row 0"},
      {DictionarySectionKind::Ub, 2, FLT_MAX, "shape 2"},
      {DictionarySectionKind::Ub, 2, 1e6f, "shape 2"},
      {DictionarySectionKind::Limp, 0, 1e6f, "Limp column 0"},
      {DictionarySectionKind::Ub_vec, 3, 1e6f, "Ub_vec[0,0]"},
      {DictionarySectionKind::Ubvol, 4, FLT_MAX, "Ubvol[0,0]"},
      {DictionarySectionKind::R_straight, kNoShape, 1e6f, "interfaces: R_straight[0,0]"},
      {DictionarySectionKind::Trlf_r, kNoShape, FLT_MAX, "interfaces: Trlf_r[0,0]"},
      {DictionarySectionKind::Ur, kNoShape, 1e6f, "interfaces: Ur[0,0]"},
  };
  for (const Case& c : cases) {
    std::vector<std::byte> bytes = clean;
    put_u32(bytes, section_value_offset(bytes, c.kind, c.shape, 0), std::bit_cast<std::uint32_t>(c.value));
    reseal_dictionary(bytes);
    Result<Dictionary> d = parse_dictionary(bytes, "poked.modrt");
    ASSERT_FALSE(d.ok()) << dictionary_section_name(std::uint32_t(c.kind)) << " = " << c.value;
    EXPECT_EQ(d.status().code(), ErrorCode::invalid_argument);
    EXPECT_NE(d.status().message().find(c.expect), std::string::npos) << d.status().message();
    EXPECT_NE(d.status().message().find("above the limit"), std::string::npos) << d.status().message();
    std::printf("%s = %g: %s\n", dictionary_section_name(std::uint32_t(c.kind)), double(c.value),
                d.status().message().c_str());
  }
}

// The same for a level file: a record's T, resealed.
TEST(OperatorLimits, PokedLevelResponseIsRefusedNamingIt) {
  const std::vector<std::byte> clean = read_bytes(corpus("level_file/maze11.modrtlevel"));
  Result<Level> level = parse_level(clean, "clean");
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  ASSERT_FALSE(level->records.empty());
  // Record 0's T[0,0] from the layout (level_io.h): header, blocks, slots of 12 + 4 n bytes,
  // then record 0's four u32 fields.
  std::size_t at = kLevelFileHeaderBytes + kLevelFileBlockBytes * level->blocks.size();
  for (const ResponseSlot& slot : level->slots) at += 12 + 4 * slot.ur_row_to_sample.size();
  at += 16;
  ASSERT_LE(at + 4, clean.size());
  ASSERT_EQ(get_u32(clean, at), std::bit_cast<std::uint32_t>(level->records[0].T.data[0]));
  ASSERT_NE(at, 0u);
  for (float value : {FLT_MAX, 1e6f}) {
    std::vector<std::byte> bytes = clean;
    put_u32(bytes, at, std::bit_cast<std::uint32_t>(value));
    reseal_level(bytes);
    Result<Level> l = parse_level(bytes, "poked.modrtlevel");
    ASSERT_FALSE(l.ok()) << value;
    EXPECT_EQ(l.status().code(), ErrorCode::invalid_argument);
    EXPECT_NE(l.status().message().find("record 0: T["), std::string::npos) << l.status().message();
    std::printf("record 0 T = %g: %s\n", double(value), l.status().message().c_str());
  }
}

// A level whose chain gain would let ld <= kMaxLightValue overflow is refused at creation
// (check_level_operators), naming the output; the loader's per-operator limits alone
// allow it (every T entry at the limit).
TEST(OperatorLimits, LevelGainAboveTheBoundIsRefusedAtCreation) {
  Level level = test::test_level("maze41").level;
  for (ResponseRecord& rec : level.records)
    for (float& v : rec.T.data) v = float(kInterfaceEntryLimit);
  ASSERT_TRUE(serialize_level(level).ok());
  const Status s = check_level_operators(level, test::small_test_dictionary());
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("gain ld -> "), std::string::npos) << s.message();
  std::printf("%s\n", s.message().c_str());
}

// Padding copies a sample texel into a padding texel (MRT §6.2); a hand-made atlas whose
// padding reads padding, or writes over a sample, is refused at creation naming the record
// (the camera skip runs each block's records apart, level_dirty.h's atlas_block_padding).
TEST(OperatorLimits, PaddingThatCopiesPaddingIsRefusedAtCreation) {
  const Level& good = test::test_level("maze11").level;
  ASSERT_GE(good.atlas.padding.size(), 2u);
  Level level = good;
  level.atlas.padding[1].src = level.atlas.padding[0].dst;  // reads another record's destination
  Status s = check_level_operators(level, test::small_test_dictionary());
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("atlas padding record 1 does not copy a sample texel into a padding texel"),
            std::string::npos)
      << s.message();
  level = good;
  level.atlas.padding[3].dst = level.atlas.sample_texel[5];  // writes over a sample
  s = check_level_operators(level, test::small_test_dictionary());
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("atlas padding record 3"), std::string::npos) << s.message();
  EXPECT_TRUE(check_level_operators(good, test::small_test_dictionary()).ok());
}

}  // namespace
}  // namespace modrt
