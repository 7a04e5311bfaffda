// SPDX-License-Identifier: MIT
#include "demo_run.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "modrt/backends.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/drt_io.h"
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/drt_cache.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/shaped_operators.h"
#include "modrt/reference_runtime.h"
#include "scene/proxy_mapping.h"

namespace modrt::demo {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

}  // namespace

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

glm::vec3 track_point(const KeyTrack& track, double frame) {
  const std::vector<float>& times = track.times;
  const bool cubic = track.interpolation == KeyTrack::Interpolation::cubic;
  const std::size_t per_key = cubic ? 3 : 1;
  if (times.empty() || track.values.size() != per_key * times.size()) return glm::vec3(0.0f);
  const auto value = [&](std::size_t k) { return track.values[per_key * k + (cubic ? 1 : 0)]; };
  double t = frame;
  if (track.period > 0.0f && std::isfinite(track.period))
    t -= std::floor(t / double(track.period)) * double(track.period);
  if (t <= double(times.front())) return value(0);
  if (t >= double(times.back())) return value(times.size() - 1);
  const std::size_t k =
      std::size_t(std::upper_bound(times.begin(), times.end(), float(t)) - times.begin()) - 1;
  if (k + 1 >= times.size()) return value(times.size() - 1);  // t rounds to the last key in float
  const double dt = double(times[k + 1]) - double(times[k]);
  const float u = float(std::clamp((t - double(times[k])) / dt, 0.0, 1.0));
  switch (track.interpolation) {
    case KeyTrack::Interpolation::step: return value(k);
    case KeyTrack::Interpolation::linear: return glm::mix(value(k), value(k + 1), u);
    case KeyTrack::Interpolation::cubic: break;
  }
  const float u2 = u * u, u3 = u2 * u;
  const glm::vec3 out_tangent = track.values[3 * k + 2], in_tangent = track.values[3 * (k + 1)];
  return (2.0f * u3 - 3.0f * u2 + 1.0f) * value(k) + float(dt) * (u3 - 2.0f * u2 + u) * out_tangent +
         (-2.0f * u3 + 3.0f * u2) * value(k + 1) + float(dt) * (u3 - u2) * in_tangent;
}

glm::vec3 light_position(const DemoLight& light, int frame) {
  if (!light.track.times.empty()) return track_point(light.track, double(frame));
  return path_point(light.path, double(frame) / double(std::max(light.period, 1)));
}

cpu::CpuLight cpu_light(const DemoLight& light, const glm::vec3& position) {
  cpu::CpuLight l;
  l.type = light.directional              ? cpu::LightType::directional
           : light.outer_cone >= 3.14159f ? cpu::LightType::point
                                          : cpu::LightType::spot;
  l.position = position;
  l.direction = light.direction;
  l.color = light.color;
  l.intensity = light.intensity;
  l.radius = light.radius;
  l.inner_angle = std::min(light.inner_cone, light.outer_cone);
  l.outer_angle = std::min(light.outer_cone, 3.14159265f);
  return l;
}

glm::vec3 dynamic_offset(const DemoScene& scene, int frame) {
  if (!scene.dynamic_track.times.empty()) return track_point(scene.dynamic_track, double(frame));
  return path_point(scene.dynamic_path, double(frame) / double(std::max(scene.dynamic_period, 1)));
}

DemoRun::~DemoRun() = default;

std::uint32_t DemoRun::frame_steps() const {
  return bounces_option_ >= 0 ? std::uint32_t(bounces_option_) : kConvergedBounces;
}

std::uint32_t DemoRun::feedback_steps() const {
  return bounces_option_ >= 0 ? std::uint32_t(bounces_option_) : converged_ ? 0 : kConvergedFallbackSteps;
}

