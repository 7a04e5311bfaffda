// SPDX-License-Identifier: MIT
// modrt-demo: the offscreen demo (README's main command). Renders the built-in default scene
// (scene/default_scene.h) or a glTF scene with OpenGL ES 3 through EGL (or OSMesa): a point light
// moving through a warped 11-block maze (a glTF scene's point and spot lights, up to four, with
// their animations), a shadow cube map per light giving direct light to the camera image
// and to the MRT proxy samples (ld), indirect light from the lightmaps the chosen backend
// computes (GLES passes or the SIMD CPU runtime), vector irradiance on normal-mapped
// surfaces, a dynamic sphere lit by the probe volume. Writes PNG (tone-mapped) and EXR
// (linear) frames and prints per-stage timings.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli_checks.h"
#include "demo_run.h"
#include "image_output.h"
#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"
#include "modrt/platform/gl_context.h"
#include "modrt/precompute/dictionary_cache.h"
#include "scene/default_scene.h"
#include "scene/gltf_scene.h"

namespace {

using namespace modrt;
using namespace modrt::demo;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modrt-demo: real-time indirect light (Modular Radiance Transfer) in an offscreen render"};
  std::string direct_name = "gpu", backend_name = "gles", platform_name = "auto", size = "960x540",
              out_dir = "out/demo", output = "combined";
  std::string scene_file, dictionary_path;
  int frames = 48, modes = 32, res = 16, bounces = kDemoConverged, every = 1;
  float exposure = 1.0f;
  bool exr = true, drt = true;
  app.add_option("--backend", backend_name, "Indirect light on the GPU (gles) or the SIMD CPU runtime (cpu)")
      ->check(CLI::IsMember({"gles", "cpu"}))
      ->capture_default_str();
  app.add_option("--direct", direct_name,
                 "Direct light at the proxy samples: GL pass with the shadow cube map (gpu) or the CPU "
                 "evaluator with proxy-wall shadows (cpu)")
      ->check(CLI::IsMember({"gpu", "cpu"}))
      ->capture_default_str();
  app.add_option("--platform", platform_name, "GL context: egl (surfaceless), egl-device, osmesa or auto")
      ->capture_default_str();
  app.add_option("--frames", frames, "Frames to render (the light loops every 96)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--size", size, "Image size WxH")->capture_default_str();
  app.add_option("--out", out_dir, "Output directory for frame_NNNN.png / .exr")->capture_default_str();
  app.add_option("--every", every, "Write every Nth frame (the last one always)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--output", output, "What the images show")
      ->check(CLI::IsMember({"combined", "direct", "indirect"}))
      ->capture_default_str();
  app.add_option("--modes", modes, "Indirect modes kb (and kr) of the dictionary")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--res", res, "Lightmap texels per proxy face edge")
      ->check(CLI::Range(2, 64))
      ->capture_default_str();
  app.add_option(
         "--bounces", bounces,
         "Multi-bounce: N >= 0 feedback steps per frame (exactly N extra bounces); -1: the converged "
         "multi-bounce where the backend has it (cpu; gles without clutter), else 4 steps every frame")
      ->check(CLI::Range(-1, 16))
      ->capture_default_str();
  app.add_option("--exposure", exposure, "Exposure before tone mapping (multiplies the linear image)")
      ->check(FiniteRange(1e-6, 1e6))
      ->capture_default_str();
  app.add_option("--dictionary", dictionary_path, "Load this dictionary file instead of the cache");
  std::string level_file;
  CLI::Option* scene_option =
      app.add_option("--scene", scene_file,
                     "glTF 2.0 scene (.gltf or .glb; proxy blocks from --level, <scene>.level.json or nodes "
                     "marked extras.modrt_block, docs/demo.md); default: the built-in scene");
  // The built-in scene has its own level: --level alone would be silently ignored.
  app.add_option("--level", level_file, "With --scene: the level JSON giving the proxy blocks")
      ->needs(scene_option);
  float animation_fps = GltfSceneOptions{}.animation_fps;
  app.add_option("--animation-fps", animation_fps,
                 "With --scene: demo frames per second of the glTF animations (key time t is frame t x this)")
      ->check(FiniteRange(1e-3, 1e6))
      ->needs(scene_option)
      ->capture_default_str();
  app.add_flag("!--no-exr", exr, "Do not write the linear EXR files");
  int drt_rays = DemoRunOptions{}.drt_rays;
  app.add_option("--drt-rays", drt_rays, "Rays per scene sample and clutter texel of the DRT operator build")
      ->check(CLI::Range(8, 65536))
      ->capture_default_str();
  std::string save_clutter;
  app.add_option(
      "--save-clutter", save_clutter,
      "Write the scene's DRT clutter operators to FILE.modrtdrt (core's drt_io.h) after they are built");
  bool camera_skip = DemoRunOptions{}.camera_skip;
  app.add_flag(
      "!--no-camera-skip", camera_skip,
      "Write every block's lightmap tiles, not only those the camera can see (the image is the same)");
  app.add_flag("!--no-drt", drt,
               "Without Delta Radiance Transfer: the scene's clutter meshes are drawn as ordinary "
               "geometry mapped onto the proxies (MRT alone), for comparison");
  CLI11_PARSE(app, argc, argv);
  int width = 0, height = 0;
  if (std::sscanf(size.c_str(), "%dx%d", &width, &height) != 2 || width < 16 || height < 16 || width > 8192 ||
      height > 8192) {
    std::fprintf(stderr, "modrt-demo: --size %s: expected WxH, each 16..8192\n", size.c_str());
    return 2;
  }
  platform::ContextRequest request{};
  if (!platform::parse_context_request(platform_name == "egl" ? "egl-surfaceless" : platform_name,
                                       &request)) {
    std::fprintf(stderr, "modrt-demo: --platform %s: expected egl, egl-device, osmesa or auto\n",
                 platform_name.c_str());
    return 2;
  }
  const OutputMode mode = output == "direct"     ? OutputMode::direct
                          : output == "indirect" ? OutputMode::indirect
                                                 : OutputMode::combined;

