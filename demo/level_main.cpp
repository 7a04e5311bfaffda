// SPDX-License-Identifier: MIT
// modrt-level: relights a whole level with the scalar reference runtime (MRT §7.3) and
// writes a top-down map of the floor (indirect light, and direct + indirect) plus the
// padded lightmap atlas. Levels come from JSON (docs/level-format.md) or a preset.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "image_output.h"
#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"
#include "modrt/level_geometry.h"
#include "modrt/level_io.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_json.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/maze.h"
#include "modrt/precompute/shaped_operators.h"
#include "modrt/reduced_feedback.h"

namespace {

using namespace modrt;

Result<LevelDescription> load_description(const std::string& name) {
  if (name == "corridor") return precompute::corridor_level();
  if (name == "l_corner") return precompute::l_corner_level();
  if (name.rfind("maze", 0) == 0 && name.find('.') == std::string::npos) {
    try {
      return precompute::maze_level(std::stoi(name.substr(4)));
    } catch (const std::exception&) {
      return Status::error(ErrorCode::invalid_argument, "--level " + name + ": expected mazeN, e.g. maze41");
    }
  }
  return precompute::load_level_json(name);
}

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

float exposure_for(const std::vector<float>& rgb) {
  std::vector<float> v(rgb);
  std::sort(v.begin(), v.end());
  const float p = v.empty() ? 1.0f : v[std::min(v.size() - 1, v.size() * 98 / 100)];
  return p > 0.0f ? 0.85f / p : 1.0f;
}

// Floor of every block seen from above (x right, z down), `ppc` pixels per cell.
std::vector<float> floor_map(const Level& level, const std::vector<float>& signal, int ppc, int& w, int& h) {
  glm::ivec3 lo(1 << 30), hi(-(1 << 30));
  std::map<std::pair<int, int>, std::size_t> at;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    lo = glm::min(lo, level.blocks[i].cell);
    hi = glm::max(hi, level.blocks[i].cell);
    at[{level.blocks[i].cell.x, level.blocks[i].cell.z}] = i;
  }
  w = (hi.x - lo.x + 1) * ppc;
  h = (hi.z - lo.z + 1) * ppc;
  std::vector<float> img(3 * std::size_t(w) * std::size_t(h), 0.0f);
  const int res = level.res;
  for (int py = 0; py < h; ++py)
    for (int px = 0; px < w; ++px) {
      const double wx = lo.x + (px + 0.5) / ppc, wz = lo.z + (py + 0.5) / ppc;
      auto it = at.find({int(std::floor(wx)), int(std::floor(wz))});
      if (it == at.end()) continue;
      const LevelBlock& b = level.blocks[it->second];
      const glm::dvec3 local =
          rotate_point(glm::dvec3(wx, b.cell.y, wz) - glm::dvec3(b.cell), -b.quarter_turns);
      const FaceFrame& fr = face_frame(kFaceNegY);
      const double u = glm::dot(local - fr.origin, fr.u_axis) * res - 0.5;
      const double v = glm::dot(local - fr.origin, fr.v_axis) * res - 0.5;
      const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(b.shape), res);
      const int x0 = int(std::floor(u)), y0 = int(std::floor(v));
      const double ax = u - x0, ay = v - y0;
      for (int c = 0; c < 3; ++c) {
        double sum = 0.0;
        for (int bj = 0; bj < 2; ++bj)
          for (int ai = 0; ai < 2; ++ai) {
            const int i = std::clamp(x0 + ai, 0, res - 1), j = std::clamp(y0 + bj, 0, res - 1);
            sum +=
                (ai ? ax : 1 - ax) * (bj ? ay : 1 - ay) *
                signal[3 * (b.sample_offset + std::size_t(layout.index(kFaceNegY, i, j))) + std::size_t(c)];
          }
        img[3 * (std::size_t(py) * std::size_t(w) + std::size_t(px)) + std::size_t(c)] = float(sum);
      }
    }
  return img;
}

