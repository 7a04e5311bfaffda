// SPDX-License-Identifier: MIT
// F against analytic references: unit-square form factors and Lambert's point-to-polygon
// formula (architecture.md §8).
#include <gtest/gtest.h>

#include <array>
#include <cstdio>

#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/form_factors.h"
#include "modrt/precompute/transport.h"

namespace modrt::precompute {
namespace {

std::array<glm::dvec3, 4> face_corners(int face) {
  return {face_point(face, 0, 0), face_point(face, 1, 0), face_point(face, 1, 1), face_point(face, 0, 1)};
}

TEST(FormFactors, ClosedFormsMatchTabulatedValues) {
  // Unit squares: parallel at distance 1 and perpendicular with a shared edge (standard
  // radiative-transfer tables: 0.19982 and 0.20004).
  EXPECT_NEAR(parallel_rectangles_form_factor(1, 1, 1), 0.19982, 1e-5);
  EXPECT_NEAR(perpendicular_rectangles_form_factor(1, 1, 1), 0.20004, 1e-5);
  // Reciprocity A1 F12 = A2 F21 for unequal perpendicular rectangles.
  EXPECT_NEAR(2.0 * perpendicular_rectangles_form_factor(2, 1, 1),
              1.0 * perpendicular_rectangles_form_factor(1, 2, 1), 1e-12);
}

TEST(FormFactors, LambertContourIntegratesToClosedForms) {
  // Average the point-to-polygon form factor over the floor by a 200^2 midpoint rule.
  const auto ceiling = face_corners(kFacePosY);
  const auto wall = face_corners(kFaceNegX);
  const glm::dvec3 up = face_frame(kFaceNegY).normal;
  double to_ceiling = 0.0, to_wall = 0.0;
  const int m = 200;
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) {
      const glm::dvec3 x = face_point(kFaceNegY, (i + 0.5) / m, (j + 0.5) / m);
      to_ceiling += point_to_polygon_form_factor(x, up, ceiling);
      to_wall += point_to_polygon_form_factor(x, up, wall);
    }
  EXPECT_NEAR(to_ceiling / (m * m), parallel_rectangles_form_factor(1, 1, 1), 2e-5);
  EXPECT_NEAR(to_wall / (m * m), perpendicular_rectangles_form_factor(1, 1, 1), 2e-4);
}

// The floor's rows of F, summed over another face's texels and averaged over the floor,
// are the floor-to-face form factor.
TEST(TransportF, FloorToCeilingAndWallMatchUnitSquareFormFactorsWithin1Percent) {
  const SampleLayout layout = SampleLayout::make(kAllFaces, 16);
  const BlockScene scene(kAllFaces);
  const int begin = layout.index(kFaceNegY, 0, 0);
  const int end = begin + layout.texels_per_face();
  const RowMatrixXd F = gather_transport(scene, layout, 16384, 7, begin, end);
  auto face_to_face = [&](int to) {
    const int c0 = layout.index(to, 0, 0);
    return F.block(begin, c0, end - begin, layout.texels_per_face()).sum() / (end - begin);
  };
  const double parallel = face_to_face(kFacePosY);
  const double perpendicular = face_to_face(kFaceNegX);
  std::printf("floor->ceiling %.5f (analytic %.5f), floor->-X %.5f (analytic %.5f)\n", parallel,
              parallel_rectangles_form_factor(1, 1, 1), perpendicular,
              perpendicular_rectangles_form_factor(1, 1, 1));
  EXPECT_NEAR(parallel / parallel_rectangles_form_factor(1, 1, 1), 1.0, 0.01);
  EXPECT_NEAR(perpendicular / perpendicular_rectangles_form_factor(1, 1, 1), 1.0, 0.01);
  // Own face receives nothing (planar face cannot see itself).
  EXPECT_EQ(face_to_face(kFaceNegY), 0.0);
}

TEST(TransportF, RowSumsEqualVisibleFractionOfTheHemisphere) {
  for (int shape : {0, 1, 3, 5}) {
    const FaceMask mask = dictionary_shape_mask(shape);
    const SampleLayout layout = SampleLayout::make(mask, 6);
    const BlockScene scene(mask);
    const RowMatrixXd F = gather_transport(scene, layout, 16384, 11);
    double worst = 0.0;
    for (int s = 0; s < layout.sample_count(); ++s) {
      // Visible fraction = 1 - form factor to the missing faces (Lambert, exact).
      double missing = 0.0;
      for (int f = 0; f < kFaceCount; ++f)
        if (!face_present(mask, f)) {
          const auto corners = face_corners(f);
          missing += point_to_polygon_form_factor(layout.position(s), layout.normal(s), corners);
        }
      worst = std::max(worst, std::abs(F.row(s).sum() - (1.0 - missing)));
    }
    EXPECT_LT(worst, 3e-3) << dictionary_shape_name(shape);
  }
}

}  // namespace
}  // namespace modrt::precompute
