// SPDX-License-Identifier: MIT
// Delta Radiance Transfer (SPEC §6, [Loos et al. 2012]): the operators of clutter boxes,
// the scalar reference runtime, and the accuracy gain over MRT alone against the
// ground-truth path tracer on the paper's Figure 1 set-up and a maze block with pillars.
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

namespace modrt::precompute {
namespace {

const Dictionary& dict() { return test::small_test_dictionary(); }

using test::box_room_two_boxes;
using test::ClutterScene;
using test::l_shaped_level_with_a_box;
using test::maze_block_four_pillars;

double rel_l2(std::span<const float> x, std::span<const float> ref, const std::vector<std::uint8_t>& skip) {
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
Frame evaluate_mrt(const Level& level, std::span<const float> ld) {
  const LevelBufferSizes sz = level_buffer_sizes(level, dict());
  Frame f;
  f.ld.assign(ld.begin(), ld.end());
  f.b.resize(sz.b);
  f.r.resize(sz.r);
  f.lightmap.resize(sz.lightmap);
  EXPECT_TRUE(level_evaluate(level, dict(), f.ld, f.b, f.r, f.lightmap).ok());
  return f;
}

bool operators_equal(const DrtObjectOperators& a, const DrtObjectOperators& b) {
  return a.texel_count == b.texel_count && a.face_count == b.face_count && a.dUb_sample == b.dUb_sample &&
         a.dUb_block == b.dUb_block && a.dUb.data == b.dUb.data && a.Td_c.data == b.Td_c.data &&
         a.dUc_sample == b.dUc_sample && a.dUc.data == b.dUc.data && a.Cb_blocks == b.Cb_blocks &&
         a.Uc.data == b.Uc.data && a.Vc.data == b.Vc.data && a.Cc_objects == b.Cc_objects &&
         a.Cc.rows == b.Cc.rows && a.Cc.cols == b.Cc.cols && a.Cc.data == b.Cc.data &&
         a.dUb_vec_sample == b.dUb_vec_sample && a.dUb_vec_block == b.dUb_vec_block &&
         a.dUb_vec.data == b.dUb_vec.data && a.dUc_vec_sample == b.dUc_vec_sample &&
         a.dUc_vec.data == b.dUc_vec.data && a.Udyn_probe == b.Udyn_probe && a.Udyn_block == b.Udyn_block &&
         a.Udyn.data == b.Udyn.data && a.Udyn_c_probe == b.Udyn_c_probe && a.Udyn_c.data == b.Udyn_c.data;
}

TEST(Drt, NoClutterMeansEmptyOperatorsAndABitIdenticalLightmap) {
  const ClutterScene s = box_room_two_boxes();
  const Level level = build_level(s.description, dict()).value();
  const DrtBuilder builder(level, dict());
  const DrtOperators drt = builder.build({}).value();
  EXPECT_TRUE(drt.empty());
  EXPECT_EQ(drt.storage_bytes(), 0u);
  const DrtBufferSizes sz = drt_buffer_sizes(drt);
  EXPECT_EQ(sz.c + sz.clutter_ld + sz.clutter_lightmap, 0u);
  EXPECT_TRUE(check_drt_operators(level, drt).ok());
  const LevelScene scene(level, level.res);
  const Frame f = evaluate_mrt(
      level, level_direct_light(scene, s.description.lights, level_albedo(level, s.description), 8));
  std::vector<float> lightmap = f.lightmap;
  EXPECT_TRUE(drt_compute_c(drt, {}, {}).ok());
  drt_apply(level, drt, f.b, {}, lightmap);
  drt_clutter_lightmap(drt, f.b, {}, {});
  EXPECT_EQ(0, std::memcmp(lightmap.data(), f.lightmap.data(), lightmap.size() * sizeof(float)));
}

// The packet query the gathers use returns exactly the single-ray hits, clutter included.
TEST(Drt, PacketIntersectionsEqualSingleRays) {
  const ClutterScene s = box_room_two_boxes();
  const Level level = build_level(s.description, dict()).value();
  const LevelScene scene(level, level.res, s.clutter);
  std::vector<glm::dvec3> dirs;
  for (int i = 0; i < 203; ++i) {  // not a multiple of the packet width
    const double z = 1.0 - 2.0 * (i + 0.5) / 203.0, phi = 2.399963 * i;
    dirs.push_back(glm::dvec3(std::sqrt(1 - z * z) * std::cos(phi), z, std::sqrt(1 - z * z) * std::sin(phi)));
  }
  std::vector<LevelHit> hits(dirs.size());
  const glm::dvec3 origin(0.45, 0.3, 0.5);
  scene.intersect_many(origin, dirs, hits);
  int on_clutter = 0;
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    const LevelHit one = scene.intersect(origin, dirs[i]);
    EXPECT_EQ(hits[i].block, one.block);
    EXPECT_EQ(hits[i].face, one.face);
    EXPECT_EQ(hits[i].clutter, one.clutter);
    EXPECT_EQ(hits[i].u, one.u);
    EXPECT_EQ(hits[i].v, one.v);
    EXPECT_EQ(hits[i].t, one.t);
    on_clutter += one.clutter >= 0;
  }
  EXPECT_GT(on_clutter, 0);
}

TEST(Drt, ValidationNamesTheProblem) {
  const ClutterScene s = box_room_two_boxes();
  const Level level = build_level(s.description, dict()).value();
  std::vector<ClutterObject> bad = s.clutter;
  bad[1].block = 3;
  Status st = validate_clutter(level, bad);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.to_string().find("clutter object 1"), std::string::npos) << st.to_string();
  bad = s.clutter;
  bad[0].box.half_extent.y = 0.0;
  EXPECT_FALSE(validate_clutter(level, bad).ok());
  bad = s.clutter;
  bad[0].box.rotation[0][0] = 2.0;
  EXPECT_FALSE(validate_clutter(level, bad).ok());
  const DrtBuilder builder(level, dict());
  DrtOperators drt = builder.build(s.clutter).value();
  ASSERT_TRUE(check_drt_operators(level, drt).ok());
  const DrtOperators good = drt;
  drt.objects[0].dUb_sample.back() = level.sample_count;
  EXPECT_FALSE(check_drt_operators(level, drt).ok());
  // Clutter-to-clutter operators: a source must be another object, and Cc m x its faces.
  ASSERT_EQ(good.objects[1].Cc_objects, std::vector<std::uint32_t>{0});
  drt = good;
  drt.objects[1].Cc_objects = {1};
  st = check_drt_operators(level, drt);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.to_string().find("DRT object 1: Cc"), std::string::npos) << st.to_string();
  drt = good;
  drt.objects[1].Cc = Matrix(drt.objects[1].Cc.rows, drt.objects[1].Cc.cols + 1);
  EXPECT_FALSE(check_drt_operators(level, drt).ok());
  drt = good;
  drt.objects[1].Cc.data[5] = std::nanf("");
  EXPECT_FALSE(check_drt_operators(level, drt).ok());
  // Vector operators: 4 rows per entry, entries sorted.
  DrtBuildSettings vs;
  vs.rays = 256;
  vs.vector = true;
  vs.probes = true;
  const DrtOperators with_vec = DrtBuilder(level, dict(), vs).build(s.clutter).value();
  ASSERT_TRUE(check_drt_operators(level, with_vec).ok());
  drt = with_vec;
  drt.objects[1].Udyn_probe.back() = drt.probes_per_block * std::uint32_t(level.blocks.size());
  EXPECT_FALSE(check_drt_operators(level, drt).ok());
  drt = with_vec;
  drt.objects[1].Udyn_c = Matrix(drt.objects[1].Udyn_c.rows, drt.objects[1].Udyn_c.cols + 1);
  EXPECT_FALSE(check_drt_operators(level, drt).ok());
  drt = with_vec;
  drt.objects[0].dUb_vec = Matrix(drt.objects[0].dUb_vec.rows - 4, level.kb);
  EXPECT_FALSE(check_drt_operators(level, drt).ok());
  drt = with_vec;
  std::swap(drt.objects[0].dUc_vec_sample.front(), drt.objects[0].dUc_vec_sample.back());
  EXPECT_FALSE(check_drt_operators(level, drt).ok());
}

