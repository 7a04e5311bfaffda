// SPDX-License-Identifier: MIT
// The offscreen demo (demo/): proxy mapping (MRT §7.2) lands real geometry on its own proxy
// face; the GLES ld pass (shadow cube map over geometry images) matches ray-traced direct
// light; the CPU and GLES backends render the same image; and the default scene's first
// frame under OSMesa matches the stored golden image (metric below). Uses the small test
// dictionary, so frames render in well under a second each.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/matrix.hpp>

#include "compare_support.h"
#include "delta_e.h"
#include "demo_run.h"
#include "gl_test_context.h"
#include "image_output.h"
#include "modrt/drt_io.h"
#include "modrt/level_geometry.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/probe_sampler.h"
#include "scene/clutter_shapes.h"
#include "scene/default_scene.h"
#include "scene/proxy_mapping.h"
#include "test_support.h"

namespace modrt::demo {
namespace {

const Dictionary& dict() { return test::small_test_dictionary(); }

// modrt-demo's defaults, with the DRT operators kept in the test cache: built once for all
// tests that light the same clutter with the same settings (load_or_build_drt).
DemoRunOptions run_options() {
  DemoRunOptions options;
  options.drt_cache_dir = MODRT_TEST_CACHE_DIR "/drt";
  return options;
}

const DemoScene& scene() {
  static const DemoScene s = [] {
    Result<DemoScene> r = default_scene();
    if (!r.ok()) {
      std::fprintf(stderr, "default scene: %s\n", r.status().to_string().c_str());
      std::abort();
    }
    return std::move(r).value();
  }();
  return s;
}

// The default scene with only the walls (plain and normal-mapped), the geometry that the
// ray-traced reference knows.
DemoScene walls_only() {
  DemoScene s = scene();
  std::erase_if(s.meshes, [&](const Mesh& m) {
    const std::string& material = s.materials[std::size_t(m.material)].name;
    return !(material.rfind("wall", 0) == 0 || material == "brick wall" || material == "tiled floor");
  });
  s.clutter.clear();  // its meshes are gone with the other detail geometry
  return s;
}

// The default scene's maze unwarped, its walls as the only meshes, the same light and camera:
// what a ray-traced reference with planar proxies sees exactly.
DemoScene unwarped_walls() {
  DemoScene walls;
  walls.level = scene().level;
  for (BlockDescription& b : walls.level.blocks) b.warped = false;
  add_wall_meshes(walls, 4);
  walls.lights = scene().lights;
  walls.camera = scene().camera;
  return walls;
}

// The program's OSMesa context (gl_test_context.h), or null with the reason printed.
platform::GlContext* osmesa() {
  test::GlContextSlot& slot = test::gl_context_for(platform::ContextRequest::osmesa);
  if (!slot.context) std::printf("  no OSMesa context: %s\n", slot.status.to_string().c_str());
  return slot.context.get();
}

TEST(ProxyMapping, WorldToBlockInvertsTheWarp) {
  Result<Level> level = precompute::build_level(scene().level, dict());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0.0;
  int warped = 0;
  for (const LevelBlock& b : level->blocks) {
    warped += b.corners[7] - b.corners[0] != glm::dvec3(1.0);
    for (int i = 0; i < 50; ++i) {
      const glm::dvec3 p(u(rng), u(rng), u(rng));
      worst = std::max(worst, glm::length(world_to_block(b, block_to_world(b, p)) - p));
    }
  }
  EXPECT_GT(warped, 0);  // the default scene's blocks are warped, so Newton has work to do
  EXPECT_LT(worst, 1e-9);
}

// Every wall triangle's lightmap coordinates lead back, through the tile they fall in, to
// the wall itself: tile -> (block, face, u, v) -> block_to_world lands on the triangle. A
// wrong block (a wall shared by two blocks) or a wrong face would land a cell away.
TEST(ProxyMapping, WallsLandOnTheirOwnFaceTiles) {
  const DemoScene walls = walls_only();
  Result<Level> level = precompute::build_level(walls.level, dict());
  ASSERT_TRUE(level.ok());
  Result<std::vector<MappedMesh>> mapped = map_to_proxies(walls, level.value());
  ASSERT_TRUE(mapped.ok()) << mapped.status().to_string();
  const LightmapAtlas& atlas = level->atlas;
  const double res = level->res;
  double worst = 0.0;
  std::size_t triangles = 0;
  for (const MappedMesh& m : mapped.value()) {
    EXPECT_EQ(m.triangles_outside, 0);
    for (std::size_t t = 0; t + 2 < m.vertices.size(); t += 3) {
      glm::dvec3 centroid(0.0);
      glm::dvec2 lm(0.0);
      for (int k = 0; k < 3; ++k) {
        centroid += glm::dvec3(m.vertices[t + std::size_t(k)].position) / 3.0;
        lm += glm::dvec2(m.vertices[t + std::size_t(k)].lightmap) / 3.0;
      }
      bool found = false;
      for (std::size_t bi = 0; bi < level->blocks.size() && !found; ++bi)
        for (int f = 0; f < kFaceCount && !found; ++f) {
          const double ox = atlas.tile_origin_x[bi][std::size_t(f)] + 1,
                       oy = atlas.tile_origin_y[bi][std::size_t(f)] + 1;
          if (ox < 1 || lm.x < ox || lm.x > ox + res || lm.y < oy || lm.y > oy + res) continue;
          found = true;
          const glm::dvec3 p = face_point(f, (lm.x - ox) / res, (lm.y - oy) / res);
          const double dist = glm::length(block_to_world(level->blocks[bi], p) - centroid);
          worst = std::max(worst, dist);
        }
      EXPECT_TRUE(found) << "triangle " << t / 3 << " of mesh " << m.mesh;
      ++triangles;
    }
  }
  EXPECT_GT(triangles, 500u);
  // Normal-mapped walls sit 1 mm in front of the proxy; bilinear warps bend a little more.
  EXPECT_LT(worst, 5e-3);
  std::printf("  %zu wall triangles, worst round trip %.2e\n", triangles, worst);
}

// ld from the GLES pass (cube shadow map, geometry images) against precompute's Embree
// direct light (point light, one visibility ray) on the same walls: relative L2 <= 3 %, the
// shadow map's texel-sized penumbra at shadow edges being the difference. Unwarped blocks:
// on a warped (non-planar) face the reference's shadow rays start at the bilinear surface,
// which its triangle tessellation can pass in front of, and would shadow the sample itself.
TEST(DemoRender, LdPassMatchesRayTracedDirectLight) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  const DemoScene walls = unwarped_walls();
  DemoRunOptions options = run_options();
  options.renderer.width = 64, options.renderer.height = 36;
  Result<std::unique_ptr<DemoRun>> run = DemoRun::create(walls, dict(), *ctx, options);
  ASSERT_TRUE(run.ok()) << run.status().to_string();
  std::vector<float> linear(3 * 64 * 36);
  std::vector<std::uint8_t> srgb(linear.size());
  for (int frame : {0, 30, 60}) {
    ASSERT_TRUE(run.value()->render(frame, linear, srgb).ok());
    const Level& level = run.value()->level();
    const DemoLight& light = walls.lights.front();
    LightDescription l;
    l.position = glm::dvec3(path_point(light.path, double(frame) / light.period));
    l.radius = light.radius;
    l.color = glm::dvec3(light.color);
    l.intensity = light.intensity;
    const precompute::LevelScene rt(level, level.res);
    const std::vector<float> ref =
        precompute::level_direct_light(rt, std::span(&l, 1), level_sample_albedo(level), 1);
    const std::span<const float> ld = run.value()->ld();
    double num = 0, den = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      num += (double(ld[i]) - ref[i]) * (double(ld[i]) - ref[i]);
      den += double(ref[i]) * ref[i];
    }
    const double rel = std::sqrt(num / den);
    double sum_ld = 0, sum_ref = 0;
    std::size_t only_ld = 0, only_ref = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      sum_ld += ld[i], sum_ref += ref[i];
      only_ld += ld[i] > 0 && ref[i] == 0;
      only_ref += ref[i] > 0 && ld[i] == 0;
    }
    std::printf("  sums %g %g, lit only on GPU %zu, only in reference %zu of %zu\n", sum_ld, sum_ref, only_ld,
                only_ref, ref.size());
    EXPECT_LT(rel, 0.03) << "frame " << frame;
    std::printf("  frame %d: GLES ld vs ray-traced rel L2 %.4f\n", frame, rel);
  }
}

