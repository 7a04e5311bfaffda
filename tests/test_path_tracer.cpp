// SPDX-License-Identifier: MIT
// The ground-truth path tracer against analytic references, within its own reported
// standard error (architecture.md §8).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "modrt/precompute/form_factors.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/path_tracer.h"
#include "test_support.h"

namespace modrt::precompute {
namespace {

LevelDescription single_closed_block() {
  LevelDescription d;
  BlockDescription b;
  b.faces = kAllFaces;
  for (auto& a : b.albedo) a = glm::dvec3(0.5);
  d.blocks = {b};
  return d;
}

// Closed box, uniform emitted radiance E, albedo rho, B bounces: every path hits, so
// E_ind/pi = E (1 + rho + ... + rho^(B-1)) exactly, with zero variance.
TEST(PathTracer, FurnaceMatchesTheGeometricSeries) {
  const LevelDescription d = single_closed_block();
  const Level level = build_level(d, test::small_test_dictionary()).value();
  const LevelScene scene(level, level.res);
  const double E = 0.5, rho = 0.5;
  const DirectRadiance direct = [&](const LevelHit&, const glm::dvec3&, const glm::dvec3&) {
    return glm::dvec3(E);
  };
  const SurfaceAlbedo albedo = [&](const LevelHit&) { return glm::dvec3(rho); };
  PathTracerSettings settings;
  settings.paths = 64;
  settings.bounces = 12;
  const IndirectEstimate est =
      trace_indirect(scene, scene.samples().position, scene.samples().normal, direct, albedo, settings);
  const double expected = E * (1.0 - std::pow(rho, settings.bounces)) / (1.0 - rho);
  for (std::size_t i = 0; i < est.value.size(); ++i) {
    ASSERT_NEAR(est.value[i], expected, 1e-5 * expected) << "sample " << i / 3;
    ASSERT_LE(est.standard_error[i], 1e-5 * expected);
  }
  // And the infinite-bounce limit E / (1 - rho) that the runtime's furnace test uses.
  EXPECT_NEAR(expected / (E / (1.0 - rho)), 1.0, 1e-3);
}

// One bounce from a single emitting face: the floor average is the unit-square form
// factor, within 4 standard errors of the estimate.
TEST(PathTracer, OneBounceMatchesUnitSquareFormFactorsWithinItsStandardError) {
  const LevelDescription d = single_closed_block();
  const Level level = build_level(d, test::small_test_dictionary()).value();
  const LevelScene scene(level, level.res);
  std::vector<glm::dvec3> points, normals;
  const int m = 32;
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) {
      points.push_back(face_point(kFaceNegY, (i + 0.5) / m, (j + 0.5) / m));
      normals.push_back(face_frame(kFaceNegY).normal);
    }
  const SurfaceAlbedo albedo = [](const LevelHit&) { return glm::dvec3(0.5); };
  PathTracerSettings settings;
  settings.paths = 256;
  settings.bounces = 1;
  for (const auto& [emitter, analytic] :
       {std::pair{int(kFacePosY), parallel_rectangles_form_factor(1, 1, 1)},
        std::pair{int(kFaceNegX), perpendicular_rectangles_form_factor(1, 1, 1)}}) {
    const DirectRadiance direct = [emitter = emitter](const LevelHit& hit, const glm::dvec3&,
                                                      const glm::dvec3&) {
      return glm::dvec3(hit.face == emitter ? 1.0 : 0.0);
    };
    const IndirectEstimate est = trace_indirect(scene, points, normals, direct, albedo, settings);
    double mean = 0.0, se2 = 0.0;
    for (std::size_t p = 0; p < points.size(); ++p) {
      mean += est.value[3 * p];
      se2 += double(est.standard_error[3 * p]) * est.standard_error[3 * p];
    }
    mean /= double(points.size());
    const double se = std::sqrt(se2) / double(points.size());
    std::printf("floor -> %s: path traced %.5f +- %.5f (1 s.e.), analytic %.5f\n", face_name(emitter), mean,
                se, analytic);
    EXPECT_GT(se, 0.0);
    EXPECT_LE(std::abs(mean - analytic), 4.0 * se + 1e-4);
  }
}

// The standard error is honest: it is computed as for independent paths, while the first
// direction is stratified, so it bounds the seed-to-seed spread from above without being
// loose by more than a small factor (measured: spread / reported = 0.47).
TEST(PathTracer, ReportedStandardErrorIsAConservativeBound) {
  const LevelDescription d = single_closed_block();
  const Level level = build_level(d, test::small_test_dictionary()).value();
  const LevelScene scene(level, level.res);
  const std::vector<glm::dvec3> point = {face_point(kFaceNegY, 0.3, 0.6)},
                                normal = {face_frame(kFaceNegY).normal};
  const DirectRadiance direct = [](const LevelHit& hit, const glm::dvec3&, const glm::dvec3&) {
    return glm::dvec3(hit.face == kFacePosY || hit.face == kFaceNegX ? 1.0 : 0.0);
  };
  const SurfaceAlbedo albedo = [](const LevelHit&) { return glm::dvec3(0.6); };
  PathTracerSettings settings;
  settings.paths = 64;
  settings.bounces = 3;
  std::vector<double> values;
  double reported = 0.0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    settings.seed = seed * 7919;
    const IndirectEstimate est = trace_indirect(scene, point, normal, direct, albedo, settings);
    values.push_back(est.value[0]);
    reported += est.standard_error[0] / 40.0;
  }
  double mean = 0.0, var = 0.0;
  for (double v : values) mean += v / double(values.size());
  for (double v : values) var += (v - mean) * (v - mean) / double(values.size() - 1);
  std::printf("seed-to-seed spread %.5f, mean reported standard error %.5f\n", std::sqrt(var), reported);
  EXPECT_GT(std::sqrt(var) / reported, 0.2);
  EXPECT_LT(std::sqrt(var) / reported, 1.2);
}