// Culling is exact: a build that tests every object from every sample and texel gives the
// same operators (one box; four pillars that see each other, Cc included), and no sample
// with the whole box behind its tangent plane has a row.
TEST(Drt, CullingIsExact) {
  const ClutterScene s = l_shaped_level_with_a_box();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 256;
  const DrtBuilder culled(level, dict(), settings);
  settings.cull = false;
  const DrtBuilder full(level, dict(), settings);
  DrtBuildReport rc, rf;
  const DrtObjectOperators a = culled.build_object(s.clutter[0], &rc).value();
  const DrtObjectOperators b = full.build_object(s.clutter[0], &rf).value();
  std::printf("box: traced %zu samples, culled %zu (without culling traced %zu)\n", rc.traced_samples,
              rc.culled_samples, rf.traced_samples);
  EXPECT_GT(rc.culled_samples, 0u);
  EXPECT_LT(rc.traced_samples, rf.traced_samples);
  EXPECT_TRUE(operators_equal(a, b));
  const LevelSampleGeometry g = level_sample_geometry(level);
  std::vector<std::uint8_t> has_row(level.sample_count, 0);
  for (std::uint32_t smp : a.dUb_sample) has_row[smp] = 1;
  for (std::uint32_t smp : a.dUc_sample) has_row[smp] = 1;
  std::size_t behind = 0;
  for (std::size_t i = 0; i < g.position.size(); ++i) {
    double nearest = -1e300;  // the box corner farthest in front of the tangent plane
    for (int corner = 0; corner < 8; ++corner) {
      const glm::dvec3 q((corner & 1) ? 1.0 : 0.0, (corner & 2) ? 1.0 : 0.0, (corner & 4) ? 1.0 : 0.0);
      nearest =
          std::max(nearest, glm::dot(g.normal[i], clutter_to_world(s.clutter[0].box, q) - g.position[i]));
    }
    if (nearest < 0.0) {
      ++behind;
      EXPECT_FALSE(has_row[i]) << "sample " << i;
    }
  }
  EXPECT_GT(behind, 0u);
  // The box shades the next block through the opening (DRT §4: propagated beyond the
  // block), with rows that use the b of the block whose wall it hides.
  bool other_block_row = false, other_block_b = false;
  for (std::size_t k = 0; k < a.dUb_sample.size(); ++k) {
    other_block_row |= g.block[a.dUb_sample[k]] != 0;
    other_block_b |= a.dUb_block[k] != std::uint32_t(g.block[a.dUb_sample[k]]);
  }
  EXPECT_TRUE(other_block_row);
  EXPECT_TRUE(other_block_b);

  const ClutterScene p = maze_block_four_pillars();
  const Level corridor = build_level(p.description, dict()).value();
  settings.cull = true;
  const DrtOperators pc = DrtBuilder(corridor, dict(), settings).build(p.clutter).value();
  settings.cull = false;
  const DrtOperators pf = DrtBuilder(corridor, dict(), settings).build(p.clutter).value();
  for (std::size_t k = 0; k < p.clutter.size(); ++k) {
    EXPECT_TRUE(operators_equal(pc.objects[k], pf.objects[k])) << "pillar " << k;
    EXPECT_EQ(pc.objects[k].Cc_objects.size(), 3u);
  }
}

// Samples under a box are inpainted (DRT §5): mean shadowed transport Ub + dUb of the
// valid neighbours minus the sample's own Ub.
TEST(Drt, SamplesInsideClutterAreInpainted) {
  const ClutterScene s = box_room_two_boxes();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 256;
  DrtBuildReport report;
  const DrtObjectOperators op =
      DrtBuilder(level, dict(), settings).build_object(s.clutter[0], &report).value();
  settings.inpaint = false;
  const DrtObjectOperators raw = DrtBuilder(level, dict(), settings).build_object(s.clutter[0]).value();
  std::printf("box 0: %zu samples inside, %zu inpainted\n", report.inside_samples, report.inpainted_samples);
  ASSERT_GT(report.inside_samples, 0u);
  EXPECT_EQ(report.inpainted_samples, report.inside_samples);
  const LevelSampleGeometry g = level_sample_geometry(level);
  const ShapeOperators& shape = dict().shapes[std::size_t(level.blocks[0].shape)];
  const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(level.blocks[0].shape), level.res);
  auto row_of = [](const DrtObjectOperators& o, std::size_t smp) -> int {
    for (std::size_t k = 0; k < o.dUb_sample.size(); ++k)
      if (o.dUb_sample[k] == smp) return int(k);
    return -1;
  };
  int checked = 0;
  for (std::size_t i = 0; i < g.position.size(); ++i) {
    if (!clutter_contains(s.clutter[0].box, g.position[i], 1e-6)) continue;
    EXPECT_EQ(row_of(raw, i), -1) << "inside sample " << i << " traced without inpainting";
    ASSERT_GE(row_of(op, i), 0) << "inside sample " << i << " not inpainted";
    // A rim sample (every valid neighbour traced): the inpainting formula by hand.
    const int face = layout.face_of(int(i)),
              within = int(i) - layout.slot[std::size_t(face)] * level.res * level.res;
    const int i0 = within % level.res, j0 = within / level.res;
    std::vector<std::size_t> nbrs;
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        const int ii = i0 + di, jj = j0 + dj;
        if ((di == 0 && dj == 0) || ii < 0 || jj < 0 || ii >= level.res || jj >= level.res) continue;
        const std::size_t q = std::size_t(layout.index(face, ii, jj));
        if (!clutter_contains(s.clutter[0].box, g.position[q], 1e-6)) nbrs.push_back(q);
      }
    if (nbrs.empty()) continue;
    for (std::uint32_t c = 0; c < level.kb; ++c) {
      double expected = -double(shape.Ub(std::uint32_t(i), c));
      for (std::size_t q : nbrs) {
        const int r = row_of(op, q);
        expected += (shape.Ub(std::uint32_t(q), c) + (r >= 0 ? op.dUb(std::uint32_t(r), c) : 0.0)) /
                    double(nbrs.size());
      }
      EXPECT_NEAR(op.dUb(std::uint32_t(row_of(op, i)), c), expected, 1e-5);
    }
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

// Two boxes in a row on the floor of a closed room, so that many rays pass through both
// (overlapping shadows) and each box's facing sides see the other (clutter-to-clutter light).
ClutterScene two_boxes_in_a_row() {
  ClutterScene s = box_room_two_boxes();
  s.clutter[0].box.center = glm::dvec3(0.33, 0.15, 0.5);
  s.clutter[0].box.half_extent = glm::dvec3(0.08, 0.15, 0.1);
  s.clutter[1].box.center = glm::dvec3(0.62, 0.22, 0.5);
  s.clutter[1].box.half_extent = glm::dvec3(0.09, 0.22, 0.12);
  s.clutter[1].box.rotation = glm::dmat3(1.0);
  return s;
}

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
  DrtBuildSettings settings;
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
      const std::span<const float> limp = dict().shapes[std::size_t(blk.shape)].Limp.row(q);
      const std::size_t blk_index = std::size_t(&blk - level.blocks.data());
      for (std::uint32_t k = 0; k < level.kb; ++k)
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
  DrtBuildSettings settings;
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
      const std::span<const float> limp = dict().shapes[std::size_t(blk.shape)].Limp.row(q);
      for (std::uint32_t k = 0; k < level.kb; ++k)
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
  DrtBuildSettings settings;
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
      const std::span<const float> limp = dict().shapes[std::size_t(blk.shape)].Limp.row(q);
      for (std::uint32_t k = 0; k < level.kb; ++k)
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
    const std::span<const float> limp = dict().shapes[std::size_t(blk.shape)].Limp.row(q);
    for (std::uint32_t k = 0; k < level.kb; ++k)
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
      level_direct_light(scene, s.description.lights, level_albedo(level, s.description), 8);
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

