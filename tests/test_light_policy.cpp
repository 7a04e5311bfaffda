// SPDX-License-Identifier: MIT
// Issue 18, lights and rays (modrt/light_policy.h): rays Embree cannot trace, lights out of
// reach, the texel-footprint bound on the point-light singularity, light fields of level JSON,
// the empty level, and the run shortcut of LevelScene::occluded_from (item 10).
#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "modrt/cpu/direct_light.h"
#include "modrt/level_geometry.h"
#include "modrt/level_runtime.h"
#include "modrt/light_policy.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_json.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/maze.h"
#include "modrt/precompute/sampling.h"
#include "test_support.h"

namespace modrt {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

const Dictionary& dict() { return test::small_test_dictionary(); }

Level build(const LevelDescription& d) {
  Result<Level> level = precompute::build_level(d, dict());
  EXPECT_TRUE(level.ok()) << level.status().to_string();
  return level.ok() ? std::move(level).value() : Level{};
}

// n blocks in a straight line along +Z joined through their shared faces, a light in each end.
LevelDescription straight_corridor(int n) {
  LevelDescription d;
  d.name = "straight" + std::to_string(n);
  for (int i = 0; i < n; ++i) {
    BlockDescription b;
    b.cell = glm::ivec3(0, 0, i);
    b.faces = kAllFaces;
    if (i > 0) b.faces = FaceMask(b.faces & ~(1u << kFaceNegZ));
    if (i + 1 < n) b.faces = FaceMask(b.faces & ~(1u << kFacePosZ));
    b.albedo.fill(glm::dvec3(0.7));
    d.blocks.push_back(b);
  }
  d.lights.push_back({{0.5, 0.5, 0.5}, 0.05, glm::dvec3(1.0), 1.0});
  d.lights.push_back({{0.5, 0.5, n - 0.5}, 0.05, glm::dvec3(1.0), 1.0});
  return d;
}

std::pair<float, float> min_max(const std::vector<float>& v) {
  if (v.empty()) return {0.0f, 0.0f};
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return {*lo, *hi};
}

bool all_finite(const std::vector<float>& v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

TEST(LightPolicy, RaysEmbreeCannotTraceAreMissesOrBlockedNeverAborts) {
  const precompute::BlockScene block(kAllFaces);
  const glm::dvec3 c(0.5);
  for (const double bad : {1e20, 1e19, -1e16, kInf, -kInf, kNaN}) {
    // Before the guard each of these aborted in Embree (ray.valid() in bvh_intersector1.cpp).
    EXPECT_TRUE(block.occluded(c, {bad, 0.5, 0.5})) << bad;
    EXPECT_TRUE(block.occluded({0.5, bad, 0.5}, c)) << bad;
    EXPECT_EQ(block.intersect(c, {bad, 0.0, 0.0}).face, -1) << bad;
    EXPECT_EQ(block.intersect({0.5, 0.5, bad}, {1.0, 0.0, 0.0}).face, -1) << bad;
    EXPECT_EQ(block.intersect(c, {1.0, 0.0, 0.0}, bad).face, -1) << bad;
  }
  // A good ray still hits.
  EXPECT_EQ(block.intersect(c, {1.0, 0.0, 0.0}).face, kFacePosX);
  EXPECT_FALSE(block.occluded(c, {0.25, 0.5, 0.5}));

  const Level level = build(precompute::corridor_level());
  const precompute::LevelScene scene(level, level.res);
  EXPECT_TRUE(scene.occluded(c, {1e20, 0.5, 0.5}));
  EXPECT_TRUE(scene.occluded_from(0, c, {kNaN, 0.5, 0.5}));
  EXPECT_EQ(scene.intersect(c, {kInf, 0.0, 0.0}).block, -1);
  const std::vector<glm::dvec3> dirs = {{1, 0, 0}, {1e20, 0, 0}, {kNaN, 0, 0}, {0, -1, 0}, {0, 0, -1e19}};
  std::vector<precompute::LevelHit> hits(dirs.size());
  scene.intersect_many(c, dirs, hits);
  EXPECT_GE(hits[0].block, 0);
  EXPECT_EQ(hits[1].block, -1);
  EXPECT_EQ(hits[2].block, -1);
  EXPECT_GE(hits[3].block, 0);
  EXPECT_EQ(hits[4].block, -1);
}

TEST(LightPolicy, LightsOutOfReachGiveZeroOnEveryPath) {
  const LevelDescription corridor = precompute::corridor_level();
  const Level level = build(corridor);
  const precompute::LevelScene scene(level, level.res);
  const std::vector<float> albedo = level_sample_albedo(level);
  // Clutter: one box in block 0, for the DRT clutter direct light.
  ClutterObject box;
  box.block = 0;
  box.box.center = glm::dvec3(0.5, 0.2, 0.5);
  const std::vector<ClutterObject> clutter = {box};
  const precompute::LevelScene cluttered(level, level.res, clutter);
  const SampleLayout layout = SampleLayout::make(kAllFaces, level.res);
  const precompute::BlockScene block(kAllFaces);
  struct Case {
    glm::dvec3 position;
    double radius;
  };
  for (const Case& c :
       {Case{{1e20, 0.5, 0.5}, 0.05}, Case{{1e19, 0.5, 0.5}, 0.0}, Case{{0.5, 0.5, 0.5}, 1e20},
        Case{{0.5, -1e16, 0.5}, 0.05}, Case{{kInf, 0.5, 0.5}, 0.05}}) {
    SCOPED_TRACE(std::to_string(c.position.x) + " " + std::to_string(c.position.y) + " r " +
                 std::to_string(c.radius));
    EXPECT_FALSE(light_in_reach(c.position, c.radius));
    const LightDescription light{c.position, c.radius, glm::dvec3(1.0), 1.0};
    const std::vector<float> ld = precompute::level_direct_light(scene, {&light, 1}, albedo, 16);
    EXPECT_EQ(min_max(ld), std::make_pair(0.0f, 0.0f));
    const std::vector<float> cl = precompute::clutter_direct_light(cluttered, {&light, 1}, 16);
    EXPECT_FALSE(cl.empty());
    EXPECT_EQ(min_max(cl), std::make_pair(0.0f, 0.0f));
    std::vector<double> e(std::size_t(layout.sample_count()), -1.0);
    precompute::direct_light(block, layout, {c.position, c.radius, 1.0}, 16, e);
    EXPECT_EQ(*std::max_element(e.begin(), e.end()), 0.0);
    EXPECT_EQ(*std::min_element(e.begin(), e.end()), 0.0);
    // The CPU evaluator: 0 as well (or, for a non-finite position, a refusal naming it).
    Result<cpu::CpuDirectLight> dl = cpu::CpuDirectLight::create(level, albedo, {});
    ASSERT_TRUE(dl.ok());
    cpu::CpuLight l;
    l.type = cpu::LightType::point;
    l.position = glm::vec3(c.position);
    l.radius = float(c.radius);
    l.intensity = 1.0f;
    std::vector<float> cpu_ld(3 * std::size_t(level.sample_count), -1.0f);
    const Status s = dl->evaluate({&l, 1}, cpu_ld);
    if (std::isfinite(c.position.x) && std::isfinite(float(c.radius))) {
      ASSERT_TRUE(s.ok()) << s.to_string();
      EXPECT_EQ(min_max(cpu_ld), std::make_pair(0.0f, 0.0f));
    } else {
      EXPECT_FALSE(s.ok());
    }
  }
}

TEST(LightPolicy, LevelJsonLightFieldsAreCheckedAtParseTime) {
  const std::string head =
      R"({"format": "modrt-level", "version": 1, "blocks": [{"cell": [0, 0, 0]}], "lights": [)";
  struct Case {
    const char* light;
    const char* field;  // the path the message names
  };
  for (const Case& c : {
           Case{R"({"position": [1e20, 0.5, 0.5]})", "lights[0].position"},
           Case{R"({"position": [0.5, -1e19, 0.5]})", "lights[0].position"},
           Case{R"({"position": [3.5, 0.5, 0.5]})", "lights[0].position"},
           Case{R"({"position": [0.5, 0.5, 0.5], "radius": 1e20})", "lights[0].radius"},
           Case{R"({"position": [0.5, 0.5, 0.5], "intensity": 1e308})", "lights[0].intensity"},
           Case{R"({"position": [0.5, 0.5, 0.5], "color": [1, 1e308, 1]})", "lights[0].color[1]"},
           Case{R"({"position": [0.5, 0.5, 0.5], "color": [1e10, 1, 1], "intensity": 1e10})",
                "lights[0].intensity"},
       }) {
    const Result<LevelDescription> r = precompute::parse_level_json(head + c.light + "]}", "t.json");
    ASSERT_FALSE(r.ok()) << c.light;
    const std::string m = r.status().to_string();
    std::printf("  %s -> %s\n", c.light, m.c_str());
    EXPECT_NE(m.find(std::string("t.json: ") + c.field + ":"), std::string::npos) << m;
  }
  // Inside the grown box, and at the bounds of intensity: accepted.
  for (const char* ok :
       {R"({"position": [1.9, -0.9, 0.5]})", R"({"position": [0.5, 0.5, 0.5], "intensity": 1e18})",
        R"({"position": [0.5, 0.5, 0.5], "radius": 1.0})"}) {
    const Result<LevelDescription> r = precompute::parse_level_json(head + ok + "]}", "t.json");
    EXPECT_TRUE(r.ok()) << ok << ": " << r.status().to_string();
  }
}

TEST(LightPolicy, EmptyLevelBuildsAndLightsToNothing) {
  const Result<LevelDescription> d = precompute::parse_level_json(
      R"({"format": "modrt-level", "version": 1, "blocks": [], "lights": [{"position": [0.5, 0.5, 0.5]}]})",
      "e.json");
  ASSERT_TRUE(d.ok()) << d.status().to_string();
  Result<Level> level = precompute::build_level(d.value(), dict());
  ASSERT_TRUE(level.ok()) << level.status().to_string();
  // Before: "Embree: cannot allocate level geometry".
  const precompute::LevelScene scene(level.value(), level->res);
  const std::vector<float> albedo = level_sample_albedo(level.value());
  EXPECT_TRUE(precompute::level_direct_light(scene, d->lights, albedo, 16).empty());
  EXPECT_FALSE(scene.occluded(glm::dvec3(0.1), glm::dvec3(0.9)));
  EXPECT_EQ(scene.intersect(glm::dvec3(0.5), {1, 0, 0}).block, -1);
}

// Item 7: a radius-0 light on, 1e-12 and 1e-7 above and just behind a floor texel centre. The
// texel footprint bounds E / pi by 2 I / A (light_policy.h): finite, >= 0, no 1e11 spikes, on
// the Embree path and the CPU evaluator alike, and both agree.
TEST(LightPolicy, PointLightsOnAndNearSurfacesAreBoundedByTheTexelFootprint) {
  const LevelDescription corridor = precompute::corridor_level();
  const Level level = build(corridor);
  const precompute::LevelScene scene(level, level.res);
  const std::vector<float> albedo = level_sample_albedo(level);
  const LevelSampleGeometry g = level_sample_geometry(level);
  const double area = block_texel_area(level.blocks[0].corners, level.res);
  // A floor texel of block 0 near its centre.
  std::size_t s0 = 0;
  double best = kInf;
  for (std::size_t s = 0; s < g.position.size(); ++s)
    if (g.block[s] == 0 && g.normal[s].y > 0.9) {
      const double d = glm::length(g.position[s] - glm::dvec3(0.5, 0.0, 0.5));
      if (d < best) best = d, s0 = s;
    }
  const glm::dvec3 x = g.position[s0], n = g.normal[s0];
  Result<cpu::CpuDirectLight> dl = cpu::CpuDirectLight::create(level, albedo, {});
  ASSERT_TRUE(dl.ok());
  for (const double intensity : {1.0, 1e6}) {
    const double bound = 2.0 * intensity / area * (1.0 + 1e-6);  // E / pi <= 2 I / A, albedo <= 1
    for (const double h : {0.0, 1e-12, 1e-7, 1e-3, -1e-7, -1e-3}) {
      SCOPED_TRACE("I " + std::to_string(intensity) + " h " + std::to_string(h));
      const LightDescription light{x + h * n, 0.0, glm::dvec3(1.0), intensity};
      const std::vector<float> ld = precompute::level_direct_light(scene, {&light, 1}, albedo, 1);
      const auto [lo, hi] = min_max(ld);
      EXPECT_TRUE(all_finite(ld));
      EXPECT_GE(lo, 0.0f);
      EXPECT_LE(hi, bound);
      cpu::CpuLight l;
      l.type = cpu::LightType::point;
      l.position = glm::vec3(light.position);
      l.radius = 0.0f;
      l.intensity = float(intensity);
      std::vector<float> cpu_ld(ld.size(), -1.0f);
      const Status st = dl->evaluate({&l, 1}, cpu_ld);
      ASSERT_TRUE(st.ok()) << st.to_string();
      const auto [clo, chi] = min_max(cpu_ld);
      EXPECT_TRUE(all_finite(cpu_ld));
      EXPECT_GE(clo, 0.0f);
      EXPECT_LE(chi, bound);
      // The two paths agree (the light's own texel included: its ld is at the floor's bound),
      // except for a light inside the wall by less than the shadow rays' end tolerance (Embree:
      // 1e-6 of the segment, the CPU walk: 1e-4 of a block), where each may see it or not.
      if (h < 0.0 && h > -1e-4) continue;
      double diff2 = 0.0, ref2 = 0.0;
      for (std::size_t i = 0; i < ld.size(); ++i) {
        diff2 += (double(ld[i]) - cpu_ld[i]) * (double(ld[i]) - cpu_ld[i]);
        ref2 += double(ld[i]) * ld[i];
      }
      EXPECT_LE(std::sqrt(diff2), 1e-3 * std::sqrt(ref2) + 1e-12);
      // The indirect light of that ld: finite, and its negative lobes bounded (non-negative
      // output is the runtimes' clamp; here: no 1e8 swings).
      const LevelBufferSizes sizes = level_buffer_sizes(level, dict());
      std::vector<float> b(sizes.b), r(sizes.r), lightmap(sizes.lightmap);
      ASSERT_TRUE(level_evaluate(level, dict(), ld, b, r, lightmap).ok());
      const auto [mlo, mhi] = min_max(lightmap);
      std::printf("  I %-6g h %-7g: ld max %.4g (bound %.4g), cpu ld max %.4g, lightmap min %.4g max %.4g\n",
                  intensity, h, double(hi), bound, double(chi), double(mlo), double(mhi));
      EXPECT_TRUE(all_finite(lightmap));
      EXPECT_GE(mlo, -0.1f * std::max(mhi, 1.0f));
    }
  }
  // Away from surfaces nothing changes: the floor is below every d^2 there.
  for (std::size_t s = 0; s < g.position.size(); ++s) {
    const glm::dvec3 w = glm::dvec3(0.5) - g.position[s];
    ASSERT_EQ(light_falloff_d2(glm::dot(w, w), 0.05, area), glm::dot(w, w));
  }
}

// Item 10: the run shortcut gives Embree's answer. Random targets in random blocks near the
// sample, on straight corridors, mazes (with loops and crossings) and a warped maze.
TEST(LightPolicy, RunShortcutAgreesWithEmbree) {
  precompute::MazeSettings warped;
  warped.blocks = 11;
  warped.seed = 3;
  warped.loop_fraction = 0.3;
  warped.warp = 0.2;
  precompute::MazeSettings loops;
  loops.blocks = 30;
  loops.seed = 5;
  loops.loop_fraction = 0.5;
  for (const LevelDescription& d :
       {straight_corridor(12), precompute::corridor_level(), precompute::maze_level(41).value(),
        precompute::generate_maze(loops).value(), precompute::generate_maze(warped).value()}) {
    const Level level = build(d);
    const precompute::LevelScene scene(level, level.res);
    const LevelSampleGeometry& g = scene.samples();
    precompute::Rng rng(7, 0);
    std::size_t differ = 0, tested = 0, free = 0;
    for (std::size_t s = 0; s < g.position.size(); s += 3) {
      const LevelBlock& b =
          level.blocks[std::size_t(rng.next_double() * double(level.blocks.size())) % level.blocks.size()];
      const glm::dvec3 target = block_to_world(b, {rng.next_double(), rng.next_double(), rng.next_double()});
      if (glm::dot(target - g.position[s], g.normal[s]) <= 0.0) continue;
      const bool a = scene.occluded_from(g.block[s], g.position[s], target);
      const bool e = scene.occluded(g.position[s], target);
      differ += a != e;
      free += !a;
      ++tested;
    }
    std::printf("  %s: %zu segments, %zu unoccluded, %zu differ from Embree\n", d.name.c_str(), tested, free,
                differ);
    EXPECT_GT(free, 0u);
    EXPECT_EQ(differ, 0u) << d.name;
  }
}

// The sun on clutter (clutter_directional_light, the demo's DRT clutter under a directional
// light) is a point light very far away: at 1 km along the sun's direction, with its intensity
// times 1 km^2, clutter_direct_light gives the same ld to 1e-3 (the 1/d^2 and the direction vary
// by the box's size over 1 km). One block open to the outside at -X, a box on its floor; the
// sun comes in through the opening and down, lighting some faces and not others.
TEST(LightPolicy, SunOnClutterIsAFarPointLight) {
  LevelDescription d;
  d.name = "open_block";
  BlockDescription& b = d.blocks.emplace_back();
  b.faces = FaceMask(kAllFaces & ~(1u << kFaceNegX));
  b.albedo.fill(glm::dvec3(0.5));
  const Level level = build(d);
  ClutterObject box;
  box.block = 0;
  box.box.center = glm::dvec3(0.5, 0.1, 0.5);
  const std::vector<ClutterObject> clutter = {box};
  const precompute::LevelScene scene(level, level.res, clutter);
  const glm::dvec3 direction = glm::normalize(glm::dvec3(1.0, -0.5, 0.2));
  const glm::dvec3 irradiance(2.0, 1.5, 1.0);
  const std::vector<float> sun = precompute::clutter_directional_light(scene, direction, irradiance);
  constexpr double kFar = 1000.0;
  const LightDescription far{box.box.center - kFar * direction, 0.0, irradiance / 2.0, 2.0 * kFar * kFar};
  const std::vector<float> point = precompute::clutter_direct_light(scene, {&far, 1}, 1);
  ASSERT_EQ(sun.size(), point.size());
  ASSERT_FALSE(sun.empty());
  double num = 0.0, den = 0.0;
  std::size_t lit = 0, dark = 0;
  for (std::size_t i = 0; i < sun.size(); ++i) {
    num += (double(sun[i]) - point[i]) * (double(sun[i]) - point[i]);
    den += double(point[i]) * point[i];
    ASSERT_TRUE(std::isfinite(sun[i]) && sun[i] >= 0.0f) << i;
    (sun[i] > 0.0f ? lit : dark) += 1;
  }
  EXPECT_GT(lit, sun.size() / 10);
  EXPECT_GT(dark, sun.size() / 10);
  EXPECT_LT(std::sqrt(num / std::max(den, 1e-30)), 1e-3);
  // No direction: no light, not NaN.
  const std::vector<float> none = precompute::clutter_directional_light(scene, glm::dvec3(0.0), irradiance);
  EXPECT_EQ(min_max(none), std::make_pair(0.0f, 0.0f));
}

}  // namespace
}  // namespace modrt