  // The output directory before anything slow (issue 18 item 9: a first-run bake takes
  // minutes): created here and probed with a file.
  if (Status s = check_writable_directory(out_dir); !s.ok()) {
    std::fprintf(stderr, "modrt-demo: --out: %s\n", s.to_string().c_str());
    return 1;
  }
  if (!save_clutter.empty()) {
    if (!drt) {
      std::fprintf(stderr, "modrt-demo: --save-clutter needs the DRT operators: not with --no-drt\n");
      return 2;
    }
    if (Status s = check_writable_file(save_clutter); !s.ok()) {
      std::fprintf(stderr, "modrt-demo: --save-clutter: %s\n", s.to_string().c_str());
      return 1;
    }
  }

  // ---- scene, dictionary, level ----
  // The scene first: a bad file is refused before a dictionary bake of many seconds.
  const Clock::time_point t_setup = Clock::now();
  std::vector<std::string> warnings;
  Result<DemoScene> scene = Status::success();
  if (scene_file.empty()) {
    scene = default_scene();
  } else {
    GltfSceneOptions gltf;
    gltf.level_path = level_file;
    gltf.animation_fps = animation_fps;
    gltf.warnings = &warnings;
    scene = load_gltf_scene(scene_file, gltf);
  }
  for (const std::string& w : warnings) std::fprintf(stderr, "modrt-demo: warning: %s\n", w.c_str());
  if (!scene.ok()) {
    std::fprintf(stderr, "modrt-demo: scene: %s\n", scene.status().to_string().c_str());
    return 1;
  }
  Result<Dictionary> dict = Status::success();
  Result<Matrix> interface_basis = Status::error(ErrorCode::invalid_argument, "--dictionary: no basis");
  if (!dictionary_path.empty()) {
    dict = load_dictionary(dictionary_path);
  } else {
    DictionarySettings settings;
    settings.res = std::uint32_t(res);
    settings.kb = settings.kr = std::uint32_t(modes);
    precompute::BakeProgress progress;
    progress.on_stage = [](const std::string& stage, int s, double seconds) {
      if (s >= 0)
        std::printf("  bake shape %d (%s): %-18s %6.2f s\n", s, dictionary_shape_name(s), stage.c_str(),
                    seconds);
      else
        std::printf("  bake %-30s %6.2f s\n", stage.c_str(), seconds);
      std::fflush(stdout);
    };
    dict = precompute::load_or_bake_dictionary(settings, precompute::default_cache_dir(), progress,
                                               [](const std::string& m) { std::printf("%s\n", m.c_str()); });
    // Shaped blocks' interfaces (a few seconds' re-bake for a dictionary cached without it).
    if (dict.ok() && settings.lightfield_spatial > 0) {
      interface_basis = precompute::load_or_bake_interface_basis(
          settings, precompute::default_cache_dir(), progress,
          [](const std::string& m) { std::printf("%s\n", m.c_str()); });
      if (!interface_basis.ok())
        std::fprintf(stderr,
                     "modrt-demo: warning: %s; stretched blocks connected to others keep cube operators\n",
                     interface_basis.status().to_string().c_str());
    }
  }
  if (!dict.ok()) {
    std::fprintf(stderr, "modrt-demo: dictionary: %s\n", dict.status().to_string().c_str());
    return 1;
  }
  if (!drt && !scene->clutter.empty()) {
    // MRT alone: the clutter meshes become detail geometry lit through the proxies' lightmaps.
    scene->clutter.clear();
    for (Mesh& m : scene->meshes) m.clutter = -1, m.lightmap_uv.clear();
  }

