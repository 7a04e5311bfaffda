// SPDX-License-Identifier: MIT
#include "modrt/probe_sampler.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <glm/mat3x3.hpp>

#include "modrt/cube.h"
#include "modrt/level_geometry.h"
#include "modrt/sh.h"

namespace modrt {
namespace {

// How far canonical p lies outside [0,1]^3 (0 inside).
double outside(const glm::dvec3& p) {
  double d = 0.0;
  for (int a = 0; a < 3; ++a) d = std::max({d, -p[a], p[a] - 1.0});
  return d;
}

}  // namespace

ProbeSampler::ProbeSampler(const Level& level, int grid) : level_(&level), grid_(grid) {
  box_lo_.resize(level.blocks.size());
  box_hi_.resize(level.blocks.size());
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    glm::dvec3 lo = level.blocks[i].corners[0], hi = lo;
    for (const glm::dvec3& c : level.blocks[i].corners) lo = glm::min(lo, c), hi = glm::max(hi, c);
    const glm::dvec3 grow = 0.01 * (hi - lo) + 1e-9;
    box_lo_[i] = lo - grow;
    box_hi_[i] = hi + grow;
  }
  for (int t = 0; t < 4; ++t) rotation_[std::size_t(t)] = sh9_quarter_turn_rotation(t);
}

namespace {
// c_world = M c (M = rotation(quarter_turns)), band l scaled by A_l / pi for E / pi (sh.h,
// irradiance_from_radiance_sh9).
void to_world(const std::array<double, 81>& m, const double sh[27], bool irradiance, float out[27]) {
  for (int k = 0; k < 9; ++k) {
    const double scale = !irradiance ? 1.0 : (k == 0 ? 1.0 : k < 4 ? 2.0 / 3.0 : 0.25);
    for (int c = 0; c < 3; ++c) {
      double v = 0.0;
      for (int j = 0; j < 9; ++j) v += m[std::size_t(9 * k + j)] * sh[3 * j + c];
      out[3 * k + c] = float(scale * v);
    }
  }
}
}  // namespace

int ProbeSampler::containing_block(const glm::dvec3& x, glm::dvec3* canonical) const {
  std::size_t block = 0;
  double best = 1e30;
  glm::dvec3 p(0.5);
  for (std::size_t i = 0; i < box_lo_.size() && best > 0.0; ++i) {
    if (glm::any(glm::lessThan(x, box_lo_[i])) || glm::any(glm::greaterThan(x, box_hi_[i]))) continue;
    const glm::dvec3 q = world_to_block(level_->blocks[i], x);
    const double o = outside(q);
    if (o < best) best = o, block = i, p = q;
  }
  if (best > 0.01) return -1;
  if (canonical) *canonical = p;
  return int(block);
}

Result<ProbeCell> ProbeSampler::locate(const glm::dvec3& x, const char* what) const {
  glm::dvec3 p(0.5);
  const int found = containing_block(x, &p);
  if (found < 0) {
    char text[200];
    std::snprintf(text, sizeof text, "%s (%g, %g, %g) lies outside every block of the level", what, x.x, x.y,
                  x.z);
    return Status::error(ErrorCode::invalid_argument, text);
  }
  const std::size_t block = std::size_t(found);
  const int g = grid_;
  // Probe centres sit at (i + 0.5) / g; outside the outermost centres the value is held.
  const glm::dvec3 gc = glm::clamp(p * double(g) - 0.5, glm::dvec3(0.0), glm::dvec3(std::max(g - 1, 0)));
  ProbeCell cell;
  cell.block = block;
  cell.i0 = glm::min(glm::ivec3(glm::floor(gc)), glm::ivec3(std::max(g - 2, 0)));
  cell.f = g > 1 ? gc - glm::dvec3(cell.i0) : glm::dvec3(0.0);
  return cell;
}

Status ProbeSampler::sample(std::span<const float> probes, const glm::dvec3& x, bool irradiance,
                            float out[27]) const {
  const Result<ProbeCell> located = locate(x);
  if (!located.ok()) return located.status();
  const ProbeCell& cell = located.value();
  const int g = grid_;
  const std::size_t per_block = 27 * std::size_t(g) * std::size_t(g) * std::size_t(g);
  const float* base = probes.data() + per_block * cell.block;
  double sh[27] = {};
  const glm::dvec3 f = cell.f;
  for (int c = 0; c < 8; ++c) {
    const glm::ivec3 o(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    const glm::ivec3 q = glm::min(cell.i0 + o, glm::ivec3(g - 1));
    const double w = (o.x ? f.x : 1 - f.x) * (o.y ? f.y : 1 - f.y) * (o.z ? f.z : 1 - f.z);
    if (w == 0.0) continue;
    const float* probe = base + 27 * std::size_t(q.x + g * (q.y + g * q.z));
    for (int k = 0; k < 27; ++k) sh[k] += w * double(probe[k]);
  }
  to_world(rotation(level_->blocks[cell.block].quarter_turns), sh, irradiance, out);
  return Status::success();
}

void ProbeSampler::world_probes(std::span<const float> probes, bool irradiance, std::span<float> out) const {
  const std::size_t per_block = 27 * std::size_t(grid_) * std::size_t(grid_) * std::size_t(grid_);
  for (std::size_t b = 0; b < level_->blocks.size(); ++b) {
    const std::array<double, 81>& m = rotation(level_->blocks[b].quarter_turns);
    for (std::size_t at = per_block * b; at < per_block * (b + 1) && at + 27 <= probes.size(); at += 27) {
      double sh[27];
      for (int k = 0; k < 27; ++k) sh[k] = double(probes[at + std::size_t(k)]);
      to_world(m, sh, irradiance, out.data() + at);
    }
  }
}

glm::dvec3 ProbeSampler::probe_position(std::size_t block, int p) const {
  const int g = grid_;
  const glm::dvec3 cell(p % g, (p / g) % g, p / (g * g));
  return block_to_world(level_->blocks[block], (cell + 0.5) / double(g));
}

}  // namespace modrt
