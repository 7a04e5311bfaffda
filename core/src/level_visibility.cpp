// SPDX-License-Identifier: MIT
#include "modrt/level_visibility.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <glm/vec4.hpp>

#include "modrt/cube.h"

namespace modrt {
namespace {

// Portals this close to the camera plane (clip w) are treated as crossing it.
constexpr double kNearW = 1e-9;

struct Rect {
  double x0, y0, x1, y1;
  bool empty() const { return !(x0 < x1 && y0 < y1); }
};

// The screen rectangle of a portal intersected with `within`; `within` itself when a corner
// lies behind the camera plane (the projection does not bound it); empty when every corner
// does (the portal is behind the camera) or the rectangles do not overlap.
Rect portal_rect(const std::array<glm::dvec3, 4>& corners, const glm::dmat4& vp, const Rect& within) {
  Rect r{1e300, 1e300, -1e300, -1e300};
  int behind = 0;
  for (const glm::dvec3& c : corners) {
    const glm::dvec4 p = vp * glm::dvec4(c, 1.0);
    if (p.w <= kNearW) {
      ++behind;
      continue;
    }
    const double x = p.x / p.w, y = p.y / p.w;
    r.x0 = std::min(r.x0, x), r.x1 = std::max(r.x1, x);
    r.y0 = std::min(r.y0, y), r.y1 = std::max(r.y1, y);
  }
  if (behind == 4) return Rect{0, 0, 0, 0};
  if (behind > 0) return within;
  return Rect{std::max(r.x0, within.x0), std::max(r.y0, within.y0), std::min(r.x1, within.x1),
              std::min(r.y1, within.y1)};
}

}  // namespace

std::array<glm::dvec3, 4> block_face_corners(const LevelBlock& block, int face) {
  // The corners are indexed in the world (x + 2y + 4z): the face's world side.
  const int world = rotate_face(face, block.quarter_turns);
  const int axis = world / 2, side = world % 2;
  std::array<glm::dvec3, 4> out{};
  int n = 0;
  for (int i = 0; i < 8; ++i)
    if (((i >> axis) & 1) == side) out[std::size_t(n++)] = block.corners[std::size_t(i)];
  return out;
}

VisibilityStats level_visible_blocks(const Level& level, const glm::dmat4& view_projection, int camera_block,
                                     std::span<std::uint8_t> visible, VisibilityScratch& scratch) {
  const std::size_t blocks = level.blocks.size();
  VisibilityStats stats;
  if (camera_block < 0 || std::size_t(camera_block) >= blocks) {
    std::fill(visible.begin(), visible.end(), std::uint8_t(1));
    stats.visible = blocks, stats.camera_outside = true;
    return stats;
  }
  std::fill(visible.begin(), visible.end(), std::uint8_t(0));
  scratch.rect.assign(4 * blocks, 0.0);
  for (std::size_t i = 0; i < blocks; ++i)
    scratch.rect[4 * i] = 1.0, scratch.rect[4 * i + 2] = -1.0;  // empty
  scratch.stack.clear();
  scratch.stack.push_back({camera_block, -1.0, -1.0, 1.0, 1.0});
  visible[std::size_t(camera_block)] = 1;
  double* own = scratch.rect.data() + 4 * std::size_t(camera_block);
  own[0] = -1.0, own[1] = -1.0, own[2] = 1.0, own[3] = 1.0;
  // Each push enlarges a block's rectangle; the cap keeps a pathological level finite (then
  // everything is marked, which is conservative).
  std::size_t pushes = 0;
  const std::size_t cap = 64 * blocks + 64;
  while (!scratch.stack.empty()) {
    const VisibilityScratch::Item item = scratch.stack.back();
    scratch.stack.pop_back();
    const LevelBlock& blk = level.blocks[std::size_t(item.block)];
    const Rect within{item.x0, item.y0, item.x1, item.y1};
    for (int f = 0; f < kFaceCount; ++f) {
      const int j = blk.neighbour[std::size_t(f)];
      if (j < 0 || std::size_t(j) >= blocks) continue;
      const Rect r = portal_rect(block_face_corners(blk, f), view_projection, within);
      if (r.empty()) continue;
      double* u = scratch.rect.data() + 4 * std::size_t(j);
      const bool had = u[0] < u[2] && u[1] < u[3];
      if (had && r.x0 >= u[0] && r.y0 >= u[1] && r.x1 <= u[2] && r.y1 <= u[3]) continue;  // nothing new
      if (had) {
        u[0] = std::min(u[0], r.x0), u[1] = std::min(u[1], r.y0), u[2] = std::max(u[2], r.x1),
        u[3] = std::max(u[3], r.y1);
      } else {
        u[0] = r.x0, u[1] = r.y0, u[2] = r.x1, u[3] = r.y1;
      }
      visible[std::size_t(j)] = 1;
      if (++pushes > cap) {
        std::fill(visible.begin(), visible.end(), std::uint8_t(1));
        stats.visible = blocks;
        return stats;
      }
      scratch.stack.push_back({j, u[0], u[1], u[2], u[3]});
    }
  }
  for (std::uint8_t v : visible) stats.visible += v;
  return stats;
}

CameraVisibility::CameraVisibility(const Level& level)
    : level_(&level), sampler_(level, 1), visible_(level.blocks.size(), 1) {
  scratch_.rect.reserve(4 * level.blocks.size());
  scratch_.stack.reserve(level.blocks.size() + 1);
}

Result<VisibilityStats> CameraVisibility::update(const glm::dmat4& view_projection, const glm::dvec3& eye) {
  if (!level_) return Status::error(ErrorCode::invalid_argument, "camera visibility: no level");
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(view_projection[c][r]))
        return Status::error(ErrorCode::non_finite, "camera visibility: view_projection[" +
                                                        std::to_string(c) + "][" + std::to_string(r) +
                                                        "] is not finite");
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(eye[k]))
      return Status::error(ErrorCode::non_finite,
                           "camera visibility: eye[" + std::to_string(k) + "] is not finite");
  camera_block_ = sampler_.containing_block(eye);
  return level_visible_blocks(*level_, view_projection, camera_block_, visible_, scratch_);
}

}  // namespace modrt
