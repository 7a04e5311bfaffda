// SPDX-License-Identifier: MIT
// Delta Radiance Transfer with triangle-mesh clutter (drt.h ClutterKind::mesh,
// precompute/clutter_mesh.h) and with clutter priors (Td_c's basis): a box given as a mesh
// gives the box's deltas, the path-tracer accuracy with a sphere and a concave L, incremental
// rebuilds, validation.
#include <gtest/gtest.h>

#include <Eigen/SVD>

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
#include "drt_accuracy.h"
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
  DrtBuildSettings settings = paper_operators();  // dUb, dUc and Cb compared
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
        level_direct_light(scene, s.description.lights, level_sample_albedo(level), 8);
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
  expect_real_gather_meets_the_issue(a);
  DrtBuildSettings settings;
  settings.clutter_prior_modes = 8;
  const AccuracyResult prior =
      accuracy(box_room_sphere_and_l(), "sphere and L, 8-mode lighting prior", settings);
  EXPECT_LT(prior.drt, a.drt);
  EXPECT_LT(prior.clutter, 1.01 * a.clutter);
}

// The real-radiance gathers at 256 rays (docs/drt.md, "Gathering the real radiance"; the
// 1024-ray figures come from the tests above): error and entries against the ray count.
TEST(Drt, DISABLED_RealRadianceGatherAt256Rays) {
  DrtBuildSettings settings;
  settings.rays = 256;
  expect_real_gather_meets_the_issue(
      accuracy(box_room_two_boxes(), "box room, two boxes, 256 rays", settings));
  expect_real_gather_meets_the_issue(
      accuracy(maze_block_four_pillars(), "maze block, four pillars, 256 rays", settings));
  expect_real_gather_meets_the_issue(
      accuracy(box_room_sphere_and_l(), "box room, sphere and L meshes, 256 rays", settings));
}

// A compact form of G_s (docs/drt.md, "Gathering the real radiance"): each object's clutter
// texels x touched scene samples, truncated to r singular modes (Eigen's BDCSVD), against the
// sparse rows: the clutter lightmap's relL2 against the path tracer and its lowest texel as a
// fraction of the largest, with the texel light G_t clutter_ld kept exact.
void low_rank_gather_study(const ClutterScene& s, const char* name) {
  const Level level = build_level(s.description, dict()).value();
  const LevelScene scene(level, level.res, s.clutter);
  const std::vector<float> ld =
      level_direct_light(scene, s.description.lights, level_sample_albedo(level), 8);
  const std::vector<float> clutter_ld = clutter_direct_light(scene, s.description.lights, 8);
  DrtBuildSettings settings;
  settings.sample_gather = true;
  DrtBuildState state;
  ASSERT_TRUE(DrtBuilder(level, dict(), settings).build(s.clutter, nullptr, &state).ok());
  const std::vector<ClutterSampleGather> gs = state.sample_gather(), gt = state.sample_gather(true);
  const IndirectEstimate truth = clutter_one_bounce_truth(scene, s);
  const std::size_t texels = truth.value.size() / 3;
  const std::vector<std::uint8_t> none(texels, 0);
  for (const int r : {0, 4, 8, 16, 32}) {
    std::vector<float> out(3 * texels);
    std::size_t base = 0, floats = 0;
    for (std::size_t k = 0; k < gs.size(); ++k) {
      const std::size_t m = gs[k].row_start.size() - 1;
      std::span<float> o = std::span(out).subspan(3 * base, 3 * m);
      std::vector<float> light(3 * m);
      clutter_gather_radiance(gt[k], clutter_ld, light);
      if (r == 0) {
        clutter_gather_radiance(gs[k], ld, o);
        floats += 2 * gs[k].sample.size();
      } else {
        std::vector<std::uint32_t> touched(gs[k].sample);
        std::sort(touched.begin(), touched.end());
        touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
        Eigen::MatrixXd G = Eigen::MatrixXd::Zero(Eigen::Index(m), Eigen::Index(touched.size()));
        for (std::size_t t = 0; t < m; ++t)
          for (std::uint32_t e = gs[k].row_start[t]; e < gs[k].row_start[t + 1]; ++e) {
            const auto col =
                std::lower_bound(touched.begin(), touched.end(), gs[k].sample[e]) - touched.begin();
            G(Eigen::Index(t), col) += gs[k].weight[e];
          }
        Eigen::BDCSVD<Eigen::MatrixXd> svd(G, Eigen::ComputeThinU | Eigen::ComputeThinV);
        const Eigen::Index keep = std::min<Eigen::Index>(r, svd.singularValues().size());
        const Eigen::MatrixXd U = svd.matrixU().leftCols(keep) * svd.singularValues().head(keep).asDiagonal();
        const Eigen::MatrixXd V = svd.matrixV().leftCols(keep).transpose();
        Eigen::MatrixXd L(Eigen::Index(touched.size()), 3);
        for (std::size_t j = 0; j < touched.size(); ++j)
          for (int ch = 0; ch < 3; ++ch) L(Eigen::Index(j), ch) = ld[3 * touched[j] + std::size_t(ch)];
        const Eigen::MatrixXd E = U * (V * L);
        for (std::size_t t = 0; t < m; ++t)
          for (int ch = 0; ch < 3; ++ch) o[3 * t + std::size_t(ch)] = float(E(Eigen::Index(t), ch));
        floats += std::size_t(keep) * (m + touched.size());
      }
      for (std::size_t i = 0; i < o.size(); ++i) o[i] += light[i];
      base += m;
    }
    const float lo = *std::min_element(out.begin(), out.end()),
                hi = *std::max_element(out.begin(), out.end());
    std::printf("%s: G_s %s: clutter relL2 %.4f, lowest texel %.4f of the largest, %zu floats\n", name,
                r == 0 ? "sparse rows" : ("rank " + std::to_string(r)).c_str(),
                rel_l2(out, truth.value, none), double(lo / hi), floats);
  }
}

TEST(Drt, DISABLED_RealRadianceGatherLowRank) {
  low_rank_gather_study(box_room_two_boxes(), "box room, two boxes");
  low_rank_gather_study(maze_block_four_pillars(), "maze block, four pillars");
  low_rank_gather_study(box_room_sphere_and_l(), "box room, sphere and L meshes");
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

}  // namespace
}  // namespace modrt::precompute