// A spot light is the point light at the same place times its cone: samples inside the
// inner cone get the point light's ld exactly, samples beyond the outer cone nothing, and
// the ones between something in between.
TEST(DemoRender, SpotLightIsThePointLightTimesItsCone) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  DemoScene point = walls_only();
  DemoLight& l = point.lights.front();
  l.path = {l.path.front()};  // held still
  DemoScene spot = point;
  DemoLight& s = spot.lights.front();
  s.direction = glm::vec3(0.3f, -1.0f, 0.1f);
  s.inner_cone = 0.5f;
  s.outer_cone = 0.75f;
  std::vector<std::vector<float>> ld;
  std::vector<float> linear(3 * 32 * 18);
  std::vector<std::uint8_t> srgb(linear.size());
  for (const DemoScene* sc : {&point, &spot}) {
    DemoRunOptions options = run_options();
    options.renderer.width = 32, options.renderer.height = 18;
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(*sc, dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    ASSERT_TRUE(run.value()->render(0, linear, srgb).ok());
    ld.emplace_back(run.value()->ld().begin(), run.value()->ld().end());
  }
  Result<Level> level = precompute::build_level(point.level, dict());
  ASSERT_TRUE(level.ok());
  const LevelSampleGeometry g = level_sample_geometry(level.value());
  const glm::dvec3 axis = glm::normalize(glm::dvec3(s.direction));
  std::size_t inside = 0, outside = 0, between = 0;
  for (std::size_t i = 0; i < g.position.size(); ++i) {
    const double angle = std::acos(
        std::clamp(glm::dot(glm::normalize(g.position[i] - glm::dvec3(s.path[0])), axis), -1.0, 1.0));
    for (std::size_t c = 0; c < 3; ++c) {
      const float p = ld[0][3 * i + c], q = ld[1][3 * i + c];
      if (angle < s.inner_cone - 1e-3) {
        EXPECT_NEAR(q, p, 1e-5f * p + 1e-9f) << "sample " << i;
        inside += c == 0 && p > 0;
      } else if (angle > s.outer_cone + 1e-3) {
        EXPECT_EQ(q, 0.0f) << "sample " << i;
        outside += c == 0 && p > 0;
      } else {
        EXPECT_LE(q, p * (1 + 1e-5f) + 1e-9f) << "sample " << i;
        between += c == 0 && q > 0 && q < p;
      }
    }
  }
  EXPECT_GT(inside, 10u);
  EXPECT_GT(outside, 100u);
  EXPECT_GT(between, 5u);
  std::printf(
      "  lit samples inside the inner cone %zu, in the fade %zu, lit by the point light beyond the cone "
      "%zu\n",
      inside, between, outside);
}

// The two sources of ld agree where they see the same occluders (walls only): the GL pass
// with its shadow cube map and the CPU evaluator with exact proxy-wall shadows, 3 % relative
// L2 as the ray-traced reference above.
TEST(DemoRender, CpuDirectLightMatchesTheLdPass) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  const DemoScene walls = unwarped_walls();
  std::vector<std::vector<float>> ld;
  std::vector<float> linear(3 * 32 * 18);
  std::vector<std::uint8_t> srgb(linear.size());
  for (DemoDirect direct : {DemoDirect::gpu, DemoDirect::cpu}) {
    DemoRunOptions options = run_options();
    options.direct = direct;
    options.renderer.width = 32, options.renderer.height = 18;
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(walls, dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    ASSERT_TRUE(run.value()->render(30, linear, srgb).ok());
    ld.emplace_back(run.value()->ld().begin(), run.value()->ld().end());
  }
  double num = 0, den = 0;
  for (std::size_t i = 0; i < ld[0].size(); ++i) {
    num += (double(ld[0][i]) - ld[1][i]) * (double(ld[0][i]) - ld[1][i]);
    den += double(ld[1][i]) * ld[1][i];
  }
  EXPECT_LT(std::sqrt(num / den), 0.03);
  std::printf("  GL ld pass vs CpuDirectLight: rel L2 %.4f\n", std::sqrt(num / den));
}

// A directional light (the sun) through a row of three blocks open to the outside at -X: the
// GL ld pass with its orthographic shadow map (in the cube's +X face) and the CPU evaluator
// with exact proxy-wall shadows agree but at the shadow's edges; the sun lights the floor and
// far walls and the walls shadow the rest.
TEST(DemoRender, SunThroughAnOpeningMatchesTheCpuEvaluator) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  DemoScene row;
  row.name = "sun row";
  for (int x = 0; x < 3; ++x) {
    BlockDescription& b = row.level.blocks.emplace_back();
    b.cell = {x, 0, 0};
    b.faces = kAllFaces;
    b.faces &= FaceMask(~(1u << kFaceNegX));  // open to the previous block (block 0: to outside)
    if (x < 2) b.faces &= FaceMask(~(1u << kFacePosX));
    b.albedo.fill(glm::dvec3(0.6));
  }
  add_wall_meshes(row, 4);
  DemoLight sun;
  sun.directional = true;
  sun.direction = glm::normalize(glm::vec3(1.0f, -0.6f, 0.25f));
  sun.intensity = 2.0f;
  sun.path = {glm::vec3(1.5f, 0.5f, 0.5f)};
  row.lights = {sun};
  row.camera.position = glm::vec3(2.6f, 0.5f, 0.5f);
  row.camera.target = glm::vec3(0.5f, 0.4f, 0.5f);
  std::vector<std::vector<float>> ld;
  std::vector<float> linear(3 * 32 * 18);
  std::vector<std::uint8_t> srgb(linear.size());
  for (DemoDirect direct : {DemoDirect::gpu, DemoDirect::cpu}) {
    DemoRunOptions options = run_options();
    options.direct = direct;
    options.renderer.width = 32, options.renderer.height = 18;
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(row, dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    ASSERT_TRUE(run.value()->render(0, linear, srgb).ok());
    ld.emplace_back(run.value()->ld().begin(), run.value()->ld().end());
  }
  const double peak = *std::max_element(ld[1].begin(), ld[1].end());
  ASSERT_GT(peak, 0.0) << "the sun lights nothing";
  const double e = test::rel_l2(ld[0], ld[1]);
  // Samples the sun reaches and samples in shadow, counted on the CPU side (a wall facing the
  // sun but behind the opening's edge is dark).
  std::size_t lit = 0, dark = 0;
  for (std::size_t i = 0; i < ld[1].size(); i += 3) (ld[1][i] > 0.05 * peak ? lit : dark) += 1;
  EXPECT_GT(lit, ld[1].size() / 30) << "too few samples lit";
  EXPECT_GT(dark, ld[1].size() / 30) << "too few samples in shadow";
  // The two disagree only at the shadow's edges, where the GL pass's point (moved along its
  // normal against acne, read from a map texel) and the CPU's exact ray fall on either side:
  // at most 1 % of the samples (a map read the wrong way round flips hundreds), and 5 % rel L2
  // (a parallel edge crosses a row of samples at once, where a point light's spreads).
  std::size_t flipped = 0;
  for (std::size_t i = 0; i < ld[1].size(); i += 3) flipped += std::abs(ld[0][i] - ld[1][i]) > 0.1 * peak;
  EXPECT_LE(flipped, ld[1].size() / 3 / 100);
  EXPECT_LT(e, 0.05);
  std::printf("  sun: GL ld pass vs CpuDirectLight: rel L2 %.4f, %zu samples lit, %zu dark, %zu flipped\n", e,
              lit, dark, flipped);
}

