// SPDX-License-Identifier: MIT
// The perceptual image metric of the golden-image tests (docs/demo.md): per-pixel CIE76 colour
// difference Delta E*ab of two sRGB8 images in CIELAB (D65), its mean and 99th percentile.
// Shared by test_demo (the demo's golden frame) and modrt_compare_images (modrt-embed-host's
// scene frame against modrt-demo's).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace modrt::test {

inline double srgb_to_linear(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// CIELAB (D65) of an sRGB8 pixel.
inline glm::dvec3 lab(const std::uint8_t* p) {
  const double r = srgb_to_linear(p[0] / 255.0), g = srgb_to_linear(p[1] / 255.0),
               b = srgb_to_linear(p[2] / 255.0);
  const glm::dvec3 xyz(0.4124 * r + 0.3576 * g + 0.1805 * b, 0.2126 * r + 0.7152 * g + 0.0722 * b,
                       0.0193 * r + 0.1192 * g + 0.9505 * b);
  auto f = [](double t) { return t > 0.008856 ? std::cbrt(t) : 7.787 * t + 16.0 / 116.0; };
  const double fx = f(xyz.x / 0.95047), fy = f(xyz.y), fz = f(xyz.z / 1.08883);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

// Perceptual difference of two sRGB8 images (3 bytes per pixel, same size): mean and 99th
// percentile of the per-pixel CIE76 colour difference (Delta E*ab; 1 is about a
// just-noticeable difference, 2.3 a JND in the usual reading). Golden test bounds: mean <= 1.0
// and 99th percentile <= 8: the image may differ by unnoticeable amounts everywhere and
// visibly only on a few edge and shadow-boundary pixels, which move with driver rasterisation
// details.
struct DeltaE {
  double mean = 0, p99 = 0;
};
inline DeltaE delta_e(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b) {
  std::vector<double> d(a.size() / 3);
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = glm::length(lab(&a[3 * i]) - lab(&b[3 * i]));
  DeltaE e;
  for (double v : d) e.mean += v / double(d.size());
  std::sort(d.begin(), d.end());
  e.p99 = d.empty() ? 0.0 : d[d.size() * 99 / 100];
  return e;
}

}  // namespace modrt::test