TEST(Drt, CcOfAFacingParallelFaceIsItsFormFactor) {
  ClutterScene s = two_boxes_in_a_row();
  s.clutter[0].res = 15;  // a texel at the exact centre of each face
  const Level level = build_level(s.description, dict()).value();
  const DrtOperators drt = DrtBuilder(level, dict()).build(s.clutter).value();
  const DrtObjectOperators& a = drt.objects[0];
  ASSERT_EQ(a.Cc_objects, std::vector<std::uint32_t>{1});
  // Texel (7, 7) of box 0's +x face (slot 1: faces -X, +X, +Y, -Z, +Z are lit).
  const std::uint32_t t = 1 * 15 * 15 + 7 * 15 + 7;
  const ClutterTexelGeometry cg = clutter_texel_geometry(s.clutter[0]);
  ASSERT_EQ(cg.face[t], kFacePosX);
  const ClutterBox& bb = s.clutter[1].box;
  const glm::dvec3 p = cg.position[t];
  const double d = (bb.center.x - bb.half_extent.x) - p.x;  // distance to the facing plane
  // Corner form factor of a rectangle x by y at distance d, the corner above the point.
  auto corner = [&](double x, double y) {
    const double X = x / d, Y = y / d;
    return (X / std::sqrt(1 + X * X) * std::atan(Y / std::sqrt(1 + X * X)) +
            Y / std::sqrt(1 + Y * Y) * std::atan(X / std::sqrt(1 + Y * Y))) /
           (2.0 * std::numbers::pi);
  };
  // The facing rectangle split at the point's foot into four corner rectangles.
  const double y0 = bb.center.y - bb.half_extent.y - p.y, y1 = bb.center.y + bb.half_extent.y - p.y;
  const double z0 = bb.center.z - bb.half_extent.z - p.z, z1 = bb.center.z + bb.half_extent.z - p.z;
  ASSERT_LT(y0, 0.0);
  ASSERT_GT(y1, 0.0);
  const double F = corner(-y0, -z0) + corner(-y0, z1) + corner(y1, -z0) + corner(y1, z1);
  // Columns of box 1's faces: -X is its slot 0.
  const double cc = a.Cc(t, 0);
  std::printf("Cc of a head-on parallel face: %.5f, form factor %.5f\n", cc, F);
  EXPECT_NEAR(cc, F, 0.01 * F + 1e-3);
  for (std::uint32_t col = 1; col < a.Cc.cols; ++col) EXPECT_EQ(a.Cc(t, col), 0.0f) << "face slot " << col;
}

// Antiradiance removes light, never much more than MRT put there: with uniform ld, the
// shadowed lightmap Ub b + dUb b stays above -2 % of the unshadowed maximum.
TEST(Drt, ShadowedLightmapIsNotMuchNegativeUnderUniformLight) {
  for (const ClutterScene& s : {box_room_two_boxes(), maze_block_four_pillars()}) {
    const Level level = build_level(s.description, dict()).value();
    const DrtOperators drt = DrtBuilder(level, dict()).build(s.clutter).value();
    std::vector<float> ld(3 * std::size_t(level.sample_count), 0.5f);
    const Frame f = evaluate_mrt(level, ld);
    std::vector<float> c(drt_buffer_sizes(drt).c, 0.0f), shadowed = f.lightmap;
    drt_apply(level, drt, f.b, c, shadowed);
    const float peak = *std::max_element(f.lightmap.begin(), f.lightmap.end());
    const float low = *std::min_element(shadowed.begin(), shadowed.end());
    float removed = 0.0f;
    for (std::size_t i = 0; i < shadowed.size(); ++i)
      removed = std::max(removed, f.lightmap[i] - shadowed[i]);
    std::printf("uniform ld: MRT max %.4f, MRT+dUb min %.5f, largest shadow %.4f\n", peak, low, removed);
    EXPECT_GT(removed, 0.05f * peak);  // the clutter does cast indirect shadows
    EXPECT_GE(low, -0.02f * peak);
  }
}

// Cb's SVD truncation (DRT §5, 5 modes): the reported error is the truncated singular
// energy, it matches the reconstruction, and it is small.
TEST(Drt, CbTruncationErrorIsReportedAndBounded) {
  const ClutterScene s = maze_block_four_pillars();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 256;
  const DrtObjectOperators five = DrtBuilder(level, dict(), settings).build_object(s.clutter[0]).value();
  settings.cb_modes = 1000;
  const DrtObjectOperators all = DrtBuilder(level, dict(), settings).build_object(s.clutter[0]).value();
  ASSERT_EQ(five.Uc.cols, 5u);
  double num = 0.0, den = 0.0;
  for (std::uint32_t t = 0; t < all.texel_count; ++t)
    for (std::uint32_t c = 0; c < all.Vc.cols; ++c) {
      double full = 0.0, trunc = 0.0;
      for (std::uint32_t q = 0; q < all.Uc.cols; ++q) full += double(all.Uc(t, q)) * all.Vc(q, c);
      for (std::uint32_t q = 0; q < five.Uc.cols; ++q) trunc += double(five.Uc(t, q)) * five.Vc(q, c);
      num += (full - trunc) * (full - trunc);
      den += full * full;
    }
  std::printf("Cb: %zu singular values, %u blocks; 5-mode truncation error %.4f (measured %.4f)\n",
              five.Cb_sigma.size(), unsigned(five.Cb_blocks.size()), five.Cb_truncation_error,
              std::sqrt(num / den));
  EXPECT_NEAR(std::sqrt(num / den), five.Cb_truncation_error, 1e-3);
  EXPECT_LT(all.Cb_truncation_error, 1e-6f);
  // Measured 0.122 for a pillar that sees three blocks (96 columns).
  EXPECT_LT(five.Cb_truncation_error, 0.15f);
}

// Dropping small dUb rows (storage) stays within its stated bound |row|_2 |b|_2 per sample
// and channel, and the accuracy figure barely moves (printed).
TEST(Drt, DroppedDUbRowsStayWithinTheirBound) {
  const ClutterScene s = maze_block_four_pillars();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 256;
  const DrtOperators all = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  settings.drop_tolerance = 0.03;
  DrtBuildReport report;
  const DrtOperators kept = DrtBuilder(level, dict(), settings).build(s.clutter, &report).value();
  const LevelScene scene(level, level.res, s.clutter);
  const Frame f = evaluate_mrt(
      level, level_direct_light(scene, s.description.lights, level_albedo(level, s.description), 8));
  std::vector<float> c(drt_buffer_sizes(all).c, 0.0f), a = f.lightmap, k = f.lightmap;
  drt_apply(level, all, f.b, c, a);
  drt_apply(level, kept, f.b, c, k);
  std::vector<double> bound(level.sample_count, 0.0);
  std::size_t rows_all = 0, rows_kept = 0;
  for (std::size_t o = 0; o < all.objects.size(); ++o) {
    const DrtObjectOperators& A = all.objects[o];
    const DrtObjectOperators& K = kept.objects[o];
    rows_all += A.dUb.rows;
    rows_kept += K.dUb.rows;
    std::size_t j = 0;
    for (std::uint32_t r = 0; r < A.dUb.rows; ++r) {
      if (j < K.dUb_sample.size() && K.dUb_sample[j] == A.dUb_sample[r] && K.dUb_block[j] == A.dUb_block[r]) {
        ++j;
        continue;
      }
      double row2 = 0.0, b2 = 0.0;
      for (float v : A.dUb.row(r)) row2 += double(v) * v;
      for (std::uint32_t q = 0; q < level.kb; ++q)
        for (int ch = 0; ch < 3; ++ch) {
          const double bv = f.b[3 * (std::size_t(level.kb) * A.dUb_block[r] + q) + std::size_t(ch)];
          b2 += bv * bv;  // all channels: bounds each channel's norm
        }
      bound[A.dUb_sample[r]] += std::sqrt(row2) * std::sqrt(b2);
    }
    EXPECT_EQ(j, K.dUb_sample.size());  // kept rows are a subsequence of all rows
  }
  EXPECT_EQ(rows_all - rows_kept, report.dropped_rows);
  EXPECT_GT(report.dropped_rows, 0u);
  for (std::size_t i = 0; i < a.size(); ++i)
    ASSERT_LE(std::abs(double(a[i]) - k[i]), bound[i / 3] + 1e-6) << "sample " << i / 3;
  std::printf("drop tolerance 0.03: %zu of %zu dUb rows dropped, storage %zu -> %zu bytes\n",
              report.dropped_rows, rows_all, all.storage_bytes(), kept.storage_bytes());
}

