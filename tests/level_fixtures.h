// SPDX-License-Identifier: MIT
// Shared by the backend tests (CPU, GLES): a single block, a corridor and the 11- and
// 41-block mazes built against the small test dictionary, with their direct light and
// albedo, and core's scalar reference for a given ld. Each built once per test program, when
// first used.
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
  std::string name;  // "single", "corridor", "maze11", "maze41"
  LevelDescription description;
  Level level;
  std::vector<float> ld, albedo;
};

// The names of the test levels, in test_levels() order.
inline constexpr const char* kTestLevelNames[] = {"single", "corridor", "maze11", "maze41"};

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
  else {
    std::fprintf(stderr, "no test level named %s\n", name.c_str());
    std::abort();
  }
  Result<Level> level = precompute::build_level(t.description, small_test_dictionary());
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
