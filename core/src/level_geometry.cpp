// SPDX-License-Identifier: MIT
// modrt — world geometry of a built level (level_geometry.h).
#include "modrt/level_geometry.h"

#include <cmath>
#include <cstddef>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "modrt/cube.h"
#include "modrt/level_description.h"

namespace modrt {

glm::dvec3 block_to_world(const LevelBlock& b, const glm::dvec3& p) {
  return trilinear(b.corners, rotate_point(p, b.quarter_turns));
}

glm::dvec3 world_to_block(const LevelBlock& b, const glm::dvec3& x) {
  glm::dvec3 p(0.5);
  for (int it = 0; it < 16; ++it) {
    const glm::dvec3 f = block_to_world(b, p) - x;
    if (glm::dot(f, f) < 1e-24) break;
    // The trilinear map is linear along each axis: central differences are exact.
    const double h = 1e-3;
    glm::dmat3 J;
    for (int a = 0; a < 3; ++a) {
      glm::dvec3 e(0.0);
      e[a] = h;
      J[a] = (block_to_world(b, p + e) - block_to_world(b, p - e)) / (2 * h);
    }
    if (std::abs(glm::determinant(J)) < 1e-12) break;
    p -= glm::inverse(J) * f;
  }
  return p;
}

glm::dvec3 block_face_normal(const LevelBlock& b, int face, double u, double v) {
  const FaceFrame& fr = face_frame(face);
  const glm::dvec3 p = face_point(face, u, v);
  // The map is linear along each canonical axis, so a central difference along u_axis or
  // v_axis (both canonical axes) is exact up to rounding; h only sets that rounding.
  const double h = 1e-4;
  const glm::dvec3 du = block_to_world(b, p + h * fr.u_axis) - block_to_world(b, p - h * fr.u_axis);
  const glm::dvec3 dv = block_to_world(b, p + h * fr.v_axis) - block_to_world(b, p - h * fr.v_axis);
  return glm::normalize(glm::cross(du, dv));
}

LevelSampleGeometry level_sample_geometry(const Level& level) {
  LevelSampleGeometry g;
  g.position.resize(level.sample_count);
  g.normal.resize(level.sample_count);
  g.block.resize(level.sample_count);
  g.face.resize(level.sample_count);
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& b = level.blocks[bi];
    const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(b.shape), level.res);
    for (int s = 0; s < layout.sample_count(); ++s) {
      const std::size_t k = b.sample_offset + std::size_t(s);
      g.position[k] = block_to_world(b, layout.position(s));
      const int f = layout.face_of(s);
      const int t = s % layout.texels_per_face();
      g.normal[k] =
          block_face_normal(b, f, (t % level.res + 0.5) / level.res, (t / level.res + 0.5) / level.res);
      g.block[k] = int(bi);
      g.face[k] = f;
    }
  }
  return g;
}

std::vector<double> level_sample_area(const Level& level) {
  std::vector<double> area(level.sample_count, 0.0);
  const double res = double(level.res);
  for (const LevelBlock& b : level.blocks) {
    const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(b.shape), level.res);
    for (int s = 0; s < layout.sample_count(); ++s) {
      const int f = layout.face_of(s);
      const int t = s % layout.texels_per_face();
      const double u0 = (t % level.res) / res, v0 = (t / level.res) / res, u1 = u0 + 1.0 / res,
                   v1 = v0 + 1.0 / res;
      const glm::dvec3 p00 = block_to_world(b, face_point(f, u0, v0)),
                       p10 = block_to_world(b, face_point(f, u1, v0)),
                       p01 = block_to_world(b, face_point(f, u0, v1)),
                       p11 = block_to_world(b, face_point(f, u1, v1));
      area[b.sample_offset + std::size_t(s)] = 0.5 * (glm::length(glm::cross(p10 - p00, p11 - p00)) +
                                                      glm::length(glm::cross(p11 - p00, p01 - p00)));
    }
  }
  return area;
}

std::vector<double> level_block_means(const Level& level, std::span<const float> signal) {
  std::vector<double> means(3 * level.blocks.size(), 0.0);
  if (signal.size() < 3 * std::size_t(level.sample_count)) return means;
  const std::vector<double> area = level_sample_area(level);
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& b = level.blocks[bi];
    double sum[3] = {0, 0, 0}, total = 0.0;
    for (std::uint32_t s = b.sample_offset; s < b.sample_offset + b.sample_count; ++s) {
      total += area[s];
      for (int ch = 0; ch < 3; ++ch)
        sum[ch] += area[s] * double(signal[3 * std::size_t(s) + std::size_t(ch)]);
    }
    if (total > 0.0)
      for (int ch = 0; ch < 3; ++ch) means[3 * bi + std::size_t(ch)] = sum[ch] / total;
  }
  return means;
}

void level_sample_albedo(const Level& level, std::span<float> out) {
  for (const LevelBlock& b : level.blocks) {
    const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(b.shape), level.res);
    for (int s = 0; s < layout.sample_count(); ++s) {
      const std::size_t k = 3 * (b.sample_offset + std::size_t(s));
      if (k + 3 > out.size()) return;  // the caller's buffer is checked; never write past it
      const glm::vec3& a = b.albedo[std::size_t(layout.face_of(s))];
      out[k] = a.r;
      out[k + 1] = a.g;
      out[k + 2] = a.b;
    }
  }
}

std::vector<float> level_sample_albedo(const Level& level) {
  std::vector<float> albedo(3 * std::size_t(level.sample_count));
  level_sample_albedo(level, albedo);
  return albedo;
}

}  // namespace modrt