// Objects see each other, so moving one changes the others' operators; the incremental
// rebuild re-traces what the move can change and equals a full build bit for bit, over a
// sequence of moves of different objects (one of them a turn and a new face mask).
TEST(Drt, IncrementalRebuildOfAMovedObjectEqualsAFullBuild) {
  ClutterScene s = maze_block_four_pillars();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 256;
  settings.drop_tolerance = 0.01;  // dropping depends on every row of an object
  settings.vector = true;
  settings.probes = true;
  const DrtBuilder builder(level, dict(), settings);
  DrtBuildState state;
  DrtOperators drt = builder.build(s.clutter, nullptr, &state).value();
  struct Move {
    std::size_t index;
    glm::dvec3 shift;
  };
  for (const Move& move : {Move{2, glm::dvec3(0.1, 0.0, -0.05)}, Move{0, glm::dvec3(0.05, 0.0, 0.1)},
                           Move{2, glm::dvec3(-0.2, 0.0, 0.0)}}) {
    const DrtOperators before = drt;
    s.clutter[move.index].box.center += move.shift;
    if (move.index == 0) {
      s.clutter[0].box.rotation = test::rotation_y(20.0);
      s.clutter[0].faces = test::without(kAllFaces, {kFaceNegY});
    }
    DrtBuildReport report;
    ASSERT_TRUE(builder.rebuild_object(s.clutter, move.index, drt, state, &report).ok());
    const DrtOperators full = builder.build(s.clutter).value();
    ASSERT_TRUE(check_drt_operators(level, drt).ok());
    int others_changed = 0;
    for (std::size_t k = 0; k < s.clutter.size(); ++k) {
      EXPECT_TRUE(operators_equal(drt.objects[k], full.objects[k]))
          << "object " << k << " after moving " << move.index;
      others_changed += k != move.index && !operators_equal(before.objects[k], full.objects[k]);
    }
    EXPECT_FALSE(operators_equal(drt.objects[move.index], before.objects[move.index]));
    EXPECT_GT(others_changed, 0);  // its shadows and light reach the other pillars
    std::printf("moved pillar %zu: re-traced %zu of %u samples and %zu texels; %d other objects changed\n",
                move.index, report.traced_samples, level.sample_count, report.traced_texels, others_changed);
  }
  // Only one object may change per rebuild, and the state must be this list's.
  s.clutter[1].box.center.x += 0.05;
  s.clutter[3].box.center.x += 0.05;
  EXPECT_FALSE(builder.rebuild_object(s.clutter, 1, drt, state).ok());
  EXPECT_FALSE(builder.rebuild_object(s.clutter, 4, drt, state).ok());
  DrtBuildState none;
  EXPECT_FALSE(builder.rebuild_object(s.clutter, 1, drt, none).ok());
  // A state built without the vector and probe passes cannot feed a builder that has them.
  s.clutter[3].box.center.x -= 0.05;
  DrtBuildSettings plain = settings;
  plain.vector = plain.probes = false;
  DrtBuildState other;
  DrtOperators drt_plain = DrtBuilder(level, dict(), plain).build(s.clutter, nullptr, &other).value();
  s.clutter[1].box.center.x -= 0.05;
  const Status st = builder.rebuild_object(s.clutter, 1, drt_plain, other);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.to_string().find("other vector / probe settings"), std::string::npos) << st.to_string();
}

// MRT's clutter shading: the volume probes (SH9 radiance, trilinear between the g^3 probes
// of the owning block) turned into E/pi at the texel normal (MRT §6.5).
std::vector<float> probe_shading(const Level& level, std::span<const float> probes,
                                 std::span<const ClutterObject> clutter) {
  const int grid = int(dict().settings.probe_grid);
  const int count = grid * grid * grid;
  std::vector<float> out;
  for (const ClutterObject& o : clutter) {
    const LevelBlock& blk = level.blocks[std::size_t(o.block)];
    const ClutterTexelGeometry cg = clutter_texel_geometry(o);
    for (std::size_t t = 0; t < cg.position.size(); ++t) {
      const glm::dvec3 p = rotate_point(cg.position[t] - blk.corners[0], -blk.quarter_turns);
      const glm::dvec3 n = rotate_direction(cg.normal[t], -blk.quarter_turns);
      double radiance[3][9] = {};
      for (int q = 0; q < count; ++q) {
        const glm::dvec3 pp = probe_position(q, grid);
        double w = 1.0;
        for (int a = 0; a < 3; ++a) {
          const double x = std::clamp(p[a], 0.5 / grid, 1.0 - 0.5 / grid);
          w *= std::max(0.0, 1.0 - std::abs(x - pp[a]) * grid);
        }
        if (w == 0.0) continue;
        for (int j = 0; j < 9; ++j)
          for (int c = 0; c < 3; ++c)
            radiance[c][j] += w * probes[std::size_t(o.block) * 27 * std::size_t(count) +
                                         3 * (9 * std::size_t(q) + std::size_t(j)) + std::size_t(c)];
      }
      for (int c = 0; c < 3; ++c) {
        double irr[9];
        irradiance_from_radiance_sh9(radiance[c], irr);
        out.push_back(float(std::max(0.0, sh9_eval_sum(irr, n))));
      }
    }
  }
  return out;
}

// Level samples inside clutter (invisible: left out of the error), per sample: inside a box
// grown by 1e-6, or a mesh just off the sample along its normal (as the build decides).
std::vector<std::uint8_t> samples_inside_clutter(const LevelSampleGeometry& g,
                                                 std::span<const ClutterObject> clutter) {
  std::vector<std::unique_ptr<ClutterMeshShape>> shapes;
  for (const ClutterObject& o : clutter)
    shapes.push_back(
        o.kind == ClutterKind::mesh
            ? std::make_unique<ClutterMeshShape>(
                  ClutterMeshShape::create(o.mesh->mesh, o.mesh->chart_of_triangle, "mesh").value())
            : nullptr);
  std::vector<std::uint8_t> inside(g.position.size(), 0);
  for (std::size_t i = 0; i < g.position.size(); ++i)
    for (std::size_t k = 0; k < clutter.size(); ++k)
      inside[i] |= shapes[k] ? shapes[k]->contains(g.position[i] + 1e-5 * g.normal[i])
                             : clutter_contains(clutter[k].box, g.position[i], 1e-6);
  return inside;
}

// The clutter texels as path-tracer points (just off the surface) and normals.
void clutter_texel_points(std::span<const ClutterObject> clutter, std::vector<glm::dvec3>& points,
                          std::vector<glm::dvec3>& normals) {
  for (const ClutterObject& o : clutter) {
    const ClutterTexelGeometry cg = clutter_texel_geometry(o);
    for (std::size_t t = 0; t < cg.position.size(); ++t) {
      points.push_back(cg.position[t] + 1e-5 * cg.normal[t]);
      normals.push_back(cg.normal[t]);
    }
  }
}