Result<std::unique_ptr<DemoRun>> DemoRun::create(const DemoScene& scene, const Dictionary& dict,
                                                 platform::GlContext& context,
                                                 const DemoRunOptions& options) {
  if (scene.lights.empty())
    return Status::error(
        ErrorCode::invalid_argument,
        "demo: the scene has no light (load_gltf_scene adds a default one; a scene built in code "
        "must have one)");
  if (scene.lights.size() > kMaxDemoLights)
    return Status::error(ErrorCode::invalid_argument,
                         "demo: the scene has " + std::to_string(scene.lights.size()) +
                             " lights; the demo renders at most " + std::to_string(kMaxDemoLights) +
                             " (kMaxDemoLights, a shadow cube map each; load_gltf_scene keeps the first " +
                             std::to_string(kMaxDemoLights) + " and names the others in a warning)");
  std::unique_ptr<DemoRun> run(new DemoRun());
  run->scene_ = &scene;
  run->dict_ = &dict;
  run->context_ = &context;
  run->options_ = options;
  precompute::ShapedOperatorCache shaped_cache(options.shaped_cache_dir);
  precompute::LevelBuildSettings build_settings;
  build_settings.shaped_cache = &shaped_cache;
  build_settings.interface_basis = options.interface_basis;
  Result<Level> level = precompute::build_level(scene.level, dict, build_settings);
  if (!level.ok()) return level.status();
  run->level_ = std::move(level).value();
  const Level& lv = run->level_;
  run->camera_visibility_ = CameraVisibility(lv);
  run->visible_blocks_ = lv.blocks.size();
  const std::vector<float> albedo = level_sample_albedo(lv);
  Result<std::vector<MappedMesh>> mapped = map_to_proxies(scene, lv);
  if (!mapped.ok()) return mapped.status();
  for (const MappedMesh& m : mapped.value()) {
    run->mapped_triangles_ += m.vertices.size() / 3;
    run->static_triangles_ += scene.meshes[std::size_t(m.mesh)].indices.size() / 3;
    run->split_triangles_ += std::size_t(m.triangles_split);
    run->outside_triangles_ += std::size_t(m.triangles_outside);
  }
  const platform::GlFunctions& gl = context.gl();
  Result<std::unique_ptr<SceneRenderer>> renderer =
      SceneRenderer::create(gl, context.info().gles, scene, mapped.value(), lv, albedo, options.renderer);
  if (!renderer.ok()) return renderer.status();
  run->renderer_ = std::move(renderer).value();
  run->vector_ = check_level_vector_operators(lv, dict).ok();
  BackendCreateInfo info;
  info.level = &lv;
  info.dict = &dict;
  info.vector_irradiance = run->vector_;
  info.timing = true;
  info.gl = &gl;
  info.gles_context = context.info().gles;
  Result<std::unique_ptr<Backend>> be =
      create_backend(options.backend == DemoBackend::gles ? BackendKind::gles : BackendKind::cpu, info);
  if (!be.ok()) return be.status();
  run->backend_ = std::move(be).value();
  FrameOptions frame;
  run->bounces_option_ = std::clamp(options.bounces, kDemoConverged, int(kMaxFrameBounces) / 3);
  Result<FramePipeline> pipeline = FramePipeline::create(*run->backend_, frame);
  if (!pipeline.ok()) return pipeline.status();
  run->pipeline_.emplace(std::move(pipeline).value());
  if (Status s = run->pipeline_->set_albedo(albedo); !s.ok()) return s;
  if (!scene.clutter.empty()) {
    // DRT operators once for the static clutter; the light moves, the clutter does not.
    const Clock::time_point t0 = Clock::now();
    precompute::DrtBuildSettings settings;
    settings.rays = options.drt_rays;
    Result<precompute::DrtCacheResult> drt =
        precompute::load_or_build_drt(lv, dict, scene.clutter, settings, options.drt_cache_dir);
    if (!drt.ok()) return drt.status();
    run->drt_startup_.source = drt->source;
    run->drt_startup_.retraced = drt->retraced;
    run->drt_startup_.cache_file = drt->path;
    run->drt_startup_.rebuilt = drt->rebuilt;
    run->drt_startup_.state_unused = drt->state_unused;
    run->drt_ = std::make_unique<DrtOperators>(std::move(drt->operators));
    run->drt_startup_.seconds = ms_since(t0) * 1e-3;
    run->drt_startup_.objects = scene.clutter.size();
    run->drt_startup_.bytes = run->drt_->storage_bytes();
    if (!options.save_clutter.empty())
      if (Status s = save_drt(options.save_clutter, *run->drt_); !s.ok()) return s;
    if (Status s = run->pipeline_->set_clutter(run->drt_.get()); !s.ok()) return s;
    // Multi-bounce feeds the clutter's own indirect light back too (docs/drt.md, "Multi-bounce").
    std::vector<float> clutter_albedo;
    for (const ClutterObject& object : scene.clutter)
      for (int t = 0; t < clutter_texel_count(object); ++t)
        for (int c = 0; c < 3; ++c) clutter_albedo.push_back(float(object.albedo[c]));
    if (Status s = run->pipeline_->set_clutter_albedo(clutter_albedo); !s.ok()) return s;
    run->clutter_scene_ = std::make_unique<precompute::LevelScene>(lv, lv.res, scene.clutter);
    for (const ClutterObject& object : scene.clutter) {
      const ClutterTexelGeometry g = clutter_texel_geometry(object);
      run->clutter_position_.insert(run->clutter_position_.end(), g.position.begin(), g.position.end());
    }
    run->drt_startup_.texels = run->clutter_position_.size();
    run->clutter_ld_.assign(run->backend_->clutter_sizes().clutter_ld, 0.0f);
    run->clutter_lightmap_.assign(run->backend_->clutter_sizes().clutter_lightmap, 0.0f);
  } else if (!options.save_clutter.empty()) {
    return Status::error(
        ErrorCode::invalid_argument,
        options.save_clutter + ": the scene has no clutter objects, so there are no DRT operators to write");
  }
  if (options.direct == DemoDirect::cpu) {
    Result<cpu::CpuDirectLight> direct = cpu::CpuDirectLight::create(lv, albedo);
    if (!direct.ok()) return direct.status();
    run->cpu_direct_ = std::make_unique<cpu::CpuDirectLight>(std::move(direct).value());
  } else {
    Result<std::unique_ptr<gles::GlesDirectLight>> direct = gles::GlesDirectLight::create(gl, lv, albedo);
    if (!direct.ok()) return direct.status();
    run->gpu_direct_ = std::move(direct).value();
  }
  const LevelBufferSizes& sizes = run->backend_->sizes();
  run->ld_.assign(sizes.ld, 0.0f);
  run->atlas_.assign(sizes.atlas, 0.0f);
  run->probes_.assign(sizes.probes, 0.0f);
  run->vector_lightmap_.assign(run->vector_ ? sizes.vector_lightmap : 0, 0.0f);
  run->coefficient_.assign(run->vector_ ? sizes.lightmap : 0, 0.0f);
  if (!run->probes_.empty()) {
    run->probe_sampler_ = ProbeSampler(lv, int(dict.settings.probe_grid));
    // A GLES backend turns its probes into the world frame on the GPU (world_probe_texture);
    // a CPU backend's are turned here and uploaded.
    if (run->backend_->kind() == BackendKind::gles)
      run->probes_.clear();
    else
      run->world_probes_.assign(sizes.probes, 0.0f);
  }
  // DRT on a GLES backend: the clutter lightmap is gathered from its clutter atlas on the GPU.
  if (run->drt_ && run->backend_->output_texture(BackendOutput::clutter_atlas)) {
    const Backend& backend = *run->backend_;
    if (Status s = run->renderer_->set_clutter_atlas_layout(
            [&backend](std::size_t k, std::uint32_t t) { return backend.clutter_atlas_texel(k, t); });
        !s.ok())
      return s;
  }
  // The converged solve includes the clutter (its c) where the backend has it (CPU); GLES solves
  // without clutter only.
  run->converged_ = run->bounces_option_ == kDemoConverged && run->backend_->converged_available();
  return run;
}

