// SPDX-License-Identifier: MIT
// Sampling the level's probe volume at a world point (architecture.md §5 step 9, MRT §6.5): the block
// containing the point, its canonical coordinates (Newton on the trilinear warp), trilinear
// weights of the g^3 probes, and the SH9 rotation from the block's canonical frame into the
// world. Everything is prepared at creation; locate() and sample() do not allocate. Used by the
// C API (modrt_context_probe_sh) and by renderers that sample the probe volume on the GPU
// (locate() gives the cell and weights a shader needs).
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/level.h"
#include "modrt/status.h"

namespace modrt {

// Where a world point lies in the probe volume: its block, the lower corner i0 of the 2 x 2 x 2
// probes around it on the block's canonical g^3 grid (i0 + 1 clamped to g - 1 at the edges) and
// the trilinear weights f in [0, 1]^3 towards i0 + 1.
struct ProbeCell {
  std::size_t block = 0;
  glm::ivec3 i0{0};
  glm::dvec3 f{0.0};
};

class ProbeSampler {
 public:
  ProbeSampler() = default;
  ProbeSampler(const Level& level, int grid);

  // The cell of world point x. Fails (invalid_argument, naming `what` and x) for a point outside
  // every block by more than 1% of a block.
  Result<ProbeCell> locate(const glm::dvec3& x, const char* what = "probe position") const;
  // The block containing world point x (within 1% of a block), or -1: locate's search, with no
  // message (it allocates nothing; a camera outside the level is no error, level_visibility.h).
  // `canonical`, when given, receives x in that block's canonical coordinates.
  int containing_block(const glm::dvec3& x, glm::dvec3* canonical = nullptr) const;
  // out[3 k + c], world frame; `irradiance`: E/pi (bands scaled by A_l / pi = 1, 2/3, 1/4).
  // Fails (invalid_argument) for a point outside every block by more than 1% of a block.
  Status sample(std::span<const float> probes, const glm::dvec3& x, bool irradiance, float out[27]) const;

  // Every probe of `probes` (canonical frames) rotated into the world frame, into `out`
  // (probes.size() floats, same order); `irradiance` as in sample().
  void world_probes(std::span<const float> probes, bool irradiance, std::span<float> out) const;
  // World position of probe p = i + g (j + g k) of block `block`: its canonical cell centre
  // ((i, j, k) + 0.5) / g through the block's warp.
  glm::dvec3 probe_position(std::size_t block, int p) const;
  int grid() const { return grid_; }

  // Canonical block coordinates of world point x in block `block`.
  // c_world = M c_canonical for a block turned by `quarter_turns` (0..3).
  const std::array<double, 81>& rotation(int quarter_turns) const {
    return rotation_[std::size_t(quarter_turns & 3)];
  }

 private:
  const Level* level_ = nullptr;
  int grid_ = 0;
  std::vector<glm::dvec3> box_lo_, box_hi_;  // per block, corners' box grown by 1%
  std::array<std::array<double, 81>, 4> rotation_{};
};

}  // namespace modrt
