// SPDX-License-Identifier: MIT
// Shared by the backend tests (CPU, GLES): a single block, a corridor and the 11- and
// 41-block mazes built against the small test dictionary, with their direct light and
// albedo, and core's scalar reference for a given ld. Built once per test program.
#pragma once

#include <cstdio>
#include <cstdlib>
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

inline const std::vector<TestLevel>& test_levels() {
  static const std::vector<TestLevel> levels = [] {
    std::vector<TestLevel> out;
    const std::pair<const char*, LevelDescription> descriptions[] = {
        {"single", precompute::maze_level(1).value()},
        {"corridor", precompute::corridor_level()},
        {"maze11", precompute::maze_level(11).value()},
        {"maze41", precompute::maze_level(41).value()},
    };
    for (const auto& [name, description] : descriptions) {
      TestLevel t{name, description, {}, {}, {}};
      Result<Level> level = precompute::build_level(t.description, small_test_dictionary());
      if (!level.ok()) {
        std::fprintf(stderr, "%s: %s\n", name, level.status().to_string().c_str());
        std::abort();
      }
      t.level = std::move(level).value();
      const precompute::LevelScene scene(t.level, t.level.res);
      t.albedo = level_sample_albedo(t.level);
      t.ld = precompute::level_direct_light(scene, t.description.lights, t.albedo, 4);
      out.push_back(std::move(t));
    }
    return out;
  }();
  return levels;
}

inline const TestLevel& test_level(const std::string& name) {
  for (const TestLevel& t : test_levels())
    if (t.name == name) return t;
  std::fprintf(stderr, "no test level named %s\n", name.c_str());
  std::abort();
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

}  // namespace modrt::test
