// modrt-demo: the offscreen demo (README's main command). Renders the built-in default scene
// (scene/default_scene.h) with OpenGL ES 3 through EGL (or OSMesa): a point light moving
// through a warped 11-block maze, its shadow cube map giving direct light to the camera image
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
#include <glm/geometric.hpp>

#include "image_output.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/dictionary_io.h"
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/level_runtime.h"
#include "modrt/platform/gl_context.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "render/scene_renderer.h"
#include "scene/default_scene.h"
#include "scene/proxy_mapping.h"

namespace {

using namespace modrt;
using namespace modrt::demo;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Catmull-Rom through the closed loop of keys, t in [0, 1).
glm::vec3 path_point(const std::vector<glm::vec3>& keys, double t) {
  if (keys.empty()) return glm::vec3(0.0f);
  if (keys.size() == 1) return keys[0];
  const double x = (t - std::floor(t)) * double(keys.size());
  const int n = int(keys.size()), i = int(x) % n;
  const float u = float(x - std::floor(x));
  const glm::vec3 p0 = keys[std::size_t((i + n - 1) % n)], p1 = keys[std::size_t(i)],
                  p2 = keys[std::size_t((i + 1) % n)], p3 = keys[std::size_t((i + 2) % n)];
  return 0.5f * ((2.0f * p1) + (-p0 + p2) * u + (2.0f * p0 - 5.0f * p1 + 4.0f * p2 - p3) * u * u +
                 (-p0 + 3.0f * p1 - 3.0f * p2 + p3) * u * u * u);
}

// E/pi SH9 of the probe volume at world point x (trilinear between the g^3 probes of the
// block containing x, canonical block frame) and the world -> canonical rotation.
void probe_lighting(const Level& level, std::span<const float> probes, int grid, const glm::vec3& x,
                    FrameState& frame) {
  std::size_t block = 0;
  double best = 1e30;
  glm::dvec3 p(0.5);
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const glm::dvec3 q = world_to_block(level.blocks[i], glm::dvec3(x));
    double out = 0.0;
    for (int a = 0; a < 3; ++a) out = std::max({out, -q[a], q[a] - 1.0});
    if (out < best) best = out, block = i, p = q;
  }
  const std::size_t rows = 9 * std::size_t(grid) * std::size_t(grid) * std::size_t(grid);
  const float* base = probes.data() + 3 * rows * block;
  glm::vec3 sh[9] = {};
  glm::dvec3 g = glm::clamp(p * double(grid) - 0.5, glm::dvec3(0.0), glm::dvec3(grid - 1));
  const glm::ivec3 i0 = glm::min(glm::ivec3(glm::floor(g)), glm::ivec3(grid - 2 < 0 ? 0 : grid - 2));
  const glm::dvec3 f = grid > 1 ? g - glm::dvec3(i0) : glm::dvec3(0.0);
  for (int c = 0; c < 8; ++c) {
    const glm::ivec3 o(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    const glm::ivec3 q = glm::min(i0 + o, glm::ivec3(grid - 1));
    const double w = (o.x ? f.x : 1 - f.x) * (o.y ? f.y : 1 - f.y) * (o.z ? f.z : 1 - f.z);
    const std::size_t probe = std::size_t(q.x + grid * (q.y + grid * q.z));
    for (int k = 0; k < 9; ++k)
      for (int ch = 0; ch < 3; ++ch)
        sh[k][ch] += float(w) * base[3 * (9 * probe + std::size_t(k)) + std::size_t(ch)];
  }
  // Radiance -> E/pi: band l scaled by A_l / pi = 1, 2/3, 1/4 (sh.h).
  for (int k = 0; k < 9; ++k)
    frame.probe_sh[std::size_t(k)] = sh[k] * (k == 0 ? 1.0f : k < 4 ? 2.0f / 3.0f : 0.25f);
  const int turns = level.blocks[block].quarter_turns;
  for (int a = 0; a < 3; ++a) {
    glm::dvec3 e(0.0);
    e[a] = 1.0;
    frame.to_canonical[a] = glm::vec3(rotate_direction(e, -turns));
  }
}

struct StageTimes {
  double shadows = 0, direct = 0, indirect = 0, render = 0, write = 0;
  // GLES backend only: its passes (GPU timer queries, or CPU time around glFinish).
  double b = 0, r = 0, lightmaps = 0, probes = 0, vector = 0;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modrt-demo: real-time indirect light (Modular Radiance Transfer) in an offscreen render"};
  std::string backend_name = "gles", platform_name = "auto", size = "960x540", out_dir = "out/demo",
              output = "combined";
  std::string scene_file, dictionary_path;
  int frames = 48, modes = 32, res = 16, bounces = 2, every = 1;
  float exposure = 1.0f;
  bool exr = true;
  app.add_option("--backend", backend_name, "Indirect light on the GPU (gles) or the SIMD CPU runtime (cpu)")
      ->check(CLI::IsMember({"gles", "cpu"}))
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
  app.add_option("--bounces", bounces, "Extra indirect bounces (multi-bounce feedback steps) per frame")
      ->check(CLI::Range(0, 16))
      ->capture_default_str();
  app.add_option("--exposure", exposure, "Exposure before tone mapping")->capture_default_str();
  app.add_option("--dictionary", dictionary_path, "Load this dictionary file instead of the cache");
  app.add_option("--scene", scene_file, "glTF 2.0 scene (not available yet: the built-in scene is rendered)");
  app.add_flag("!--no-exr", exr, "Do not write the linear EXR files");
  CLI11_PARSE(app, argc, argv);
  if (!scene_file.empty()) {
    std::fprintf(stderr, "modrt-demo: --scene %s: glTF scenes are not supported by this build yet\n",
                 scene_file.c_str());
    return 2;
  }
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

