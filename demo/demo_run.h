// SPDX-License-Identifier: MIT
// modrt demo — one demo run: a scene, its built level, the renderer and the backend, and the
// per-frame pipeline (shadow map, ld at the proxy samples, indirect light, camera image).
// Used by modrt-demo and by the demo's golden-image tests.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "modrt/backend.h"
#include "modrt/cpu/direct_light.h"
#include "modrt/dictionary.h"
#include "modrt/drt.h"
#include "modrt/frame_pipeline.h"
#include "modrt/level.h"
#include "modrt/level_visibility.h"
#include "modrt/platform/gl_context.h"
#include "modrt/precompute/drt_cache.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/probe_sampler.h"
#include "render/scene_renderer.h"
#include "scene/demo_scene.h"

namespace modrt::demo {

enum class DemoBackend { gles, cpu };
// Who computes ld at the proxy samples: the GL pass over the geometry images with the camera
// image's shadow cube map (shadows from every mesh), or modrt::cpu::CpuDirectLight (shadows
// from the proxy walls only; no GPU needed for the lightmaps).
enum class DemoDirect { gpu, cpu };

inline constexpr int kDemoConverged = -1;

struct DemoRunOptions {
  DemoBackend backend = DemoBackend::gles;
  DemoDirect direct = DemoDirect::gpu;
  RendererOptions renderer;
  OutputMode output = OutputMode::combined;
  float exposure = 1.0f;
  // Multi-bounce: kDemoConverged (the default) is the converged multi-bounce every frame where
  // the backend has it (Backend::converged_available: the CPU backend, clutter included; GLES
  // without clutter), else the frame pipeline's kConvergedFallbackSteps feedback steps every frame; N >= 0 is
  // exactly N feedback steps every frame.
  int bounces = -1;
  // DRT for the scene's clutter (docs/drt.md): operators built at create(). The clutter
  // meshes need it (they are lit by the clutter lightmap); a caller that turns it off must
  // pass a scene whose clutter is ordinary geometry (demo_main's --no-drt does that).
  // DrtBuildSettings::rays. At 256 the shadow delta under furniture is visibly mottled
  // (docs/demo.md: the imported flat's table at 256, 1024 and 4096 rays); 1024 is as smooth
  // as 4096, and the operators are built once (drt_cache_dir).
  int drt_rays = 1024;
  // The camera skip (docs/cpu.md): the backend writes the lightmap tiles and atlas rectangles of
  // the blocks the camera can see only (CameraVisibility -> Backend::set_visible_blocks, each
  // frame); the image is the same, bit for bit (DemoRender.CameraSkipRendersTheSameImage).
  bool camera_skip = true;
  // When set: the DRT operators built at create() are written there (.modrtdrt, core's
  // drt_io.h), for an app that loads them without the precompute library.
  std::string save_clutter;
  // Where the level build keeps operators baked for blocks that are not cubes (MRT §8,
  // precompute/shaped_operators.h), so a second run loads them; empty: baked every run.
  std::string shaped_cache_dir;
  // Where the DRT operators are kept (precompute/drt_cache.h: named by a hash of the level,
  // dictionary, clutter and build settings), so a second start loads them; empty: built every
  // run.
  std::string drt_cache_dir;
  // The dictionary's interface basis (precompute::load_or_bake_interface_basis): with it,
  // stretched blocks connected to others get shaped operators too; null: only unconnected ones.
  const Matrix* interface_basis = nullptr;
};

// Wall-clock milliseconds per stage, summed over frames (glFinish closes each stage).
struct StageTimes {
  double shadows = 0, direct = 0, indirect = 0, render = 0;
  // GLES backend only, from its pass timers (GPU timer queries where the context has them):
  // the frame's first update; feedback steps repeat b, r and lightmaps.
  double b = 0, r = 0, lightmaps = 0, probes = 0, vector = 0;
  // DRT: the clutter's direct light (Embree, included in `direct`) and the clutter lightmap's
  // gather on the GPU (GLES backend) or readback and upload (CPU backend), included in `indirect`.
  double clutter_direct = 0, clutter_lightmap = 0;
};

// The DRT operator build at create().
struct DrtStartup {
  std::size_t objects = 0, texels = 0, bytes = 0;
  double seconds = 0.0;
  // Loaded from DemoRunOptions::drt_cache_dir, rebuilt there incrementally from the scene's
  // build state (only the objects in `retraced` changed since its build) or built.
  precompute::DrtCacheSource source = precompute::DrtCacheSource::built;
  std::vector<std::size_t> retraced;
  std::string cache_file;    // where they were loaded from or saved (empty: no cache)
  std::string rebuilt;       // why a cached file was not used (it was replaced), or empty
  std::string state_unused;  // why the scene's build state was not used (a full build), or empty
};

class DemoRun {
 public:
  // Builds the level against `dict`, maps the meshes onto it and creates the renderer and
  // the backend in `context` (current on this thread). `scene` and `dict` must outlive the run.
  // Every light of the scene (1 to kMaxDemoLights point or spot lights) lights every frame: a
  // shadow cube map each, their ld summed, all of them in the camera image and the clutter's
  // direct light.
  static Result<std::unique_ptr<DemoRun>> create(const DemoScene& scene, const Dictionary& dict,
                                                 platform::GlContext& context, const DemoRunOptions& options);
  ~DemoRun();

