// SPDX-License-Identifier: MIT
// Delta Radiance Transfer (architecture.md §6): every DRT operator against a brute-force
// gather that traces the same rays and sums what they bring (clutter-to-clutter light, the
// vector deltas and vector Cb, the clutter-aware probes).
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
#include "drt_test_support.h"
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

namespace modrt::precompute {
namespace {

using namespace drt_test;

// An independent estimate of what the DRT operators stand for, ray by ray: iid cosine rays
// (not the build's stratified sets) against the walls with the clutter (first hit) and the
// walls alone (the wall behind). A scene ray whose first hit is clutter object k's face f
// brings -Limp(wall behind) b + c(k, f); a clutter-texel ray brings Limp(wall) b when it
// reaches a wall first and c(k, f) when it enters another object first. v holds Limp b per
// level sample (3 per sample), c the face values (3 per face, objects in order).
// Limp b (v: 3 per level sample) at a wall hit, bilinear on the hit face's texel grid.
double wall_limp_b(const Level& level, std::span<const float> v, const LevelHit& hit, int ch) {
  const LevelBlock& hb = level.blocks[std::size_t(hit.block)];
  const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(hb.shape), level.res);
  const BilinearTaps taps = bilinear_taps(hit.u, hit.v, level.res);
  double value = 0.0;
  for (int k = 0; k < 4; ++k)
    value +=
        taps.w[k] * v[3 * (hb.sample_offset + std::size_t(layout.index(hit.face, taps.i[k], taps.j[k]))) +
                      std::size_t(ch)];
  return value;
}

// The slot of box face `face` among the object's lit faces (its column of c), -1 when unlit.
int lit_slot(const ClutterObject& o, int face) {
  for (int f = 0, slot = 0; f < kFaceCount; ++f)
    if (face_present(o.faces, f)) {
      if (f == face) return slot;
      ++slot;
    }
  return -1;
}

struct Estimate {
  double mean[3] = {0, 0, 0}, se[3] = {0, 0, 0};
};
Estimate brute_force(const LevelScene& scene, const LevelScene& walls, std::span<const float> v,
                     std::span<const float> c, const glm::dvec3& x, const glm::dvec3& n, bool clutter_texel,
                     int rays, std::uint64_t stream) {
  const Level& level = scene.level();
  std::vector<std::size_t> face0(1, 0);
  for (const ClutterObject& o : scene.clutter())
    face0.push_back(face0.back() + std::size_t(clutter_face_count(o)));
  auto wall_value = [&](const LevelHit& hit, int ch) { return wall_limp_b(level, v, hit, ch); };
  Rng rng(0xb7f0ull, stream);
  glm::dvec3 t, b;
  tangent_frame(n, t, b);
  double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
  for (int r = 0; r < rays; ++r) {
    const double u1 = rng.next_double(), u2 = rng.next_double();
    const glm::dvec3 dir = to_world(cosine_hemisphere(glm::dvec2(u1, u2)), t, b, n);
    const LevelHit first = scene.intersect(x, dir);
    double value[3] = {0, 0, 0};
    if (first.clutter >= 0) {
      const ClutterObject& o = scene.clutter()[std::size_t(first.clutter)];
      int slot = -1;
      for (int f = 0, k = 0; f < kFaceCount; ++f)
        if (face_present(o.faces, f)) {
          if (f == first.face) slot = k;
          ++k;
        }
      const LevelHit behind = walls.intersect(x, dir);
      for (int ch = 0; ch < 3; ++ch) {
        if (slot >= 0)
          value[ch] += c[3 * (face0[std::size_t(first.clutter)] + std::size_t(slot)) + std::size_t(ch)];
        if (!clutter_texel && behind.block >= 0) value[ch] -= wall_value(behind, ch);
      }
    } else if (clutter_texel && first.block >= 0) {
      for (int ch = 0; ch < 3; ++ch) value[ch] = wall_value(first, ch);
    }
    for (int ch = 0; ch < 3; ++ch) {
      sum[ch] += value[ch];
      sum2[ch] += value[ch] * value[ch];
    }
  }
  Estimate e;
  for (int ch = 0; ch < 3; ++ch) {
    e.mean[ch] = sum[ch] / rays;
    e.se[ch] = std::sqrt(std::max(0.0, sum2[ch] / rays - e.mean[ch] * e.mean[ch]) / rays);
  }
  return e;
}

// The joint build against the brute-force estimate at the scene samples with the largest
// DRT delta and at the clutter texels of the two facing sides: dUb b + dUc c and Cb b + Cc c
// (Cb untruncated) within 4 combined standard errors. Objects built alone (each traced
// against the walls and itself) subtract overlapping shadows twice and miss the other box's
// light, and fail the same comparison.
TEST(Drt, ClutterSeesClutterAsTheBruteForceGatherDoes) {
  const ClutterScene s = two_boxes_in_a_row();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings = paper_operators();
  settings.rays = 4096;
  settings.cb_modes = 1000;  // Cb exactly, so that only the gather is compared
  const DrtBuilder builder(level, dict(), settings);
  const DrtOperators drt = builder.build(s.clutter).value();
  ASSERT_TRUE(check_drt_operators(level, drt).ok());
  DrtOperators alone;
  alone.kb = drt.kb;
  for (const ClutterObject& o : s.clutter) alone.objects.push_back(builder.build_object(o).value());
  std::size_t with_cc = 0;
  for (const DrtObjectOperators& o : drt.objects) with_cc += o.Cc.rows;
  EXPECT_EQ(with_cc, drt.objects[0].texel_count + drt.objects[1].texel_count);

  // A b with structure (uniform ld) and distinct face values c.
  const std::vector<float> ld(3 * std::size_t(level.sample_count), 0.5f);
  const Frame f = evaluate_mrt(level, ld);
  std::vector<float> c(drt_buffer_sizes(drt).c);
  for (std::size_t i = 0; i < c.size(); ++i) c[i] = 0.05f + 0.03f * float(i % 7);
  std::vector<float> v(3 * std::size_t(level.sample_count), 0.0f);
  for (const LevelBlock& blk : level.blocks)
    for (std::uint32_t q = 0; q < blk.sample_count; ++q) {
      const std::span<const float> limp = block_operators(dict(), level, blk).Limp.row(q);
      const std::size_t blk_index = std::size_t(&blk - level.blocks.data());
      for (std::uint32_t k = 0; k < limp.size(); ++k)
        for (int ch = 0; ch < 3; ++ch)
          v[3 * (blk.sample_offset + q) + std::size_t(ch)] +=
              limp[k] * f.b[3 * (std::size_t(level.kb) * blk_index + k) + std::size_t(ch)];
    }
  std::vector<float> delta(3 * std::size_t(level.sample_count), 0.0f), delta_alone = delta;
  drt_apply(level, drt, f.b, c, delta);
  drt_apply(level, alone, f.b, c, delta_alone);
  std::vector<float> gather(drt_buffer_sizes(drt).clutter_lightmap), gather_alone(gather.size());
  drt_clutter_lightmap(drt, f.b, {}, gather);
  drt_clutter_add_cc(drt, c, gather);
  drt_clutter_lightmap(alone, f.b, {}, gather_alone);

  const LevelScene scene(level, level.res, s.clutter), walls(level, level.res);
  const LevelSampleGeometry& g = scene.samples();
  constexpr int kRays = 16384;
  // Error of the build's own 4096-ray estimate, bounded by that of 4096 iid rays.
  const double build_se_factor = std::sqrt(double(kRays) / settings.rays);
  int checked = 0, alone_off = 0;
  auto compare = [&](const Estimate& e, const float* drt_value, const float* alone_value, const char* what,
                     std::size_t index) {
    for (int ch = 0; ch < 3; ++ch) {
      const double tol = 4.0 * e.se[ch] * std::sqrt(1.0 + build_se_factor * build_se_factor) + 1e-6;
      EXPECT_NEAR(drt_value[ch], e.mean[ch], tol) << what << " " << index << " channel " << ch;
      alone_off += std::abs(alone_value[ch] - e.mean[ch]) > tol;
    }
    ++checked;
  };
  // Scene samples: the 12 largest deltas, not inside clutter.
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < g.position.size(); ++i)
    if (!clutter_contains(s.clutter[0].box, g.position[i], 1e-6) &&
        !clutter_contains(s.clutter[1].box, g.position[i], 1e-6))
      order.push_back(i);
  std::partial_sort(order.begin(), order.begin() + 12, order.end(), [&](std::size_t a, std::size_t b) {
    return std::abs(delta[3 * a]) > std::abs(delta[3 * b]);
  });
  for (int k = 0; k < 12; ++k) {
    const std::size_t i = order[std::size_t(k)];
    const Estimate e = brute_force(scene, walls, v, c, g.position[i], g.normal[i], false, kRays, i);
    compare(e, &delta[3 * i], &delta_alone[3 * i], "scene sample", i);
  }
  // Clutter texels: box 0's +x face and box 1's -x face face each other.
  std::size_t texel0 = 0;
  for (std::size_t k = 0; k < 2; ++k) {
    const ClutterTexelGeometry cg = clutter_texel_geometry(s.clutter[k]);
    const int facing = k == 0 ? kFacePosX : kFaceNegX;
    for (std::size_t t = 0; t < cg.position.size(); t += 13) {
      if (cg.face[t] != facing) continue;
      const Estimate e = brute_force(scene, walls, v, c, cg.position[t] + 1e-6 * cg.normal[t], cg.normal[t],
                                     true, kRays, 1000000 + texel0 + t);
      compare(e, &gather[3 * (texel0 + t)], &gather_alone[3 * (texel0 + t)], "clutter texel", texel0 + t);
    }
    texel0 += cg.position.size();
  }
  std::printf(
      "clutter sees clutter: %d points compared with the brute-force gather; objects alone off at %d of %d "
      "values\n",
      checked, alone_off, 3 * checked);
  EXPECT_GT(checked, 20);
  EXPECT_GT(alone_off, checked);  // the test can tell the joint build from independent objects
}