  // ---- GL context and the run (level, renderer, backend) ----
  Result<std::unique_ptr<platform::GlContext>> context = platform::create_context(request);
  if (!context.ok()) {
    std::fprintf(stderr, "modrt-demo: GL context: %s\n", context.status().to_string().c_str());
    return 1;
  }
  platform::GlContext& ctx = *context.value();
  std::printf("modrt-demo: %s\n  GL: %s | %s\n%s\n", scene->name.c_str(), ctx.info().renderer.c_str(),
              ctx.info().version.c_str(), ctx.info().selection_report.c_str());
  DemoRunOptions options;
  options.backend = backend_name == "cpu" ? DemoBackend::cpu : DemoBackend::gles;
  options.direct = direct_name == "cpu" ? DemoDirect::cpu : DemoDirect::gpu;
  options.renderer.width = width;
  options.renderer.height = height;
  options.output = mode;
  options.exposure = exposure;
  options.bounces = bounces;
  options.drt_rays = drt_rays;
  options.camera_skip = camera_skip;
  options.save_clutter = save_clutter;
  options.shaped_cache_dir = precompute::default_cache_dir();
  options.drt_cache_dir = precompute::default_cache_dir();
  options.interface_basis = interface_basis.ok() ? &interface_basis.value() : nullptr;
  Result<std::unique_ptr<DemoRun>> run = DemoRun::create(scene.value(), dict.value(), ctx, options);
  if (!run.ok()) {
    std::fprintf(stderr, "modrt-demo: %s\n", run.status().to_string().c_str());
    return 1;
  }
  const Level& level = run.value()->level();
  std::printf(
      "  %zu blocks, %u samples, res %d, kb %u, %zu Tb->r records; %zu mapped triangles (from %zu static "
      "triangles, %zu of them cut at block boundaries, %zu partly in no block); backend: %s\n"
      "  setup %.1f s\n",
      level.blocks.size(), level.sample_count, level.res, level.kb, level.records.size(),
      run.value()->mapped_triangles(), run.value()->static_triangles(), run.value()->split_triangles(),
      run.value()->outside_triangles(), run.value()->backend().description(), ms_since(t_setup) / 1000.0);
  if (!level.shaped.empty()) {
    std::size_t blocks = 0;
    for (const LevelBlock& b : level.blocks) blocks += b.shaped >= 0;
    std::printf("  shaped operators: %zu sets for %zu blocks that are not cubes%s\n", level.shaped.size(),
                blocks,
                options.interface_basis ? "" : " (connected blocks keep cube operators: no interface basis)");
  }
  if (const DrtStartup& d = run.value()->drt_startup(); d.objects > 0) {
    if (!d.rebuilt.empty()) std::printf("  DRT: cached operators not used (%s)\n", d.rebuilt.c_str());
    if (!d.state_unused.empty()) std::printf("  DRT: build state not used (%s)\n", d.state_unused.c_str());
    std::string how = precompute::drt_cache_source_name(d.source);
    if (d.source == precompute::DrtCacheSource::incremental) {
      how += d.retraced.size() == 1 ? " (re-traced object" : " (re-traced objects";
      for (std::size_t i = 0; i < d.retraced.size(); ++i)
        how += (i ? ", " : " ") + std::to_string(d.retraced[i]);
      how += ")";
    }
    const bool loaded = d.source == precompute::DrtCacheSource::loaded;
    std::printf("  DRT: %zu clutter objects, %zu texels; operators %s in %.2f s, %.2f MB%s%s\n", d.objects,
                d.texels, how.c_str(), d.seconds, double(d.bytes) / 1e6,
                d.cache_file.empty() ? ""
                : loaded             ? " from "
                                     : ", saved to ",
                d.cache_file.c_str());
  } else if (!drt)
    std::printf("  DRT: off (--no-drt)\n");

