// SPDX-License-Identifier: MIT
// modrt tests — DRT's accuracy against the path tracer (test_drt_accuracy.cpp, test_drt_mesh.cpp):
// MRT's probe shading of clutter, the samples inside clutter (left out of the error), the
// clutter texel points, and one-bounce accuracy of MRT and MRT + DRT on a scene.
#pragma once

#include <map>

#include "drt_test_support.h"

namespace modrt::precompute::drt_test {

// MRT's clutter shading: the volume probes (SH9 radiance, trilinear between the g^3 probes
// of the owning block) turned into E/pi at the texel normal (MRT §6.5).
inline std::vector<float> probe_shading(const Level& level, std::span<const float> probes,
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
inline std::vector<std::uint8_t> samples_inside_clutter(const LevelSampleGeometry& g,
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
inline void clutter_texel_points(std::span<const ClutterObject> clutter, std::vector<glm::dvec3>& points,
                                 std::vector<glm::dvec3>& normals) {
  for (const ClutterObject& o : clutter) {
    const ClutterTexelGeometry cg = clutter_texel_geometry(o);
    for (std::size_t t = 0; t < cg.position.size(); ++t) {
      points.push_back(cg.position[t] + 1e-5 * cg.normal[t]);
      normals.push_back(cg.normal[t]);
    }
  }
}

// The path tracer's one-bounce truth at the clutter texels (512 paths, light-vertex sources,
// the accuracy tests' settings), for studies that need only the clutter's side.
inline IndirectEstimate clutter_one_bounce_truth(const LevelScene& scene, const ClutterScene& s) {
  PathTracerSettings pt;
  pt.paths = 512;
  pt.bounces = 1;
  pt.light_vertex_sources = level_light_centres(s.description);
  std::vector<glm::dvec3> cp, cn;
  clutter_texel_points(s.clutter, cp, cn);
  return trace_indirect(scene, cp, cn, level_direct_radiance(scene, s.description, 8),
                        level_surface_albedo(scene, s.description), pt);
}

// The path tracer's indirect light on the real geometry with the clutter (`paths` paths,
// `bounces` bounces, light-vertex sources; the accuracy tests' direct-light model): at the
// level samples, with the mask of those inside clutter (invisible), and at the clutter texels.
struct ClutterSceneTruth {
  IndirectEstimate scene, clutter;
  std::vector<std::uint8_t> skip;           // per level sample: inside clutter
  std::vector<std::uint8_t> none;           // per clutter texel: 0 (every texel counts)
  std::vector<glm::dvec3> texels, normals;  // the clutter texels' points
};
inline ClutterSceneTruth clutter_scene_truth(const LevelScene& scene, const ClutterScene& s, int paths,
                                             int bounces) {
  PathTracerSettings pt;
  pt.paths = paths;
  pt.bounces = bounces;
  pt.light_vertex_sources = level_light_centres(s.description);
  const DirectRadiance direct = level_direct_radiance(scene, s.description, 8);
  const SurfaceAlbedo albedo = level_surface_albedo(scene, s.description);
  const LevelSampleGeometry& g = scene.samples();
  ClutterSceneTruth t;
  t.scene = trace_indirect(scene, g.position, g.normal, direct, albedo, pt);
  t.skip = samples_inside_clutter(g, s.clutter);
  clutter_texel_points(s.clutter, t.texels, t.normals);
  t.clutter = trace_indirect(scene, t.texels, t.normals, direct, albedo, pt);
  t.none.assign(t.texels.size(), 0);
  return t;
}

// The truth's own relative noise: sqrt(sum se^2 / sum value^2) over the points not skipped.
inline double noise_floor(const IndirectEstimate& truth, const std::vector<std::uint8_t>& skip) {
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
  // The DRT issue's study (docs/drt.md, "Gathering the real radiance"): the clutter lightmap
  // with the same rays gathering the scene's real exitant radiance (ld) instead of Limp b,
  // plus Cc c; its entries (texel, sample); and per clutter face (box face or mesh chart) the
  // worst |mean / truth mean - 1| of Cb b + Cc c and of the real gather.
  double clutter_real = 0;
  std::size_t gather_entries = 0;
  double worst_face_cb = 0, worst_face_real = 0;
  // The same with the clutter-to-clutter light gathered per texel too (in place of Cc c).
  double clutter_real_texels = 0, worst_face_real_texels = 0;
  // The scene lightmap with dUb b replaced by the real radiance of the hidden samples, and
  // then dUc c by the clutter's light gathered per texel; the worst floor strip's mean
  // error (worst_floor_strip_error) of those and of MRT + DRT.
  double drt_real_shadow = 0, drt_real_both = 0;
  double strip_drt = 0, strip_real_shadow = 0, strip_real_both = 0;
  float min_cb = 0, min_real = 0;  // the lowest texel value of each, before any clamp
  // The run-time operators (DrtBuildSettings::gather) applied by core's reference: clutter
  // lightmap (drt_clutter_indirect, before any clamp) and scene lightmap (drt_apply +
  // drt_apply_gather) against the truth, their lowest clutter texel, worst face and floor
  // strip, their agreement with the study's rows above (rel L2; the scene's at the samples
  // outside clutter), their storage and build seconds.
  double gather_clutter = 0, gather_scene = 0, gather_worst_face = 0, gather_strip = 0;
  float gather_min = 0;
  double gather_vs_study_clutter = 0, gather_vs_study_scene = 0;
  std::size_t gather_bytes = 0, limp_bytes = 0;
  double gather_build_s = 0, limp_build_s = 0;
};

// The DRT issue's acceptance for the clutter lightmap, met by gathering the real radiance
// (the scene's ld at the samples and the other objects' clutter_ld at their texels, one
// bounce): relL2 <= 0.15, every face's mean within 20 % of the truth, no texel below 0
// (a sum of non-negative weights times non-negative radiance), and at most half the error
// of Cb b + Cc c.
// The run-time operators must be the study's rows (1e-5), and the scene lightmap must be no
// worse than MRT + DRT's (noise allowance 0.005) with every floor strip within 20 %.
inline void expect_real_gather_meets_the_issue(const AccuracyResult& a) {
  EXPECT_LE(a.clutter_real_texels, 0.15);
  EXPECT_LE(a.worst_face_real_texels, 0.20);
  EXPECT_GE(a.min_real, 0.0f);
  EXPECT_LT(a.clutter_real_texels, 0.5 * a.clutter);
  EXPECT_LE(a.gather_vs_study_clutter, 1e-5);
  EXPECT_LE(a.gather_vs_study_scene, 1e-5);
  EXPECT_LE(a.gather_clutter, 0.15);
  EXPECT_LE(a.gather_worst_face, 0.20);
  EXPECT_GE(a.gather_min, 0.0f);
  EXPECT_LE(a.gather_scene, a.drt + 0.005);
  EXPECT_LE(std::abs(a.gather_strip), 0.20);
}

// Bytes of the scene-side operators (dUb with its sample and block indices, dUc with its
// sample indices; float32 and uint32), the rest of storage_bytes being the clutter's.
inline std::size_t scene_operator_bytes(const DrtOperators& drt) {
  std::size_t bytes = 0;
  for (const DrtObjectOperators& op : drt.objects)
    bytes += 4 * (op.dUb_sample.size() + op.dUb_block.size() + op.dUb.data.size() + op.dUc_sample.size() +
                  op.dUc.data.size());
  return bytes;
}

// The floor strip of the DRT issue: per object, the upward-facing level samples within 0.15
// of its box (mesh: its bounds), not inside clutter; the worst signed mean(value) /
// mean(truth) - 1 over the objects (largest magnitude), all three channels summed.
inline double worst_floor_strip_error(const LevelSampleGeometry& g, std::span<const ClutterObject> clutter,
                                      const std::vector<std::uint8_t>& skip, std::span<const float> value,
                                      std::span<const float> truth) {
  double worst = 0;
  for (const ClutterObject& o : clutter) {
    double v = 0, t = 0;
    for (std::size_t i = 0; i < g.position.size(); ++i) {
      if (skip[i] || g.normal[i].y < 0.9 || !clutter_contains(o.box, g.position[i], 0.15)) continue;
      for (int ch = 0; ch < 3; ++ch) {
        v += value[3 * i + std::size_t(ch)];
        t += truth[3 * i + std::size_t(ch)];
      }
    }
    if (t > 0 && std::abs(v / t - 1.0) > std::abs(worst)) worst = v / t - 1.0;
  }
  return worst;
}

// The worst |mean(value) / mean(truth) - 1| over the clutter's faces (box faces and mesh
// charts, each object's own), all three channels summed.
inline double worst_face_mean_error(std::span<const ClutterObject> clutter, std::span<const float> value,
                                    std::span<const float> truth) {
  double worst = 0;
  std::size_t base = 0;
  for (const ClutterObject& o : clutter) {
    const ClutterTexelGeometry cg = clutter_texel_geometry(o);
    std::map<int, std::pair<double, double>> sums;
    for (std::size_t t = 0; t < cg.face.size(); ++t)
      for (int ch = 0; ch < 3; ++ch) {
        sums[cg.face[t]].first += value[3 * (base + t) + std::size_t(ch)];
        sums[cg.face[t]].second += truth[3 * (base + t) + std::size_t(ch)];
      }
    for (const auto& [face, sum] : sums)
      if (sum.second > 0) worst = std::max(worst, std::abs(sum.first / sum.second - 1.0));
    base += cg.face.size();
  }
  return worst;
}

// One bounce at the level's texels and the clutter texels: MRT (lightmap Ub b + Ur r; the
// clutter shaded by probes) and MRT + DRT (+ dUb b + dUc c; clutter Cb b) against the path
// tracer on the real geometry with the clutter (same direct-light model; ld with the
// clutter's direct shadows for both). Texels inside clutter are not visible and skipped.
inline AccuracyResult accuracy(const ClutterScene& s, const char* name,
                               const DrtBuildSettings& settings = {}) {
  const Level level = build_level(s.description, dict()).value();
  const LevelScene scene(level, level.res, s.clutter);
  const std::vector<float> ld =
      level_direct_light(scene, s.description.lights, level_sample_albedo(level), 8);
  const Frame f = evaluate_mrt(level, ld);

  const auto t0 = std::chrono::steady_clock::now();
  const DrtBuilder builder(level, dict(), paper_operators(settings));
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

  const ClutterSceneTruth t = clutter_scene_truth(scene, s, 512, 1);
  const IndirectEstimate &truth = t.scene, &clutter_truth = t.clutter;
  const std::vector<std::uint8_t>& skip = t.skip;
  const std::vector<glm::dvec3>& cp = t.texels;
  const LevelSampleGeometry& g = scene.samples();
  const LevelBufferSizes sz = level_buffer_sizes(level, dict());
  std::vector<float> probes(sz.probes);
  level_compute_probes(level, dict(), f.b, f.r, probes);
  const std::vector<float> probe_lightmap = probe_shading(level, probes, s.clutter);
  DrtBuildSettings with_probes = paper_operators(settings);
  with_probes.probes = true;
  const DrtOperators drt_probes = DrtBuilder(level, dict(), with_probes).build(s.clutter).value();
  std::vector<float> aware = probes;
  drt_apply_probes(drt_probes, f.b, c, aware);
  const std::vector<float> aware_lightmap = probe_shading(level, aware, s.clutter);
  const std::vector<std::uint8_t> none(cp.size(), 0);
  DrtBuildSettings with_gather = paper_operators(settings);
  with_gather.sample_gather = true;
  DrtBuildState state;
  const DrtOperators drt_gather =
      DrtBuilder(level, dict(), with_gather).build(s.clutter, nullptr, &state).value();
  std::vector<float> clutter_real(clutter_lightmap.size());
  std::size_t gather_entries = 0, texel_base = 0;
  for (const ClutterSampleGather& gather : state.sample_gather()) {
    const std::size_t texels = gather.row_start.size() - 1;
    clutter_gather_radiance(gather, ld, std::span(clutter_real).subspan(3 * texel_base, 3 * texels));
    gather_entries += gather.sample.size();
    texel_base += texels;
  }
  EXPECT_EQ(texel_base, cp.size());
  // Clutter-to-clutter light gathered at the other objects' texels (their clutter_ld) in
  // place of Cc c (c: constant per face).
  std::vector<float> clutter_real_texels = clutter_real, from_clutter(clutter_real.size());
  texel_base = 0;
  std::size_t clutter_entries = gather_entries;
  for (const ClutterSampleGather& gather : state.sample_gather(true)) {
    clutter_entries += gather.sample.size();
    const std::size_t texels = gather.row_start.size() - 1;
    clutter_gather_radiance(gather, clutter_ld, std::span(from_clutter).subspan(3 * texel_base, 3 * texels));
    texel_base += texels;
  }
  for (std::size_t i = 0; i < from_clutter.size(); ++i) clutter_real_texels[i] += from_clutter[i];
  drt_clutter_add_cc(drt_gather, c, clutter_real);
  // The scene's side (the issue's item 2): the shadow subtracts the real radiance of the
  // hidden samples (ld) instead of Limp b, and, second, the clutter's light comes from its
  // texels (clutter_ld) instead of dUc c.
  std::vector<float> real_shadow = f.lightmap, real_both;
  std::size_t scene_entries = 0;
  {
    std::vector<float> delta(real_shadow.size()), light(real_shadow.size());
    const ClutterSampleGather hidden = state.scene_sample_gather(), entered = state.scene_sample_gather(true);
    scene_entries = hidden.sample.size() + entered.sample.size();
    clutter_gather_radiance(hidden, ld, delta);
    clutter_gather_radiance(entered, clutter_ld, light);
    DrtOperators dUc_only = drt_gather;
    for (DrtObjectOperators& op : dUc_only.objects) {
      op.dUb_sample.clear();
      op.dUb_block.clear();
      op.dUb = Matrix{};
    }
    for (std::size_t i = 0; i < delta.size(); ++i) real_shadow[i] += delta[i];
    real_both = real_shadow;
    for (std::size_t i = 0; i < light.size(); ++i) real_both[i] += light[i];
    drt_apply(level, dUc_only, f.b, c, real_shadow);
  }

  AccuracyResult a;
  a.limp_build_s = build_s;
  a.limp_bytes = drt.storage_bytes();
  {  // The run-time operators of the gather, applied by core's reference.
    DrtBuildSettings runtime = settings;
    runtime.gather = true;
    const auto tg = std::chrono::steady_clock::now();
    const DrtOperators op = DrtBuilder(level, dict(), runtime).build(s.clutter).value();
    a.gather_build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - tg).count();
    EXPECT_TRUE(check_drt_operators(level, op).ok());
    EXPECT_TRUE(op.has_gather());
    std::vector<float> c_op(drt_buffer_sizes(op).c), clutter_op(clutter_lightmap.size()),
        scene_op = f.lightmap;
    EXPECT_TRUE(drt_compute_c(op, clutter_ld, c_op).ok());
    drt_clutter_indirect(op, f.b, c_op, ld, clutter_ld, clutter_op);
    drt_apply(level, op, f.b, c_op, scene_op);
    drt_apply_gather(op, ld, clutter_ld, scene_op);
    a.gather_clutter = rel_l2(clutter_op, clutter_truth.value, none);
    a.gather_scene = rel_l2(scene_op, truth.value, skip);
    a.gather_worst_face = worst_face_mean_error(s.clutter, clutter_op, clutter_truth.value);
    a.gather_strip = worst_floor_strip_error(g, s.clutter, skip, scene_op, truth.value);
    a.gather_min = *std::min_element(clutter_op.begin(), clutter_op.end());
    a.gather_vs_study_clutter = rel_l2(clutter_op, clutter_real_texels, none);
    a.gather_vs_study_scene = rel_l2(scene_op, real_both, skip);
    a.gather_bytes = op.storage_bytes();
    std::printf(
        "%s: run-time gather operators: clutter relL2 %.4f (worst face %+.1f %%, lowest texel %.4g), scene "
        "relL2 %.4f (worst floor strip %+.1f %%); against the study's rows %.2e / %.2e; %zu bytes (Limp "
        "operators %zu), build %.3f s (Limp %.3f s; test builds, not benchmarks)\n",
        name, a.gather_clutter, 100.0 * a.gather_worst_face, double(a.gather_min), a.gather_scene,
        100.0 * a.gather_strip, a.gather_vs_study_clutter, a.gather_vs_study_scene, a.gather_bytes,
        a.limp_bytes, a.gather_build_s, a.limp_build_s);
  }
  a.drt_real_shadow = rel_l2(real_shadow, truth.value, skip);
  a.drt_real_both = rel_l2(real_both, truth.value, skip);
  a.strip_drt = worst_floor_strip_error(g, s.clutter, skip, lightmap, truth.value);
  a.strip_real_shadow = worst_floor_strip_error(g, s.clutter, skip, real_shadow, truth.value);
  a.strip_real_both = worst_floor_strip_error(g, s.clutter, skip, real_both, truth.value);
  std::printf(
      "%s: scene lightmap relL2 with the real radiance behind clutter %.4f, with the clutter's light from "
      "its "
      "texels too %.4f (MRT+DRT %.4f); worst floor strip (0.15 around an object) mean %+.1f %% / %+.1f %% "
      "(MRT+DRT %+.1f %%); %zu scene entries, %zu clutter entries; dUb and dUc %zu bytes, Cb and Cc %zu "
      "bytes\n",
      name, a.drt_real_shadow, a.drt_real_both, rel_l2(lightmap, truth.value, skip),
      100.0 * a.strip_real_shadow, 100.0 * a.strip_real_both, 100.0 * a.strip_drt, scene_entries,
      clutter_entries, scene_operator_bytes(drt), drt.storage_bytes() - scene_operator_bytes(drt));
  a.clutter_real = rel_l2(clutter_real, clutter_truth.value, none);
  a.clutter_real_texels = rel_l2(clutter_real_texels, clutter_truth.value, none);
  a.worst_face_real_texels = worst_face_mean_error(s.clutter, clutter_real_texels, clutter_truth.value);
  a.gather_entries = gather_entries;
  a.worst_face_cb = worst_face_mean_error(s.clutter, clutter_lightmap, clutter_truth.value);
  a.worst_face_real = worst_face_mean_error(s.clutter, clutter_real, clutter_truth.value);
  a.min_cb = *std::min_element(clutter_lightmap.begin(), clutter_lightmap.end());
  a.min_real = *std::min_element(clutter_real.begin(), clutter_real.end());
  std::printf(
      "%s: clutter gathering the real radiance (ld) + Cc c: relL2 %.4f (Cb b + Cc c %.4f); worst face mean "
      "%+.1f %% (Cb b + Cc c %+.1f %%); lowest texel %.4g (Cb b + Cc c %.4g, largest truth %.4g); %zu gather "
      "entries for %zu texels; clutter light gathered per texel too: relL2 %.4f, worst face mean %+.1f %%\n",
      name, a.clutter_real, rel_l2(clutter_lightmap, clutter_truth.value, none), 100.0 * a.worst_face_real,
      100.0 * a.worst_face_cb, double(a.min_real), double(a.min_cb),
      double(*std::max_element(clutter_truth.value.begin(), clutter_truth.value.end())), a.gather_entries,
      cp.size(), a.clutter_real_texels, 100.0 * a.worst_face_real_texels);
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

}  // namespace modrt::precompute::drt_test
