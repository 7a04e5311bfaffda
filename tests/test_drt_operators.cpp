// SPDX-License-Identifier: MIT
// Delta Radiance Transfer (architecture.md §6, [Loos et al. 2012]), the operators of clutter
// boxes: empty without clutter, packet rays equal single rays, validation, exact culling,
// inpainting inside clutter, Cc as a form factor, truncation and dropped-row bounds, and the
// incremental rebuild of a moved object equal to a full build.
#include <gtest/gtest.h>

#include <limits>

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
  const Frame f =
      evaluate_mrt(level, level_direct_light(scene, s.description.lights, level_sample_albedo(level), 8));
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
  const DrtBuilder builder(level, dict(), paper_operators());
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
  // The gather's sparse rows: indices in range, weights >= 0 and finite, row starts that span
  // the entries, H_sample sorted; each refusal names the operator.
  const DrtOperators gather = DrtBuilder(level, dict()).build(s.clutter).value();
  ASSERT_TRUE(gather.has_gather());
  ASSERT_TRUE(check_drt_operators(level, gather).ok());
  const auto refused = [&](const char* what, auto&& spoil) {
    DrtOperators bad_gather = gather;
    spoil(bad_gather.objects[1]);
    const Status status = check_drt_operators(level, bad_gather);
    EXPECT_FALSE(status.ok()) << what;
    EXPECT_NE(status.to_string().find(what), std::string::npos) << status.to_string();
  };
  refused("Gs", [&](DrtObjectOperators& o) { o.Gs.index.back() = level.sample_count; });
  refused("Gs", [&](DrtObjectOperators& o) { o.Gs.weight.front() = -1e-3f; });
  refused("Gs", [&](DrtObjectOperators& o) { o.Gs.weight.front() = std::nanf(""); });
  refused("Gs", [&](DrtObjectOperators& o) { o.Gs.start.pop_back(); });
  refused("Gs", [&](DrtObjectOperators& o) { o.Gs.start[1] = o.Gs.start[2] + 1; });
  refused("Gt", [&](DrtObjectOperators& o) {
    o.Gt.index.back() = std::uint32_t(drt_buffer_sizes(gather).clutter_texels);
  });
  refused("Hs", [&](DrtObjectOperators& o) { o.Hs.weight.back() = std::numeric_limits<float>::infinity(); });
  refused("Ht", [&](DrtObjectOperators& o) { o.Ht.start.back() += 1; });
  refused("H_sample", [&](DrtObjectOperators& o) { std::swap(o.H_sample.front(), o.H_sample.back()); });
}

// Culling is exact: a build that tests every object from every sample and texel gives the
// same operators (one box; four pillars that see each other, Cc included), and no sample
// with the whole box behind its tangent plane has a row.
TEST(Drt, CullingIsExact) {
  const ClutterScene s = l_shaped_level_with_a_box();
  const Level level = build_level(s.description, dict()).value();
  DrtBuildSettings settings = paper_operators();
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
  DrtBuildSettings settings = paper_operators();
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

TEST(Drt, CcOfAFacingParallelFaceIsItsFormFactor) {
  ClutterScene s = two_boxes_in_a_row();
  s.clutter[0].res = 15;  // a texel at the exact centre of each face
  const Level level = build_level(s.description, dict()).value();
  const DrtOperators drt = DrtBuilder(level, dict(), paper_operators()).build(s.clutter).value();
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
  DrtBuildSettings settings = paper_operators();
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
  DrtBuildSettings settings = paper_operators();
  settings.rays = 256;
  const DrtOperators all = DrtBuilder(level, dict(), settings).build(s.clutter).value();
  settings.drop_tolerance = 0.03;
  DrtBuildReport report;
  const DrtOperators kept = DrtBuilder(level, dict(), settings).build(s.clutter, &report).value();
  const LevelScene scene(level, level.res, s.clutter);
  const Frame f =
      evaluate_mrt(level, level_direct_light(scene, s.description.lights, level_sample_albedo(level), 8));
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

// max_clutter_rays caps the clutter texels' rays alone: 0 or a cap at or above `rays` gives the
// same operators bit for bit; a lower cap changes the clutter rows (Gs, Gt) and leaves the
// scene's (H_sample, Hs, Ht, dUb, dUc) as they were; every texel row's weights sum to at most 1
// (each ray at most one hit, bilinear taps summing to its weight).
TEST(Drt, MaxClutterRaysCapsTheTexelRaysOnly) {
  const ClutterScene s = box_room_two_boxes();
  const Level level = build_level(s.description, dict()).value();
  const auto build = [&](int cap) {
    DrtBuildSettings settings;
    settings.rays = 128;
    settings.max_clutter_rays = cap;
    return DrtBuilder(level, dict(), settings).build(s.clutter).value();
  };
  const DrtOperators all = build(0), same = build(128), above = build(4096), capped = build(32);
  for (std::size_t k = 0; k < all.objects.size(); ++k) {
    const DrtObjectOperators &a = all.objects[k], &c = capped.objects[k];
    EXPECT_TRUE(operators_equal(a, same.objects[k]));
    EXPECT_TRUE(operators_equal(a, above.objects[k]));
    EXPECT_FALSE(sparse_equal(a.Gs, c.Gs));
    EXPECT_TRUE(a.H_sample == c.H_sample && sparse_equal(a.Hs, c.Hs) && sparse_equal(a.Ht, c.Ht));
    EXPECT_EQ(a.dUb.data, c.dUb.data);
    for (const DrtObjectOperators* o : {&a, &c})
      for (std::uint32_t t = 0; t < o->texel_count; ++t) {
        double sum = 0.0;
        for (std::uint32_t e = o->Gs.start[t]; e < o->Gs.start[t + 1]; ++e) sum += o->Gs.weight[e];
        for (std::uint32_t e = o->Gt.start[t]; e < o->Gt.start[t + 1]; ++e) sum += o->Gt.weight[e];
        ASSERT_LE(sum, 1.0 + 1e-5) << "object " << k << " texel " << t;
      }
  }
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

}  // namespace
}  // namespace modrt::precompute
