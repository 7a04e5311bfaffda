// SPDX-License-Identifier: MIT
// Canonical block geometry: frames, rotations, canonicalisation, sample layout.
#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include "modrt/cube.h"

namespace modrt {
namespace {

TEST(Cube, FramesAreRightHandedInwardAndOnTheirFace) {
  for (int f = 0; f < kFaceCount; ++f) {
    const FaceFrame& fr = face_frame(f);
    EXPECT_NEAR(glm::length(glm::cross(fr.u_axis, fr.v_axis) - fr.normal), 0.0, 1e-12) << face_name(f);
    // The face centre plus a little along the inward normal is inside the cube.
    const glm::dvec3 inside = face_point(f, 0.5, 0.5) + 0.1 * fr.normal;
    for (int a = 0; a < 3; ++a) EXPECT_TRUE(inside[a] > 0.0 && inside[a] < 1.0) << face_name(f);
    // All four corners lie on the cube's boundary plane of this face.
    const int axis = f / 2;
    const double plane = (f % 2) ? 1.0 : 0.0;
    for (double u : {0.0, 1.0})
      for (double v : {0.0, 1.0}) EXPECT_DOUBLE_EQ(face_point(f, u, v)[axis], plane) << face_name(f);
  }
}

TEST(Cube, QuarterTurnMapsWallsTexelForTexel) {
  for (int f : {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ}) {
    const int g = rotate_face(f, 1);
    for (double u : {0.1, 0.5, 0.9})
      for (double v : {0.2, 0.7}) {
        const glm::dvec3 p = rotate_point(face_point(f, u, v), 1);
        EXPECT_NEAR(glm::length(p - face_point(g, u, v)), 0.0, 1e-12) << face_name(f) << "->" << face_name(g);
      }
    EXPECT_NEAR(glm::length(rotate_direction(face_frame(f).normal, 1) - face_frame(g).normal), 0.0, 1e-12);
  }
  EXPECT_EQ(rotate_face(kFaceNegY, 3), kFaceNegY);
  EXPECT_EQ(rotate_face(kFaceNegX, 4), kFaceNegX);
  EXPECT_EQ(rotate_face(kFaceNegX, -1), rotate_face(kFaceNegX, 3));
}

TEST(Cube, DictionaryHasSixShapesAndTwelveInterfaces) {
  int missing = 0;
  for (int s = 0; s < kDictionaryShapeCount; ++s)
    missing += kFaceCount - face_count(dictionary_shape_mask(s));
  EXPECT_EQ(missing, 12);
  // Every floor+ceiling mask canonicalises, and the rotation reproduces it.
  int seen[kDictionaryShapeCount] = {};
  for (unsigned sides = 0; sides < 16; ++sides) {
    FaceMask mask = FaceMask((1u << kFaceNegY) | (1u << kFacePosY));
    const int side_faces[4] = {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ};
    for (int k = 0; k < 4; ++k)
      if (sides & (1u << k)) mask |= FaceMask(1u << side_faces[k]);
    Result<ShapeOrientation> o = canonicalise_face_mask(mask);
    ASSERT_TRUE(o.ok()) << o.status().to_string();
    EXPECT_EQ(rotate_face_mask(dictionary_shape_mask(o->shape), o->quarter_turns), mask);
    ++seen[o->shape];
  }
  for (int s = 0; s < kDictionaryShapeCount; ++s) EXPECT_GT(seen[s], 0) << dictionary_shape_name(s);
}

TEST(Cube, CanonicaliseRejectsMissingFloorOrStrayBits) {
  Result<ShapeOrientation> no_floor = canonicalise_face_mask(FaceMask(kAllFaces & ~(1u << kFaceNegY)));
  ASSERT_FALSE(no_floor.ok());
  EXPECT_EQ(no_floor.status().code(), ErrorCode::invalid_argument);
  EXPECT_NE(no_floor.status().message().find("floor"), std::string::npos);
  EXPECT_FALSE(canonicalise_face_mask(FaceMask(0xFF)).ok());
}

TEST(Cube, SampleLayoutIndexesRoundTrip) {
  const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(3), 5);
  EXPECT_EQ(layout.sample_count(), 4 * 25);
  for (int f = 0; f < kFaceCount; ++f) {
    if (!face_present(layout.mask, f)) {
      EXPECT_EQ(layout.slot[f], -1);
      continue;
    }
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) {
        const int s = layout.index(f, i, j);
        EXPECT_EQ(layout.face_of(s), f);
        const glm::dvec3 p = layout.position(s);
        EXPECT_NEAR(glm::length(p - face_point(f, (i + 0.5) / 5, (j + 0.5) / 5)), 0.0, 1e-12);
      }
  }
}

}  // namespace
}  // namespace modrt