  std::vector<float> linear(3 * std::size_t(width) * std::size_t(height)), flipped(linear.size());
  std::vector<std::uint8_t> srgb(linear.size());
  std::vector<std::string> written;
  double write_ms = 0.0;
  for (int frame = 0; frame < frames; ++frame) {
    if (Status s = run.value()->render(frame, linear, srgb); !s.ok()) {
      std::fprintf(stderr, "\nmodrt-demo: frame %d: %s\n", frame, s.to_string().c_str());
      return 1;
    }
    const Clock::time_point t = Clock::now();
    if (frame % every == 0 || frame == frames - 1) {
      char name[64];
      std::snprintf(name, sizeof name, "frame_%04d", frame);
      const std::string base = (std::filesystem::path(out_dir) / name).string();
      if (Status w = write_rgb8_image(base + ".png", width, height, srgb); !w.ok()) {
        std::fprintf(stderr, "\nmodrt-demo: %s\n", w.to_string().c_str());
        return 1;
      }
      written.push_back(base + ".png");
      if (exr) {
        for (int y = 0; y < height; ++y)  // GL rows run bottom to top
          std::copy_n(linear.begin() + 3 * std::ptrdiff_t(height - 1 - y) * width, 3 * width,
                      flipped.begin() + 3 * std::ptrdiff_t(y) * width);
        if (Status w = write_rgb_float_image(base + ".exr", width, height, flipped); !w.ok()) {
          std::fprintf(stderr, "\nmodrt-demo: %s\n", w.to_string().c_str());
          return 1;
        }
      }
    }
    write_ms += ms_since(t);
    const int filled = (frame + 1) * 30 / frames;  // progress bar
    std::fprintf(stderr, "\r  [%.*s%.*s] frame %d/%d", filled, "##############################", 30 - filled,
                 "                              ", frame + 1, frames);
  }
  std::fprintf(stderr, "\n");
  const StageTimes& total = run.value()->times();
  const double n = double(frames);
  const bool gles_backend = options.backend == DemoBackend::gles;
  std::printf("per-stage time per frame (mean of %d frames, ms; wall clock, glFinish after each stage):\n",
              frames);
  std::printf("  shadows (%zu cube shadow map%s, 6 faces each) %8.3f\n", scene->lights.size(),
              scene->lights.size() == 1 ? "" : "s", total.shadows / n);
  std::printf("  direct (ld at the proxy samples, %s)     %8.3f\n",
              options.direct == DemoDirect::cpu ? "CPU evaluator"
              : gles_backend                    ? "GL pass, stays on the GPU"
                                                : "GL pass + readback",
              total.direct / n);
  const std::string steps =
      run.value()->converged()
          ? std::string("converged solve")
          : "update + " + std::to_string(run.value()->feedback_steps()) + " feedback steps";
  std::printf("  indirect (%s backend: %s%s) %8.3f\n", gles_backend ? "gles" : "cpu", steps.c_str(),
              gles_backend ? "" : ", atlas upload", total.indirect / n);
  if (camera_skip) {
    const BackendEvaluationStats es = run.value()->backend().evaluation_stats();
    std::printf(
        "    camera skip: %zu of %zu blocks visible in the last frame; tiles written %llu, hidden %llu, "
        "caught up %llu; probe blocks computed %llu, on read %llu\n",
        run.value()->visible_blocks(), level.blocks.size(), (unsigned long long)es.tiles_written,
        (unsigned long long)es.tiles_hidden, (unsigned long long)es.tiles_caught_up,
        (unsigned long long)es.probe_blocks_computed, (unsigned long long)es.probe_blocks_caught_up);
  }
  if (gles_backend)
    std::printf(
        "    first update's passes: b %.3f, r %.3f, lightmaps + padding %.3f, probes %.3f, vector %.3f\n",
        total.b / n, total.r / n, total.lightmaps / n, total.probes / n, total.vector / n);
  if (run.value()->drt_startup().objects > 0)
    std::printf("    DRT: clutter direct light (in direct) %.3f, clutter lightmap %s (in indirect) %.3f\n",
                total.clutter_direct / n, gles_backend ? "gathered on the GPU" : "read back + uploaded",
                total.clutter_lightmap / n);
  std::printf("  render (camera image, tone map, readback)  %8.3f\n", total.render / n);
  std::printf("  write images                               %8.3f\n", write_ms / n);
  std::printf("vector irradiance on normal maps: %s\n",
              run.value()->vector_irradiance() ? "yes" : "no (the dictionary has no vector operators)");
  std::printf("wrote %zu frames, last: %s\n", written.size(), written.empty() ? "-" : written.back().c_str());
  return 0;
}
