// SPDX-License-Identifier: MIT
// The 24 rotations of the canonical block and the 3D dictionary's shapes (cube_rotation.h),
// checked exhaustively: a group of 24 proper rotations agreeing with cube.h's quarter turns,
// faces, points and face texel coordinates mapped consistently, and every one of the 64 face
// masks canonicalised into ten classes of the sizes rotation theory gives.
#include <gtest/gtest.h>

#include <set>
#include <tuple>

#include <glm/geometric.hpp>

#include "modrt/cube.h"
#include "modrt/cube_rotation.h"

namespace modrt {
namespace {

int determinant(const CubeMatrix& m) {
  return m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2]) -
         m[1][0] * (m[0][1] * m[2][2] - m[2][1] * m[0][2]) +
         m[2][0] * (m[0][1] * m[1][2] - m[1][1] * m[0][2]);
}

bool near(const glm::dvec3& a, const glm::dvec3& b) { return glm::length(a - b) < 1e-12; }

TEST(CubeRotation, TwentyFourDistinctProperRotationsFormAGroup) {
  std::set<std::tuple<int, int, int, int, int, int, int, int, int>> seen;
  for (int r = 0; r < kCubeRotationCount; ++r) {
    const CubeMatrix& m = cube_rotation(r).matrix;
    EXPECT_EQ(determinant(m), 1) << r;
    for (int c = 0; c < 3; ++c) {
      int nonzero = 0;
      for (int i = 0; i < 3; ++i) nonzero += m[c][i] != 0 ? 1 : 0;
      EXPECT_EQ(nonzero, 1) << "rotation " << r << " column " << c;
    }
    seen.insert({m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2]});
    const int inv = cube_rotation(r).inverse;
    EXPECT_EQ(compose_cube_rotations(r, inv), 0);
    EXPECT_EQ(compose_cube_rotations(inv, r), 0);
    for (int s = 0; s < kCubeRotationCount; ++s) {
      const int rs = compose_cube_rotations(r, s);
      ASSERT_GE(rs, 0) << r << " then " << s << " is no rotation of the table";
      for (int f = 0; f < kFaceCount; ++f)
        EXPECT_EQ(rotate_face_3d(f, rs), rotate_face_3d(rotate_face_3d(f, r), s));
    }
  }
  EXPECT_EQ(seen.size(), std::size_t(kCubeRotationCount));
  EXPECT_EQ(cube_rotation(0).matrix, CubeMatrix(1));
}

TEST(CubeRotation, TheFirstFourAreTheQuarterTurnsOfThe2DDictionary) {
  const glm::dvec3 p(0.1, 0.25, 0.7), d(0.3, -0.5, 0.8);
  for (int q = 0; q < 4; ++q) {
    for (int f = 0; f < kFaceCount; ++f) EXPECT_EQ(rotate_face_3d(f, q), rotate_face(f, q)) << q;
    EXPECT_TRUE(near(rotate_point_3d(p, q), rotate_point(p, q))) << q;
    EXPECT_TRUE(near(rotate_direction_3d(d, q), rotate_direction(d, q))) << q;
  }
  // Rotation 4 k + q takes +Y to the k-th of +Y, -Y, +X, -X, +Z, -Z.
  const int up[6] = {kFacePosY, kFaceNegY, kFacePosX, kFaceNegX, kFacePosZ, kFaceNegZ};
  for (int r = 0; r < kCubeRotationCount; ++r) EXPECT_EQ(rotate_face_3d(kFacePosY, r), up[r / 4]) << r;
}