// The truth's own relative noise: sqrt(sum se^2 / sum value^2) over the points not skipped.
double noise_floor(const IndirectEstimate& truth, const std::vector<std::uint8_t>& skip) {
  double se = 0, v = 0;
  for (std::size_t i = 0; i < truth.value.size(); ++i)
    if (skip.empty() || !skip[i / 3]) {
      se += double(truth.standard_error[i]) * truth.standard_error[i];
      v += double(truth.value[i]) * truth.value[i];
    }
  return std::sqrt(se / v);
}

struct AccuracyResult {
  double mrt = 0, drt = 0, noise = 0, probes = 0, clutter = 0, clutter_noise = 0;
  // The same with every object built alone (each traced against the walls and itself: no
  // clutter-to-clutter shadows or light), and the clutter with Cb b only (no Cc c).
  double drt_alone = 0, clutter_alone = 0, clutter_cb_only = 0;
  // The clutter shaded by the volume probes with the U_dyn delta (clutter-aware probes).
  double probes_udyn = 0;
};

// One bounce at the level's texels and the clutter texels: MRT (lightmap Ub b + Ur r; the
// clutter shaded by probes) and MRT + DRT (+ dUb b + dUc c; clutter Cb b) against the path
// tracer on the real geometry with the clutter (same direct-light model; ld with the
// clutter's direct shadows for both). Texels inside clutter are not visible and skipped.
AccuracyResult accuracy(const ClutterScene& s, const char* name, const DrtBuildSettings& settings = {}) {
  const Level level = build_level(s.description, dict()).value();
  const LevelScene scene(level, level.res, s.clutter);
  const std::vector<float> ld =
      level_direct_light(scene, s.description.lights, level_albedo(level, s.description), 8);
  const Frame f = evaluate_mrt(level, ld);

  const auto t0 = std::chrono::steady_clock::now();
  const DrtBuilder builder(level, dict(), settings);
  const DrtOperators drt = builder.build(s.clutter).value();
  const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(check_drt_operators(level, drt).ok());
  const std::vector<float> clutter_ld = clutter_direct_light(scene, s.description.lights, 8);
  std::vector<float> c(drt_buffer_sizes(drt).c), lightmap = f.lightmap;
  EXPECT_TRUE(drt_compute_c(drt, clutter_ld, c).ok());
  drt_apply(level, drt, f.b, c, lightmap);
  std::vector<float> clutter_lightmap(drt_buffer_sizes(drt).clutter_lightmap);
  drt_clutter_lightmap(drt, f.b, {}, clutter_lightmap);
  const std::vector<float> clutter_cb_only = clutter_lightmap;
  drt_clutter_add_cc(drt, c, clutter_lightmap);
  DrtOperators alone;
  alone.kb = drt.kb;
  for (const ClutterObject& o : s.clutter) alone.objects.push_back(builder.build_object(o).value());
  std::vector<float> lightmap_alone = f.lightmap, clutter_alone(clutter_lightmap.size());
  drt_apply(level, alone, f.b, c, lightmap_alone);
  drt_clutter_lightmap(alone, f.b, {}, clutter_alone);

  PathTracerSettings pt;
  pt.paths = 512;
  pt.bounces = 1;
  pt.light_vertex_sources = level_light_centres(s.description);
  const DirectRadiance direct = level_direct_radiance(scene, s.description, 8);
  const SurfaceAlbedo albedo = level_surface_albedo(scene, s.description);
  const LevelSampleGeometry& g = scene.samples();
  const IndirectEstimate truth = trace_indirect(scene, g.position, g.normal, direct, albedo, pt);
  const std::vector<std::uint8_t> skip = samples_inside_clutter(g, s.clutter);
  std::vector<glm::dvec3> cp, cn;
  clutter_texel_points(s.clutter, cp, cn);
  const IndirectEstimate clutter_truth = trace_indirect(scene, cp, cn, direct, albedo, pt);
  const LevelBufferSizes sz = level_buffer_sizes(level, dict());
  std::vector<float> probes(sz.probes);
  level_compute_probes(level, dict(), f.b, f.r, probes);
  const std::vector<float> probe_lightmap = probe_shading(level, probes, s.clutter);
  DrtBuildSettings with_probes = settings;
  with_probes.probes = true;
  const DrtOperators drt_probes = DrtBuilder(level, dict(), with_probes).build(s.clutter).value();
  std::vector<float> aware = probes;
  drt_apply_probes(drt_probes, f.b, c, aware);
  const std::vector<float> aware_lightmap = probe_shading(level, aware, s.clutter);
  const std::vector<std::uint8_t> none(cp.size(), 0);

  AccuracyResult a;
  a.mrt = rel_l2(f.lightmap, truth.value, skip);
  a.drt = rel_l2(lightmap, truth.value, skip);
  a.noise = noise_floor(truth, skip);
  a.probes = rel_l2(probe_lightmap, clutter_truth.value, none);
  a.clutter = rel_l2(clutter_lightmap, clutter_truth.value, none);
  a.drt_alone = rel_l2(lightmap_alone, truth.value, skip);
  a.clutter_alone = rel_l2(clutter_alone, clutter_truth.value, none);
  a.clutter_cb_only = rel_l2(clutter_cb_only, clutter_truth.value, none);
  a.probes_udyn = rel_l2(aware_lightmap, clutter_truth.value, none);
  a.clutter_noise = noise_floor(clutter_truth, {});
  std::printf(
      "%s: scene lightmap relL2 MRT %.4f, MRT+DRT %.4f (%.0f %% lower; objects alone %.4f; truth noise floor "
      "%.4f); clutter relL2 MRT probes %.4f (+ U_dyn %.4f), DRT Cb b + Cc c %.4f (Cb b only %.4f, objects "
      "alone %.4f; noise "
      "floor %.4f); %zu objects, build %.3f s (test build, not a benchmark), storage %zu bytes\n",
      name, a.mrt, a.drt, 100.0 * (1.0 - a.drt / a.mrt), a.drt_alone, a.noise, a.probes, a.probes_udyn,
      a.clutter, a.clutter_cb_only, a.clutter_alone, a.clutter_noise, s.clutter.size(), build_s,
      drt.storage_bytes());
  return a;
}

TEST(Drt, LowersTheErrorOfMrtAgainstThePathTracerOnTheBoxRoomWithTwoBoxes) {
  const AccuracyResult a = accuracy(box_room_two_boxes(), "box room, two boxes");
  EXPECT_LT(a.drt, 0.7 * a.mrt);
  EXPECT_LT(a.clutter, a.probes);
}

TEST(Drt, LowersTheErrorOfMrtAgainstThePathTracerOnAMazeBlockWithFourPillars) {
  const AccuracyResult a = accuracy(maze_block_four_pillars(), "maze block, four pillars");
  EXPECT_LT(a.drt, 0.7 * a.mrt);
  EXPECT_LT(a.clutter, a.probes);
}