// The vector deltas (OHLSH E/pi in each sample's face frame, DRT §5) against an independent
// estimate: iid uniform-hemisphere rays in the frame of level_compute_vector_irradiance
// (canonical face frame turned with the block), each ray's value (-Limp(wall behind) b +
// c(face) when its first hit is clutter) projected to SH9, convolved to E/pi and turned into
// OHLSH; every coefficient and channel within 4 combined standard errors at the 12 samples
// with the largest scalar delta. Evaluated at the face normal, the vector delta stays within
// 5 % (rel L2) of the scalar delta (OHLSH's linear approximation plus both estimates' noise;
// measured 1 %).
// An iid gather of the OHLSH coefficients of E/pi (uniform hemisphere rays, 2 pi / rays each)
// of RGB radiance values, compared with an operator's 4 x RGB values within 4 combined
// standard errors (the gather's and, scaled by build_se_factor, the build's own).
struct OhlshGather {
  double sum[4][3] = {}, sum2[4][3] = {};
  int rays = 0;
  void add(const glm::dvec3& local, const double value[3]) {
    double y[9], a[4];
    sh9_eval(local, y);
    irradiance_from_radiance_sh9(y, y);
    ohlsh_from_sh9(y, a);
    for (int i = 0; i < 4; ++i)
      for (int ch = 0; ch < 3; ++ch) {
        const double x = 2.0 * std::numbers::pi * value[ch] * a[i];
        sum[i][ch] += x;
        sum2[i][ch] += x * x;
      }
    ++rays;
  }
  // got(i, ch): the operator's coefficient; returns the worst deviation in standard errors.
  template <class Got>
  double check(double build_se_factor, Got&& got, const std::string& what) const {
    double worst = 0.0;
    for (int i = 0; i < 4; ++i)
      for (int ch = 0; ch < 3; ++ch) {
        const double mean = sum[i][ch] / rays;
        const double se = std::sqrt(std::max(0.0, sum2[i][ch] / rays - mean * mean) / rays);
        const double tol = 4.0 * se * std::sqrt(1.0 + build_se_factor * build_se_factor) + 1e-6;
        const double value = got(i, ch);
        EXPECT_NEAR(value, mean, tol) << what << " coefficient " << i << " channel " << ch;
        worst = std::max(worst, std::abs(value - mean) / (tol / 4.0));
      }
    return worst;
  }
};

