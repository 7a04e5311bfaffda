// SPDX-License-Identifier: MIT
// modrt-relight: the single-block relighting demo. Bakes (or loads the cached) dictionary,
// lights one dictionary shape with a sphere light and coloured walls, evaluates indirect
// light with the scalar reference runtime and writes the block's unfolded lightmaps.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli_checks.h"
#include "image_output.h"
#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"
#include "modrt/light_policy.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/reference_runtime.h"
#include "unfolded_lightmap.h"

namespace {

using namespace modrt;

int shape_by_name(const std::string& name) {
  for (int s = 0; s < kDictionaryShapeCount; ++s)
    if (name == dictionary_shape_name(s)) return s;
  return -1;
}

// Exposure that maps the 99th percentile of a signal to 0.85.
float auto_exposure(const std::vector<float>& rgb) {
  std::vector<float> v(rgb);
  std::sort(v.begin(), v.end());
  const float p99 = v.empty() ? 1.0f : v[std::min(v.size() - 1, v.size() * 99 / 100)];
  return p99 > 0.0f ? 0.85f / p99 : 1.0f;
}

Status write_unfolded(const std::string& path, const SampleLayout& layout, const std::vector<float>& signal) {
  const demo::UnfoldedImage img = demo::unfold_lightmap(layout, signal, 16);
  std::vector<std::uint8_t> pixels(img.rgb.size());
  demo::encode_srgb8(img.rgb, auto_exposure(signal), pixels);
  return demo::write_rgb8_image(path, img.width, img.height, pixels);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modrt-relight: single-block MRT relighting demo; writes the unfolded lightmap as PNG"};
  std::string dictionary_path;
  std::string cache_dir = precompute::default_cache_dir();
  std::string out_dir = "out";
  std::string shape_name = "dead_end";
  std::vector<double> light_pos = {0.3, 0.75, 0.6};
  double light_intensity = 1.0;
  int bounces = 8;
  DictionarySettings settings;
  app.add_option("--dictionary", dictionary_path,
                 "dictionary file to load (default: bake on first use into the cache)");
  app.add_option("--cache-dir", cache_dir, "where the baked dictionary is cached");
  app.add_option("--out", out_dir, "output directory for the PNG images");
  app.add_option("--shape", shape_name,
                 "dictionary shape: closed, dead_end, corridor, corner, t_junction, crossing");
  // Bounds (light_policy.h): the light's centre is checked against the block after parsing;
  // its intensity within kMaxLightIntensity, as for every authored light.
  app.add_option("--light", light_pos, "sphere light centre x,y,z in block units")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--intensity", light_intensity, "light intensity (W/sr)")
      ->check(modrt::demo::FiniteRange(0.0, kMaxLightIntensity));
  app.add_option("--bounces", bounces, "multi-bounce feedback iterations (0 = one bounce)")
      ->check(CLI::Range(0, 10000));
  app.add_option("--rays", settings.rays, "bake: gather rays per sample (only when baking)");
  CLI11_PARSE(app, argc, argv);

  // The light (light_policy.h), before any bake: its centre in the block grown by one block on
  // every side ([-1, 2]^3, where the prior's lights lie; NaN and Inf are outside).
  const glm::dvec3 light_centre(light_pos[0], light_pos[1], light_pos[2]);
  if (!light_position_in_level(light_centre, glm::dvec3(0.0), glm::dvec3(1.0), 1.0)) {
    std::fprintf(stderr,
                 "modrt-relight: --light %.9g,%.9g,%.9g: outside the block grown by one block, [-1, 2]^3\n",
                 light_pos[0], light_pos[1], light_pos[2]);
    return 2;
  }

  if (Status s = check_writable_directory(out_dir); !s.ok()) {  // before a first-run bake
    std::fprintf(stderr, "modrt-relight: --out: %s\n", s.to_string().c_str());
    return 1;
  }
  const int shape = shape_by_name(shape_name);
  if (shape < 0) {
    std::fprintf(stderr, "modrt-relight: --shape %s: unknown shape\n", shape_name.c_str());
    return 2;
  }

  Result<Dictionary> dict = Status::error(ErrorCode::internal_error, "not loaded");
  if (!dictionary_path.empty()) {
    dict = load_dictionary(dictionary_path);
  } else {
    precompute::BakeProgress progress;
    progress.on_stage = [](const std::string& stage, int s, double seconds) {
      if (s >= 0)
        std::printf("  bake shape %d (%s): %-18s %6.2f s\n", s, dictionary_shape_name(s), stage.c_str(),
                    seconds);
      else
        std::printf("  bake %-30s %6.2f s\n", stage.c_str(), seconds);
      std::fflush(stdout);
    };
    dict = precompute::load_or_bake_dictionary(settings, cache_dir, progress,
                                               [](const std::string& m) { std::printf("%s\n", m.c_str()); });
  }
  if (!dict.ok()) {
    std::fprintf(stderr, "modrt-relight: %s\n", dict.status().to_string().c_str());
    return 1;
  }

  const ShapeOperators& op = dict->shapes[std::size_t(shape)];
  const SampleLayout layout = SampleLayout::make(op.face_mask, int(dict->settings.res));
  const std::size_t n = std::size_t(layout.sample_count());

  // Cornell-style walls: -X red, +X green, the rest white.
  std::vector<float> albedo(3 * n);
  for (std::size_t s = 0; s < n; ++s) {
    const int f = layout.face_of(int(s));
    const float rgb[3] = {f == kFaceNegX   ? 0.75f
                          : f == kFacePosX ? 0.15f
                                           : 0.75f,
                          f == kFaceNegX   ? 0.15f
                          : f == kFacePosX ? 0.75f
                                           : 0.75f,
                          f == kFaceNegX || f == kFacePosX ? 0.15f : 0.75f};
    for (int c = 0; c < 3; ++c) albedo[3 * s + std::size_t(c)] = rgb[c];
  }

  std::vector<double> irradiance(n);
  try {
    const precompute::BlockScene scene(op.face_mask);
    precompute::direct_light(scene, layout, {light_centre, 0.05, light_intensity}, 16, irradiance);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "modrt-relight: direct light: %s\n", e.what());
    return 1;
  }
  std::vector<float> ld(3 * n);
  for (std::size_t i = 0; i < 3 * n; ++i) ld[i] = albedo[i] * float(irradiance[i / 3]);