TEST(CubeRotation, FacesPointsAndTexelCoordinatesMoveTogether) {
  const double uv[3][2] = {{0.5, 0.5}, {0.1, 0.8}, {0.9, 0.3}};
  for (int r = 0; r < kCubeRotationCount; ++r) {
    std::set<int> images;
    for (int f = 0; f < kFaceCount; ++f) {
      const int g = rotate_face_3d(f, r);
      images.insert(g);
      // The face's inward normal turns into the image face's inward normal.
      EXPECT_TRUE(near(rotate_direction_3d(face_frame(f).normal, r), face_frame(g).normal)) << r << " " << f;
      for (const auto& c : uv) {
        const glm::dvec2 t = rotate_face_uv(f, r, {c[0], c[1]});
        EXPECT_TRUE(near(rotate_point_3d(face_point(f, c[0], c[1]), r), face_point(g, t.x, t.y)))
            << "rotation " << r << " face " << f;
        EXPECT_GE(t.x, -1e-12);
        EXPECT_LE(t.x, 1.0 + 1e-12);
        EXPECT_GE(t.y, -1e-12);
        EXPECT_LE(t.y, 1.0 + 1e-12);
      }
      // A texel centre lands on a texel centre of the image face (res 4): the sample grids
      // map onto each other, as a rotated sample layout needs.
      const glm::dvec2 t = rotate_face_uv(f, r, {1.5 / 4, 0.5 / 4});
      for (const double x : {t.x * 4 - 0.5, t.y * 4 - 0.5}) EXPECT_NEAR(x, std::round(x), 1e-12);
    }
    EXPECT_EQ(images.size(), std::size_t(kFaceCount)) << r;
  }
}

TEST(CubeRotation, EveryFaceMaskIsOneOfTenShapesTurned) {
  // Orbit sizes under the 24 rotations: closed 1, dead end 6, corridor 3, corner 12, T 12,
  // crossing 3, corner open above 8, T open above 12, crossing open above 6, open 1 (sum 64).
  const int orbit[kCubeShapeCount] = {1, 6, 3, 12, 12, 3, 8, 12, 6, 1};
  int count[kCubeShapeCount] = {};
  for (unsigned mask = 0; mask < 64; ++mask) {
    const Result<ShapeRotation> sr = canonicalise_face_mask_3d(FaceMask(mask));
    ASSERT_TRUE(sr.ok()) << mask;
    EXPECT_EQ(rotate_face_mask_3d(cube_shape_mask(sr->shape), sr->rotation), FaceMask(mask));
    ++count[sr->shape];
    // No smaller rotation gives the mask.
    for (int r = 0; r < sr->rotation; ++r)
      EXPECT_NE(rotate_face_mask_3d(cube_shape_mask(sr->shape), r), FaceMask(mask));
    // Masks with floor and ceiling present: the 2D dictionary's answer.
    if (face_present(FaceMask(mask), kFaceNegY) && face_present(FaceMask(mask), kFacePosY)) {
      const Result<ShapeOrientation> two = canonicalise_face_mask(FaceMask(mask));
      ASSERT_TRUE(two.ok());
      EXPECT_EQ(sr->shape, two->shape) << mask;
      EXPECT_EQ(sr->rotation, two->quarter_turns) << mask;
    }
  }
  for (int s = 0; s < kCubeShapeCount; ++s) {
    EXPECT_EQ(count[s], orbit[s]) << cube_shape_name(s);
    // Each canonical mask is its own class's representative, and its stabiliser has 24 /
    // orbit rotations.
    const Result<ShapeRotation> own = canonicalise_face_mask_3d(cube_shape_mask(s));
    ASSERT_TRUE(own.ok());
    EXPECT_EQ(own->shape, s);
    EXPECT_EQ(own->rotation, 0);
    int stabiliser = 0;
    for (int r = 0; r < kCubeRotationCount; ++r)
      stabiliser += rotate_face_mask_3d(cube_shape_mask(s), r) == cube_shape_mask(s);
    EXPECT_EQ(stabiliser * orbit[s], kCubeRotationCount) << cube_shape_name(s);
  }
  for (int s = 0; s < kDictionaryShapeCount; ++s) {
    EXPECT_EQ(cube_shape_mask(s), dictionary_shape_mask(s));
    EXPECT_STREQ(cube_shape_name(s), dictionary_shape_name(s));
  }
  EXPECT_STREQ(cube_shape_name(kCubeShapeCount), "?");
  EXPECT_FALSE(canonicalise_face_mask_3d(FaceMask(0x40)).ok());
}

}  // namespace
}  // namespace modrt
