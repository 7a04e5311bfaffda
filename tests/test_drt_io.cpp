// SPDX-License-Identifier: MIT
// The DRT operator file (core/drt_io.h): operators with every part built (vector, probe and
// clutter-to-clutter operators included) load back field for field and give the same delta,
// and every kind of damage is refused with a message naming the part.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "binary_test_support.h"
#include "drt_test_support.h"
#include "modrt/drt_io.h"
#include "modrt/file_io.h"

namespace modrt::precompute::drt_test {
namespace {

using modrt::test::put_u32;
void reseal(std::vector<std::byte>& b) { modrt::test::reseal_sealed_file(b); }

void expect_same_matrix(const Matrix& a, const Matrix& b, const std::string& what) {
  EXPECT_EQ(a.rows, b.rows) << what;
  EXPECT_EQ(a.cols, b.cols) << what;
  EXPECT_EQ(a.data, b.data) << what;
}

// Every field of DrtObjectOperators (drt.h), compared.
void expect_same_object(const DrtObjectOperators& a, const DrtObjectOperators& b) {
  EXPECT_EQ(a.texel_count, b.texel_count);
  EXPECT_EQ(a.face_count, b.face_count);
  EXPECT_EQ(a.dUb_sample, b.dUb_sample);
  EXPECT_EQ(a.dUb_block, b.dUb_block);
  expect_same_matrix(a.dUb, b.dUb, "dUb");
  expect_same_matrix(a.Td_c, b.Td_c, "Td_c");
  EXPECT_EQ(a.dUc_sample, b.dUc_sample);
  expect_same_matrix(a.dUc, b.dUc, "dUc");
  EXPECT_EQ(a.Cb_blocks, b.Cb_blocks);
  expect_same_matrix(a.Uc, b.Uc, "Uc");
  expect_same_matrix(a.Vc, b.Vc, "Vc");
  EXPECT_EQ(a.Cb_sigma, b.Cb_sigma);
  EXPECT_EQ(a.Cb_truncation_error, b.Cb_truncation_error);
  EXPECT_EQ(a.Cc_objects, b.Cc_objects);
  expect_same_matrix(a.Cc, b.Cc, "Cc");
  EXPECT_EQ(a.dUb_vec_sample, b.dUb_vec_sample);
  EXPECT_EQ(a.dUb_vec_block, b.dUb_vec_block);
  expect_same_matrix(a.dUb_vec, b.dUb_vec, "dUb_vec");
  EXPECT_EQ(a.dUc_vec_sample, b.dUc_vec_sample);
  expect_same_matrix(a.dUc_vec, b.dUc_vec, "dUc_vec");
  EXPECT_EQ(a.Udyn_probe, b.Udyn_probe);
  EXPECT_EQ(a.Udyn_block, b.Udyn_block);
  expect_same_matrix(a.Udyn, b.Udyn, "Udyn");
  EXPECT_EQ(a.Udyn_c_probe, b.Udyn_c_probe);
  expect_same_matrix(a.Udyn_c, b.Udyn_c, "Udyn_c");
  EXPECT_EQ(a.Cb_vec_blocks, b.Cb_vec_blocks);
  expect_same_matrix(a.Uc_vec, b.Uc_vec, "Uc_vec");
  expect_same_matrix(a.Vc_vec, b.Vc_vec, "Vc_vec");
  EXPECT_EQ(a.Cb_vec_truncation_error, b.Cb_vec_truncation_error);
  EXPECT_EQ(a.Cc_vec_objects, b.Cc_vec_objects);
  expect_same_matrix(a.Cc_vec, b.Cc_vec, "Cc_vec");
  EXPECT_EQ(a.texel_position, b.texel_position);
  EXPECT_EQ(a.texel_normal, b.texel_normal);
  EXPECT_EQ(a.cell_res, b.cell_res);
  EXPECT_EQ(a.texel_cell, b.texel_cell);
  for (const auto& [x, y, what] : {std::tuple(&a.Gs, &b.Gs, "Gs"), std::tuple(&a.Gt, &b.Gt, "Gt"),
                                   std::tuple(&a.Hs, &b.Hs, "Hs"), std::tuple(&a.Ht, &b.Ht, "Ht")}) {
    EXPECT_EQ(x->start, y->start) << what;
    EXPECT_EQ(x->index, y->index) << what;
    EXPECT_EQ(x->weight, y->weight) << what;
  }
  EXPECT_EQ(a.H_sample, b.H_sample);
}

struct Built {
  ClutterScene scene;
  Level level;
  DrtOperators drt;
};
const Built& built() {
  static const Built b = [] {
    Built out;
    out.scene = two_boxes_in_a_row();
    out.level = build_level(out.scene.description, dict()).value();
    DrtBuildSettings settings = paper_operators();
    settings.rays = 256;
    settings.vector = true;
    settings.probes = true;
    out.drt = DrtBuilder(out.level, dict(), settings).build(out.scene.clutter).value();
    // And the gather's rows on the same objects (an operator set may carry both), so that
    // every field of the file is exercised.
    settings.gather = true;
    const DrtOperators gather = DrtBuilder(out.level, dict(), settings).build(out.scene.clutter).value();
    for (std::size_t k = 0; k < gather.objects.size(); ++k) {
      DrtObjectOperators& o = out.drt.objects[k];
      const DrtObjectOperators& g = gather.objects[k];
      o.Gs = g.Gs, o.Gt = g.Gt, o.H_sample = g.H_sample, o.Hs = g.Hs, o.Ht = g.Ht;
    }
    return out;
  }();
  return b;
}

TEST(DrtFile, OperatorsRoundTripAndGiveTheSameDelta) {
  const Built& b = built();
  const DrtOperators& drt = b.drt;
  ASSERT_EQ(drt.objects.size(), 2u);
  // Every part was built, so a field the file left out could not go unnoticed.
  ASSERT_FALSE(drt.objects[1].Cc.empty());
  ASSERT_FALSE(drt.objects[0].dUb_vec.empty());
  ASSERT_FALSE(drt.objects[0].Udyn.empty());
  ASSERT_FALSE(drt.objects[0].Uc_vec.empty());
  ASSERT_FALSE(drt.objects[0].Cb_sigma.empty());
  ASSERT_FALSE(drt.objects[0].texel_position.empty());
  ASSERT_EQ(drt.objects[0].texel_cell.size(), 3 * std::size_t(drt.objects[0].texel_count));
  ASSERT_GT(drt.objects[0].cell_res, 0u);
  ASSERT_GT(drt.probes_per_block, 0u);
  ASSERT_FALSE(drt.objects[0].Gs.empty());
  ASSERT_FALSE(drt.objects[0].Gt.empty());  // the two boxes see each other
  ASSERT_FALSE(drt.objects[0].H_sample.empty());

  const std::vector<std::byte> bytes = serialize_drt(drt).value();
  Result<DrtOperators> back = parse_drt(bytes, "two_boxes.modrtdrt");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->kb, drt.kb);
  EXPECT_EQ(back->probes_per_block, drt.probes_per_block);
  ASSERT_EQ(back->objects.size(), drt.objects.size());
  for (std::size_t i = 0; i < drt.objects.size(); ++i) {
    SCOPED_TRACE("object " + std::to_string(i));
    expect_same_object(back->objects[i], drt.objects[i]);
  }
  EXPECT_EQ(serialize_drt(back.value()).value(), bytes);
  ASSERT_TRUE(check_drt_operators(b.level, back.value()).ok());