// --stats: per block its index, name (the description's, when it has one), cell and the mean
// indirect E/pi and direct light per channel (level_block_means: area-weighted over its
// samples), written atomically as JSON, so that runs compare without images.
Status write_stats(const std::string& path, const std::string& level_name, const LevelDescription& desc,
                   const Level& level, int bounces, const std::vector<float>& ld,
                   const std::vector<float>& lightmap) {
  const std::vector<double> indirect = level_block_means(level, lightmap),
                            direct = level_block_means(level, ld);
  nlohmann::json blocks = nlohmann::json::array();
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const glm::ivec3 c = level.blocks[i].cell;
    blocks.push_back(
        {{"block", i},
         {"name", i < desc.blocks.size() ? desc.blocks[i].name : std::string()},
         {"cell", {c.x, c.y, c.z}},
         {"mean_indirect_E_over_pi", {indirect[3 * i], indirect[3 * i + 1], indirect[3 * i + 2]}},
         {"mean_direct", {direct[3 * i], direct[3 * i + 1], direct[3 * i + 2]}}});
  }
  const nlohmann::json j = {{"level", level_name},
                            {"bounces", bounces < 0 ? std::string("converged") : std::to_string(bounces)},
                            {"res", level.res},
                            {"samples", level.sample_count},
                            {"blocks", blocks}};
  const std::string text = j.dump(2) + "\n";
  return write_file_atomic(path, std::as_bytes(std::span<const char>(text.data(), text.size())));
}

