// SPDX-License-Identifier: MIT
// Interfaces of shaped blocks (shaped_interfaces.h): the unit box reproduces the dictionary's
// canonical operators in every orientation, free-space transport through a box matches the
// analytic form factor of its end faces, a connected stretched block is built with its box's
// interfaces, and the interface basis round-trips through its cache file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include "compare_support.h"
#include "modrt/level_geometry.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/interfaces.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/linalg.h"
#include "modrt/precompute/matrix_file.h"
#include "modrt/precompute/shaped_interfaces.h"
#include "test_support.h"

namespace modrt::precompute {
namespace {

constexpr int kSides[4] = {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ};

double relative_difference(const Matrix& a, const Matrix& b) {
  EXPECT_EQ(a.rows, b.rows);
  EXPECT_EQ(a.cols, b.cols);
  if (a.rows != b.rows || a.cols != b.cols) return 1e30;
  return (to_eigen(a) - to_eigen(b)).norm() / std::max(to_eigen(b).norm(), 1e-30);
}

TEST(ShapedInterfaces, UnitBoxReproducesTheDictionaryInEveryOrientation) {
  const Dictionary& dict = test::small_test_dictionary();
  const Matrix& Hrlf = test::small_test_interface_basis();
  const int crossing = 5;  // all four side faces missing: every (entry, exit) pair
  const ShapedInterfaces box =
      bake_shaped_interfaces(dict, Hrlf, crossing, glm::dvec3(1.0), dict.shapes[crossing].Limp);
  const Matrix* R[3] = {&dict.interfaces.R_straight, &dict.interfaces.R_left, &dict.interfaces.R_right};
  for (int e : kSides) {
    // The dictionary's Rb->rlf came from the double Limp, this one from the stored floats;
    // R is traced turned to the dictionary's orientation, so it matches to float precision.
    EXPECT_LT(relative_difference(box.Rb_rlf[e], dict.shapes[crossing].Rb_rlf[e]), 1e-3) << "face " << e;
    EXPECT_LT(relative_difference(box.Trlf_r[e], dict.interfaces.Trlf_r), 1e-3) << "entry " << e;
    for (int x : kSides) {
      if (x == e) continue;
      Propagation dir;
      ASSERT_TRUE(classify_propagation(e, x, dir));
      EXPECT_LT(relative_difference(box.R[e][x], *R[int(dir)]), 1e-6) << "entry " << e << " exit " << x;
    }
  }
}

// Form factor between two directly opposed, equal a x b rectangles at distance c (Howell's
// catalogue, C-11).
double parallel_rectangles(double a, double b, double c) {
  const double X = a / c, Y = b / c, X2 = X * X, Y2 = Y * Y;
  return 2.0 / (std::numbers::pi * X * Y) *
         (0.5 * std::log((1 + X2) * (1 + Y2) / (1 + X2 + Y2)) +
          X * std::sqrt(1 + Y2) * std::atan(X / std::sqrt(1 + Y2)) +
          Y * std::sqrt(1 + X2) * std::atan(Y / std::sqrt(1 + X2)) - X * std::atan(X) - Y * std::atan(Y));
}

TEST(ShapedInterfaces, StraightTransportThroughABoxIsTheFormFactorOfItsEnds) {
  // Uniform radiance entering through -Z; the mean over the exit's bins (equal area, equal
  // projected solid angle) is the fraction of the entry's flux reaching +Z: F(-Z -> +Z).
  InterfaceSettings s;
  s.spatial = 8;
  s.directional = 24;
  s.supersample = 3;
  for (const glm::dvec3 extent : {glm::dvec3(1.0), glm::dvec3(0.8, 0.8, 2.4), glm::dvec3(2.0, 1.0, 0.5)}) {
    const SparseRowMatrix P = box_propagation_operator(extent, kFaceNegZ, kFacePosZ, s);
    const VectorXd out = P * VectorXd::Ones(P.cols());
    const double expected = parallel_rectangles(extent.x, extent.y, extent.z);
    EXPECT_NEAR(out.mean(), expected, 0.02 * expected + 0.003)
        << "box " << extent.x << " x " << extent.y << " x " << extent.z;
    // The side exit of the same box gets the rest that leaves through a side (no walls).
    const VectorXd side =
        box_propagation_operator(extent, kFaceNegZ, kFacePosX, s) * VectorXd::Ones(P.cols());
    EXPECT_GT(side.mean(), 0.0);
  }
  // Rotations: entering through +X of the box turned a quarter is entering -Z of this one.
  const glm::dvec3 box(0.8, 1.0, 2.4);
  const VectorXd a = box_propagation_operator(box, kFaceNegZ, kFacePosZ, s) *
                     VectorXd::Ones(s.spatial * s.spatial * s.directional * s.directional);
  const int turned_entry = rotate_face(kFaceNegZ, 1), turned_exit = rotate_face(kFacePosZ, 1);
  const VectorXd b = box_propagation_operator(glm::dvec3(box.z, box.y, box.x), turned_entry, turned_exit, s) *
                     VectorXd::Ones(a.size());
  EXPECT_NEAR(a.mean(), b.mean(), 1e-9);
}

TEST(ShapedInterfaces, ALongerBoxPassesLessAndLightsItsDeadEndLess) {
  const Dictionary& dict = test::small_test_dictionary();
  const Matrix& Hrlf = test::small_test_interface_basis();
  const int corridor = 2;  // -Z and +Z missing
  const glm::dvec3 cube(1.0), long_box(0.7, 0.7, 2.0);
  const ShapedInterfaces unit =
      bake_shaped_interfaces(dict, Hrlf, corridor, cube, dict.shapes[corridor].Limp);
  const ShapedInterfaces stretched =
      bake_shaped_interfaces(dict, Hrlf, corridor, long_box, dict.shapes[corridor].Limp);
  // The straight operator's norm: the long box passes a smaller solid angle.
  const double unit_pass = to_eigen(unit.R[kFaceNegZ][kFacePosZ]).norm();
  const double long_pass = to_eigen(stretched.R[kFaceNegZ][kFacePosZ]).norm();
  EXPECT_LT(long_pass, 0.8 * unit_pass);
  // Light entering a long dead end lights its walls less than a cube's per unit radiance...
  // but the response is not empty and has the sizes the records need.
  EXPECT_EQ(stretched.Trlf_r[kFaceNegZ].rows, dict.interfaces.Trlf_r.rows);
  EXPECT_EQ(stretched.Trlf_r[kFaceNegZ].cols, dict.interfaces.Trlf_r.cols);
  EXPECT_GT(to_eigen(stretched.Trlf_r[kFaceNegZ]).norm(), 0.1 * to_eigen(unit.Trlf_r[kFaceNegZ]).norm());
  EXPECT_TRUE(stretched.R[kFaceNegX][kFacePosZ].empty());  // -X is a wall of the corridor
}

// Two 1 x 1 x 3 blocks joined end to end (a 1 x 1 x 6 corridor open at its far end), lit
// near the closed end.
LevelDescription long_corridor() {
  LevelDescription d;
  for (int i = 0; i < 2; ++i) {
    BlockDescription b;
    b.cell = {0, 0, i};
    b.warped = true;
    b.albedo.fill(glm::dvec3(0.7));
    for (int k = 0; k < 8; ++k)
      b.corners[k] = glm::dvec3(k & 1 ? 1.0 : 0.0, k & 2 ? 1.0 : 0.0, 3.0 * (i + (k & 4 ? 1 : 0)));
    b.faces = FaceMask(kAllFaces & ~(1u << kFacePosZ) & (i == 0 ? kAllFaces : ~(1u << kFaceNegZ)));
    d.blocks.push_back(b);
  }
  LightDescription light;
  light.position = {0.5, 0.6, 0.5};
  d.lights.push_back(light);
  return d;
}

using test::rel_l2;

// Against the exact one bounce F_level ld on the corridor's own walls: with cube interfaces
// the light crossing into the second block spreads as if both were cubes; traced in their
// boxes, the interfaces carry it the corridor's real distances.
TEST(ShapedInterfaces, CorridorOfStretchedBlocksFollowsTheCorridor) {
  const Dictionary& dict = test::small_test_dictionary();
  const LevelDescription d = long_corridor();
  double error[2] = {0, 0};
  for (int traced = 0; traced < 2; ++traced) {
    LevelBuildSettings settings;
    settings.shaped_cache = &test::test_shaped_cache();
    if (traced) settings.interface_basis = &test::small_test_interface_basis();
    Result<Level> level = build_level(d, dict, settings);
    ASSERT_TRUE(level.ok()) << level.status().to_string();
    const LevelScene scene(level.value(), level->res);
    const std::vector<float> albedo = level_sample_albedo(level.value());
    const std::vector<float> ld = level_direct_light(scene, d.lights, albedo, 8);
    const std::vector<float> exact = level_one_bounce(scene, ld, 2048, 5);
    const LevelBufferSizes sizes = level_buffer_sizes(level.value(), dict);
    std::vector<float> b(sizes.b), r(sizes.r), lightmap(sizes.lightmap);
    ASSERT_TRUE(level_evaluate(level.value(), dict, ld, b, r, lightmap).ok());
    error[traced] = rel_l2(lightmap, exact);
  }
  std::printf(
      "corridor of two 1x1x3 blocks, one bounce rel L2 against F_level ld: cube operators %.3f, "
      "shaped with traced interfaces %.3f\n",
      error[0], error[1]);
  // Measured 0.354 and 0.029 (res 8 test dictionary).
  EXPECT_GT(error[0], 0.2);
  EXPECT_LT(error[1], 0.08);
  EXPECT_LT(error[1], error[0] / 4.0);
}

TEST(ShapedInterfaces, ConnectedStretchedBlocksGetShapedOperatorsWithABasisOnly) {
  const Dictionary& dict = test::small_test_dictionary();
  const LevelDescription d = long_corridor();
  LevelBuildSettings settings;
  settings.shaped_cache = &test::test_shaped_cache();
  Result<Level> without = build_level(d, dict, settings);
  ASSERT_TRUE(without.ok()) << without.status().to_string();
  EXPECT_TRUE(without->shaped.empty());
  settings.interface_basis = &test::small_test_interface_basis();
  Result<Level> with = build_level(d, dict, settings);
  ASSERT_TRUE(with.ok()) << with.status().to_string();
  ASSERT_FALSE(with->shaped.empty());
  for (const LevelBlock& b : with->blocks) EXPECT_GE(b.shaped, 0);
  // The same slots and sources; each record has its source's modes (the box's, more than the
  // cube's: shaped_mode_factor) and the light they carry differs (the box's transport).
  ASSERT_EQ(with->records.size(), without->records.size());
  for (const ResponseRecord& rec : with->records)
    EXPECT_EQ(rec.T.cols, block_kb(dict, with.value(), with->blocks[rec.source_block]));
  EXPECT_GT(with->kb, dict.settings.kb);
  std::vector<float> r[2];
  for (int k = 0; k < 2; ++k) {
    const Level& level = k == 0 ? without.value() : with.value();
    const LevelScene scene(level, level.res);
    const std::vector<float> ld = level_direct_light(scene, d.lights, level_sample_albedo(level), 4);
    const LevelBufferSizes sizes = level_buffer_sizes(level, dict);
    std::vector<float> b(sizes.b), lightmap(sizes.lightmap);
    r[k].resize(sizes.r);
    ASSERT_TRUE(level_evaluate(level, dict, ld, b, r[k], lightmap).ok());
  }
  EXPECT_GT(rel_l2(r[1], r[0]), 0.05);
}

TEST(ShapedInterfaces, BasisFileRoundTripsAndDamageIsNamed) {
  const Matrix& Hrlf = test::small_test_interface_basis();
  const std::string dir = std::string(MODRT_TEST_CACHE_DIR) + "/matrix-file-test";
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/basis.lfbasis";
  const MatrixRef ref{"Hrlf", &Hrlf};
  ASSERT_TRUE(save_matrix_file(path, "tag", std::span(&ref, 1)).ok());
  Result<std::vector<NamedMatrix>> back = load_matrix_file(path, "tag");
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  ASSERT_EQ(back->size(), 1u);
  EXPECT_EQ(back.value()[0].matrix.data, Hrlf.data);
  Result<std::vector<NamedMatrix>> other = load_matrix_file(path, "another tag");
  ASSERT_FALSE(other.ok());
  EXPECT_NE(other.status().message().find("expected 'another tag'"), std::string::npos);
  // One flipped byte in the body: the checksum names it.
  {
    std::FILE* f = std::fopen(path.c_str(), "r+b");
    ASSERT_NE(f, nullptr);
    std::fseek(f, 40, SEEK_SET);
    std::fputc(0x5a, f);
    std::fclose(f);
  }
  Result<std::vector<NamedMatrix>> damaged = load_matrix_file(path, "tag");
  ASSERT_FALSE(damaged.ok());
  EXPECT_EQ(damaged.status().code(), ErrorCode::checksum_mismatch);
  EXPECT_NE(damaged.status().message().find(path), std::string::npos);
  std::filesystem::resize_file(path, 30);
  EXPECT_FALSE(load_matrix_file(path, "tag").ok());
}

}  // namespace
}  // namespace modrt::precompute