TEST(Drt, VectorDeltasMatchTheBruteForceGather) {
  const ClutterScene s = two_boxes_in_a_row();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings = paper_operators();
  settings.rays = 4096;
  settings.vector = true;
  const DrtOperators drt = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  ASSERT_TRUE(check_drt_operators(level, drt).ok());
  ASSERT_FALSE(drt.objects[0].dUb_vec.empty());
  ASSERT_FALSE(drt.objects[1].dUc_vec.empty());
  const std::vector<float> ld(3 * std::size_t(level.sample_count), 0.5f);
  const Frame f = evaluate_mrt(level, ld);
  std::vector<float> c(drt_buffer_sizes(drt).c);
  for (std::size_t i = 0; i < c.size(); ++i) c[i] = 0.05f + 0.03f * float(i % 7);
  std::vector<float> v(3 * std::size_t(level.sample_count), 0.0f);
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& blk = level.blocks[bi];
    for (std::uint32_t q = 0; q < blk.sample_count; ++q) {
      const std::span<const float> limp = block_operators(dict(), level, blk).Limp.row(q);
      for (std::uint32_t k = 0; k < limp.size(); ++k)
        for (int ch = 0; ch < 3; ++ch)
          v[3 * (blk.sample_offset + q) + std::size_t(ch)] +=
              limp[k] * f.b[3 * (std::size_t(level.kb) * bi + k) + std::size_t(ch)];
    }
  }
  std::vector<float> delta(3 * std::size_t(level.sample_count), 0.0f),
      vec(12 * std::size_t(level.sample_count), 0.0f);
  drt_apply(level, drt, f.b, c, delta);
  drt_apply_vector(level, drt, f.b, c, vec);

  const LevelScene scene(level, level.res, s.clutter), walls(level, level.res);
  const LevelSampleGeometry& g = scene.samples();
  std::vector<std::size_t> face0(1, 0);
  for (const ClutterObject& o : s.clutter) face0.push_back(face0.back() + std::size_t(clutter_face_count(o)));
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < g.position.size(); ++i)
    if (!clutter_contains(s.clutter[0].box, g.position[i], 1e-6) &&
        !clutter_contains(s.clutter[1].box, g.position[i], 1e-6))
      order.push_back(i);
  std::partial_sort(order.begin(), order.begin() + 12, order.end(), [&](std::size_t a, std::size_t b) {
    return std::abs(delta[3 * a]) > std::abs(delta[3 * b]);
  });
  constexpr int kRays = 16384;
  const double build_se_factor = std::sqrt(double(kRays) / settings.rays);
  double worst_z = 0.0, flat_num = 0.0, flat_den = 0.0;
  for (int k = 0; k < 12; ++k) {
    const std::size_t smp = order[std::size_t(k)];
    const FaceFrame& cf = face_frame(g.face[smp]);
    const int turns = level.blocks[std::size_t(g.block[smp])].quarter_turns;
    const glm::dvec3 n = g.normal[smp];
    glm::dvec3 u = rotate_direction(cf.u_axis, turns);
    u = glm::normalize(u - glm::dot(u, n) * n);
    glm::dvec3 w = rotate_direction(cf.v_axis, turns);
    w = glm::normalize(w - glm::dot(w, n) * n - glm::dot(w, u) * u);
    OhlshGather gather;
    Rng rng(0x7665ull, smp);
    for (int r = 0; r < kRays; ++r) {
      const glm::dvec3 local = uniform_hemisphere(rng.next_dvec2());
      const glm::dvec3 dir = to_world(local, u, w, n);
      const LevelHit first = scene.intersect(g.position[smp], dir);
      double value[3] = {0, 0, 0};
      if (first.clutter >= 0) {
        const int slot = lit_slot(s.clutter[std::size_t(first.clutter)], first.face);
        const LevelHit behind = walls.intersect(g.position[smp], dir);
        for (int ch = 0; ch < 3; ++ch) {
          if (slot >= 0)
            value[ch] += c[3 * (face0[std::size_t(first.clutter)] + std::size_t(slot)) + std::size_t(ch)];
          if (behind.block >= 0) value[ch] -= wall_limp_b(level, v, behind, ch);
        }
      }
      gather.add(local, value);
    }
    worst_z = std::max(
        worst_z, gather.check(
                     build_se_factor,
                     [&](int i, int ch) { return vec[3 * (4 * smp + std::size_t(i)) + std::size_t(ch)]; },
                     "sample " + std::to_string(smp)));
    // Evaluated at the face normal, the vector delta approximates the scalar one.
    for (int ch = 0; ch < 3; ++ch) {
      double a[4];
      for (int i = 0; i < 4; ++i) a[i] = vec[3 * (4 * smp + std::size_t(i)) + std::size_t(ch)];
      const double flat = ohlsh_eval(a, glm::dvec3(0, 0, 1));
      flat_num += (flat - delta[3 * smp + std::size_t(ch)]) * (flat - delta[3 * smp + std::size_t(ch)]);
      flat_den += double(delta[3 * smp + std::size_t(ch)]) * delta[3 * smp + std::size_t(ch)];
    }
  }
  std::printf(
      "vector deltas: 12 samples x 4 OHLSH coefficients x 3 channels within 4 combined standard errors "
      "(worst %.2f); at the normal vs the scalar delta: rel L2 %.4f\n",
      worst_z, std::sqrt(flat_num / flat_den));
  EXPECT_LT(std::sqrt(flat_num / flat_den), 0.05);
}

