// SPDX-License-Identifier: MIT
// Blocks that are not cubes (MRT §8, Figure 12): the stretched block scene against analytic
// form factors, the box's symmetries, the unit box against the cube bake, the level build's
// proportion lattice and cache, the level file, and a long room against the exact one-bounce
// reference on its real geometry (cube operators under a warp against shaped operators).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "compare_support.h"
#include "level_fixtures.h"
#include "modrt/level_io.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/bake.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/form_factors.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/shaped_operators.h"
#include "modrt/precompute/symmetry.h"
#include "modrt/precompute/transport.h"
#include "test_support.h"

namespace modrt::precompute {
namespace {

const Dictionary& test_dictionary() { return test::small_test_dictionary(); }

TEST(ShapedBox, SceneHitsReportNormalisedFaceCoordinates) {
  const glm::dvec3 extent(3.0, 1.0, 0.5);
  const BlockScene scene(kAllFaces, extent);
  // From the box's centre towards +X: the +X face's centre, at distance 1.5.
  const FaceHit hit = scene.intersect(scene.point(glm::dvec3(0.5)), glm::dvec3(1, 0, 0));
  ASSERT_EQ(hit.face, kFacePosX);
  EXPECT_NEAR(hit.t, 1.5, 1e-6);
  EXPECT_NEAR(hit.u, 0.5, 1e-6);
  EXPECT_NEAR(hit.v, 0.5, 1e-6);
  // A point a quarter along the floor's x: u (or v) = 0.25 whichever axis the frame uses.
  const FaceHit down = scene.intersect({0.75, 0.5, 0.25}, glm::dvec3(0, -1, 0));
  ASSERT_EQ(down.face, kFaceNegY);
  const FaceFrame& floor = face_frame(kFaceNegY);
  const glm::dvec3 canonical = glm::dvec3(0.25, 0.0, 0.5) - floor.origin;
  EXPECT_NEAR(down.u, glm::dot(canonical, floor.u_axis), 1e-6);
  EXPECT_NEAR(down.v, glm::dot(canonical, floor.v_axis), 1e-6);
  EXPECT_NEAR(scene.texel_area(kFacePosX, 4), 1.0 * 0.5 / 16.0, 1e-15);
  EXPECT_NEAR(scene.texel_area(kFaceNegY, 4), 3.0 * 0.5 / 16.0, 1e-15);
  EXPECT_THROW(BlockScene(kAllFaces, glm::dvec3(1.0, 0.0, 1.0)), std::invalid_argument);
  EXPECT_THROW(BlockScene(kAllFaces, glm::dvec3(1.0, std::nan(""), 1.0)), std::invalid_argument);
}

TEST(ShapedBox, SymmetriesAreTheBoxes) {
  EXPECT_EQ(shape_symmetries(kAllFaces).size(), 8u);
  // x != z: no odd quarter turn maps the box onto itself.
  const std::vector<BlockSymmetry> long_box = shape_symmetries(kAllFaces, {3.0, 1.0, 1.0});
  EXPECT_EQ(long_box.size(), 4u);
  for (const BlockSymmetry& g : long_box) EXPECT_EQ(g.quarter_turns % 2, 0);
  EXPECT_EQ(shape_symmetries(kAllFaces, {2.0, 0.5, 2.0}).size(), 8u);
}

// F of a closed box gathered in the stretched box: every ray hits a face (rows sum to 1),
// the floor's view of the ceiling and of a wall match the analytic rectangle form factors,
// and flux is reciprocal between faces of different areas.
TEST(ShapedBox, ClosedBoxTransportMatchesAnalyticFormFactors) {
  const glm::dvec3 e(2.0, 1.0, 0.5);
  const int res = 6;
  const BlockScene scene(kAllFaces, e);
  const SampleLayout layout = SampleLayout::make(kAllFaces, res);
  const RowMatrixXd F = gather_transport(scene, layout, 4096, 11);
  for (int s = 0; s < layout.sample_count(); ++s) EXPECT_NEAR(F.row(s).sum(), 1.0, 1e-9) << "sample " << s;
  // Face-to-face form factor: the area-weighted mean of the rows' sums over the target face.
  auto face_ff = [&](int from, int to) {
    double sum = 0.0;
    for (int i = 0; i < res * res; ++i)
      for (int j = 0; j < res * res; ++j)
        sum += F(layout.index(from, i % res, i / res), layout.index(to, j % res, j / res));
    return sum / (res * res);
  };
  // Floor (x by z = 2 x 0.5) to ceiling at distance 1.
  EXPECT_NEAR(face_ff(kFaceNegY, kFacePosY), parallel_rectangles_form_factor(2.0, 0.5, 1.0), 0.01);
  // Floor to the -Z wall: they share the edge of length 2 (x); floor depth 0.5, wall height 1.
  EXPECT_NEAR(face_ff(kFaceNegY, kFaceNegZ), perpendicular_rectangles_form_factor(0.5, 1.0, 2.0), 0.01);
  // Reciprocity A_f F_fg = A_g F_gf between the floor (area 1) and the -X wall (area 0.5).
  EXPECT_NEAR(1.0 * face_ff(kFaceNegY, kFaceNegX), 0.5 * face_ff(kFaceNegX, kFaceNegY), 0.01);
  // The unit cube's values differ by far more than the tolerance: the box is really stretched.
  EXPECT_GT(std::abs(parallel_rectangles_form_factor(1.0, 1.0, 1.0) -
                     parallel_rectangles_form_factor(2.0, 0.5, 1.0)),
            0.03);
  EXPECT_GT(std::abs(perpendicular_rectangles_form_factor(1.0, 1.0, 1.0) -
                     perpendicular_rectangles_form_factor(0.5, 1.0, 2.0)),
            0.03);
}

TEST(ShapedBox, UnitBoxBakesTheCube) {
  DictionarySettings s = test::small_test_settings();
  s.res = 4;
  s.rays = 256;
  const ShapeBake cube = bake_shape(dictionary_shape_mask(2), s, false);
  const ShapeBake box = bake_box_shape(dictionary_shape_mask(2), glm::dvec3(1.0), s, false);
  EXPECT_EQ(cube.transfer.Ub, box.transfer.Ub);
  EXPECT_EQ(cube.transfer.Td_b, box.transfer.Td_b);
  const ShapeBake stretched = bake_box_shape(dictionary_shape_mask(2), {2.0, 1.0, 0.5}, s, false);
  EXPECT_GT((stretched.transfer.Limp - cube.transfer.Limp).norm(), 0.1 * cube.transfer.Limp.norm());
}

TEST(ShapedBox, ProportionLattice) {
  const int steps = 8;
  EXPECT_EQ(quantise_proportions({1.0, 1.0, 1.0}, steps), (ProportionSteps{0, 0, 0}));
  EXPECT_EQ(quantise_proportions({2.0, 2.0, 2.0}, steps), (ProportionSteps{0, 0, 0}));   // scale-free
  EXPECT_EQ(quantise_proportions({1.03, 1.0, 1.0}, steps), (ProportionSteps{0, 0, 0}));  // within half a step
  const ProportionSteps q = quantise_proportions({3.0, 1.0, 1.0}, steps);
  const glm::dvec3 e = proportions_extent(q, steps);
  EXPECT_NEAR(e.x / e.y, 3.0, 3.0 * (std::exp2(0.5 / steps) - 1.0) * 2.0);
  EXPECT_NEAR(e.y, e.z, 1e-12);
  EXPECT_NEAR(e.x * e.y * e.z, 1.0, 1e-9);  // geometric mean 1
}

// A box's operators keep the modes of the cubes it stands for (rounded down, at most four), a
// slab's shortest edge counted as half its middle one; kd follows, kb never exceeds the samples.
TEST(ShapedBox, ModeFactorCountsTheCubesABoxStandsFor) {
  EXPECT_EQ(shaped_mode_factor({1.0, 1.0, 1.0}), 1);
  EXPECT_EQ(shaped_mode_factor({1.5, 1.0, 1.0}), 1);  // measured within 1.13x of cubes at the cube's kb
  EXPECT_EQ(shaped_mode_factor({2.0, 1.0, 1.0}), 2);
  EXPECT_EQ(shaped_mode_factor({1.0, 3.0, 1.0}), 3);
  EXPECT_EQ(shaped_mode_factor(proportions_extent(quantise_proportions({3.0, 1.0, 1.0}, 8), 8)), 3);  // 2.83
  EXPECT_EQ(shaped_mode_factor({1.0, 1.0, 6.0}), kMaxShapedModeFactor);
  EXPECT_EQ(shaped_mode_factor({2.0, 1.0, 2.0}), 4);
  EXPECT_EQ(shaped_mode_factor({1.0, 0.3, 1.0}), 2);  // 0.3 / (0.5^3): a slab, not 11 cubes
  EXPECT_EQ(shaped_mode_factor({0.0, 1.0, 1.0}), 1);
  EXPECT_EQ(shaped_mode_factor({std::nan(""), 1.0, 1.0}), 1);
  DictionarySettings d = test::small_test_settings();
  const DictionarySettings s = shaped_bake_settings(d, dictionary_shape_mask(1), {3.0, 1.0, 1.0});
  EXPECT_EQ(s.kb, 3 * d.kb);
  EXPECT_EQ(s.kd, std::min(8 * d.kd, 320u));  // 8 kd, at most the dead end's 5 x 8^2 samples
  EXPECT_EQ(shaped_bake_settings(d, dictionary_shape_mask(1), {1.2, 1.0, 1.0}).kd, d.kd);
  EXPECT_EQ(s.res, d.res);
  d.res = 2;  // 5 faces x 4 samples: kb stops at the sample count
  const DictionarySettings tiny = shaped_bake_settings(d, dictionary_shape_mask(1), {3.0, 1.0, 1.0});
  EXPECT_EQ(tiny.kb, std::max(d.kb, 20u));
}

// A room of `extent` (x, y, z) open at +Z, as one warped block.
LevelDescription one_block_room(const glm::dvec3& extent, const glm::dvec3& light) {
  LevelDescription d;
  d.name = "room";
  BlockDescription b;
  b.cell = {0, 0, 0};
  b.faces = FaceMask(kAllFaces & ~(1u << kFacePosZ));
  b.warped = true;
  for (int k = 0; k < 8; ++k)
    b.corners[std::size_t(k)] = glm::dvec3(k & 1, (k >> 1) & 1, (k >> 2) & 1) * extent;
  for (glm::dvec3& a : b.albedo) a = glm::dvec3(0.7);
  b.albedo[kFaceNegX] = {0.8, 0.2, 0.2};
  b.albedo[kFacePosX] = {0.2, 0.8, 0.2};
  d.blocks.push_back(b);
  LightDescription l;
  l.position = light;
  l.radius = 0.05;
  d.lights.push_back(l);
  return d;
}

TEST(ShapedLevel, StretchedBlocksGetOperatorsOfTheirBoxSharedAndCached) {
  LevelDescription d = one_block_room({2.9, 1.0, 1.0}, {0.4, 0.6, 0.5});
  // A second room, 2 % longer (the same lattice point: 8.2 and 8.3 steps), and a cube: the
  // cube keeps the dictionary's operators.
  BlockDescription longer = d.blocks[0];
  longer.cell = {0, 0, 3};
  for (int k = 0; k < 8; ++k)
    longer.corners[std::size_t(k)] = glm::dvec3(k & 1 ? 2.95 : 0.0, (k >> 1) & 1, ((k >> 2) & 1) + 3.0);
  d.blocks.push_back(longer);
  BlockDescription cube = d.blocks[0];
  cube.cell = {0, 0, 6};
  cube.warped = false;
  d.blocks.push_back(cube);
  ShapedOperatorCache cache;
  LevelBuildSettings settings;
  settings.shaped_cache = &cache;
  Result<Level> level = build_level(d, test_dictionary(), settings);
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  ASSERT_EQ(level->shaped.size(), 1u);
  EXPECT_EQ(level->blocks[0].shaped, 0);
  EXPECT_EQ(level->blocks[1].shaped, 0);
  EXPECT_EQ(level->blocks[2].shaped, -1);
  EXPECT_EQ(cache.bakes(), 1u);
  const ShapeOperators& ops = block_operators(test_dictionary(), level.value(), level->blocks[0]);
  EXPECT_EQ(&ops, &level->shaped[0].operators);
  EXPECT_EQ(ops.Ub.rows, test_dictionary().shapes[std::size_t(level->blocks[0].shape)].Ub.rows);
  EXPECT_GT(level->shaped[0].extent.x / level->shaped[0].extent.y, 2.7f);
  // A rebuild traces no ray.
  Result<Level> again = build_level(d, test_dictionary(), settings);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(cache.bakes(), 1u);
  EXPECT_EQ(cache.hits(), 1u);
  EXPECT_EQ(again->shaped[0].operators.Ub.data, level->shaped[0].operators.Ub.data);
  // Off: every block on its cube's operators.
  settings.shaped_operators = false;
  Result<Level> cubes = build_level(d, test_dictionary(), settings);
  ASSERT_TRUE(cubes.ok());
  EXPECT_TRUE(cubes->shaped.empty());
  for (const LevelBlock& b : cubes->blocks) EXPECT_EQ(b.shaped, -1);
  settings.proportion_steps_per_octave = 0;
  const Result<Level> bad = build_level(d, test_dictionary(), settings);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("proportion_steps_per_octave"), std::string::npos);
}

TEST(ShapedLevel, DiskCacheServesAnotherProcessAndTheLevelFileKeepsTheOperators) {
  const std::string dir = (std::filesystem::path(MODRT_TEST_CACHE_DIR) / "shaped-test").string();
  std::filesystem::remove_all(dir);
  const LevelDescription d = one_block_room({1.0, 0.3, 1.0}, {0.3, 0.15, 0.5});
  LevelBuildSettings settings;
  ShapedOperatorCache first(dir);
  settings.shaped_cache = &first;
  Result<Level> level = build_level(d, test_dictionary(), settings);
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  EXPECT_EQ(first.bakes(), 1u);
  ShapedOperatorCache second(dir);  // as a later process would
  settings.shaped_cache = &second;
  Result<Level> loaded = build_level(d, test_dictionary(), settings);
  ASSERT_TRUE(loaded.ok());
  EXPECT_EQ(second.bakes(), 0u);
  EXPECT_EQ(second.disk_loads(), 1u);
  EXPECT_EQ(loaded->shaped[0].operators.Td_b.data, level->shaped[0].operators.Td_b.data);
  ASSERT_EQ(loaded->records.size(), level->records.size());
  // The level file round trip keeps the sets and the blocks' indices.
  Result<std::vector<std::byte>> bytes = serialize_level(level.value());
  ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
  Result<Level> parsed = parse_level(bytes.value(), "room.modrtlevel");
  ASSERT_TRUE(parsed.ok()) << parsed.status().to_string();
  ASSERT_EQ(parsed->shaped.size(), 1u);
  EXPECT_EQ(parsed->blocks[0].shaped, 0);
  EXPECT_EQ(parsed->shaped[0].operators.Ub.data, level->shaped[0].operators.Ub.data);
  EXPECT_EQ(parsed->shaped[0].operators.Ubvol.data, level->shaped[0].operators.Ubvol.data);
  EXPECT_EQ(parsed->shaped[0].extent, level->shaped[0].extent);
  // A block pointing past the sets is refused by name.
  Level broken = level.value();
  broken.blocks[0].shaped = 1;
  const Result<std::vector<std::byte>> refused = serialize_level(broken);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("block 0: shaped operators 1 out of range"), std::string::npos)
      << refused.status().message();
  // A corrupt entry is baked again.
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    std::filesystem::resize_file(entry.path(), 100);
  ShapedOperatorCache third(dir);
  settings.shaped_cache = &third;
  ASSERT_TRUE(build_level(d, test_dictionary(), settings).ok());
  EXPECT_EQ(third.bakes(), 1u);
  std::filesystem::remove_all(dir);
}