using test::delta_e;
using test::DeltaE;

constexpr int kGoldenWidth = 320, kGoldenHeight = 180;

TEST(DemoRender, CpuAndGlesBackendsRenderTheSameImage) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  std::vector<std::vector<std::uint8_t>> images;
  std::vector<std::vector<float>> linear;
  for (DemoBackend backend : {DemoBackend::gles, DemoBackend::cpu}) {
    DemoRunOptions options = run_options();
    options.backend = backend;
    options.bounces = 2;  // the same feedback steps on both (their converged solves stop at other iterates)
    options.renderer.width = kGoldenWidth, options.renderer.height = kGoldenHeight;
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(scene(), dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    linear.emplace_back(3 * kGoldenWidth * kGoldenHeight);
    images.emplace_back(linear.back().size());
    for (int frame = 0; frame < 3; ++frame)
      ASSERT_TRUE(run.value()->render(frame, linear.back(), images.back()).ok());
  }
  double num = 0, den = 0;
  for (std::size_t i = 0; i < linear[0].size(); ++i) {
    num += (double(linear[0][i]) - linear[1][i]) * (double(linear[0][i]) - linear[1][i]);
    den += double(linear[1][i]) * linear[1][i];
  }
  const DeltaE e = delta_e(images[0], images[1]);
  // Both backends agree with the scalar reference to ~1e-7 (test_gles_backend); what is left
  // is float summation order through the multi-bounce feedback.
  EXPECT_LT(std::sqrt(num / den), 1e-4);
  EXPECT_LT(e.p99, 0.5);
  std::printf("  GLES vs CPU backend image: linear rel L2 %.2e, Delta E mean %.3f, p99 %.3f\n",
              std::sqrt(num / den), e.mean, e.p99);
}

// The default multi-bounce is the converged one on both backends, on the walls alone and on the
// built-in scene with its clutter (GLES: its solve fed by the GPU's ld texture; the clutter's
// operators gather the real radiance, so the level is solved without them and
// kGatherConvergedSteps feedback steps with them follow): with the light held still, frame 7's
// indirect light is frame 0's within 1 % (the check; before, frame 0 ran 6 feedback steps
// and the others 2). Two explicit feedback steps per frame are measurably darker than the
// converged solve, so the comparison can fail.
TEST(DemoRender, FramesAfterTheFirstAreAsBrightAsTheFirst) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  for (const DemoBackend backend : {DemoBackend::cpu, DemoBackend::gles})
    for (const bool clutter : {false, true}) {
      DemoScene still = clutter ? scene() : walls_only();  // scene(): the built-in one, its clutter pillar
      for (DemoLight& l : still.lights) l.path.resize(1);  // a single key holds the light still
      const auto mean_indirect = [&](int bounces, int frame, bool* converged) {
        DemoRunOptions options = run_options();
        options.backend = backend;
        options.output = OutputMode::indirect;
        options.bounces = bounces;
        options.renderer.width = kGoldenWidth, options.renderer.height = kGoldenHeight;
        Result<std::unique_ptr<DemoRun>> run = DemoRun::create(still, dict(), *ctx, options);
        EXPECT_TRUE(run.ok()) << run.status().to_string();
        if (!run.ok()) return 0.0;
        if (converged) *converged = run.value()->converged();
        std::vector<float> linear(3 * kGoldenWidth * kGoldenHeight);
        std::vector<std::uint8_t> srgb(linear.size());
        double sum = 0.0;
        for (int f = 0; f <= frame; ++f) EXPECT_TRUE(run.value()->render(f, linear, srgb).ok());
        for (float v : linear) sum += v;
        return sum / double(linear.size());
      };
      bool converged = false;
      const double first = mean_indirect(kDemoConverged, 0, &converged);
      const double seventh = mean_indirect(kDemoConverged, 7, nullptr);
      const bool gles = backend == DemoBackend::gles;
      std::printf("  %s, %s: mean indirect: %s frame 0 %.5f, frame 7 %.5f\n", gles ? "gles" : "cpu",
                  clutter ? "with clutter" : "walls", converged ? "converged" : "4 feedback steps", first,
                  seventh);
      EXPECT_TRUE(converged);
      ASSERT_GT(first, 0.0);
      EXPECT_NEAR(seventh / first, 1.0, 0.01);
      if (converged) {
        const double two_steps = mean_indirect(2, 7, nullptr);
        std::printf("    2 feedback steps frame 7 %.5f\n", two_steps);
        EXPECT_LT(two_steps / first, 0.99);
      }
    }
}

// The camera skip (on by default) writes only the tiles of the blocks the camera can see; the
// rendered image is the same as without it, bit for bit, on both backends over frames in which
// the light moves (a block the walk missed would show stale light), and the default scene's
// camera does hide blocks (else the comparison would prove nothing).
TEST(DemoRender, CameraSkipRendersTheSameImage) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  for (DemoBackend backend : {DemoBackend::cpu, DemoBackend::gles}) {
    std::vector<std::vector<float>> linear;
    std::size_t visible = 0, blocks = 0;
    std::uint64_t hidden = 0;
    for (bool skip : {true, false}) {
      DemoRunOptions options = run_options();
      options.backend = backend;
      options.camera_skip = skip;
      options.renderer.width = kGoldenWidth, options.renderer.height = kGoldenHeight;
      Result<std::unique_ptr<DemoRun>> run = DemoRun::create(scene(), dict(), *ctx, options);
      ASSERT_TRUE(run.ok()) << run.status().to_string();
      linear.emplace_back(3 * kGoldenWidth * kGoldenHeight);
      std::vector<std::uint8_t> srgb(linear.back().size());
      for (int frame = 0; frame < 4; ++frame)
        ASSERT_TRUE(run.value()->render(frame * 7, linear.back(), srgb).ok());
      if (skip) {
        visible = run.value()->visible_blocks(), blocks = run.value()->level().blocks.size();
        hidden = run.value()->backend().evaluation_stats().tiles_hidden;
      }
    }
    std::printf("  %s: %zu of %zu blocks visible, %llu tiles hidden over 4 frames\n",
                backend == DemoBackend::cpu ? "cpu" : "gles", visible, blocks, (unsigned long long)hidden);
    EXPECT_LT(visible, blocks);
    EXPECT_GT(hidden, 0u);
    EXPECT_EQ(linear[0], linear[1]) << "the image with the camera skip differs";
  }
}

// --save-clutter on a scene without clutter is an error naming the file, not a silent no-op.
TEST(DemoRender, SaveClutterWithoutClutterIsAnError) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  DemoRunOptions options = run_options();
  options.renderer.width = 32, options.renderer.height = 18;
  options.save_clutter = (std::filesystem::path(MODRT_TEST_CACHE_DIR) / "no_clutter.modrtdrt").string();
  Result<std::unique_ptr<DemoRun>> run = DemoRun::create(unwarped_walls(), dict(), *ctx, options);
  ASSERT_FALSE(run.ok());
  EXPECT_NE(run.status().message().find("no_clutter.modrtdrt: the scene has no clutter objects"),
            std::string::npos)
      << run.status().message();
}