// The clutter's direct light, albedo * E/pi per texel (what Td_c reads): precompute's model of
// the level's direct light with shadows from the proxy walls and all clutter (Embree), the
// light treated as the renderer treats it (a point, E clamped at its radius) and the spot
// cone of lighting.glsl applied per texel. The renderer draws the clutter's direct light
// itself, as for every mesh, so the clutter lightmap gets none (clutter_direct empty).
std::span<const float> DemoRun::ld() {
  if (gpu_direct_ && backend_->kind() == BackendKind::gles &&
      !(scene_->lights.size() > 1 ? renderer_->read_summed_ld(ld_) : gpu_direct_->read_ld(ld_)).ok())
    std::fill(ld_.begin(), ld_.end(), 0.0f);  // a GL error: nothing to show
  return ld_;
}

std::span<const float> DemoRun::clutter_lightmap() {
  if (drt_ && backend_->output_texture(BackendOutput::clutter_atlas) &&
      !backend_->read_clutter_lightmap(clutter_lightmap_).ok())
    std::fill(clutter_lightmap_.begin(), clutter_lightmap_.end(), 0.0f);  // a GL error: nothing to show
  return clutter_lightmap_;
}

Status DemoRun::clutter_light(const FrameState& state) {
  const Clock::time_point t = Clock::now();
  // One light at a time (the spot cone is applied per light), summed in light order.
  std::vector<double> sum(clutter_ld_.size(), 0.0);
  for (std::size_t li = 0; li < state.lights.size(); ++li) {
    const DemoLight& light = scene_->lights[li];
    if (light.directional) {
      const std::vector<float> e = precompute::clutter_directional_light(
          *clutter_scene_, glm::dvec3(light.direction), glm::dvec3(light.color) * double(light.intensity));
      if (e.size() != clutter_ld_.size())
        return Status::error(ErrorCode::internal_error, "demo: clutter direct light has the wrong size");
      for (std::size_t i = 0; i < e.size(); ++i) sum[i] += double(e[i]);
      continue;
    }
    LightDescription l;
    l.position = glm::dvec3(state.lights[li].position);
    l.radius = light.radius;
    l.color = glm::dvec3(light.color);
    l.intensity = light.intensity;
    const std::vector<float> e = precompute::clutter_direct_light(*clutter_scene_, std::span(&l, 1), 1);
    if (e.size() != clutter_ld_.size())
      return Status::error(ErrorCode::internal_error, "demo: clutter direct light has the wrong size");
    const bool spot = light.outer_cone < 3.14159f;
    const double cos_outer = std::cos(double(light.outer_cone)),
                 cos_inner = std::max(std::cos(double(std::min(light.inner_cone, light.outer_cone))),
                                      cos_outer + 1e-4);
    const glm::dvec3 axis = glm::length(light.direction) > 0.0f ? glm::normalize(glm::dvec3(light.direction))
                                                                : glm::dvec3(0.0, -1.0, 0.0);
    for (std::size_t i = 0; i < clutter_position_.size(); ++i) {
      double cone = 1.0;
      if (spot) {
        const double c = glm::dot(glm::normalize(clutter_position_[i] - l.position), axis);
        const double x = std::clamp((c - cos_outer) / (cos_inner - cos_outer), 0.0, 1.0);
        cone = x * x * (3.0 - 2.0 * x);  // GLSL smoothstep
      }
      for (std::size_t c = 0; c < 3; ++c) sum[3 * i + c] += cone * double(e[3 * i + c]);
    }
  }
  for (std::size_t i = 0; i < sum.size(); ++i) {
    const float v = float(sum[i]);
    clutter_ld_[i] = v > 0.0f ? std::min(v, kMaxLightValue) : 0.0f;
  }
  Status s = pipeline_->set_clutter_light(clutter_ld_, {});
  times_.clutter_direct += ms_since(t);
  return s;
}

