// SPDX-License-Identifier: MIT
// The camera's potentially visible blocks (core's level_visibility.h) against brute force: rays
// through a grid of pixels marched through the unwarped 41-block maze, cell by cell, through open
// faces only. Every block a ray enters must be marked (the walk is conservative), and the walk
// must leave blocks out (it prunes).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "level_fixtures.h"
#include "modrt/cube.h"
#include "modrt/level_visibility.h"
#include "modrt/probe_sampler.h"

namespace modrt {
namespace {

using test::test_level;
using test::TestLevel;

struct Camera {
  glm::dvec3 eye, target;
  glm::dmat4 vp;
};

Camera camera(glm::dvec3 eye, glm::dvec3 target) {
  const glm::dmat4 view = glm::lookAt(eye, target, glm::dvec3(0, 1, 0));
  const glm::dmat4 proj = glm::perspective(1.2, 1.0, 0.01, 100.0);
  return {eye, target, proj * view};
}

// The blocks camera rays enter: each ray walks the grid cell by cell (exact crossings of the
// cell planes) and passes a face only where the block it leaves has that face open towards the
// block it enters.
std::vector<std::uint8_t> brute_force_visible(const Level& level, const Camera& cam, int pixels) {
  std::map<std::tuple<int, int, int>, int> at;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const glm::ivec3 c = level.blocks[i].cell;
    at[{c.x, c.y, c.z}] = int(i);
  }
  std::vector<std::uint8_t> seen(level.blocks.size(), 0);
  const glm::dmat4 inv = glm::inverse(cam.vp);
  for (int py = 0; py < pixels; ++py)
    for (int px = 0; px < pixels; ++px) {
      const double x = -1.0 + 2.0 * (px + 0.5) / pixels, y = -1.0 + 2.0 * (py + 0.5) / pixels;
      glm::dvec4 far = inv * glm::dvec4(x, y, 1.0, 1.0);
      const glm::dvec3 dir = glm::normalize(glm::dvec3(far) / far.w - cam.eye);
      glm::dvec3 p = cam.eye;
      glm::ivec3 cell = glm::ivec3(glm::floor(p));
      auto found = at.find({cell.x, cell.y, cell.z});
      if (found == at.end()) continue;
      int block = found->second;
      seen[std::size_t(block)] = 1;
      for (int step = 0; step < 200; ++step) {
        // The next cell plane the ray crosses.
        double t_best = 1e300;
        int axis = -1;
        for (int a = 0; a < 3; ++a) {
          if (dir[a] == 0.0) continue;
          const double plane = dir[a] > 0 ? cell[a] + 1.0 : double(cell[a]);
          const double t = (plane - p[a]) / dir[a];
          if (t < t_best) t_best = t, axis = a;
        }
        if (axis < 0) break;
        const int world_face = 2 * axis + (dir[axis] > 0 ? 1 : 0);
        const LevelBlock& blk = level.blocks[std::size_t(block)];
        int canonical = -1;
        for (int f = 0; f < kFaceCount; ++f)
          if (rotate_face(f, blk.quarter_turns) == world_face) canonical = f;
        const int next = canonical >= 0 ? blk.neighbour[std::size_t(canonical)] : -1;
        if (next < 0) break;  // a wall, or the level's edge
        p += dir * (t_best + 1e-9);
        cell[axis] += dir[axis] > 0 ? 1 : -1;
        const auto there = at.find({cell.x, cell.y, cell.z});
        EXPECT_TRUE(there != at.end() && there->second == next)
            << "block " << block << "'s face " << canonical << " (world face " << world_face
            << ") leads to block " << next << ", not to the block of cell " << cell.x << " " << cell.y << " "
            << cell.z;
        if (there == at.end() || there->second != next) break;
        block = next;
        seen[std::size_t(block)] = 1;
      }
    }
  return seen;
}

TEST(LevelVisibility, EveryBlockARayEntersIsMarked) {
  const TestLevel& t = test_level("maze41");
  for (const LevelBlock& b : t.level.blocks)
    ASSERT_EQ(b.corners[7], glm::dvec3(b.cell) + 1.0) << "the brute force needs unwarped unit cells";
  const ProbeSampler sampler(t.level, 1);
  VisibilityScratch scratch;
  std::vector<std::uint8_t> visible(t.level.blocks.size());
  std::size_t cameras = 0, pruned = 0, walk_total = 0, rays_total = 0;
  for (std::size_t start = 0; start < t.level.blocks.size(); start += 3) {
    const glm::dvec3 eye = glm::dvec3(t.level.blocks[start].cell) + glm::dvec3(0.5, 0.45, 0.5);
    for (const glm::dvec3 look : {glm::dvec3(1, 0, 0.3), glm::dvec3(-0.4, 0.1, 1), glm::dvec3(0.2, -0.2, -1),
                                  glm::dvec3(-1, 0.05, -0.6)}) {
      const Camera cam = camera(eye, eye + look);
      const Result<ProbeCell> cell = sampler.locate(eye);
      ASSERT_TRUE(cell.ok());
      const VisibilityStats st = level_visible_blocks(t.level, cam.vp, int(cell->block), visible, scratch);
      ASSERT_FALSE(st.camera_outside);
      const std::vector<std::uint8_t> seen = brute_force_visible(t.level, cam, 96);
      std::size_t rays = 0;
      for (std::size_t i = 0; i < seen.size(); ++i) {
        rays += seen[i];
        EXPECT_TRUE(!seen[i] || visible[i])
            << "block " << i << " seen from block " << start << " but not marked";
      }
      ++cameras;
      pruned += st.visible < t.level.blocks.size();
      walk_total += st.visible, rays_total += rays;
    }
  }
  std::printf(
      "  %zu cameras in maze41: %.1f blocks marked on average, %.1f entered by rays; %zu of them "
      "leave blocks out\n",
      cameras, double(walk_total) / double(cameras), double(rays_total) / double(cameras), pruned);
  EXPECT_EQ(pruned, cameras);  // a maze hides most of itself from every camera
}

TEST(LevelVisibility, ACameraOutsideSeesEverything) {
  const TestLevel& t = test_level("maze11");
  VisibilityScratch scratch;
  std::vector<std::uint8_t> visible(t.level.blocks.size(), 0);
  const Camera cam = camera(glm::dvec3(-50, 3, -50), glm::dvec3(0));
  const VisibilityStats st = level_visible_blocks(t.level, cam.vp, -1, visible, scratch);
  EXPECT_TRUE(st.camera_outside);
  EXPECT_EQ(st.visible, t.level.blocks.size());
  for (std::uint8_t v : visible) EXPECT_EQ(v, 1);
}

// Looking straight at a wall of the camera's block from its centre: the block itself only
// when no opening lies in the view; turning round adds what the openings show.
TEST(LevelVisibility, TheCamerasBlockIsAlwaysVisible) {
  const TestLevel& t = test_level("maze11");
  VisibilityScratch scratch;
  std::vector<std::uint8_t> visible(t.level.blocks.size(), 0);
  for (std::size_t b = 0; b < t.level.blocks.size(); ++b) {
    const glm::dvec3 eye = glm::dvec3(t.level.blocks[b].cell) + 0.5;
    const VisibilityStats st =
        level_visible_blocks(t.level, camera(eye, eye + glm::dvec3(0, 0, 1)).vp, int(b), visible, scratch);
    EXPECT_EQ(visible[b], 1);
    EXPECT_GE(st.visible, 1u);
  }
}

}  // namespace
}  // namespace modrt