// U_dyn (clutter-aware volume probes, DRT §5) against an independent estimate: iid
// uniform-sphere rays from each probe, the value of a ray whose first hit is clutter
// (-Limp(wall behind) b + c(face)) projected onto SH9 in the block frame; all 9 coefficients
// and channels within 4 combined standard errors at every probe outside the boxes.
// Vector Cb and Cc (DRT §5): each OHLSH coefficient of the clutter's vector irradiance
// (Uc_vec Vc_vec b + Cc_vec c, untruncated) against an iid brute-force gather from the texel
// in its frame (tangent, cross(normal, tangent), normal) on the real geometry with the
// clutter; evaluated at the normal it approximates the scalar clutter lightmap.
TEST(Drt, VectorCbMatchesTheBruteForceGather) {
  const ClutterScene s = two_boxes_in_a_row();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings = paper_operators();
  settings.rays = 4096;
  settings.vector = true;
  settings.cb_modes = 100000;  // no truncation: the operator itself is compared
  const DrtOperators drt = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  ASSERT_TRUE(check_drt_operators(level, drt).ok());
  ASSERT_FALSE(drt.objects[0].Uc_vec.empty());
  ASSERT_FALSE(drt.objects[1].Cc_vec.empty());
  const std::vector<float> ld(3 * std::size_t(level.sample_count), 0.5f);
  const Frame f = evaluate_mrt(level, ld);
  const DrtBufferSizes sizes = drt_buffer_sizes(drt);
  std::vector<float> c(sizes.c);
  for (std::size_t i = 0; i < c.size(); ++i) c[i] = 0.05f + 0.03f * float(i % 7);
  std::vector<float> scalar(sizes.clutter_lightmap), vec(sizes.clutter_vector_lightmap);
  drt_clutter_lightmap(drt, f.b, {}, scalar);
  drt_clutter_add_cc(drt, c, scalar);
  drt_clutter_vector_lightmap(drt, f.b, c, vec);
  std::vector<float> v(3 * std::size_t(level.sample_count), 0.0f);  // Limp b per level sample
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& blk = level.blocks[bi];
    for (std::uint32_t q = 0; q < blk.sample_count; ++q) {
      const std::span<const float> limp = block_operators(dict(), level, blk).Limp.row(q);
      for (std::uint32_t k = 0; k < limp.size(); ++k)
        for (int ch = 0; ch < 3; ++ch)
          v[3 * (blk.sample_offset + q) + std::size_t(ch)] +=
              limp[k] * f.b[3 * (std::size_t(level.kb) * bi + k) + std::size_t(ch)];
    }
  }
  const LevelScene scene(level, level.res, s.clutter);
  std::vector<std::size_t> face0(1, 0), texel0(1, 0);
  for (const ClutterObject& o : s.clutter) {
    face0.push_back(face0.back() + std::size_t(clutter_face_count(o)));
    texel0.push_back(texel0.back() + std::size_t(clutter_texel_count(o)));
  }
  constexpr int kRays = 16384;
  const double build_se_factor = std::sqrt(double(kRays) / settings.rays);
  double worst_z = 0.0, flat_num = 0.0, flat_den = 0.0;
  int checked = 0;
  for (std::size_t k = 0; k < s.clutter.size(); ++k) {
    const ClutterTexelGeometry cg = clutter_texel_geometry(s.clutter[k]);
    for (std::size_t t = 5; t < cg.position.size(); t += cg.position.size() / 5) {
      const std::size_t gt = texel0[k] + t;
      const glm::dvec3 n = cg.normal[t], tu = cg.tangent[t], tv = glm::cross(n, tu);
      const glm::dvec3 x = cg.position[t] + 1e-6 * n;
      OhlshGather gather;
      Rng rng(0x7663ull, gt);
      for (int r = 0; r < kRays; ++r) {
        const glm::dvec3 local = uniform_hemisphere(rng.next_dvec2());
        const glm::dvec3 dir = to_world(local, tu, tv, n);
        const LevelHit hit = scene.intersect(x, dir);
        double value[3] = {0, 0, 0};
        if (hit.clutter >= 0 && std::size_t(hit.clutter) != k) {
          const int slot = lit_slot(s.clutter[std::size_t(hit.clutter)], hit.face);
          for (int ch = 0; ch < 3 && slot >= 0; ++ch)
            value[ch] = c[3 * (face0[std::size_t(hit.clutter)] + std::size_t(slot)) + std::size_t(ch)];
        } else if (hit.clutter < 0 && hit.block >= 0) {
          for (int ch = 0; ch < 3; ++ch) value[ch] = wall_limp_b(level, v, hit, ch);
        }
        gather.add(local, value);
      }
      worst_z = std::max(
          worst_z, gather.check(
                       build_se_factor,
                       [&](int i, int ch) { return vec[3 * (4 * gt + std::size_t(i)) + std::size_t(ch)]; },
                       "object " + std::to_string(k) + " texel " + std::to_string(t)));
      for (int ch = 0; ch < 3; ++ch) {
        double a[4];
        for (int i = 0; i < 4; ++i) a[i] = vec[3 * (4 * gt + std::size_t(i)) + std::size_t(ch)];
        const double flat = ohlsh_eval(a, glm::dvec3(0, 0, 1)), want = scalar[3 * gt + std::size_t(ch)];
        flat_num += (flat - want) * (flat - want);
        flat_den += want * want;
      }
      ++checked;
    }
  }
  std::printf(
      "vector Cb: %d texels x 4 OHLSH coefficients x 3 channels within 4 combined standard errors (worst "
      "%.2f); "
      "at the normal vs the scalar clutter lightmap: rel L2 %.4f\n",
      checked, worst_z, std::sqrt(flat_num / flat_den));
  EXPECT_GE(checked, 10);
  EXPECT_LT(std::sqrt(flat_num / flat_den), 0.05);
}