  // Renders frame `frame` of the animation: linear RGB (rows bottom to top) and sRGB8 (rows
  // top to bottom), each 3 x width x height.
  Status render(int frame, std::span<float> linear_rgb, std::span<std::uint8_t> srgb8);

  const Level& level() const { return level_; }
  // What every frame's indirect light runs: the converged solve, or one update and
  // feedback_steps() feedback steps. frame_steps() is what the pipeline is given
  // (kConvergedBounces by default: the solve, or the pipeline's fallback steps).
  bool converged() const { return converged_; }
  std::uint32_t frame_steps() const;
  std::uint32_t feedback_steps() const;
  const Backend& backend() const { return *backend_; }
  Backend& backend() { return *backend_; }
  const StageTimes& times() const { return times_; }
  // The camera skip: blocks the camera could see in the last frame (every block when it is off).
  std::size_t visible_blocks() const { return visible_blocks_; }
  std::size_t mapped_triangles() const { return mapped_triangles_; }
  // Static triangles given to the proxy mapping, those it cut at block boundaries, and those
  // with a part in no block (map_to_proxies).
  std::size_t static_triangles() const { return static_triangles_; }
  std::size_t split_triangles() const { return split_triangles_; }
  std::size_t outside_triangles() const { return outside_triangles_; }
  bool vector_irradiance() const { return vector_; }
  int width() const { return options_.renderer.width; }
  int height() const { return options_.renderer.height; }
  // The last frame's ld (3 per sample), every light's summed. With the GLES backend and the GPU
  // pass it stays on the GPU during the frame; this reads it back (for tests and tools, not per
  // frame).
  std::span<const float> ld();
  // DRT (empty without clutter): the build, the clutter's ld and clutter lightmap of the
  // last frame (3 per clutter texel).
  const DrtStartup& drt_startup() const { return drt_startup_; }
  std::span<const float> clutter_ld() const { return clutter_ld_; }
  // With the GLES backend the clutter lightmap stays on the GPU during the frame; this reads it
  // back (for tests and tools, not per frame).
  std::span<const float> clutter_lightmap();

 private:
  DemoRun() = default;
  Status clutter_light(const FrameState& state);
  const DemoScene* scene_ = nullptr;
  const Dictionary* dict_ = nullptr;
  platform::GlContext* context_ = nullptr;
  DemoRunOptions options_;
  Level level_;
  std::unique_ptr<SceneRenderer> renderer_;
  // DRT: the operators (borrowed by the backend, so they outlive it), the walls plus clutter
  // for the clutter's shadowed direct light, and the clutter texels' positions (spot cones).
  std::unique_ptr<DrtOperators> drt_;
  std::unique_ptr<precompute::LevelScene> clutter_scene_;
  std::vector<glm::dvec3> clutter_position_;
  std::vector<float> clutter_ld_, clutter_lightmap_;
  DrtStartup drt_startup_;
  std::unique_ptr<Backend> backend_;
  std::optional<FramePipeline> pipeline_;              // the frame sequence over backend_
  int bounces_option_ = kDemoConverged;                // DemoRunOptions::bounces
  bool converged_ = false;                             // the converged solve every frame
  std::unique_ptr<cpu::CpuDirectLight> cpu_direct_;    // DemoDirect::cpu
  std::unique_ptr<gles::GlesDirectLight> gpu_direct_;  // DemoDirect::gpu
  std::vector<float> ld_, atlas_, probes_, vector_lightmap_, coefficient_;
  // The probe volume: the dynamic object's cell in it, and for a CPU backend its probes in the
  // world frame (probes_ is empty with a GLES backend: its world_probe_texture is sampled).
  ProbeSampler probe_sampler_;
  std::vector<float> world_probes_;
  CameraVisibility camera_visibility_;  // DemoRunOptions::camera_skip
  std::size_t visible_blocks_ = 0;
  std::size_t mapped_triangles_ = 0, static_triangles_ = 0, split_triangles_ = 0, outside_triangles_ = 0;
  bool vector_ = false;
  StageTimes times_;
};

// Catmull-Rom through the closed loop of keys, t in [0, 1) once around.
glm::vec3 path_point(const std::vector<glm::vec3>& keys, double t);
// A KeyTrack at `frame` (demo frames, wrapped into [0, period) when period > 0): the first key's
// value before it, the last key's after it, and between keys k and k + 1 with s = (frame -
// times[k]) / (times[k + 1] - times[k]): STEP key k's value, LINEAR the mix of the two, CUBICSPLINE
// glTF's Hermite spline through the values with the out-tangent of k and the in-tangent of k + 1
// times (times[k + 1] - times[k]). An empty track gives (0, 0, 0).
glm::vec3 track_point(const KeyTrack& track, double frame);
// Where a light is at `frame`: its track when it has keys, else its path (one loop per period).
glm::vec3 light_position(const DemoLight& light, int frame);
// The light as modrt::cpu's evaluator takes it (type from the cones and `directional`), at
// `position` (light_position of the frame).
cpu::CpuLight cpu_light(const DemoLight& light, const glm::vec3& position);
// The dynamic meshes' offset at `frame`: DemoScene::dynamic_track, else dynamic_path.
glm::vec3 dynamic_offset(const DemoScene& scene, int frame);

}  // namespace modrt::demo