Status DemoRun::render(int frame, std::span<float> linear_rgb, std::span<std::uint8_t> srgb8) {
  const DemoScene& scene = *scene_;
  const platform::GlFunctions& gl = context_->gl();
  FrameState state;
  state.camera = scene.camera;
  for (const DemoLight& light : scene.lights) {
    gles::GpuLight& l = state.lights.emplace_back();
    l.position = light_position(light, frame);
    l.rgb = light.color * light.intensity;
    l.radius = light.radius;
    l.spot_direction = light.direction;
    l.spot_inner = light.inner_cone;
    l.spot_outer = light.outer_cone;
    if (light.directional) l.directional = true, l.spot_direction = light.direction;
  }
  state.dynamic_offset = dynamic_offset(scene, frame);
  state.output = options_.output;
  state.exposure = options_.exposure;

  Clock::time_point t = Clock::now();
  Status s = renderer_->render_shadows(state);
  gl.glFinish();
  times_.shadows += ms_since(t);
  t = Clock::now();
  if (s.ok() && cpu_direct_) {
    std::array<cpu::CpuLight, kMaxDemoLights> lights;
    for (std::size_t i = 0; i < scene.lights.size(); ++i)
      lights[i] = cpu_light(scene.lights[i], state.lights[i].position);
    s = cpu_direct_->evaluate(std::span(lights.data(), scene.lights.size()), ld_);
  }
  // The GPU pass, one light at a time with its shadow map, summed on the GPU when there are
  // several: a GLES backend reads the texture where it is (nothing read back); the CPU backend
  // needs ld in memory.
  const bool ld_on_gpu = gpu_direct_ && backend_->kind() == BackendKind::gles;
  const bool several = scene.lights.size() > 1;
  if (s.ok() && gpu_direct_) {
    for (std::size_t i = 0; i < state.lights.size() && s.ok(); ++i) {
      // An imported level's proxy samples lie inside the walls, up to proxy_depth behind the
      // surfaces they stand for: the walls' own faces must not shadow them.
      gles::GpuShadowCube cube = renderer_->shadow_cube(i);
      cube.normal_offset = scene.proxy_depth;
      s = gpu_direct_->render(state.lights[i], cube);
      if (s.ok() && several) s = renderer_->add_ld(gpu_direct_->ld_texture(), gpu_direct_->layout(), i == 0);
    }
    if (s.ok() && !ld_on_gpu) s = several ? renderer_->read_summed_ld(ld_) : gpu_direct_->read_ld(ld_);
  }
  const GLuint ld_texture = !gpu_direct_ ? 0 : several ? renderer_->summed_ld() : gpu_direct_->ld_texture();
  if (s.ok() && drt_) s = clutter_light(state);
  times_.direct += ms_since(t);
  // Indirect: the converged solve, or one update and feedback steps; with the camera
  // skip, only the tiles of the blocks this camera can see are written.
  t = Clock::now();
  if (s.ok() && options_.camera_skip) {
    const Result<VisibilityStats> seen = camera_visibility_.update(
        glm::dmat4(renderer_->view_projection(state.camera)), glm::dvec3(state.camera.position));
    s = seen.ok() ? backend_->set_visible_blocks(camera_visibility_.visible()) : seen.status();
    if (s.ok()) visible_blocks_ = seen->visible;
  }
  const std::uint32_t steps = frame_steps();
  if (s.ok()) s = ld_on_gpu ? pipeline_->run_from_texture(ld_texture, steps) : pipeline_->run(ld_, steps);
  // The atlas on the GPU: the backend renders it there (GLES), else it is read and uploaded.
  const GLuint gpu_atlas = backend_->output_texture(BackendOutput::atlas);
  if (s.ok() && gpu_atlas) {  // GPU stage times, summed over the frame's update and feedback steps
    const BackendStageTimes& pt = pipeline_->times();
    times_.b += double(pt.b) * 1e-6, times_.r += double(pt.r) * 1e-6,
        times_.lightmaps += double(pt.atlas) * 1e-6, times_.probes += double(pt.probes) * 1e-6,
        times_.vector += double(pt.vector) * 1e-6;
  }
  // The probe volume where the dynamic object is: the backend's world-frame texture (GLES), or
  // the CPU backend's probes of the object's block (the renderer samples that cell only; with
  // the camera skip a hidden block's are computed by this read) turned into the world frame
  // and uploaded.
  // Only a scene with dynamic meshes reads them (an imported interior has none, and its
  // origin may lie outside every block: the L hall's cut corner).
  const bool has_dynamic =
      std::any_of(scene_->meshes.begin(), scene_->meshes.end(), [](const Mesh& m) { return m.dynamic; });
  if (s.ok() && has_dynamic && probe_sampler_.grid() > 0) {
    const Result<ProbeCell> cell = probe_sampler_.locate(glm::dvec3(state.dynamic_offset), "dynamic object");
    if (!cell.ok()) s = cell.status();
    GLuint probe_texture = 0;
    if (s.ok() && probes_.empty()) {
      const Result<std::uint32_t> texture = backend_->world_probe_texture();
      if (texture.ok())
        probe_texture = GLuint(texture.value());
      else
        s = texture.status();
    } else if (s.ok()) {
      const std::size_t per_block = probes_.size() / level_.blocks.size(), block = cell.value().block;
      s = backend_->read_block_probes(block, std::span<float>(probes_).subspan(per_block * block, per_block));
    }
    if (s.ok() && !probes_.empty()) {
      probe_sampler_.world_probes(probes_, false, world_probes_);
      const Result<GLuint> uploaded = renderer_->upload_probes(world_probes_);
      if (uploaded.ok())
        probe_texture = uploaded.value();
      else
        s = uploaded.status();
    }
    if (s.ok()) {
      state.probes = probe_texture;
      state.probe_grid = probe_sampler_.grid();
      state.probe_cell = cell.value();
    }
  }
  if (s.ok() && drt_) {
    const Clock::time_point tc = Clock::now();
    if (const GLuint clutter_atlas = backend_->output_texture(BackendOutput::clutter_atlas)) {
      s = renderer_->gather_clutter_lightmap(clutter_atlas);
    } else {
      s = backend_->read_clutter_lightmap(clutter_lightmap_);
      if (s.ok()) s = renderer_->upload_clutter_lightmap(clutter_lightmap_);
    }
    times_.clutter_lightmap += ms_since(tc);
  }
  if (s.ok()) {
    if (gpu_atlas) {
      state.atlas = gpu_atlas;
      for (int i = 0; i < 4; ++i)
        state.vector_atlas[std::size_t(i)] =
            backend_->output_texture(BackendOutput(int(BackendOutput::vector0) + i));
    } else if ((s = backend_->read_atlas(atlas_)).ok()) {
      Result<GLuint> up = renderer_->upload_atlas(atlas_);
      if (up.ok())
        state.atlas = up.value();
      else
        s = up.status();
      // The vector irradiance as four atlases, padded like the scalar one, so that the CPU
      // path shades normal maps exactly as the GLES path does.
      if (s.ok() && vector_) s = backend_->read_vector_lightmap(vector_lightmap_);
      for (int i = 0; i < 4 && s.ok() && vector_; ++i) {
        for (std::size_t k = 0; k < level_.sample_count; ++k)
          for (std::size_t c = 0; c < 3; ++c)
            coefficient_[3 * k + c] = vector_lightmap_[3 * (4 * k + std::size_t(i)) + c];
        level_fill_atlas(level_, coefficient_, atlas_);
        Result<GLuint> v = renderer_->upload_atlas(atlas_, 1 + i);
        if (v.ok())
          state.vector_atlas[std::size_t(i)] = v.value();
        else
          s = v.status();
      }
    }
  }
  gl.glFinish();
  times_.indirect += ms_since(t);
  if (!s.ok()) return s;
  t = Clock::now();
  s = renderer_->render_image(state, linear_rgb, srgb8);
  times_.render += ms_since(t);
  if (!s.ok()) return s;
  // Finite input gives a finite image (the loaders bound the lights, the runtimes the light
  // values): NaN or Inf here is a fault, reported instead of saved as black or white pixels.
  if (const auto bad =
          std::count_if(linear_rgb.begin(), linear_rgb.end(), [](float v) { return !std::isfinite(v); });
      bad > 0)
    return Status::error(ErrorCode::non_finite, "demo: the rendered image has " + std::to_string(bad) +
                                                    " of " + std::to_string(linear_rgb.size()) +
                                                    " values that are not finite (NaN or Inf)");
  return s;
}

}  // namespace modrt::demo