// Light-vertex sampling (MIS with the cosine paths) for a light close to a wall: the
// estimate agrees with a cosine-only estimate of 16x the paths within their combined
// standard errors (unbiased, also with 3 bounces), and its noise floor is far lower at
// equal ray count.
TEST(PathTracer, LightVertexSamplingIsUnbiasedAndCutsTheNoiseOfANearWallLight) {
  LevelDescription d = single_closed_block();
  LightDescription light;
  light.position = glm::dvec3(0.5, 0.93, 0.4);  // 0.07 below the ceiling
  light.radius = 0.02;
  light.intensity = 1.0;
  light.color = glm::dvec3(1.0);
  d.lights = {light};
  const Level level = build_level(d, test::small_test_dictionary()).value();
  const LevelScene scene(level, level.res);
  const LevelSampleGeometry& g = scene.samples();
  const DirectRadiance direct = level_direct_radiance(scene, d, 4);
  const SurfaceAlbedo albedo = level_surface_albedo(scene, d);
  auto noise_floor = [](const IndirectEstimate& e) {
    double se2 = 0, v2 = 0;
    for (std::size_t i = 0; i < e.value.size(); ++i) {
      se2 += double(e.standard_error[i]) * e.standard_error[i];
      v2 += double(e.value[i]) * e.value[i];
    }
    return std::sqrt(se2 / v2);
  };
  for (int bounces : {1, 3}) {
    PathTracerSettings cosine;
    cosine.bounces = bounces;
    cosine.paths = 64;
    const IndirectEstimate plain = trace_indirect(scene, g.position, g.normal, direct, albedo, cosine);
    cosine.paths = 1024;
    cosine.seed = 99;
    const IndirectEstimate reference = trace_indirect(scene, g.position, g.normal, direct, albedo, cosine);
    PathTracerSettings mis;
    mis.bounces = bounces;
    mis.paths = 32;  // a light-vertex sample per path vertex: about the rays of 64 paths
    mis.light_vertex_sources = level_light_centres(d);
    const IndirectEstimate est = trace_indirect(scene, g.position, g.normal, direct, albedo, mis);
    // Mean squared z-score over all texels: ~1 when both estimates are unbiased and their
    // standard errors honest (< 1 as they are conservative); a bias shows as >> 1.
    double z2 = 0.0;
    for (std::size_t i = 0; i < est.value.size(); i += 3) {
      const double se2 = double(est.standard_error[i]) * est.standard_error[i] +
                         double(reference.standard_error[i]) * reference.standard_error[i];
      const double diff = double(est.value[i]) - reference.value[i];
      z2 += diff * diff / std::max(se2, 1e-30) / double(est.value.size() / 3);
    }
    std::printf(
        "%d bounce(s): mean z^2 %.3f; noise floor cosine-only %.4f (64 paths), MIS %.4f (32 with light "
        "vertices), "
        "reference %.4f (1024)\n",
        bounces, z2, noise_floor(plain), noise_floor(est), noise_floor(reference));
    EXPECT_LT(z2, 1.6);
    EXPECT_GT(z2, 0.05);
    EXPECT_LT(noise_floor(est), 0.5 * noise_floor(plain));
  }
}

}  // namespace
}  // namespace modrt::precompute
