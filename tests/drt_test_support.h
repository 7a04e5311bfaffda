// SPDX-License-Identifier: MIT
// modrt tests — what the DRT test files (test_drt_*.cpp) share: the small test dictionary,
// the MRT frame of a level, a relative L2 that skips texels, operator equality, and the
// two-boxes scene.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "clutter_meshes.h"
#include "drt_scenes.h"
#include "modrt/drt.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/clutter_mesh.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/path_tracer.h"
#include "modrt/precompute/sampling.h"
#include "modrt/precompute/sh_operators.h"
#include "modrt/sh.h"
#include "test_support.h"

namespace modrt::precompute::drt_test {

// The paper's operators (Cb = Uc Vc, Cc, dUb and dUc on every traced sample): the settings of
// the tests of those operators, the build default being the real-radiance gather.
inline DrtBuildSettings paper_operators(DrtBuildSettings settings = {}) {
  settings.gather = false;
  return settings;
}

inline const Dictionary& dict() { return test::small_test_dictionary(); }

using test::box_room_two_boxes;
using test::ClutterScene;
using test::l_shaped_level_with_a_box;
using test::maze_block_four_pillars;

inline double rel_l2(std::span<const float> x, std::span<const float> ref,
                     const std::vector<std::uint8_t>& skip) {
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    if (skip[i / 3]) continue;
    num += (double(x[i]) - ref[i]) * (double(x[i]) - ref[i]);
    den += double(ref[i]) * ref[i];
  }
  return std::sqrt(num / den);
}

struct Frame {
  std::vector<float> ld, b, r, lightmap;
};
inline Frame evaluate_mrt(const Level& level, std::span<const float> ld) {
  const LevelBufferSizes sz = level_buffer_sizes(level, dict());
  Frame f;
  f.ld.assign(ld.begin(), ld.end());
  f.b.resize(sz.b);
  f.r.resize(sz.r);
  f.lightmap.resize(sz.lightmap);
  EXPECT_TRUE(level_evaluate(level, dict(), f.ld, f.b, f.r, f.lightmap).ok());
  return f;
}

inline bool sparse_equal(const DrtSparseRows& a, const DrtSparseRows& b) {
  return a.start == b.start && a.index == b.index && a.weight == b.weight;
}
inline bool operators_equal(const DrtObjectOperators& a, const DrtObjectOperators& b) {
  return a.texel_count == b.texel_count && a.face_count == b.face_count && a.dUb_sample == b.dUb_sample &&
         a.dUb_block == b.dUb_block && a.dUb.data == b.dUb.data && a.Td_c.data == b.Td_c.data &&
         a.dUc_sample == b.dUc_sample && a.dUc.data == b.dUc.data && a.Cb_blocks == b.Cb_blocks &&
         a.Uc.data == b.Uc.data && a.Vc.data == b.Vc.data && a.Cc_objects == b.Cc_objects &&
         a.Cc.rows == b.Cc.rows && a.Cc.cols == b.Cc.cols && a.Cc.data == b.Cc.data &&
         a.dUb_vec_sample == b.dUb_vec_sample && a.dUb_vec_block == b.dUb_vec_block &&
         a.dUb_vec.data == b.dUb_vec.data && a.dUc_vec_sample == b.dUc_vec_sample &&
         a.dUc_vec.data == b.dUc_vec.data && a.Udyn_probe == b.Udyn_probe && a.Udyn_block == b.Udyn_block &&
         a.Udyn.data == b.Udyn.data && a.Udyn_c_probe == b.Udyn_c_probe && a.Udyn_c.data == b.Udyn_c.data &&
         a.texel_position == b.texel_position && a.texel_normal == b.texel_normal &&
         sparse_equal(a.Gs, b.Gs) && sparse_equal(a.Gt, b.Gt) && a.H_sample == b.H_sample &&
         sparse_equal(a.Hs, b.Hs) && sparse_equal(a.Ht, b.Ht);
}

// Two boxes in a row on the floor of a closed room, so that many rays pass through both
// (overlapping shadows) and each box's facing sides see the other (clutter-to-clutter light).
inline ClutterScene two_boxes_in_a_row() {
  ClutterScene s = box_room_two_boxes();
  s.clutter[0].box.center = glm::dvec3(0.33, 0.15, 0.5);
  s.clutter[0].box.half_extent = glm::dvec3(0.08, 0.15, 0.1);
  s.clutter[1].box.center = glm::dvec3(0.62, 0.22, 0.5);
  s.clutter[1].box.half_extent = glm::dvec3(0.09, 0.22, 0.12);
  s.clutter[1].box.rotation = glm::dmat3(1.0);
  return s;
}

}  // namespace modrt::precompute::drt_test
