// SPDX-License-Identifier: MIT
// modrt — the blocks a camera can see (issue 20, "skip what the camera cannot see"): a
// conservative portal walk from the camera's block through the level's open faces, each portal
// clipped to the screen rectangle of the portals before it.
//
// A block is potentially visible when a chain of open faces leads to it from the camera's block
// and every portal of the chain overlaps, on screen, the rectangle the chain has narrowed to.
// Conservative by construction: a portal partly behind the camera keeps the rectangle it was
// reached with; a camera outside every block sees every block. The screen is normalised device
// coordinates of `view_projection` (OpenGL clip space, x and y in [-1, 1]).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "modrt/level.h"
#include "modrt/probe_sampler.h"
#include "modrt/status.h"

namespace modrt {

struct VisibilityStats {
  std::size_t visible = 0;      // blocks marked 1
  bool camera_outside = false;  // the camera lies in no block: every block was marked
};

// The world corners of canonical face f of `block`: world face w = rotate_face(f, quarter_turns),
// the corners (indexed x + 2y + 4z in the world) whose bit w / 2 is w % 2.
std::array<glm::dvec3, 4> block_face_corners(const LevelBlock& block, int face);

// Marks visible[i] = 1 for every potentially visible block, 0 for the others (visible has one
// flag per block). `camera_block`: the block containing the camera (ProbeSampler::locate), or
// -1 when it is outside every block. `scratch` is reused between calls (no allocation once it
// has grown to the level's size).
struct VisibilityScratch {
  struct Item {
    int block;
    double x0, y0, x1, y1;
  };
  std::vector<Item> stack;
  std::vector<double> rect;  // per block: the union of the rectangles it was reached with (4 each)
};
VisibilityStats level_visible_blocks(const Level& level, const glm::dmat4& view_projection, int camera_block,
                                     std::span<std::uint8_t> visible, VisibilityScratch& scratch);

// The camera's visible blocks frame after frame (Backend::set_visible_blocks): the block holding
// the eye (ProbeSampler::containing_block; none: every block), then level_visible_blocks.
// Borrows `level` (it must outlive this). Construction allocates; update() does not once the
// walk's stack has grown to the level's depth.
class CameraVisibility {
 public:
  CameraVisibility() = default;
  explicit CameraVisibility(const Level& level);

  // Refused (invalid_argument, nothing changes) for a non-finite matrix or eye.
  Result<VisibilityStats> update(const glm::dmat4& view_projection, const glm::dvec3& eye);
  std::span<const std::uint8_t> visible() const { return visible_; }
  int camera_block() const { return camera_block_; }

 private:
  const Level* level_ = nullptr;
  ProbeSampler sampler_;
  VisibilityScratch scratch_;
  std::vector<std::uint8_t> visible_;
  int camera_block_ = -1;
};

}  // namespace modrt
