// SPDX-License-Identifier: MIT
// Shared by the backend tests (CPU, GLES): a single block, a corridor, the 11- and 41-block
// mazes and a bend of stretched blocks (each with operators for its own box, MRT §8) built
// against the small test dictionary, with their direct light and albedo, and core's scalar reference for a
// given ld. Each built once per test program, when first used.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "modrt/level_runtime.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/maze.h"
#include "test_support.h"

namespace modrt::test {

struct TestLevel {
  std::string name;  // kTestLevelNames
  LevelDescription description;
  Level level;
  std::vector<float> ld, albedo;
};

// The names of the test levels, in test_levels() order.
inline constexpr const char* kTestLevelNames[] = {"single", "corridor", "maze11", "maze41", "stretched"};

// Four connected blocks 0.8 high: 1.7 x 0.8 x 1, 0.6 x 0.8 x 1 and 0.7 x 0.8 x 1 along x, then
// 0.7 x 0.8 x 1.4 along z, the light in the first (connected: built with the interface basis,
// their interfaces traced in their boxes, shaped_interfaces.h); and two rooms open to the
// outside, a 1.6 x 0.8 x 1 room and a 1 x 0.3 x 1 slab, each lit by a light of its own. Every
// block is baked for its box (Level::shaped, MRT §8).
inline LevelDescription stretched_level() {
  LevelDescription d;
  d.name = "stretched";
  const double x[] = {0.0, 1.7, 2.3, 3.0}, h = 0.8;
  auto box = [&](glm::ivec3 cell, glm::dvec3 lo, glm::dvec3 hi, FaceMask faces) {
    BlockDescription b;
    b.cell = cell;
    b.faces = faces;
    b.warped = true;
    for (int k = 0; k < 8; ++k)
      b.corners[std::size_t(k)] = {k & 1 ? hi.x : lo.x, (k >> 1) & 1 ? hi.y : lo.y,
                                   (k >> 2) & 1 ? hi.z : lo.z};
    for (glm::dvec3& a : b.albedo) a = glm::dvec3(0.7);
    b.albedo[kFaceNegX] = {0.8, 0.3, 0.2};
    d.blocks.push_back(b);
  };
  auto without = [](std::initializer_list<int> faces) {
    unsigned m = kAllFaces;
    for (int f : faces) m &= ~(1u << f);
    return FaceMask(m);
  };
  box({0, 0, 0}, {x[0], 0, 0}, {x[1], h, 1}, without({kFacePosX}));
  box({1, 0, 0}, {x[1], 0, 0}, {x[2], h, 1}, without({kFaceNegX, kFacePosX}));
  box({2, 0, 0}, {x[2], 0, 0}, {x[3], h, 1}, without({kFaceNegX, kFacePosZ}));
  box({2, 0, 1}, {x[2], 0, 1}, {x[3], h, 2.4}, without({kFaceNegZ}));
  box({0, 0, 3}, {0, 0, 3}, {1.6, h, 4}, without({kFacePosZ}));
  box({4, 0, 0}, {4, 0, 0}, {5, 0.3, 1}, without({kFaceNegZ}));
  for (const glm::dvec3& p :
       {glm::dvec3(0.5, 0.5, 0.4), glm::dvec3(0.4, 0.5, 3.3), glm::dvec3(4.3, 0.15, 0.6)}) {
    LightDescription l;
    l.position = p;
    l.radius = 0.05;
    d.lights.push_back(l);
  }
  return d;
}

inline TestLevel build_test_level(const std::string& name) {
  TestLevel t{name, {}, {}, {}, {}};
  if (name == "single")
    t.description = precompute::maze_level(1).value();
  else if (name == "corridor")
    t.description = precompute::corridor_level();
  else if (name == "maze11")
    t.description = precompute::maze_level(11).value();
  else if (name == "maze41")
    t.description = precompute::maze_level(41).value();
  else if (name == "stretched")
    t.description = stretched_level();
  else {
    std::fprintf(stderr, "no test level named %s\n", name.c_str());
    std::abort();
  }
  precompute::LevelBuildSettings settings;
  settings.shaped_cache = &test_shaped_cache();
  if (name == "stretched") settings.interface_basis = &small_test_interface_basis();
  Result<Level> level = precompute::build_level(t.description, small_test_dictionary(), settings);
  if (!level.ok()) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), level.status().to_string().c_str());
    std::abort();
  }
  t.level = std::move(level).value();
  const precompute::LevelScene scene(t.level, t.level.res);
  t.albedo = level_sample_albedo(t.level);
  t.ld = precompute::level_direct_light(scene, t.description.lights, t.albedo, 4);
  return t;
}