// The default scene (its clutter pillar) plus a clutter box (a mesh with lightmap UVs) in
// block 0, `shift` along x from its place.
DemoScene scene_with_clutter_box(double shift = 0.0) {
  DemoScene s = scene();
  const std::array<glm::dvec3, 8> c0 = block_corners(s.level, s.level.blocks[0]);
  const glm::dvec3 centre = trilinear(c0, glm::dvec3(0.5));
  ClutterPrism box;
  box.name = "test clutter box";
  s.materials.push_back(Material{"clutter", glm::vec3(0.7f, 0.4f, 0.3f)});
  box.material = int(s.materials.size()) - 1;
  const double x = centre.x + 0.15 + shift, z = centre.z + 0.15;
  box.polygon = {{x, z}, {x + 0.15, z}, {x + 0.15, z + 0.15}, {x, z + 0.15}};
  box.cap_triangles = {0, 1, 2, 0, 2, 3};
  box.y0 = centre.y - 0.3, box.y1 = centre.y;
  box.res = 24;
  if (Status st = add_clutter_prism(s, box); !st.ok()) {
    std::fprintf(stderr, "clutter box: %s\n", st.to_string().c_str());
    std::abort();
  }
  return s;
}

// DRT in the demo: scene_with_clutter_box().
// Both backends build the same operators (same seeds) and must give the same clutter
// lightmap and image; the clutter lightmap must carry light (an unlit or unread lightmap
// would leave the box black in the indirect image).
TEST(DemoRender, ClutterLightmapAgreesAcrossBackends) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  const DemoScene s = scene_with_clutter_box();
  std::vector<std::vector<std::uint8_t>> images;
  std::vector<std::vector<float>> linear, clutter;
  for (DemoBackend backend : {DemoBackend::gles, DemoBackend::cpu}) {
    DemoRunOptions options = run_options();
    options.backend = backend;
    options.bounces = 2;  // the same feedback steps on both (their converged solves stop at other iterates)
    options.drt_rays = 128;
    options.renderer.width = kGoldenWidth, options.renderer.height = kGoldenHeight;
    // --save-clutter: the operators built here, written for an app (core's drt_io.h).
    const std::string saved =
        (std::filesystem::path(MODRT_TEST_CACHE_DIR) / "demo_clutter.modrtdrt").string();
    if (backend == DemoBackend::gles) options.save_clutter = saved;
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(s, dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    EXPECT_EQ(run.value()->drt_startup().objects, s.clutter.size());
    if (backend == DemoBackend::gles) {
      Result<DrtOperators> loaded = load_drt(saved);
      ASSERT_TRUE(loaded.ok()) << loaded.status().to_string();
      EXPECT_EQ(loaded->objects.size(), s.clutter.size());
      EXPECT_TRUE(check_drt_operators(run.value()->level(), loaded.value()).ok());
    }
    linear.emplace_back(3 * kGoldenWidth * kGoldenHeight);
    images.emplace_back(linear.back().size());
    for (int frame = 0; frame < 3; ++frame) {
      const Status st = run.value()->render(frame, linear.back(), images.back());
      ASSERT_TRUE(st.ok()) << st.to_string();
    }
    clutter.emplace_back(run.value()->clutter_lightmap().begin(), run.value()->clutter_lightmap().end());
    std::size_t texels = 0;
    for (const ClutterObject& o : s.clutter) texels += std::size_t(clutter_texel_count(o));
    ASSERT_EQ(clutter.back().size(), 3 * texels);
    // The direct light reaches part of the box (the light starts beside block 0's centre).
    EXPECT_GT(*std::max_element(run.value()->clutter_ld().begin(), run.value()->clutter_ld().end()), 0.0f);
  }
  using test::rel_l2;
  // Finite; slightly negative values are the SVD truncation of Cb (the renderer clamps them).
  double sum = 0.0;
  for (float v : clutter[1]) {
    ASSERT_TRUE(std::isfinite(v));
    sum += v;
  }
  EXPECT_GT(sum / double(clutter[1].size()), 1e-3);  // E/pi of the indirect light, not black
  EXPECT_LT(rel_l2(clutter[0], clutter[1]), 1e-4);
  EXPECT_LT(rel_l2(linear[0], linear[1]), 1e-4);
  const DeltaE e = delta_e(images[0], images[1]);
  EXPECT_LT(e.p99, 0.5);
  std::printf("  with clutter, GLES vs CPU: clutter lightmap rel L2 %.2e, image %.2e, Delta E p99 %.3f\n",
              rel_l2(clutter[0], clutter[1]), rel_l2(linear[0], linear[1]), e.p99);
}

// Across starts (DrtStartup, precompute's drt_cache.h): the first start builds the operators
// into the cache, a start after the clutter box moved re-traces the box alone from the scene's
// build state, and the next start loads what that one saved.
TEST(DemoRender, MovedClutterIsRebuiltAloneOnTheNextStart) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  const std::filesystem::path cache =
      std::filesystem::path(MODRT_TEST_CACHE_DIR) / ("drt-moved-" + std::to_string(long(::getpid())));
  std::filesystem::remove_all(cache);
  DemoRunOptions options = run_options();
  options.drt_cache_dir = cache.string();
  options.drt_rays = 32;
  options.renderer.width = 32, options.renderer.height = 18;
  const DemoScene before = scene_with_clutter_box(), after = scene_with_clutter_box(0.05);
  const std::size_t box = before.clutter.size() - 1;
  ASSERT_GE(before.clutter.size(), 2u);
  using precompute::DrtCacheSource;
  for (const auto& [scene, source, retraced] :
       {std::tuple<const DemoScene*, DrtCacheSource, std::vector<std::size_t>>{
            &before, DrtCacheSource::built, {}},
        {&after, DrtCacheSource::incremental, {box}},
        {&after, DrtCacheSource::loaded, {}}}) {
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(*scene, dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    const DrtStartup& d = run.value()->drt_startup();
    EXPECT_EQ(d.source, source) << precompute::drt_cache_source_name(d.source) << "; " << d.state_unused;
    EXPECT_EQ(d.retraced, retraced);
    EXPECT_EQ(d.objects, scene->clutter.size());
    EXPECT_EQ(d.cache_file.rfind(cache.string(), 0), 0u) << d.cache_file;
  }
  std::filesystem::remove_all(cache);
}