TEST(Drt, ClutterAwareProbesMatchTheBruteForceGather) {
  const ClutterScene s = two_boxes_in_a_row();
  const Level level = build_level(s.description, dict()).value();
  ASSERT_EQ(level.blocks[0].quarter_turns, 0);  // block frame = world frame
  DrtBuildSettings settings;
  settings.rays = 4096;
  settings.probes = true;
  const DrtOperators drt = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  ASSERT_TRUE(check_drt_operators(level, drt).ok());
  const int grid = int(dict().settings.probe_grid), count = grid * grid * grid;
  ASSERT_EQ(drt.probes_per_block, std::uint32_t(count));
  const std::vector<float> ld(3 * std::size_t(level.sample_count), 0.5f);
  const Frame f = evaluate_mrt(level, ld);
  std::vector<float> c(drt_buffer_sizes(drt).c);
  for (std::size_t i = 0; i < c.size(); ++i) c[i] = 0.05f + 0.03f * float(i % 7);
  std::vector<float> v(3 * std::size_t(level.sample_count), 0.0f);
  const LevelBlock& blk = level.blocks[0];
  for (std::uint32_t q = 0; q < blk.sample_count; ++q) {
    const std::span<const float> limp = block_operators(dict(), level, blk).Limp.row(q);
    for (std::uint32_t k = 0; k < limp.size(); ++k)
      for (int ch = 0; ch < 3; ++ch) v[3 * q + std::size_t(ch)] += limp[k] * f.b[3 * k + std::size_t(ch)];
  }
  std::vector<float> probes(27 * std::size_t(count), 0.0f);
  drt_apply_probes(drt, f.b, c, probes);

  const LevelScene scene(level, level.res, s.clutter), walls(level, level.res);
  const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(blk.shape), level.res);
  std::vector<std::size_t> face0(1, 0);
  for (const ClutterObject& o : s.clutter) face0.push_back(face0.back() + std::size_t(clutter_face_count(o)));
  constexpr int kRays = 16384;
  const double build_se_factor = std::sqrt(double(kRays) / settings.rays);
  double worst_z = 0.0;
  int checked = 0;
  for (int p = 0; p < count; ++p) {
    const glm::dvec3 x = block_to_world(blk, probe_position(p, grid));
    if (clutter_contains(s.clutter[0].box, x, 1e-6) || clutter_contains(s.clutter[1].box, x, 1e-6)) continue;
    double sum[9][3] = {}, sum2[9][3] = {};
    Rng rng(0x7072ull, std::uint64_t(p));
    for (int r = 0; r < kRays; ++r) {
      const glm::dvec3 dir = uniform_sphere(rng.next_dvec2());
      const LevelHit first = scene.intersect(x, dir);
      double value[3] = {0, 0, 0};
      if (first.clutter >= 0) {
        const ClutterObject& o = s.clutter[std::size_t(first.clutter)];
        int slot = -1;
        for (int fc = 0, q = 0; fc < kFaceCount; ++fc)
          if (face_present(o.faces, fc)) {
            if (fc == first.face) slot = q;
            ++q;
          }
        const LevelHit behind = walls.intersect(x, dir);
        for (int ch = 0; ch < 3; ++ch) {
          if (slot >= 0)
            value[ch] += c[3 * (face0[std::size_t(first.clutter)] + std::size_t(slot)) + std::size_t(ch)];
          if (behind.block >= 0) {
            const BilinearTaps taps = bilinear_taps(behind.u, behind.v, level.res);
            for (int t = 0; t < 4; ++t)
              value[ch] -=
                  taps.w[t] *
                  v[3 * std::size_t(layout.index(behind.face, taps.i[t], taps.j[t])) + std::size_t(ch)];
          }
        }
      }
      double y[9];
      sh9_eval(dir, y);
      for (int j = 0; j < 9; ++j)
        for (int ch = 0; ch < 3; ++ch) {
          const double xj = 4.0 * std::numbers::pi * value[ch] * y[j];
          sum[j][ch] += xj;
          sum2[j][ch] += xj * xj;
        }
    }
    for (int j = 0; j < 9; ++j)
      for (int ch = 0; ch < 3; ++ch) {
        const double mean = sum[j][ch] / kRays;
        const double se = std::sqrt(std::max(0.0, sum2[j][ch] / kRays - mean * mean) / kRays);
        const double tol = 4.0 * se * std::sqrt(1.0 + build_se_factor * build_se_factor) + 1e-6;
        const double got = probes[3 * (9 * std::size_t(p) + std::size_t(j)) + std::size_t(ch)];
        EXPECT_NEAR(got, mean, tol) << "probe " << p << " coefficient " << j << " channel " << ch;
        worst_z = std::max(worst_z, std::abs(got - mean) / (tol / 4.0));
      }
    ++checked;
  }
  std::printf(
      "clutter-aware probes: %d probes x 9 SH coefficients x 3 channels within 4 combined standard errors "
      "(worst %.2f); %zu + %zu Udyn entries\n",
      checked, worst_z, drt.objects[0].Udyn_probe.size(), drt.objects[1].Udyn_probe.size());
  EXPECT_GE(checked, 6);
  EXPECT_FALSE(drt.objects[0].Udyn.empty());
}