  // The delta of a frame: bit-identical.
  std::vector<float> ld(3 * std::size_t(b.level.sample_count));
  for (std::size_t i = 0; i < ld.size(); ++i) ld[i] = float((i * 37) % 101) / 101.0f;
  const Frame f = evaluate_mrt(b.level, ld);
  const DrtBufferSizes sz = drt_buffer_sizes(drt);
  std::vector<float> clutter_ld(sz.clutter_ld, 0.3f), c(sz.c), c_back(sz.c);
  ASSERT_TRUE(drt_compute_c(drt, clutter_ld, c).ok());
  ASSERT_TRUE(drt_compute_c(back.value(), clutter_ld, c_back).ok());
  std::vector<float> lm = f.lightmap, lm_back = f.lightmap;
  drt_apply(b.level, drt, f.b, c, lm);
  drt_apply_gather(drt, ld, clutter_ld, lm);
  drt_apply(b.level, back.value(), f.b, c_back, lm_back);
  drt_apply_gather(back.value(), ld, clutter_ld, lm_back);
  EXPECT_EQ(lm, lm_back);
  EXPECT_NE(lm, f.lightmap);

  // Through a file, written atomically.
  const std::string path =
      (std::filesystem::path(MODRT_TEST_CACHE_DIR) / "drt_io" / "two_boxes.modrtdrt").string();
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  ASSERT_TRUE(save_drt(path, drt).ok());
  Result<DrtOperators> loaded = load_drt(path);
  ASSERT_TRUE(loaded.ok()) << loaded.status().to_string();
  EXPECT_EQ(serialize_drt(loaded.value()).value(), bytes);
}

TEST(DrtFile, DamageIsRefusedNamingThePart) {
  const std::vector<std::byte> good = serialize_drt(built().drt).value();
  const auto expect_refused = [](const std::vector<std::byte>& bytes, ErrorCode code,
                                 const std::string& part) {
    Result<DrtOperators> r = parse_drt(bytes, "asset.modrtdrt");
    ASSERT_FALSE(r.ok()) << "accepted a file that should fail with " << part;
    EXPECT_EQ(r.status().code(), code) << r.status().to_string();
    EXPECT_NE(r.status().message().find("asset.modrtdrt"), std::string::npos) << r.status().message();
    EXPECT_NE(r.status().message().find(part), std::string::npos) << r.status().message();
  };
  expect_refused({}, ErrorCode::format_error, "shorter than");
  std::vector<std::byte> b = good;
  b[3] = std::byte('X');
  expect_refused(b, ErrorCode::format_error, "bad magic");
  b = good;
  put_u32(b, 8, kDrtFileVersion + 1);
  reseal(b);
  expect_refused(b, ErrorCode::version_mismatch, "rebuild the clutter operators");
  b = good;
  put_u32(b, 8, 3);  // before the gather
  reseal(b);
  expect_refused(b, ErrorCode::version_mismatch, "format version 3, this build reads 4");
  b = good;
  b[20] ^= std::byte(1);  // object count, header checksum not updated
  expect_refused(b, ErrorCode::checksum_mismatch, "header checksum");
  b = good;
  b[kDrtFileHeaderBytes + 40] ^= std::byte(0x10);
  expect_refused(b, ErrorCode::checksum_mismatch, "body checksum");
  b = good;
  b.resize(b.size() - 5);
  expect_refused(b, ErrorCode::format_error, "truncated");
  b = good;
  put_u32(b, 40, 7);
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "reserved");
  // A huge object count behind valid checksums: refused before allocating.
  b = good;
  put_u32(b, 20, 0xFFFFFFF0u);
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "objects");
  // One object more than the body holds: the decoder runs out of bytes naming the field.
  b = good;
  put_u32(b, 20, 3);
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "object 2");
  // Trailing bytes.
  b = good;
  b.insert(b.end(), 4, std::byte(0));
  put_u32(b, 48, std::uint32_t(b.size() - kDrtFileHeaderBytes));
  reseal(b);
  expect_refused(b, ErrorCode::format_error, "trailing bytes");
  // NaN smuggled into object 0's dUb behind valid checksums; and refused on write.
  const DrtObjectOperators& o = built().drt.objects[0];
  const std::size_t at =
      kDrtFileHeaderBytes + 12 + (4 + 4 * o.dUb_sample.size()) + (4 + 4 * o.dUb_block.size()) + 8;
  b = good;
  ASSERT_LT(at + 4, b.size());
  std::uint32_t stored = 0;
  for (int k = 0; k < 4; ++k) stored |= std::to_integer<std::uint32_t>(b[at + std::size_t(k)]) << (8 * k);
  ASSERT_EQ(stored, std::bit_cast<std::uint32_t>(o.dUb.data[0]));
  put_u32(b, at, 0x7FC00000u);
  reseal(b);
  expect_refused(b, ErrorCode::non_finite, "object 0 dUb has NaN or Inf");
  DrtOperators bad = built().drt;
  bad.objects[1].Vc.data[2] = std::numeric_limits<float>::infinity();
  Result<std::vector<std::byte>> written = serialize_drt(bad);
  ASSERT_FALSE(written.ok());
  EXPECT_EQ(written.status().code(), ErrorCode::non_finite);
  EXPECT_NE(written.status().message().find("object 1 Vc"), std::string::npos) << written.status().message();
}

// The fuzzer's seeds (tests/fuzz/corpus/drt_file) are valid files, so that mutations start from
// the decoder's accepting path: each parses and writes back byte for byte.
TEST(DrtFile, FuzzSeedsAreValidFiles) {
  for (const char* name : {"empty.modrtdrt", "one_box.modrtdrt", "two_objects.modrtdrt"}) {
    const std::string path = std::string(MODRT_CORPUS_DIR) + "/drt_file/" + name;
    Result<std::vector<std::byte>> bytes = read_file(path, kMaxDrtFileBytes);
    ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
    Result<DrtOperators> drt = parse_drt(bytes.value(), path);
    ASSERT_TRUE(drt.ok()) << drt.status().to_string();
    EXPECT_EQ(serialize_drt(drt.value()).value(), bytes.value()) << name;
  }
}

}  // namespace
}  // namespace modrt::precompute::drt_test