// The dynamic mesh's indirect light is the probe volume where the mesh is, sampled in the
// scene shader from the backend's world-frame probe texture (GLES) or the uploaded CPU probes:
// a white quad facing the camera in a quarter-turned block (the SH rotation matters) shows,
// in the indirect output, E/pi of ProbeSampler::sample (core, double) at its position and
// normal. A wrong cell, weight, block offset, band scale or rotation moves it by far more
// than float rounding.
TEST(DemoRender, DynamicMeshShowsTheProbeVolumeAtItsPosition) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  DemoScene s = scene();
  Result<Level> level = precompute::build_level(s.level, dict());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  const auto turned = std::find_if(level->blocks.begin(), level->blocks.end(),
                                   [](const LevelBlock& b) { return b.quarter_turns != 0; });
  ASSERT_NE(turned, level->blocks.end()) << "the default scene's symmetry finds no quarter-turned block";
  // Off the block's centre in every axis, so that the trilinear weights are all fractional.
  const glm::dvec3 at = block_to_world(*turned, glm::dvec3(0.43, 0.56, 0.38));
  const glm::vec3 n = glm::normalize(glm::vec3(0.3f, 0.25f, 0.9f));
  std::erase_if(s.meshes, [](const Mesh& m) { return m.dynamic; });
  s.materials.push_back(Material{"probe white", glm::vec3(1.0f)});
  Mesh quad;
  quad.name = "probe quad";
  quad.dynamic = true;
  quad.material = int(s.materials.size()) - 1;
  const glm::vec3 t1 = glm::normalize(glm::cross(glm::vec3(0.0f, 1.0f, 0.0f), n)), t2 = glm::cross(n, t1);
  for (const glm::vec2 c : {glm::vec2(-1, -1), glm::vec2(1, -1), glm::vec2(1, 1), glm::vec2(-1, 1)}) {
    quad.position.push_back(0.05f * (c.x * t1 + c.y * t2));  // counter-clockwise seen along -n
    quad.normal.push_back(n);
  }
  quad.indices = {0, 1, 2, 0, 2, 3};
  s.meshes.push_back(quad);
  s.dynamic_path = {glm::vec3(at)};
  s.camera.position = glm::vec3(at) + 0.25f * n;
  s.camera.target = glm::vec3(at);
  s.camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
  constexpr int kWidth = 32, kHeight = 18;
  for (DemoBackend backend : {DemoBackend::gles, DemoBackend::cpu}) {
    SCOPED_TRACE(backend == DemoBackend::gles ? "GLES backend" : "CPU backend");
    DemoRunOptions options = run_options();
    options.backend = backend;
    options.output = OutputMode::indirect;
    options.drt_rays = 64;
    options.renderer.width = kWidth, options.renderer.height = kHeight;
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(s, dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    std::vector<float> linear(3 * kWidth * kHeight);
    std::vector<std::uint8_t> image(linear.size());
    for (int frame = 0; frame < 2; ++frame) {
      const Status st = run.value()->render(frame, linear, image);
      ASSERT_TRUE(st.ok()) << st.to_string();
    }
    std::vector<float> probes(run.value()->backend().sizes().probes);
    ASSERT_FALSE(probes.empty());
    ASSERT_TRUE(run.value()->backend().read_probes(probes).ok());
    const ProbeSampler sampler(run.value()->level(), int(dict().settings.probe_grid));
    float sh[27];
    ASSERT_TRUE(sampler.sample(probes, glm::dvec3(at), true, sh).ok());
    const float y[9] = {0.282095f,
                        0.488603f * n.y,
                        0.488603f * n.z,
                        0.488603f * n.x,
                        1.092548f * n.x * n.y,
                        1.092548f * n.y * n.z,
                        0.315392f * (3.0f * n.z * n.z - 1.0f),
                        1.092548f * n.x * n.z,
                        0.546274f * (n.x * n.x - n.y * n.y)};
    const std::size_t centre = 3 * (std::size_t(kHeight / 2) * kWidth + kWidth / 2);
    for (std::size_t c = 0; c < 3; ++c) {
      float expected = 0.0f;
      for (std::size_t k = 0; k < 9; ++k) expected += sh[3 * k + c] * y[k];
      expected = std::max(expected, 0.0f);
      ASSERT_GT(expected, 1e-3f);  // lit: a black quad would prove nothing
      // float shading of double-sampled probes: rounding only.
      EXPECT_NEAR(linear[centre + c], expected, 1e-4f * expected + 1e-6f) << "channel " << c;
    }
    std::printf("  %s: quad E/pi %.5f %.5f %.5f (ProbeSampler)\n",
                backend == DemoBackend::gles ? "GLES" : "CPU ", linear[centre], linear[centre + 1],
                linear[centre + 2]);
  }
}

// A GL context that counts the glReadPixels calls made through its entry points (every GL call
// of the demo, its renderer and the backend goes through GlContext::gl()).
class ReadPixelsCountingContext : public platform::GlContext {
 public:
  explicit ReadPixelsCountingContext(platform::GlContext& inner) : inner_(inner) {
    info_ = inner.info();
    gl_ = inner.gl();
    real_read_pixels_ = gl_.glReadPixels;
    gl_.glReadPixels = &counting_read_pixels;
  }
  Status make_current() override { return inner_.make_current(); }
  struct Read {
    GLsizei width, height;
  };
  static std::vector<Read>& reads() {
    static std::vector<Read> r;
    return r;
  }

 private:
  static void GL_APIENTRY counting_read_pixels(GLint x, GLint y, GLsizei width, GLsizei height, GLenum format,
                                               GLenum type, void* pixels) {
    reads().push_back({width, height});
    real_read_pixels_(x, y, width, height, format, type, pixels);
  }
  static inline PFNGLREADPIXELSPROC real_read_pixels_ = nullptr;
  platform::GlContext& inner_;
};

// Issue 19: on the GLES path a frame reads back nothing but its image (linear and sRGB8) and,
// timed, the solve's one-texel residual: ld, the multi-bounce bound, the atlas, the probe volume
// and the clutter lightmap stay on the GPU.
// The accessors for tests (clutter_lightmap(), ld()) still read back, on request.
TEST(DemoRender, GlesFrameReadsBackOnlyItsImage) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  ReadPixelsCountingContext counting(*ctx);
  const DemoScene s = scene_with_clutter_box();
  ASSERT_TRUE(std::any_of(s.meshes.begin(), s.meshes.end(), [](const Mesh& m) { return m.dynamic; }));
  DemoRunOptions options = run_options();
  options.backend = DemoBackend::gles;
  options.drt_rays = 64;
  options.renderer.width = 48, options.renderer.height = 27;
  Result<std::unique_ptr<DemoRun>> run = DemoRun::create(s, dict(), counting, options);
  ASSERT_TRUE(run.ok()) << run.status().to_string();
  ASSERT_TRUE(run.value()->backend().output_texture(BackendOutput::clutter_atlas) != 0);
  std::vector<float> linear(3 * 48 * 27);
  std::vector<std::uint8_t> image(linear.size());
  for (int frame = 0; frame < 3; ++frame) {
    ReadPixelsCountingContext::reads().clear();
    const Status st = run.value()->render(frame, linear, image);
    ASSERT_TRUE(st.ok()) << st.to_string();
    // The image twice; and, because the demo times its passes (each waits for the GPU anyway),
    // the converged solve's residual: one texel (gles_reduced_solve.cpp), nothing larger.
    std::vector<std::pair<int, int>> reads;
    for (const auto& r : ReadPixelsCountingContext::reads())
      if (!(r.width == 1 && r.height == 1)) reads.push_back({r.width, r.height});
    ASSERT_LE(ReadPixelsCountingContext::reads().size(), 3u) << "frame " << frame;
    ASSERT_EQ(reads.size(), 2u) << "frame " << frame << ": " << reads.size() << " glReadPixels calls";
    for (const auto& r : reads) {
      EXPECT_EQ(r.first, 48);
      EXPECT_EQ(r.second, 27);
    }
  }
  ReadPixelsCountingContext::reads().clear();
  const std::span<const float> clutter = run.value()->clutter_lightmap();
  EXPECT_GE(ReadPixelsCountingContext::reads().size(), 1u);  // on request, not per frame
  EXPECT_GT(*std::max_element(clutter.begin(), clutter.end()), 0.0f);
}