  // ---- dictionary, scene, level ----
  const Clock::time_point t_setup = Clock::now();
  Result<Dictionary> dict = Status::success();
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
  }
  if (!dict.ok()) {
    std::fprintf(stderr, "modrt-demo: dictionary: %s\n", dict.status().to_string().c_str());
    return 1;
  }
  Result<DemoScene> scene = default_scene();
  if (!scene.ok()) {
    std::fprintf(stderr, "modrt-demo: scene: %s\n", scene.status().to_string().c_str());
    return 1;
  }
  Result<Level> level = precompute::build_level(scene->level, dict.value());
  if (!level.ok()) {
    std::fprintf(stderr, "modrt-demo: level: %s\n", level.status().to_string().c_str());
    return 1;
  }
  const std::vector<float> albedo = precompute::level_albedo(level.value(), scene->level);
  Result<std::vector<MappedMesh>> mapped = map_to_proxies(scene.value(), level.value());
  if (!mapped.ok()) {
    std::fprintf(stderr, "modrt-demo: %s\n", mapped.status().to_string().c_str());
    return 1;
  }
  std::size_t triangles = 0;
  for (const MappedMesh& m : mapped.value()) triangles += m.vertices.size() / 3;

  // ---- GL context, renderer, backend ----
  Result<std::unique_ptr<platform::GlContext>> context = platform::create_context(request);
  if (!context.ok()) {
    std::fprintf(stderr, "modrt-demo: GL context: %s\n", context.status().to_string().c_str());
    return 1;
  }
  platform::GlContext& ctx = *context.value();
  const platform::GlFunctions& gl = ctx.gl();
  std::printf("modrt-demo: %s\n  GL: %s | %s\n%s\n", scene->name.c_str(), ctx.info().renderer.c_str(),
              ctx.info().version.c_str(), ctx.info().selection_report.c_str());
  RendererOptions ropt;
  ropt.width = width;
  ropt.height = height;
  Result<std::unique_ptr<SceneRenderer>> renderer =
      SceneRenderer::create(gl, ctx.info().gles, scene.value(), mapped.value(), level.value(), albedo, ropt);
  if (!renderer.ok()) {
    std::fprintf(stderr, "modrt-demo: %s\n", renderer.status().to_string().c_str());
    return 1;
  }
  std::unique_ptr<Backend> backend;
  gles::GlesLevelRuntime* gles_runtime = nullptr;
  if (backend_name == "gles") {
    gles::GlesRuntimeOptions options;
    options.vector_irradiance = check_level_vector_operators(level.value(), dict.value()).ok();
    Result<std::unique_ptr<gles::GlesLevelRuntime>> rt =
        gles::GlesLevelRuntime::create(gl, ctx.info().gles, level.value(), dict.value(), options);
    if (!rt.ok()) {
      std::fprintf(stderr, "modrt-demo: GLES backend: %s\n", rt.status().to_string().c_str());
      return 1;
    }
    gles_runtime = rt.value().get();
    gles_runtime->set_timing(true);
    backend = std::move(rt).value();
  } else {
    Result<std::unique_ptr<Backend>> be = cpu::create_cpu_backend(level.value(), dict.value());
    if (!be.ok()) {
      std::fprintf(stderr, "modrt-demo: CPU backend: %s\n", be.status().to_string().c_str());
      return 1;
    }
    backend = std::move(be).value();
  }
  if (Status s = backend->set_albedo(albedo); !s.ok()) {
    std::fprintf(stderr, "modrt-demo: %s\n", s.to_string().c_str());
    return 1;
  }
  const LevelBufferSizes& sizes = backend->sizes();
  const bool has_probes = sizes.probes > 0;
  const bool has_vector = check_level_vector_operators(level.value(), dict.value()).ok();
  const int probe_grid = int(dict->settings.probe_grid);
  std::printf(
      "  %zu blocks, %u samples, res %d, kb %u, %zu Tb->r records; %zu mapped triangles; backend: %s\n"
      "  setup %.1f s\n",
      level->blocks.size(), level->sample_count, level->res, level->kb, level->records.size(), triangles,
      backend->description(), ms_since(t_setup) / 1000.0);