// Multi-bounce (docs/drt.md, "Multi-bounce"): MRT's feedback alone and with the DRT delta in
// every evaluation (drt_multi_bounce) against the path tracer with as many bounces. The
// feedback's iteration k adds bounce k + 1; the clutter's own indirect light is not fed
// back (c stays its direct light), a bias this measures.
struct MultiBounceAccuracy {
  double mrt = 0, drt = 0, noise = 0, clutter = 0;
  double fed = 0, clutter_fed = 0;  // with the clutter's indirect light fed back (clutter albedo)
};
MultiBounceAccuracy multi_bounce_accuracy(const ClutterScene& s, const char* name, int bounces) {
  const Level level = build_level(s.description, dict()).value();
  const LevelScene scene(level, level.res, s.clutter);
  const std::vector<float> albedo = level_albedo(level, s.description);
  const std::vector<float> ld = level_direct_light(scene, s.description.lights, albedo, 8);
  DrtBuildSettings settings;
  settings.rays = 512;
  const DrtOperators drt = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  const std::vector<float> clutter_ld = clutter_direct_light(scene, s.description.lights, 8);
  std::vector<float> c(drt_buffer_sizes(drt).c);
  const LevelBufferSizes sz = level_buffer_sizes(level, dict());
  MultiBounceSettings mb;
  mb.max_iterations = bounces - 1;
  mb.tolerance = 0.0f;
  std::vector<float> b(sz.b), r(sz.r), mrt(sz.lightmap), with_drt(sz.lightmap);
  const Result<MultiBounceReport> m = level_multi_bounce(level, dict(), ld, albedo, mb, b, r, mrt);
  EXPECT_TRUE(m.ok());
  const Result<MultiBounceReport> d =
      drt_multi_bounce(level, dict(), drt, ld, albedo, clutter_ld, {}, mb, b, r, with_drt, c);
  EXPECT_TRUE(d.ok());
  EXPECT_EQ(d->iterations, bounces - 1);
  std::vector<float> clutter_lightmap(drt_buffer_sizes(drt).clutter_lightmap);
  drt_clutter_lightmap(drt, b, {}, clutter_lightmap);
  drt_clutter_add_cc(drt, c, clutter_lightmap);
  // With the clutter's albedo its own indirect light bounces on too.
  std::vector<float> clutter_albedo;
  for (const ClutterObject& o : s.clutter)
    for (int t = 0; t < clutter_texel_count(o); ++t)
      for (int ch = 0; ch < 3; ++ch) clutter_albedo.push_back(float(o.albedo[ch]));
  std::vector<float> fed(sz.lightmap), c_fed(c.size());
  const Result<MultiBounceReport> f =
      drt_multi_bounce(level, dict(), drt, ld, albedo, clutter_ld, clutter_albedo, mb, b, r, fed, c_fed);
  EXPECT_TRUE(f.ok());
  std::vector<float> clutter_fed(clutter_lightmap.size());
  drt_clutter_lightmap(drt, b, {}, clutter_fed);
  drt_clutter_add_cc(drt, c_fed, clutter_fed);

  PathTracerSettings pt;
  pt.paths = 256;
  pt.bounces = bounces;
  pt.light_vertex_sources = level_light_centres(s.description);
  const DirectRadiance direct = level_direct_radiance(scene, s.description, 8);
  const SurfaceAlbedo surface_albedo = level_surface_albedo(scene, s.description);
  const LevelSampleGeometry& g = scene.samples();
  const IndirectEstimate truth = trace_indirect(scene, g.position, g.normal, direct, surface_albedo, pt);
  const std::vector<std::uint8_t> skip = samples_inside_clutter(g, s.clutter);
  std::vector<glm::dvec3> cp, cn;
  clutter_texel_points(s.clutter, cp, cn);
  const IndirectEstimate clutter_truth = trace_indirect(scene, cp, cn, direct, surface_albedo, pt);
  MultiBounceAccuracy a;
  a.mrt = rel_l2(mrt, truth.value, skip);
  a.drt = rel_l2(with_drt, truth.value, skip);
  a.fed = rel_l2(fed, truth.value, skip);
  a.clutter_fed = rel_l2(clutter_fed, clutter_truth.value, std::vector<std::uint8_t>(cp.size(), 0));
  a.clutter = rel_l2(clutter_lightmap, clutter_truth.value, std::vector<std::uint8_t>(cp.size(), 0));
  a.noise = noise_floor(truth, skip);
  std::printf(
      "%s, %d bounces: scene lightmap relL2 MRT %.4f, MRT+DRT %.4f with the clutter's indirect light "
      "fed back (%.0f %% lower), %.4f without; truth noise floor %.4f; clutter (Cb b + Cc c) %.4f "
      "fed back, %.4f without\n",
      name, bounces, a.mrt, a.fed, 100.0 * (1.0 - a.fed / a.mrt), a.drt, a.noise, a.clutter_fed, a.clutter);
  return a;
}

// The clutter feedback cannot diverge: albedo 1 everywhere (clamped to max_albedo), bright
// clutter light, 300 iterations: every value finite and within the energy bound, and the
// iteration converges.
TEST(Drt, MultiBounceWithClutterFeedbackStaysBounded) {
  const ClutterScene s = box_room_two_boxes();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 64;
  const DrtOperators drt = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  const DrtBufferSizes d = drt_buffer_sizes(drt);
  const LevelBufferSizes sz = level_buffer_sizes(level, dict());
  const std::vector<float> ld(sz.lightmap, 0.3f), albedo(sz.lightmap, 1.0f),
      clutter_albedo(d.clutter_ld, 1.0f);
  const std::vector<float> clutter_ld(d.clutter_ld, 5.0f);
  MultiBounceSettings mb;
  mb.max_iterations = 300;
  mb.tolerance = 1e-6f;
  std::vector<float> b(sz.b), r(sz.r), lightmap(sz.lightmap), c(d.c);
  const Result<MultiBounceReport> rep =
      drt_multi_bounce(level, dict(), drt, ld, albedo, clutter_ld, clutter_albedo, mb, b, r, lightmap, c);
  ASSERT_TRUE(rep.ok()) << rep.status().to_string();
  EXPECT_TRUE(rep->albedo_clamped);
  EXPECT_TRUE(rep->converged) << rep->iterations << " iterations";
  const float bound = drt_feedback_bound(ld[0], mb.max_albedo, clutter_ld[0], mb.max_albedo);
  for (float v : lightmap) ASSERT_TRUE(std::isfinite(v));
  for (float v : c) {
    ASSERT_TRUE(std::isfinite(v));
    EXPECT_LE(v, clutter_ld[0] + mb.max_albedo * bound * 1.0001f);
  }
  std::printf(
      "clutter feedback at albedo 1 (clamped to %.2f): converged after %d iterations, max c %.3f, bound "
      "%.3f\n",
      double(mb.max_albedo), rep->iterations, double(*std::max_element(c.begin(), c.end())), double(bound));
  // Bad clutter albedo is refused naming it.
  std::vector<float> bad = clutter_albedo;
  bad[4] = std::nanf("");
  const Result<MultiBounceReport> refused =
      drt_multi_bounce(level, dict(), drt, ld, albedo, clutter_ld, bad, mb, b, r, lightmap, c);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().to_string().find("clutter_albedo"), std::string::npos)
      << refused.status().to_string();
}

TEST(Drt, MultiBounceLowersTheErrorAgainstAMultiBouncePathTracer) {
  const MultiBounceAccuracy a =
      multi_bounce_accuracy(maze_block_four_pillars(), "maze block, four pillars", 4);
  EXPECT_LT(a.fed, 0.7 * a.mrt);
  EXPECT_LT(a.fed, 0.8 * a.drt);  // the clutter's bounce matters
  EXPECT_LT(a.clutter_fed, a.clutter);
  const MultiBounceAccuracy room = multi_bounce_accuracy(box_room_two_boxes(), "box room, two boxes", 4);
  EXPECT_LT(room.fed, 0.7 * room.mrt);
  EXPECT_LT(room.fed, 0.8 * room.drt);
}

// ---- Triangle-mesh clutter (drt.h ClutterKind::mesh, precompute/clutter_mesh.h) ----

ClutterObject mesh_object(ClutterMesh mesh, int block, const glm::dvec3& albedo, int res) {
  Result<ClutterObject> o = make_mesh_clutter(std::move(mesh), block, albedo, res, "test mesh");
  EXPECT_TRUE(o.ok()) << o.status().to_string();
  return o.ok() ? o.value() : ClutterObject{};
}