Status write(const std::string& path, int w, int h, const std::vector<float>& rgb, float exposure) {
  std::vector<std::uint8_t> px(rgb.size());
  demo::encode_srgb8(rgb, exposure, px);
  return demo::write_rgb8_image(path, w, h, px);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "modrt-level: relight a level (MRT scalar reference runtime) and write floor maps and the atlas"};
  std::string level_name = "maze11", out_dir = "out", dictionary_path,
              cache_dir = precompute::default_cache_dir();
  std::string save_path, stats_path;
  bool cube_operators = false;
  int bounces = -1, dmax = 8;
  app.add_option("--level", level_name, "level JSON file, or corridor, l_corner, mazeN (e.g. maze41)");
  app.add_option("--out", out_dir, "output directory");
  app.add_option(
      "--dictionary", dictionary_path,
      "dictionary file (default: bake on first use into the cache; a file has no interface basis, so "
      "stretched blocks connected to others keep cube operators)");
  app.add_option("--cache-dir", cache_dir, "dictionary cache directory");
  app.add_option("--bounces", bounces,
                 "multi-bounce: N >= 0 feedback iterations (0 = one bounce); -1: the converged multi-bounce "
                 "(reduced_feedback.h, tolerance 1e-3)")
      ->check(CLI::Range(-1, 10000))
      ->capture_default_str();
  app.add_option("--dmax", dmax, "maximum interfaces a light path crosses")
      ->check(CLI::Range(0, precompute::kMaxLevelDmax));
  app.add_flag("--cube-operators", cube_operators,
               "every block on its dictionary shape's cube operators, even a stretched one (the default "
               "bakes operators for each block's box, MRT §8, cached in --cache-dir)");
  app.add_option(
      "--save", save_path,
      "also write the built level to this .modrtlevel file (core/level_io.h), the form an app loads");
  app.add_option("--stats", stats_path,
                 "also write per block its name, cell and mean indirect E/pi and direct light per channel "
                 "(area-weighted over its samples) to this JSON file");
  CLI11_PARSE(app, argc, argv);
  // Outputs that cannot be written are found before the dictionary bake and the level build.
  if (Status s = check_writable_directory(out_dir); !s.ok()) {
    std::fprintf(stderr, "modrt-level: --out: %s\n", s.to_string().c_str());
    return 1;
  }
  if (!save_path.empty()) {
    if (Status s = check_writable_file(save_path); !s.ok()) {
      std::fprintf(stderr, "modrt-level: --save: %s\n", s.to_string().c_str());
      return 1;
    }
  }
  if (!stats_path.empty()) {
    if (Status s = check_writable_file(stats_path); !s.ok()) {
      std::fprintf(stderr, "modrt-level: --stats: %s\n", s.to_string().c_str());
      return 1;
    }
  }

  Result<LevelDescription> desc = load_description(level_name);
  if (!desc.ok()) {
    std::fprintf(stderr, "modrt-level: %s\n", desc.status().to_string().c_str());
    return 1;
  }
  Result<Dictionary> dict =
      dictionary_path.empty()
          ? precompute::load_or_bake_dictionary(DictionarySettings{}, cache_dir, {},
                                                [](const std::string& m) { std::printf("%s\n", m.c_str()); })
          : load_dictionary(dictionary_path);
  if (!dict.ok()) {
    std::fprintf(stderr, "modrt-level: %s\n", dict.status().to_string().c_str());
    return 1;
  }
  // Shaped blocks connected to others need the dictionary's interface basis, which only a
  // cached dictionary has beside it.
  Result<Matrix> interface_basis = Status::error(ErrorCode::invalid_argument, "no basis");
  if (!cube_operators && dictionary_path.empty() && !dict->interfaces.empty()) {
    interface_basis = precompute::load_or_bake_interface_basis(
        DictionarySettings{}, cache_dir, {}, [](const std::string& m) { std::printf("%s\n", m.c_str()); });
    if (!interface_basis.ok()) {
      std::fprintf(stderr, "modrt-level: %s\n", interface_basis.status().to_string().c_str());
      return 1;
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  precompute::LevelBuildSettings build_settings;
  build_settings.dmax = dmax;
  build_settings.shaped_operators = !cube_operators;
  precompute::ShapedOperatorCache shaped_cache(cache_dir);
  build_settings.shaped_cache = &shaped_cache;
  build_settings.interface_basis = interface_basis.ok() ? &interface_basis.value() : nullptr;
  Result<Level> level = precompute::build_level(desc.value(), dict.value(), build_settings);
  if (!level.ok()) {
    std::fprintf(stderr, "modrt-level: %s: %s\n", level_name.c_str(), level.status().to_string().c_str());
    return 1;
  }
  const double build_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  // Passes that ran past 2 s say so on stderr (stdout keeps the summary line).
  if (build_ms > 2000.0) std::fprintf(stderr, "modrt-level: level build: %.1f s\n", build_ms / 1000.0);
  if (!level->shaped.empty())
    std::printf("shaped operators: %zu sets for blocks that are not cubes (%zu baked, %zu loaded from %s)\n",
                level->shaped.size(), shaped_cache.bakes(), shaped_cache.disk_loads(), cache_dir.c_str());
  if (!save_path.empty()) {
    if (Status s = save_level(save_path, level.value()); !s.ok()) {
      std::fprintf(stderr, "modrt-level: %s\n", s.to_string().c_str());
      return 1;
    }
    std::printf("wrote %s\n", save_path.c_str());
  }

  if (level->blocks.empty()) {
    // Allowed (docs/level-format.md), and nothing to light: no samples, no images.
    std::printf("%s: 0 blocks, 0 samples: the level is empty, nothing to light or write\n",
                level_name.c_str());
    if (!stats_path.empty())  // no blocks to list, but the file the caller asked for
      if (Status s = write_stats(stats_path, level_name, desc.value(), level.value(), bounces, {}, {});
          !s.ok()) {
        std::fprintf(stderr, "modrt-level: --stats: %s\n", s.to_string().c_str());
        return 1;
      }
    return 0;
  }
  std::vector<float> albedo, ld;
  try {
    const auto td = std::chrono::steady_clock::now();
    const precompute::LevelScene scene(level.value(), level->res);
    albedo = level_sample_albedo(level.value());
    // Progress on stderr once the pass has run 2 s (a long level takes minutes).
    bool shown = false;
    ld = precompute::level_direct_light(scene, desc->lights, albedo, 16, [&](double fraction) {
      const double s = seconds_since(td);
      if (s < 2.0 && !shown) return;
      shown = true;
      std::fprintf(stderr, "\rmodrt-level: direct light: %5.1f %% (%.1f s)%s", 100.0 * fraction, s,
                   fraction >= 1.0 ? "\n" : "");
      std::fflush(stderr);
    });
  } catch (const std::exception& e) {
    std::fprintf(stderr, "modrt-level: direct light: %s\n", e.what());
    return 1;
  }
  const LevelBufferSizes sizes = level_buffer_sizes(level.value(), dict.value());
  std::vector<float> b(sizes.b), r(sizes.r), lightmap(sizes.lightmap), atlas(sizes.atlas);
  const auto t1 = std::chrono::steady_clock::now();
  if (bounces == 0) {
    if (Status s = level_evaluate(level.value(), dict.value(), ld, b, r, lightmap); !s.ok()) {
      std::fprintf(stderr, "modrt-level: %s\n", s.to_string().c_str());
      return 1;
    }
  } else if (bounces < 0) {
    Result<ConvergedBounceReport> rep =
        level_converged_bounce(level.value(), dict.value(), ld, albedo, {}, b, r, lightmap);
    if (!rep.ok()) {
      std::fprintf(stderr, "modrt-level: %s\n", rep.status().to_string().c_str());
      return 1;
    }
    std::printf(
        "converged multi-bounce: %d iterations (%s, contraction %.3f), estimated error %.1e of max |b|\n",
        rep->solve.iterations, rep->block_jacobi ? "block Jacobi" : "plain", rep->contraction,
        double(rep->solve.error_bound));
  } else {
    MultiBounceSettings mb;
    mb.max_iterations = bounces;
    Result<MultiBounceReport> rep =
        level_multi_bounce(level.value(), dict.value(), ld, albedo, mb, b, r, lightmap);
    if (!rep.ok()) {
      std::fprintf(stderr, "modrt-level: %s\n", rep.status().to_string().c_str());
      return 1;
    }
  }
  level_fill_atlas(level.value(), lightmap, atlas);
  const double frame_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  if (frame_ms > 2000.0) std::fprintf(stderr, "modrt-level: reference runtime: %.1f s\n", frame_ms / 1000.0);

  std::vector<float> shaded(lightmap.size());
  for (std::size_t i = 0; i < shaded.size(); ++i) shaded[i] = ld[i] + albedo[i] * std::max(lightmap[i], 0.0f);
  int w = 0, h = 0;
  const std::vector<float> indirect_map = floor_map(level.value(), lightmap, 64, w, h);
  const std::vector<float> shaded_map = floor_map(level.value(), shaded, 64, w, h);
  // Output names from the level's name: a built-in name as it is, a JSON path by its stem
  // (levels/hall.json -> hall_floor_indirect.png).
  std::string stem = std::filesystem::path(level_name).stem().string();
  if (stem.empty()) stem = "level";
  const std::string base = out_dir + "/" + stem;
  for (const auto& [path, status] :
       {std::pair{base + "_floor_indirect.png",
                  write(base + "_floor_indirect.png", w, h, indirect_map, exposure_for(indirect_map))},
        std::pair{base + "_floor_shaded.png",
                  write(base + "_floor_shaded.png", w, h, shaded_map, exposure_for(shaded_map))},
        std::pair{base + "_atlas.png", write(base + "_atlas.png", level->atlas.width, level->atlas.height,
                                             atlas, exposure_for(atlas))}}) {
    if (!status.ok()) {
      std::fprintf(stderr, "modrt-level: %s\n", status.to_string().c_str());
      return 1;
    }
    std::printf("wrote %s\n", path.c_str());
  }
  if (!stats_path.empty()) {
    if (Status s = write_stats(stats_path, level_name, desc.value(), level.value(), bounces, ld, lightmap);
        !s.ok()) {
      std::fprintf(stderr, "modrt-level: --stats: %s\n", s.to_string().c_str());
      return 1;
    }
    std::printf("wrote %s\n", stats_path.c_str());
  }
  // Ranges of the direct and indirect light (the hostile corpus checks them: finite, bounded).
  const auto ld_range = std::minmax_element(ld.begin(), ld.end());
  const auto lm_range = std::minmax_element(lightmap.begin(), lightmap.end());
  if (!ld.empty())
    std::printf("ld in [%.6g, %.6g], indirect lightmap in [%.6g, %.6g]\n", double(*ld_range.first),
                double(*ld_range.second), double(*lm_range.first), double(*lm_range.second));
  std::printf(
      "%s: %zu blocks, %u samples, %zu Tb->r records; build %.1f ms; reference runtime (%s) %.1f ms\n",
      level_name.c_str(), level->blocks.size(), level->sample_count, level->records.size(), build_ms,
      bounces < 0 ? "converged bounces, their operators built included"
                  : (std::to_string(bounces) + " bounce iterations").c_str(),
      frame_ms);
  return 0;
}