  std::vector<float> ld(sizes.ld), atlas(sizes.atlas), probes(sizes.probes), vec(sizes.vector_lightmap);
  std::vector<float> linear(3 * std::size_t(width) * std::size_t(height));
  std::vector<std::uint8_t> srgb(linear.size());
  std::vector<float> flipped(linear.size());
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  StageTimes total;
  const DemoLight& light = scene->lights.front();
  std::vector<std::string> written;
  for (int frame = 0; frame < frames; ++frame) {
    FrameState state;
    state.camera = scene->camera;
    state.light_position = path_point(light.path, double(frame) / double(light.period));
    state.light_rgb = light.color * light.intensity;
    state.light_radius = light.radius;
    state.dynamic_offset = path_point(scene->dynamic_path, double(frame) / double(scene->dynamic_period));
    state.output = mode;
    state.exposure = exposure;

    Clock::time_point t = Clock::now();
    Status s = renderer.value()->render_shadows(state);
    gl.glFinish();
    total.shadows += ms_since(t);
    t = Clock::now();
    if (s.ok()) s = renderer.value()->compute_ld(state, ld);
    total.direct += ms_since(t);
    // Indirect: one update, then feedback steps (the first frame converges further).
    t = Clock::now();
    if (s.ok()) s = backend->update(ld);
    if (gles_runtime) {
      const gles::GlesPassTimes& pt = gles_runtime->pass_times();
      total.b += double(pt.b) * 1e-6, total.r += double(pt.r) * 1e-6,
          total.lightmaps += double(pt.atlas) * 1e-6, total.probes += double(pt.probes) * 1e-6,
          total.vector += double(pt.vector) * 1e-6;
    }
    const int steps = frame == 0 ? 3 * bounces : bounces;
    for (int k = 0; k < steps && s.ok(); ++k) s = backend->multi_bounce_step(ld);
    if (s.ok() && has_probes) s = backend->read_probes(probes);
    GLuint atlas_texture = 0;
    if (s.ok()) {
      if (gles_runtime) {
        atlas_texture = gles_runtime->atlas_texture();
        for (int i = 0; i < 4; ++i) state.vector_atlas[std::size_t(i)] = gles_runtime->vector_texture(i);
      } else if ((s = backend->read_atlas(atlas)).ok()) {
        Result<GLuint> up = renderer.value()->upload_atlas(atlas);
        if (up.ok())
          atlas_texture = up.value();
        else
          s = up.status();
      }
    }
    gl.glFinish();
    total.indirect += ms_since(t);
    if (!s.ok()) {
      std::fprintf(stderr, "\nmodrt-demo: frame %d: %s\n", frame, s.to_string().c_str());
      return 1;
    }
    state.atlas = atlas_texture;
    if (has_probes) probe_lighting(level.value(), probes, probe_grid, state.dynamic_offset, state);
    t = Clock::now();
    s = renderer.value()->render_image(state, linear, srgb);
    total.render += ms_since(t);
    if (!s.ok()) {
      std::fprintf(stderr, "\nmodrt-demo: frame %d: %s\n", frame, s.to_string().c_str());
      return 1;
    }
    t = Clock::now();
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
    total.write += ms_since(t);
    // Progress bar.
    const int filled = (frame + 1) * 30 / frames;
    std::fprintf(stderr, "\r  [%.*s%.*s] frame %d/%d", filled, "##############################", 30 - filled,
                 "                              ", frame + 1, frames);
  }
  std::fprintf(stderr, "\n");
  const double n = double(frames);
  std::printf("per-stage time per frame (mean of %d frames, ms; wall clock around glFinish):\n", frames);
  std::printf("  shadows (cube shadow map)       %8.3f\n", total.shadows / n);
  std::printf("  direct (ld at proxy samples)    %8.3f\n", total.direct / n);
  std::printf("  indirect (%s, %d bounce steps) %8.3f\n",
              backend->kind() == BackendKind::gles ? "gles" : "cpu", bounces, total.indirect / n);
  if (gles_runtime)
    std::printf(
        "    of which, first update: b %.3f, r %.3f, lightmaps + padding %.3f, probes %.3f, vector %.3f\n",
        total.b / n, total.r / n, total.lightmaps / n, total.probes / n, total.vector / n);
  std::printf("  render (camera image, tone map, readback) %8.3f\n", total.render / n);
  std::printf("  write images                    %8.3f\n", total.write / n);
  std::printf("vector irradiance on normal maps: %s\n",
              has_vector && gles_runtime ? "yes" : "no (scalar lightmap)");
  std::printf("wrote %zu frames, last: %s\n", written.size(), written.empty() ? "-" : written.back().c_str());
  return 0;
}