// Area-weighted mean of each face's (chart's) clutter lightmap, per channel.
std::vector<double> face_means(const ClutterObject& object, std::span<const float> lightmap) {
  const ClutterTexelGeometry g = clutter_texel_geometry(object);
  const std::vector<double> area = clutter_texel_area(object);
  const int faces = object.kind == ClutterKind::mesh ? clutter_face_count(object) : kFaceCount;
  std::vector<double> sum(3 * std::size_t(faces), 0.0), total(std::size_t(faces), 0.0);
  for (std::size_t t = 0; t < g.position.size(); ++t) {
    const std::size_t f = std::size_t(g.face[t]);
    total[f] += area[t];
    for (int c = 0; c < 3; ++c) sum[3 * f + std::size_t(c)] += area[t] * lightmap[3 * t + std::size_t(c)];
  }
  for (std::size_t i = 0; i < sum.size(); ++i) sum[i] /= std::max(total[i / 3], 1e-300);
  return sum;
}

// The same rotated box as a box object and as a 12-triangle mesh whose faces land on
// grid-aligned UV squares (the same texels): the scene rays are the same, so the scene
// delta dUb b + dUc c must agree up to the float ray-triangle tests on grazing rays; the
// clutter texels use other random streams, so their face means agree up to Monte-Carlo noise.
TEST(DrtMesh, ABoxGivenAsAMeshGivesTheBoxsDeltas) {
  ClutterScene s = box_room_two_boxes();
  ClutterObject box;
  box.box.center = glm::dvec3(0.45, 0.35, 0.5);
  box.box.half_extent = glm::dvec3(0.15, 0.1, 0.12);
  box.box.rotation = test::rotation_y(30.0);
  box.albedo = glm::dvec3(0.7, 0.6, 0.3);
  const int n = 12, res = 3 * (n + 2);
  box.res = n;
  const ClutterObject mesh = mesh_object(test::box_mesh(box.box, n, res), 0, box.albedo, res);
  ASSERT_EQ(clutter_texel_count(mesh), clutter_texel_count(box));
  ASSERT_EQ(clutter_face_count(mesh), kFaceCount);
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 256;
  const DrtBuilder builder(level, dict(), settings);
  struct Out {
    std::vector<float> delta, clutter;
    DrtOperators drt;
  };
  auto run = [&](const ClutterObject& object) {
    const std::vector<ClutterObject> objects{object};
    const LevelScene scene(level, level.res, objects);
    const std::vector<float> ld =
        level_direct_light(scene, s.description.lights, level_albedo(level, s.description), 8);
    const Frame f = evaluate_mrt(level, ld);
    Out out;
    out.drt = builder.build(objects).value();
    EXPECT_TRUE(check_drt_operators(level, out.drt).ok());
    const std::vector<float> clutter_ld = clutter_direct_light(scene, s.description.lights, 8);
    std::vector<float> c(drt_buffer_sizes(out.drt).c);
    EXPECT_TRUE(drt_compute_c(out.drt, clutter_ld, c).ok());
    std::vector<float> lightmap = f.lightmap;
    drt_apply(level, out.drt, f.b, c, lightmap);
    for (std::size_t i = 0; i < lightmap.size(); ++i) out.delta.push_back(lightmap[i] - f.lightmap[i]);
    out.clutter.resize(drt_buffer_sizes(out.drt).clutter_lightmap);
    drt_clutter_lightmap(out.drt, f.b, clutter_ld, out.clutter);
    return out;
  };
  const Out a = run(box), b = run(mesh);
  double num = 0, den = 0;
  for (std::size_t i = 0; i < a.delta.size(); ++i) {
    num += (double(b.delta[i]) - a.delta[i]) * (double(b.delta[i]) - a.delta[i]);
    den += double(a.delta[i]) * a.delta[i];
  }
  const double scene_err = std::sqrt(num / den);
  EXPECT_GT(den, 0.0);
  EXPECT_LT(scene_err, 2e-3);
  EXPECT_EQ(a.drt.objects[0].dUb_sample.size(), b.drt.objects[0].dUb_sample.size());
  // Charts are numbered as the faces (box_mesh lists faces in order), so face means compare.
  const std::vector<double> ma = face_means(box, a.clutter), mb = face_means(mesh, b.clutter);
  double worst = 0;
  for (std::size_t i = 0; i < ma.size(); ++i)
    worst = std::max(worst, std::abs(mb[i] - ma[i]) / std::max(ma[i], 1e-3));
  EXPECT_LT(worst, 0.02);
  std::printf("box as a mesh: scene delta rel L2 %.2e, clutter face means worst rel diff %.2e\n", scene_err,
              worst);
}

// A sphere (curved, one chart) and an extruded L (concave: it shadows itself) in the
// paper's box room: DRT with mesh clutter lowers MRT's error against the path tracer on the
// real meshes as it does for boxes.
ClutterScene box_room_sphere_and_l() {
  ClutterScene s = box_room_two_boxes();
  s.clutter.clear();
  s.clutter.push_back(mesh_object(test::uv_sphere_mesh(glm::dvec3(0.3, 0.22, 0.32), 0.16, 10, 20), 0,
                                  glm::dvec3(0.8, 0.8, 0.3), 40));
  s.clutter.push_back(
      mesh_object(test::l_prism_mesh(0.5, 0.5, 0.35, 0.12, 0.0, 0.3, 48), 0, glm::dvec3(0.3, 0.5, 0.8), 48));
  return s;
}

// With a lighting prior for c (DrtBuildSettings::clutter_prior_modes, see DrtPrior below) the
// sphere's light reaches the scene with its shape rather than as one constant.
TEST(DrtMesh, LowersTheErrorOfMrtAgainstThePathTracerWithASphereAndAConcaveL) {
  const AccuracyResult a = accuracy(box_room_sphere_and_l(), "box room, sphere and L meshes");
  EXPECT_LT(a.drt, 0.7 * a.mrt);
  EXPECT_LT(a.clutter, a.probes);
  DrtBuildSettings settings;
  settings.clutter_prior_modes = 8;
  const AccuracyResult prior =
      accuracy(box_room_sphere_and_l(), "sphere and L, 8-mode lighting prior", settings);
  EXPECT_LT(prior.drt, a.drt);
  EXPECT_LT(prior.clutter, 1.01 * a.clutter);
}

TEST(DrtMesh, IncrementalRebuildOfAMovedMeshEqualsAFullBuild) {
  ClutterScene s = box_room_sphere_and_l();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 128;
  const DrtBuilder builder(level, dict(), settings);
  DrtBuildState state;
  DrtOperators drt = builder.build(s.clutter, nullptr, &state).value();
  const DrtOperators before = drt;
  // Move the sphere: a new mesh (positions shifted), the same UVs.
  ClutterMesh moved = s.clutter[0].mesh->mesh;
  for (glm::dvec3& p : moved.positions) p += glm::dvec3(0.1, 0.05, 0.0);
  s.clutter[0] = mesh_object(std::move(moved), 0, s.clutter[0].albedo, s.clutter[0].res);
  DrtBuildReport report;
  ASSERT_TRUE(builder.rebuild_object(s.clutter, 0, drt, state, &report).ok());
  const DrtOperators full = builder.build(s.clutter).value();
  for (std::size_t k = 0; k < s.clutter.size(); ++k)
    EXPECT_TRUE(operators_equal(drt.objects[k], full.objects[k])) << "object " << k;
  EXPECT_FALSE(operators_equal(drt.objects[0], before.objects[0]));
  EXPECT_FALSE(operators_equal(drt.objects[1], before.objects[1]));  // the L sees the sphere
  EXPECT_LT(report.traced_samples, std::size_t(level.sample_count));
  // A copy of the objects (the same mesh data, or equal meshes) is not a change.
  std::vector<ClutterObject> copy = s.clutter;
  copy[1] = mesh_object(s.clutter[1].mesh->mesh, 0, s.clutter[1].albedo, s.clutter[1].res);
  EXPECT_TRUE(builder.rebuild_object(copy, 0, drt, state).ok());
}

