// SPDX-License-Identifier: MIT
// Shared by the Google Benchmark programs: the DEFAULT full dictionary (res 16, kb 32), loaded
// from $MODRT_BENCH_DICTIONARY when set (a dictionary file, e.g. on a machine without the
// cache), else from the cache ($MODRT_CACHE_DIR, ...) or baked on first use (about a minute);
// and mazes built against it (dmax 8) with a fixed synthetic non-negative ld (the cost of a
// frame does not depend on it). Both are built once per program and kept.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "modrt/dictionary_io.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/maze.h"

namespace modrt::bench {

inline const Dictionary* dictionary() {
  static const std::unique_ptr<Dictionary> dict = [] {
    const char* file = std::getenv("MODRT_BENCH_DICTIONARY");
    Result<Dictionary> d =
        file ? load_dictionary(file)
             : precompute::load_or_bake_dictionary(DictionarySettings{}, precompute::default_cache_dir());
    if (!d.ok()) {
      std::fprintf(stderr, "bench: dictionary: %s\n", d.status().to_string().c_str());
      return std::unique_ptr<Dictionary>();
    }
    return std::make_unique<Dictionary>(std::move(d).value());
  }();
  return dict.get();
}

struct BenchLevel {
  Level level;
  std::vector<float> ld;
};

// maze_level(blocks) against dictionary(); null (after printing why) when either fails.
inline const BenchLevel* bench_level(int blocks) {
  static std::map<int, std::unique_ptr<BenchLevel>> cache;
  auto it = cache.find(blocks);
  if (it != cache.end()) return it->second.get();
  std::unique_ptr<BenchLevel> out;
  if (const Dictionary* dict = dictionary()) {
    Result<LevelDescription> desc = precompute::maze_level(blocks);
    Result<Level> level =
        desc.ok() ? precompute::build_level(desc.value(), *dict) : Result<Level>(desc.status());
    if (level.ok()) {
      out = std::make_unique<BenchLevel>();
      out->level = std::move(level).value();
      out->ld.resize(3 * std::size_t(out->level.sample_count));
      for (std::size_t i = 0; i < out->ld.size(); ++i) out->ld[i] = float((i * 7919) % 1000) / 1000.0f;
    } else {
      std::fprintf(stderr, "bench: maze %d: %s\n", blocks, level.status().to_string().c_str());
    }
  }
  return cache.emplace(blocks, std::move(out)).first->second.get();
}

// The camera skip's flight (BM_CpuCameraSkip, BM_GlesCameraSkip): 64 cameras from block centre to
// block centre (4 frames each), 16:9 with a 69 degree vertical field, turning a quarter every 8
// frames and 0.3 rad per frame in between.
struct CameraFlight {
  std::vector<glm::dmat4> view_projection;
  std::vector<glm::dvec3> eye;
};
inline CameraFlight camera_flight(const Level& level) {
  CameraFlight flight;
  for (std::size_t f = 0; f < 64; ++f) {
    glm::dvec3 eye(0.0);
    for (const glm::dvec3& c : level.blocks[(f / 4) % level.blocks.size()].corners) eye += c / 8.0;
    const double a = 1.5707963267948966 * double(f / 8) + 0.3 * double(f % 8);
    flight.eye.push_back(eye);
    flight.view_projection.push_back(
        glm::perspective(1.2, 16.0 / 9.0, 0.01, 100.0) *
        glm::lookAt(eye, eye + glm::dvec3(std::cos(a), 0.0, std::sin(a)), glm::dvec3(0, 1, 0)));
  }
  return flight;
}

}  // namespace modrt::bench