// One level, built on first use: ctest runs every test in its own process, and a test that
// needs the corridor should not pay for the 41-block maze's build (most of a short test's time,
// and under the sanitizers most of the suite's).
inline const TestLevel& test_level(const std::string& name) {
  static std::mutex mutex;
  static std::map<std::string, std::unique_ptr<const TestLevel>> built;
  const std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<const TestLevel>& slot = built[name];
  if (!slot) slot = std::make_unique<const TestLevel>(build_test_level(name));
  return *slot;
}

// Every test level, in kTestLevelNames order.
inline const std::vector<std::reference_wrapper<const TestLevel>>& test_levels() {
  static const std::vector<std::reference_wrapper<const TestLevel>> levels = [] {
    std::vector<std::reference_wrapper<const TestLevel>> out;
    for (const char* name : kTestLevelNames) out.emplace_back(test_level(name));
    return out;
  }();
  return levels;
}

struct LevelReference {
  std::vector<float> b, r, lightmap, atlas, probes, vector_lightmap;
};

// level_evaluate, level_fill_atlas, level_compute_probes and level_compute_vector_irradiance
// for `ld`.
inline LevelReference level_reference(const Level& level, std::span<const float> ld) {
  const Dictionary& dict = small_test_dictionary();
  const LevelBufferSizes s = level_buffer_sizes(level, dict);
  LevelReference ref{std::vector<float>(s.b),        std::vector<float>(s.r),
                     std::vector<float>(s.lightmap), std::vector<float>(s.atlas),
                     std::vector<float>(s.probes),   std::vector<float>(s.vector_lightmap)};
  if (Status st = level_evaluate(level, dict, ld, ref.b, ref.r, ref.lightmap); !st.ok()) {
    std::fprintf(stderr, "level_evaluate: %s\n", st.to_string().c_str());
    std::abort();
  }
  level_fill_atlas(level, ref.lightmap, ref.atlas);
  level_compute_probes(level, dict, ref.b, ref.r, ref.probes);
  if (Status st = level_compute_vector_irradiance(level, dict, ref.b, ref.r, ref.vector_lightmap); !st.ok()) {
    std::fprintf(stderr, "level_compute_vector_irradiance: %s\n", st.to_string().c_str());
    std::abort();
  }
  return ref;
}

// The skipping tests' animation: frame `frame` of a light moving through the level. Every
// fifth frame repeats the last ld (the light stands still); the others rescale the ld of one
// block (three on every third frame) from `base`, the rest of ld staying as it was.
inline void animate_moving_light(const Level& level, std::span<const float> base, int frame,
                                 std::vector<float>& ld) {
  if (frame % 5 == 4) return;
  const std::size_t blocks = level.blocks.size();
  const int moved = frame % 3 == 0 ? 3 : 1;
  for (int m = 0; m < moved; ++m) {
    const LevelBlock& blk = level.blocks[std::size_t(frame * 7 + m * 13) % blocks];
    for (std::size_t i = 0; i < 3 * std::size_t(blk.sample_count); ++i)
      ld[3 * std::size_t(blk.sample_offset) + i] =
          base[3 * std::size_t(blk.sample_offset) + i] * (1.0f + 0.05f * float((frame + m) % 9));
  }
}

}  // namespace modrt::test