using test::rel_l2;

// The long room: 3 x 1 x 1, open at +Z, the light near the -X end. Against the exact
// one-bounce F_level ld on the block's own geometry (which is the room), the cube's operators
// under the warp spread light as if the room were a cube; the shaped operators do not.
TEST(ShapedLevel, LongRoomOneBounceFollowsTheRoom) {
  const LevelDescription d = one_block_room({3.0, 1.0, 1.0}, {0.4, 0.6, 0.5});
  double error[2] = {0, 0};
  for (int shaped = 0; shaped < 2; ++shaped) {
    LevelBuildSettings settings;
    settings.shaped_operators = shaped == 1;
    Result<Level> level = build_level(d, test_dictionary(), settings);
    ASSERT_TRUE(level.ok()) << level.status().to_string();
    const LevelScene scene(level.value(), level->res);
    const std::vector<float> albedo = level_sample_albedo(level.value());
    const std::vector<float> ld = level_direct_light(scene, d.lights, albedo, 8);
    const std::vector<float> exact = level_one_bounce(scene, ld, 2048, 5);
    const LevelBufferSizes sizes = level_buffer_sizes(level.value(), test_dictionary());
    std::vector<float> b(sizes.b), r(sizes.r), lightmap(sizes.lightmap);
    ASSERT_TRUE(level_evaluate(level.value(), test_dictionary(), ld, b, r, lightmap).ok());
    error[shaped] = rel_l2(lightmap, exact);
  }
  std::printf("long room, one bounce rel L2 against F_level ld: cube operators %.3f, shaped %.3f\n", error[0],
              error[1]);
  // Measured 0.46 / 0.023 (0.049 with the cube's kb and kd: shaped_mode_factor's modes).
  EXPECT_GT(error[0], 0.3);
  EXPECT_LT(error[1], 0.035);
  EXPECT_LT(error[1], error[0] / 10.0);
}