// A texel at the centre of one box's face, facing a parallel face of another box head on:
// its Cc column for that face is the fraction of cosine-weighted rays reaching it, the
// differential-area-to-rectangle form factor (Howell's catalogue, B-3), and no other face of
// that box is visible.
// U_dyn against the change the clutter makes to what the probes stand for (MRT §6.5: the
// radiance arriving at the probe from the surfaces' direct light, on SH9): an iid gather over
// the sphere at every probe of the box room outside the boxes, on the real geometry, of the
// box's direct radiance minus that of the wall behind it for the rays that hit a box (the
// walls' direct light includes the boxes' shadows in both, as ld does). MRT's probes see the
// walls behind the boxes (delta 0, error 1); U_dyn brings the difference with Limp b for the
// wall and the per-face c for the box. (The probes' own error, the small test dictionary's
// prior smoothing the light's bright spot, is MRT's and the same with and without U_dyn.)
TEST(Drt, ClutterAwareProbesMatchTheDeltaOfADirectRadianceGather) {
  const ClutterScene s = box_room_two_boxes();
  const Level level = build_level(s.description, dict()).value();
  const LevelScene scene(level, level.res, s.clutter), walls(level, level.res);
  const std::vector<float> ld =
      level_direct_light(scene, s.description.lights, level_sample_albedo(level), 8);
  const Frame f = evaluate_mrt(level, ld);
  DrtBuildSettings settings;
  settings.rays = 1024;
  settings.probes = true;
  const DrtOperators drt = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  std::vector<float> c(drt_buffer_sizes(drt).c);
  ASSERT_TRUE(drt_compute_c(drt, clutter_direct_light(scene, s.description.lights, 8), c).ok());
  std::vector<float> delta(level_buffer_sizes(level, dict()).probes, 0.0f);
  drt_apply_probes(drt, f.b, c, delta);
  const DirectRadiance direct = level_direct_radiance(scene, s.description, 8);
  const int grid = int(dict().settings.probe_grid), count = grid * grid * grid;
  constexpr int kRays = 8192;
  double num = 0, den = 0;
  int used = 0;
  for (int q = 0; q < count; ++q) {
    const glm::dvec3 x = block_to_world(level.blocks[0], probe_position(q, grid));
    bool inside = false;
    for (const ClutterObject& o : s.clutter) inside |= clutter_contains(o.box, x, 1e-6);
    if (inside) continue;
    double truth[3][9] = {};
    Rng rng(0x7072ull, std::uint64_t(q));
    for (int r = 0; r < kRays; ++r) {
      const glm::dvec3 dir = uniform_sphere(rng.next_dvec2());
      const LevelHit hit = scene.intersect(x, dir);
      if (hit.clutter < 0) continue;
      const LevelHit wall = walls.intersect(x, dir);
      glm::dvec3 L = direct(hit, x + hit.t * dir, scene.hit_normal(hit));
      if (wall.block >= 0) L -= direct(wall, x + wall.t * dir, walls.hit_normal(wall));
      double y[9];
      sh9_eval(dir, y);
      for (int j = 0; j < 9; ++j)
        for (int ch = 0; ch < 3; ++ch) truth[ch][j] += 4.0 * std::numbers::pi / kRays * L[ch] * y[j];
    }
    for (int j = 0; j < 9; ++j)
      for (int ch = 0; ch < 3; ++ch) {
        const double got = delta[3 * (9 * std::size_t(q) + std::size_t(j)) + std::size_t(ch)];
        num += (got - truth[ch][j]) * (got - truth[ch][j]);
        den += truth[ch][j] * truth[ch][j];
      }
    ++used;
  }
  const double err = std::sqrt(num / den);
  std::printf(
      "U_dyn vs the clutter's delta of a direct-radiance gather (%d probes outside the boxes, %d rays): rel "
      "L2 "
      "%.4f (MRT's probes: 1)\n",
      used, kRays, err);
  EXPECT_GE(used, 4);
  EXPECT_GT(den, 0.0);
  EXPECT_LT(err, 0.5);
}

}  // namespace
}  // namespace modrt::precompute
