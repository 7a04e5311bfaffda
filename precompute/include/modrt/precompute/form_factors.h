// SPDX-License-Identifier: MIT
// modrt precompute — analytic form factors used as references for F (architecture.md §8).
#pragma once

#include <span>

#include <glm/vec3.hpp>

namespace modrt::precompute {

// Differential-area-to-polygon form factor (Lambert's contour formula): the cosine-weighted
// fraction of the hemisphere of (x, normal) covered by the convex polygon `corners`. The
// polygon must lie in the closed half-space in front of x (no clipping is done).
double point_to_polygon_form_factor(const glm::dvec3& x, const glm::dvec3& normal,
                                    std::span<const glm::dvec3> corners);

// Two directly opposed parallel a x b rectangles at distance c.
double parallel_rectangles_form_factor(double a, double b, double c);

// From rectangle 1 (w x l) to rectangle 2 (h x l), perpendicular, sharing the edge of
// length l.
double perpendicular_rectangles_form_factor(double w, double h, double l);

}  // namespace modrt::precompute