// The golden image: frame 0 of the default scene under OSMesa, 320 x 180, small test
// dictionary. MODRT_UPDATE_GOLDEN=1 rewrites tests/data/demo_golden_osmesa.ppm (after a
// deliberate change to the renderer; look at the image before committing it).
TEST(DemoRender, FirstFrameMatchesGoldenImage) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  DemoRunOptions options = run_options();
  options.renderer.width = kGoldenWidth, options.renderer.height = kGoldenHeight;
  Result<std::unique_ptr<DemoRun>> run = DemoRun::create(scene(), dict(), *ctx, options);
  ASSERT_TRUE(run.ok()) << run.status().to_string();
  std::vector<float> linear(3 * kGoldenWidth * kGoldenHeight);
  std::vector<std::uint8_t> image(linear.size());
  ASSERT_TRUE(run.value()->render(0, linear, image).ok());
  const std::string path = std::string(MODRT_TEST_DATA_DIR) + "/demo_golden_osmesa.ppm";
  if (const char* update = std::getenv("MODRT_UPDATE_GOLDEN"); update && std::string(update) == "1") {
    std::ofstream out(path, std::ios::binary);
    out << "P6\n" << kGoldenWidth << " " << kGoldenHeight << "\n255\n";
    out.write(reinterpret_cast<const char*>(image.data()), std::streamsize(image.size()));
    ASSERT_TRUE(out.good()) << path;
    GTEST_SKIP() << "wrote " << path;
  }
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in.good()) << path << " is missing: run with MODRT_UPDATE_GOLDEN=1 to create it";
  std::string magic;
  int w = 0, h = 0, maxval = 0;
  in >> magic >> w >> h >> maxval;
  in.get();
  ASSERT_EQ(magic, "P6");
  ASSERT_EQ(w, kGoldenWidth);
  ASSERT_EQ(h, kGoldenHeight);
  ASSERT_EQ(maxval, 255);
  std::vector<std::uint8_t> golden(image.size());
  in.read(reinterpret_cast<char*>(golden.data()), std::streamsize(golden.size()));
  ASSERT_TRUE(in.good()) << path << " is truncated";
  const DeltaE e = delta_e(image, golden);
  EXPECT_LE(e.mean, 1.0);
  EXPECT_LE(e.p99, 8.0);
  std::printf("  frame 0 vs golden: Delta E mean %.3f, p99 %.3f\n", e.mean, e.p99);
  // The test can fail: a dark frame (no indirect light) is far from the golden image.
  std::vector<std::uint8_t> dark(image);
  for (std::uint8_t& v : dark) v = std::uint8_t(v / 2);
  EXPECT_GT(delta_e(dark, golden).mean, 5.0);
}

// ---- glTF as artists export it: several lights, double-sided materials, animations ----

// The default scene's first light held still at `at` (a point light), or a copy of it moved.
DemoLight still_light(const DemoScene& s, const glm::vec3& at) {
  DemoLight l = s.lights.front();
  l.path = {at};
  return l;
}

// The relative L2 distance between the linear image `sum` and a + b, leaving out the light
// markers (drawn, not summed, in exactly rgb x 20): `markers` counts the pixels left out. Not 0:
// the shader clamps indirect light at 0 (the SVD truncation leaves slightly negative values), so
// a sum of lights is linear to about 1e-5 only.
double rel_l2_of_sum(const std::vector<float>& sum, const std::vector<float>& a, const std::vector<float>& b,
                     const std::vector<glm::vec3>& marker_rgb, std::size_t* markers) {
  *markers = 0;
  const auto is_marker = [&](const std::vector<float>& image, std::size_t p) {
    for (const glm::vec3& m : marker_rgb)
      if (image[3 * p] == 20.0f * m.x && image[3 * p + 1] == 20.0f * m.y && image[3 * p + 2] == 20.0f * m.z)
        return true;
    return false;
  };
  double num = 0.0, den = 0.0;
  for (std::size_t p = 0; p < sum.size() / 3; ++p) {
    if (is_marker(sum, p) || is_marker(a, p) || is_marker(b, p)) {
      ++*markers;
      continue;
    }
    for (std::size_t c = 0; c < 3; ++c) {
      const double want = double(a[3 * p + c]) + b[3 * p + c], d = double(sum[3 * p + c]) - want;
      num += d * d, den += want * want;
    }
  }
  return std::sqrt(num / den);
}

// The demo used to render only lights.front(). Every light now lights every frame: with two lights
// (a point light and a coloured spot in another block) ld is the sum of each light's ld, the GL
// pass's summed on the GPU (the GLES backend reads that texture, the CPU backend its readback) and
// CpuDirectLight's; the clutter's direct light is the sum too; and, the transport being linear
// (two fixed feedback steps), so is the image but for the light markers.
TEST(DemoRender, EveryLightLightsTheFrame) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  struct Variant {
    const char* name;
    DemoBackend backend;
    DemoDirect direct;
    bool clutter;
  };
  for (const Variant& v : {Variant{"GLES backend, GL ld, the default scene with its clutter",
                                   DemoBackend::gles, DemoDirect::gpu, true},
                           Variant{"CPU backend, GL ld", DemoBackend::cpu, DemoDirect::gpu, false},
                           Variant{"CPU backend, CPU ld", DemoBackend::cpu, DemoDirect::cpu, false}}) {
    SCOPED_TRACE(v.name);
    const DemoScene base = v.clutter ? scene() : unwarped_walls();
    const DemoLight a = still_light(base, base.lights.front().path.front());
    DemoLight b = still_light(base, glm::vec3(trilinear(block_corners(base.level, base.level.blocks[1]),
                                                        glm::dvec3(0.5, 0.8, 0.5))));
    b.color = glm::vec3(0.2f, 0.5f, 1.0f);
    b.direction = glm::vec3(0.2f, -1.0f, 0.1f);
    b.inner_cone = 0.5f, b.outer_cone = 0.9f;
    std::vector<std::vector<float>> ld, clutter_ld, image;
    for (const std::vector<DemoLight>& lights :
         {std::vector<DemoLight>{a}, std::vector<DemoLight>{b}, std::vector<DemoLight>{a, b}}) {
      DemoScene s = base;
      s.lights = lights;
      DemoRunOptions options = run_options();
      options.backend = v.backend;
      options.direct = v.direct;
      options.bounces = 2;  // linear in ld, exactly
      options.drt_rays = 64;
      options.renderer.width = 64, options.renderer.height = 36;
      Result<std::unique_ptr<DemoRun>> run = DemoRun::create(s, dict(), *ctx, options);
      ASSERT_TRUE(run.ok()) << run.status().to_string();
      image.emplace_back(3 * 64 * 36);
      std::vector<std::uint8_t> srgb(image.back().size());
      const Status st = run.value()->render(0, image.back(), srgb);
      ASSERT_TRUE(st.ok()) << st.to_string();
      ld.emplace_back(run.value()->ld().begin(), run.value()->ld().end());
      clutter_ld.emplace_back(run.value()->clutter_ld().begin(), run.value()->clutter_ld().end());
    }
    double sum_a = 0, sum_b = 0, worst = 0;
    for (std::size_t i = 0; i < ld[2].size(); ++i) {
      sum_a += ld[0][i], sum_b += ld[1][i];
      const double want = double(ld[0][i]) + ld[1][i];
      worst = std::max(worst, std::abs(ld[2][i] - want) / (want + 1e-9));
    }
    EXPECT_GT(sum_a, 0.0);
    EXPECT_GT(sum_b, 0.02 * sum_a);  // the second light adds light of its own
    EXPECT_LT(worst, 1e-5);
    for (std::size_t i = 0; i < clutter_ld[2].size(); ++i)
      EXPECT_NEAR(clutter_ld[2][i], clutter_ld[0][i] + clutter_ld[1][i],
                  1e-5f * (clutter_ld[0][i] + clutter_ld[1][i]) + 1e-9f);
    if (v.clutter) {
      EXPECT_GT(*std::max_element(clutter_ld[2].begin(), clutter_ld[2].end()), 0.0f);
    }
    std::size_t markers = 0;
    const double image_error =
        rel_l2_of_sum(image[2], image[0], image[1], {a.color * a.intensity, b.color * b.intensity}, &markers);
    EXPECT_LT(image_error, 2e-4);
    EXPECT_LT(markers, image[2].size() / 3 / 10);
    // Not the image of the first light alone: the comparison can fail.
    std::size_t unused = 0;
    EXPECT_GT(rel_l2_of_sum(image[2], image[0], std::vector<float>(image[1].size(), 0.0f), {}, &unused),
              1e-2);
    std::printf(
        "  %s: ld of both = sum of each within %.1e (light 2 adds %.0f %%), image rel L2 %.1e (%zu light "
        "marker pixels left out)\n",
        v.name, worst, 100.0 * sum_b / sum_a, image_error, markers);
  }
}