  std::vector<float> b(3 * std::size_t(op.kb())), lightmap(3 * n);
  const auto t0 = std::chrono::steady_clock::now();
  if (bounces == 0) {
    if (Status s = compute_b(op, ld, b); !s.ok()) {
      std::fprintf(stderr, "modrt-relight: %s\n", s.to_string().c_str());
      return 1;
    }
    apply_Ub(op, b, lightmap);
  } else {
    MultiBounceSettings mb;
    mb.max_iterations = bounces;
    Result<MultiBounceReport> report = multi_bounce(op, ld, albedo, mb, b, lightmap);
    if (!report.ok()) {
      std::fprintf(stderr, "modrt-relight: %s\n", report.status().to_string().c_str());
      return 1;
    }
    std::printf("multi-bounce: %d iteration(s)%s%s\n", report->iterations,
                report->converged ? ", converged" : "", report->albedo_clamped ? ", albedo clamped" : "");
  }
  const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();

  std::vector<float> shaded(3 * n);
  for (std::size_t i = 0; i < 3 * n; ++i) shaded[i] = ld[i] + albedo[i] * std::max(lightmap[i], 0.0f);

  const std::string lightmap_path = out_dir + "/lightmap.png";
  const std::string shaded_path = out_dir + "/shaded.png";
  for (const auto& [path, signal] : {std::pair{lightmap_path, &lightmap}, std::pair{shaded_path, &shaded}}) {
    if (Status s = write_unfolded(path, layout, *signal); !s.ok()) {
      std::fprintf(stderr, "modrt-relight: %s\n", s.to_string().c_str());
      return 1;
    }
  }
  std::printf("shape %s (n = %zu samples, kb = %u): reference runtime %.1f us\n", shape_name.c_str(), n,
              op.kb(), us);
  std::printf("wrote %s (indirect E/pi) and %s (direct + indirect radiance)\n", lightmap_path.c_str(),
              shaded_path.c_str());
  return 0;
}
