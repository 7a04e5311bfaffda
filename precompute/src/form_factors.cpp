// SPDX-License-Identifier: MIT
#include "modrt/precompute/form_factors.h"

#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

namespace modrt::precompute {

double point_to_polygon_form_factor(const glm::dvec3& x, const glm::dvec3& normal,
                                    std::span<const glm::dvec3> corners) {
  double sum = 0.0;
  const std::size_t count = corners.size();
  for (std::size_t i = 0; i < count; ++i) {
    const glm::dvec3 a = glm::normalize(corners[i] - x);
    const glm::dvec3 b = glm::normalize(corners[(i + 1) % count] - x);
    const glm::dvec3 c = glm::cross(a, b);
    const double len = glm::length(c);
    if (len < 1e-300) continue;  // edge seen end-on contributes nothing
    const double angle = std::atan2(len, glm::dot(a, b));
    sum += angle * glm::dot(normal, c / len);
  }
  return std::abs(sum) / (2.0 * std::numbers::pi);
}

double parallel_rectangles_form_factor(double a, double b, double c) {
  const double X = a / c;
  const double Y = b / c;
  const double X2 = X * X;
  const double Y2 = Y * Y;
  const double term = std::log(std::sqrt((1 + X2) * (1 + Y2) / (1 + X2 + Y2))) +
                      X * std::sqrt(1 + Y2) * std::atan(X / std::sqrt(1 + Y2)) +
                      Y * std::sqrt(1 + X2) * std::atan(Y / std::sqrt(1 + X2)) - X * std::atan(X) -
                      Y * std::atan(Y);
  return 2.0 / (std::numbers::pi * X * Y) * term;
}

double perpendicular_rectangles_form_factor(double w, double h, double l) {
  const double W = w / l;
  const double H = h / l;
  const double W2 = W * W;
  const double H2 = H * H;
  const double R2 = W2 + H2;
  const double R = std::sqrt(R2);
  const double log_term = std::log((1 + W2) * (1 + H2) / (1 + R2)) +
                          W2 * std::log(W2 * (1 + R2) / ((1 + W2) * R2)) +
                          H2 * std::log(H2 * (1 + R2) / ((1 + H2) * R2));
  return (W * std::atan(1 / W) + H * std::atan(1 / H) - R * std::atan(1 / R) + 0.25 * log_term) /
         (std::numbers::pi * W);
}

}  // namespace modrt::precompute