// kMaxDemoLights lights render; more are refused by name (load_gltf_scene drops them with a
// warning before they get here).
TEST(DemoRender, FourLightsRenderAndAFifthIsRefused) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  DemoScene s = unwarped_walls();
  for (std::size_t i = 0; i < kMaxDemoLights; ++i) {
    const glm::dvec3 at = trilinear(block_corners(s.level, s.level.blocks[i % s.level.blocks.size()]),
                                    glm::dvec3(0.5, 0.7, 0.5));
    s.lights.push_back(still_light(s, glm::vec3(at)));
  }
  s.lights.erase(s.lights.begin());
  ASSERT_EQ(s.lights.size(), kMaxDemoLights);
  DemoRunOptions options = run_options();
  options.renderer.width = 32, options.renderer.height = 18;
  Result<std::unique_ptr<DemoRun>> run = DemoRun::create(s, dict(), *ctx, options);
  ASSERT_TRUE(run.ok()) << run.status().to_string();
  std::vector<float> linear(3 * 32 * 18);
  std::vector<std::uint8_t> srgb(linear.size());
  const Status st = run.value()->render(0, linear, srgb);
  ASSERT_TRUE(st.ok()) << st.to_string();
  s.lights.push_back(s.lights.front());
  Result<std::unique_ptr<DemoRun>> five = DemoRun::create(s, dict(), *ctx, options);
  ASSERT_FALSE(five.ok());
  EXPECT_NE(five.status().message().find("5 lights; the demo renders at most 4"), std::string::npos)
      << five.status().message();
}

// A light with a KeyTrack (a glTF animation) is where track_point puts it: the frame's ld equals,
// bit for bit, the ld of a light held still at that point.
TEST(DemoRender, AnimatedLightFollowsItsTrack) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  const DemoScene walls = unwarped_walls();
  const glm::vec3 p0(trilinear(block_corners(walls.level, walls.level.blocks[0]), glm::dvec3(0.3, 0.6, 0.4)));
  const glm::vec3 p1(trilinear(block_corners(walls.level, walls.level.blocks[0]), glm::dvec3(0.7, 0.8, 0.6)));
  DemoScene animated = walls;
  DemoLight& l = animated.lights.front();
  l.track.times = {0.0f, 10.0f};
  l.track.values = {p0, p1};
  l.track.period = 20.0f;
  const int frame = 7;
  const glm::vec3 at = track_point(l.track, frame);
  EXPECT_LT(glm::length(at - (0.3f * p0 + 0.7f * p1)), 1e-5f);
  DemoScene still = walls;
  still.lights.front() = still_light(walls, at);
  std::vector<std::vector<float>> ld;
  for (const DemoScene* sc : {&animated, &still}) {
    DemoRunOptions options = run_options();
    options.renderer.width = 32, options.renderer.height = 18;
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(*sc, dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    std::vector<float> linear(3 * 32 * 18);
    std::vector<std::uint8_t> srgb(linear.size());
    ASSERT_TRUE(run.value()->render(sc == &still ? 0 : frame, linear, srgb).ok());
    ld.emplace_back(run.value()->ld().begin(), run.value()->ld().end());
  }
  EXPECT_EQ(ld[0], ld[1]);
  EXPECT_GT(*std::max_element(ld[0].begin(), ld[0].end()), 0.0f);
}

// A square of half-size h centred at `centre` with normal `n`, counter-clockwise seen from the
// side n points to, in material `material`.
Mesh quad_mesh(const std::string& name, const glm::vec3& centre, const glm::vec3& n, float h, int material) {
  Mesh quad;
  quad.name = name;
  quad.material = material;
  const glm::vec3 up = std::abs(n.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 t1 = glm::normalize(glm::cross(up, n)), t2 = glm::cross(n, t1);
  for (const glm::vec2 c : {glm::vec2(-1, -1), glm::vec2(1, -1), glm::vec2(1, 1), glm::vec2(-1, 1)}) {
    quad.position.push_back(centre + h * (c.x * t1 + c.y * t2));
    quad.normal.push_back(n);
  }
  quad.indices = {0, 1, 2, 0, 2, 3};
  return quad;
}

// The back side of a double-sided static mesh is mapped onto the proxy face it faces: a
// horizontal quad's top reads the floor's tile (inward normal +Y), its underside the ceiling's,
// with its triangles wound counter-clockwise about the turned normal.
TEST(ProxyMapping, BackSidesOfDoubleSidedMeshesMapOntoTheFacesTheyFace) {
  DemoScene s;
  s.level = scene().level;
  s.materials = {Material{"one side", glm::vec3(0.5f)}, Material{"leaf", glm::vec3(0.5f)}};
  s.materials[1].double_sided = true;
  const glm::vec3 centre(trilinear(block_corners(s.level, s.level.blocks[0]), glm::dvec3(0.5, 0.4, 0.5)));
  s.meshes.push_back(quad_mesh("single", centre + glm::vec3(0.0f, 0.05f, 0.0f), {0, 1, 0}, 0.05f, 0));
  s.meshes.push_back(quad_mesh("table top", centre, {0, 1, 0}, 0.05f, 1));
  Result<Level> level = precompute::build_level(s.level, dict());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  const Result<std::vector<MappedMesh>> front = map_to_proxies(s, level.value());
  const Result<std::vector<MappedMesh>> back = map_back_sides(s, level.value());
  ASSERT_TRUE(front.ok() && back.ok());
  ASSERT_EQ(back->size(), 1u);  // the single-sided quad has no back side
  const MappedMesh& b = back->front();
  EXPECT_EQ(b.mesh, 1);
  ASSERT_EQ(b.vertices.size(), 6u);
  const MappedMesh& f = front->at(1);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(b.vertices[i].normal, glm::vec3(0, -1, 0));
    EXPECT_GT(
        glm::dot(glm::normalize(glm::cross(b.vertices[i].face_u, b.vertices[i].face_v)), glm::vec3(0, -1, 0)),
        0.9f);
    EXPECT_GT(
        glm::dot(glm::normalize(glm::cross(f.vertices[i].face_u, f.vertices[i].face_v)), glm::vec3(0, 1, 0)),
        0.9f);
  }
  for (std::size_t t = 0; t < 6; t += 3) {
    const glm::vec3 n = glm::cross(b.vertices[t + 1].position - b.vertices[t].position,
                                   b.vertices[t + 2].position - b.vertices[t].position);
    EXPECT_LT(n.y, 0.0f) << "back triangle " << t / 3 << " is not counter-clockwise about -Y";
  }
  EXPECT_GT(glm::length(b.vertices[0].lightmap - f.vertices[0].lightmap), 2.0f);  // another tile
}