// The backends' conformance suites run the "stretched" level: it must keep shaped blocks both
// connected (traced interfaces) and not, or their coverage would vanish silently.
TEST(ShapedLevel, ConformanceFixtureHasConnectedAndUnconnectedShapedBlocks) {
  const test::TestLevel& t = test::test_level("stretched");
  EXPECT_EQ(t.level.shaped.size(), 6u);
  int shaped = 0, connected = 0;
  for (const LevelBlock& b : t.level.blocks) {
    shaped += b.shaped >= 0;
    connected +=
        b.shaped >= 0 && std::any_of(b.neighbour.begin(), b.neighbour.end(), [](int n) { return n >= 0; });
  }
  EXPECT_EQ(shaped, 6);
  EXPECT_EQ(connected, 4);
  EXPECT_FALSE(t.level.records.empty());
  // Sets of different modes (shaped_mode_factor 1 to 3): b's stride is the largest, and
  // level_compute_b leaves zero past each block's modes whatever the buffer held.
  const Dictionary& dict = test::small_test_dictionary();
  std::set<std::uint32_t> modes;
  for (const LevelBlock& b : t.level.blocks) modes.insert(block_kb(dict, t.level, b));
  EXPECT_GE(modes.size(), 2u);
  EXPECT_EQ(t.level.kb, *modes.rbegin());
  EXPECT_GT(t.level.kb, dict.settings.kb);
  std::vector<float> b(level_buffer_sizes(t.level, dict).b, 7.0f);
  ASSERT_TRUE(level_compute_b(t.level, dict, t.ld, b).ok());
  for (std::size_t i = 0; i < t.level.blocks.size(); ++i)
    for (std::size_t k = 3 * block_kb(dict, t.level, t.level.blocks[i]); k < 3 * std::size_t(t.level.kb); ++k)
      ASSERT_EQ(b[3 * t.level.kb * i + k], 0.0f) << "block " << i << " entry " << k;
}

}  // namespace
}  // namespace modrt::precompute