TEST(DrtMesh, ValidationNamesTheProblem) {
  const ClutterScene s = box_room_sphere_and_l();
  const Level level = build_level(s.description, dict()).value();
  ASSERT_TRUE(validate_clutter(level, s.clutter).ok());
  std::vector<ClutterObject> bad = s.clutter;
  bad[1].mesh.reset();
  Status st = validate_clutter(level, bad);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.to_string().find("clutter object 1: kind mesh without mesh data"), std::string::npos)
      << st.to_string();
  bad = s.clutter;
  bad[0].res = 16;
  st = validate_clutter(level, bad);
  EXPECT_NE(st.to_string().find("is not the atlas's 40"), std::string::npos) << st.to_string();
  auto data = std::make_shared<ClutterMeshData>(*s.clutter[0].mesh);
  data->atlas.texels.face[3] = data->atlas.chart_count;
  bad = s.clutter;
  bad[0].mesh = data;
  st = validate_clutter(level, bad);
  EXPECT_NE(st.to_string().find("texel 3 has a bad chart"), std::string::npos) << st.to_string();
  EXPECT_FALSE(DrtBuilder(level, dict()).build(bad).ok());
  // A mesh that is not a mesh: named by make_mesh_clutter's caller.
  ClutterMesh broken = s.clutter[0].mesh->mesh;
  broken.indices.push_back(0);
  const Result<ClutterObject> r = make_mesh_clutter(broken, 0, glm::dvec3(0.5), 32, "chair.gltf node 3");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().to_string().find("chair.gltf node 3"), std::string::npos) << r.status().to_string();
}

// The lighting prior of c (DrtBuildSettings::clutter_prior_modes, DRT §4.2's optional prior):
// Td_c's rows are orthonormal in the area inner product (Td_c diag(1/area) Td_c^T = I, so
// Td_c B = I for B = diag(1/area) Td_c^T), and the incremental rebuild stays exact. The
// accuracy gain is in DrtMesh.LowersTheErrorOfMrtAgainstThePathTracerWithASphereAndAConcaveL.
TEST(DrtPrior, TdcIsAnAreaOrthonormalProjection) {
  const ClutterScene s = box_room_sphere_and_l();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 64;
  settings.clutter_prior_modes = 6;
  const DrtOperators drt = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  ASSERT_TRUE(check_drt_operators(level, drt).ok());
  for (std::size_t k = 0; k < s.clutter.size(); ++k) {
    const DrtObjectOperators& op = drt.objects[k];
    EXPECT_EQ(op.face_count, 6u);
    const std::vector<double> area = clutter_texel_area(s.clutter[k]);
    double worst = 0;
    for (std::uint32_t a = 0; a < op.face_count; ++a)
      for (std::uint32_t b = 0; b < op.face_count; ++b) {
        double dot = 0;
        for (std::uint32_t t = 0; t < op.texel_count; ++t)
          dot += double(op.Td_c(a, t)) * op.Td_c(b, t) / area[t];
        worst = std::max(worst, std::abs(dot - (a == b ? 1.0 : 0.0)));
      }
    EXPECT_LT(worst, 1e-5) << "object " << k;
  }
}

TEST(DrtPrior, IncrementalRebuildWithPriorsEqualsAFullBuild) {
  ClutterScene s = box_room_sphere_and_l();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings;
  settings.rays = 64;
  settings.clutter_prior_modes = 4;
  const DrtBuilder builder(level, dict(), settings);
  DrtBuildState state;
  DrtOperators drt = builder.build(s.clutter, nullptr, &state).value();
  ClutterMesh moved = s.clutter[1].mesh->mesh;
  for (glm::dvec3& p : moved.positions) p += glm::dvec3(-0.05, 0.0, 0.08);
  s.clutter[1] = mesh_object(std::move(moved), 0, s.clutter[1].albedo, s.clutter[1].res);
  ASSERT_TRUE(builder.rebuild_object(s.clutter, 1, drt, state).ok());
  const DrtOperators full = builder.build(s.clutter).value();
  for (std::size_t k = 0; k < s.clutter.size(); ++k)
    EXPECT_TRUE(operators_equal(drt.objects[k], full.objects[k])) << "object " << k;
}

// Timing for docs/drt.md, not a test (run with --gtest_also_run_disabled_tests
// --gtest_filter='*Timing*'): full build of the four pillars at the default settings
// (1024 rays, 16 x 16 clutter texels, 5 Cb modes), the incremental rebuild of one moved
// pillar, and the operators' storage; medians of 5 runs.
TEST(Drt, DISABLED_Timing) {
  for (int rays : {1024, 256}) {
    ClutterScene s = maze_block_four_pillars();
    const Level level = build_level(s.description, dict()).value();
    DrtBuildSettings settings;
    settings.rays = rays;
    const DrtBuilder builder(level, dict(), settings);
    auto median = [](std::vector<double> v) {
      std::sort(v.begin(), v.end());
      return v[v.size() / 2];
    };
    std::vector<double> full, incremental, scene_pass, clutter_pass;
    DrtOperators drt;
    for (int run = 0; run < 5; ++run) {
      DrtBuildReport report;
      DrtBuildState state;
      const auto t0 = std::chrono::steady_clock::now();
      drt = builder.build(s.clutter, &report, &state).value();
      full.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      scene_pass.push_back(report.scene_seconds);
      clutter_pass.push_back(report.clutter_seconds);
      s.clutter[1].box.center.x += run % 2 == 0 ? 0.05 : -0.05;
      const auto t1 = std::chrono::steady_clock::now();
      ASSERT_TRUE(builder.rebuild_object(s.clutter, 1, drt, state).ok());
      incremental.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count());
    }
    std::size_t dUb = 0, dUc = 0, Td_c = 0, Cb = 0, Cc = 0;
    for (const DrtObjectOperators& o : drt.objects) {
      dUb += o.dUb.data.size() * 4 + o.dUb_sample.size() * 8;
      dUc += o.dUc.data.size() * 4 + o.dUc_sample.size() * 4;
      Td_c += o.Td_c.data.size() * 4;
      Cb += (o.Uc.data.size() + o.Vc.data.size()) * 4 + o.Cb_blocks.size() * 4;
      Cc += o.Cc.data.size() * 4 + o.Cc_objects.size() * 4;
    }
    std::printf(
        "%d rays: four pillars (res %d level, kb %u, %u level samples): full build %.3f s (scene samples "
        "%.3f s, "
        "clutter "
        "texels %.3f s), incremental rebuild of one pillar %.3f s; storage %zu bytes (dUb %zu, dUc %zu, Td_c "
        "%zu, "
        "Cb %zu, Cc %zu)\n",
        rays, level.res, level.kb, level.sample_count, median(full), median(scene_pass), median(clutter_pass),
        median(incremental), drt.storage_bytes(), dUb, dUc, Td_c, Cb, Cc);
    accuracy(s, "four pillars (moved pillar 1)", settings);
  }
  for (int rays : {1024, 256}) {
    DrtBuildSettings settings;
    settings.rays = rays;
    std::printf("%d rays: ", rays);
    accuracy(box_room_two_boxes(), "box room, two boxes", settings);
  }
  for (double tolerance : {0.01, 0.03}) {
    DrtBuildSettings settings;
    settings.drop_tolerance = tolerance;
    std::printf("1024 rays, dUb drop tolerance %.2f: ", tolerance);
    accuracy(box_room_two_boxes(), "box room, two boxes", settings);
    std::printf("1024 rays, dUb drop tolerance %.2f: ", tolerance);
    accuracy(maze_block_four_pillars(), "four pillars", settings);
  }
}

}  // namespace
}  // namespace modrt::precompute