// glTF doubleSided: a quad seen from its back is culled when single-sided (the image is the
// same whatever its colour) and lit when double-sided, shaded with the turned normal (light.glsl's
// point light at the hit point, 1 %), whether static (its back side mapped and drawn culled)
// or dynamic (drawn without culling, the normal turned in the shader).
TEST(DemoRender, DoubleSidedQuadIsLitFromBehind) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  constexpr int kWidth = 32, kHeight = 18;
  const DemoScene walls = unwarped_walls();
  const DemoCamera& cam = walls.camera;
  const glm::vec3 forward = glm::normalize(cam.target - cam.position);
  const glm::vec3 centre = cam.position + 0.25f * forward;
  const glm::vec3 light_at = cam.position + glm::vec3(0.0f, 0.1f, 0.0f);
  // Where the centre pixel's ray meets the quad's plane (the renderer's projection).
  const glm::mat4 inverse =
      glm::inverse(glm::perspective(cam.yfov, float(kWidth) / float(kHeight), cam.znear, cam.zfar) *
                   glm::lookAt(cam.position, cam.target, cam.up));
  const glm::vec2 ndc(2.0f * (kWidth / 2 + 0.5f) / kWidth - 1.0f,
                      2.0f * (kHeight / 2 + 0.5f) / kHeight - 1.0f);
  const glm::vec4 far_h = inverse * glm::vec4(ndc, 1.0f, 1.0f);
  const glm::vec3 ray = glm::normalize(glm::vec3(far_h) / far_h.w - cam.position);
  const glm::vec3 hit =
      cam.position + ray * (glm::dot(centre - cam.position, forward) / glm::dot(ray, forward));
  const DemoLight light = still_light(walls, light_at);
  const glm::vec3 to_light = light_at - hit;
  const float d2 = glm::dot(to_light, to_light);
  // The back side's normal is -forward; red albedo 1.
  const float expected = light.color.r * light.intensity * glm::dot(-forward, to_light / std::sqrt(d2)) /
                         std::max(d2, light.radius * light.radius) / 3.14159265f;
  const std::size_t centre_pixel = 3 * (std::size_t(kHeight / 2) * kWidth + kWidth / 2);
  for (const bool dynamic : {false, true}) {
    SCOPED_TRACE(dynamic ? "dynamic quad" : "static quad");
    std::vector<std::vector<float>> images;
    for (const auto& [double_sided, colour] :
         std::vector<std::pair<bool, glm::vec3>>{{false, {1, 0, 0}}, {false, {0, 1, 0}}, {true, {1, 0, 0}}}) {
      DemoScene s = walls;
      s.lights = {light};
      s.materials.push_back(Material{"quad", colour});
      s.materials.back().double_sided = double_sided;
      Mesh quad =
          quad_mesh("quad", dynamic ? glm::vec3(0.0f) : centre, forward, 0.05f, int(s.materials.size()) - 1);
      quad.dynamic = dynamic;
      s.meshes.push_back(quad);
      if (dynamic) s.dynamic_path = {centre};
      DemoRunOptions options = run_options();
      options.output = OutputMode::direct;
      options.renderer.width = kWidth, options.renderer.height = kHeight;
      Result<std::unique_ptr<DemoRun>> run = DemoRun::create(s, dict(), *ctx, options);
      ASSERT_TRUE(run.ok()) << run.status().to_string();
      images.emplace_back(3 * kWidth * kHeight);
      std::vector<std::uint8_t> srgb(images.back().size());
      const Status st = run.value()->render(0, images.back(), srgb);
      ASSERT_TRUE(st.ok()) << st.to_string();
    }
    // Single-sided, seen from behind: absent, so its colour changes nothing.
    EXPECT_EQ(images[0], images[1]);
    // Double-sided: the red quad, lit on its back side.
    const float* px = images[2].data() + centre_pixel;
    EXPECT_NEAR(px[0], expected, 0.01f * expected);
    EXPECT_EQ(px[1], 0.0f);
    EXPECT_EQ(px[2], 0.0f);
    EXPECT_NE(images[0][centre_pixel], px[0]);
    std::printf(
        "  %s: back side E/pi %.5f (expected %.5f); single-sided shows the wall behind (%.5f %.5f %.5f)\n",
        dynamic ? "dynamic" : "static ", px[0], expected, images[0][centre_pixel],
        images[0][centre_pixel + 1], images[0][centre_pixel + 2]);
  }
}

// ---- issue 18 ----

// A light of 1e8 cd (1.5e5 W/sr) put Inf into the half-float EXR, 1e20 cd every pixel: the
// frame itself is finite (float32 targets) and is now written as float32 EXR.
TEST(DemoRender, BrightLightRendersFiniteAndWritesFloat32Exr) {
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  for (const double candela : {1e8, 1e20}) {
    DemoScene bright = walls_only();
    bright.lights[0].intensity = float(candela / 683.0);
    DemoRunOptions options = run_options();
    options.renderer.width = 64, options.renderer.height = 36;
    Result<std::unique_ptr<DemoRun>> run = DemoRun::create(bright, dict(), *ctx, options);
    ASSERT_TRUE(run.ok()) << run.status().to_string();
    std::vector<float> linear(3 * 64 * 36);
    std::vector<std::uint8_t> srgb(linear.size());
    ASSERT_TRUE(run.value()->render(0, linear, srgb).ok());
    EXPECT_EQ(count_non_finite(linear), 0u) << candela << " cd";
    const float largest = *std::max_element(linear.begin(), linear.end());
    EXPECT_GT(largest, kHalfMax) << candela << " cd";
    bool float32 = false;
    const std::string path = (std::filesystem::temp_directory_path() /
                              ("modrt_test_demo_bright_" + std::to_string(::getpid()) + ".exr"))
                                 .string();
    const Status w = write_rgb_float_image(path, 64, 36, linear, &float32);
    std::filesystem::remove(path);
    ASSERT_TRUE(w.ok()) << w.to_string();
    EXPECT_TRUE(float32) << candela << " cd: largest value " << largest;
    std::printf("  %.0e cd: largest linear value %.3g, EXR float32\n", candela, double(largest));
  }
}

// glBufferData's failure was unchecked, and llvmpipe crashed drawing from the buffer it could
// not allocate (a 2.9 GB glTF scene). A 1 TiB request fails in the driver and is an error.
TEST(DemoRender, FailedBufferAllocationIsAnError) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ASan aborts on a 1 TiB allocation instead of returning null";
#else
  platform::GlContext* ctx = osmesa();
  if (!ctx) GTEST_SKIP() << "no OSMesa context";
  const platform::GlFunctions& gl = ctx->gl();
  GLuint buffer = 0;
  gl.glGenBuffers(1, &buffer);
  gl.glBindBuffer(GL_ARRAY_BUFFER, buffer);
  const Status s =
      buffer_data_checked(gl, GL_ARRAY_BUFFER, std::size_t(1) << 40, nullptr, "a 1 TiB test buffer");
  gl.glBindBuffer(GL_ARRAY_BUFFER, 0);
  gl.glDeleteBuffers(1, &buffer);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("renderer: glBufferData of 1099511627776 bytes for a 1 TiB test buffer: GL_"),
            std::string::npos)
      << s.message();
  std::printf("  %s\n", s.to_string().c_str());
  // The context stays usable: no error is left pending.
  EXPECT_EQ(gl.glGetError(), GLenum(GL_NO_ERROR));
#endif
}

}  // namespace
}  // namespace modrt::demo
