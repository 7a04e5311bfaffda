// SPDX-License-Identifier: MIT
// modrt_context: one level evaluated by the CPU runtime or the GLES runtime, with the CPU
// direct-light evaluator in front and the probe sampler behind.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

#include "c_api_internal.h"
#include "modrt/backends.h"
#include "modrt/cpu/direct_light.h"
#include "modrt/feedback_policy.h"
#include "modrt/frame_pipeline.h"
#include "modrt/level_geometry.h"
#include "modrt/level_runtime.h"
#include "modrt/level_visibility.h"
#include "modrt/operator_limits.h"
#include "modrt/probe_sampler.h"
#if MODRT_RUNTIME_GLES
#include <glm/gtc/type_ptr.hpp>

#include "modrt/gles/gles_direct_light.h"
#include "modrt/platform/gl_functions.h"
#endif

namespace modrt::capi {
#if MODRT_RUNTIME_GLES
void* default_gl_loader(const char* name, void* user);  // gl_loader_egl.cpp, or null there
bool has_default_gl_loader();
#endif
}  // namespace modrt::capi

using namespace modrt;
using namespace modrt::capi;

struct modrt_context {
  Allocator alloc;
  modrt_dictionary* dictionary = nullptr;
  modrt_level* level = nullptr;
  modrt_context_options options{};
  std::string description;
  LevelBufferSizes sizes;
  int probe_grid = 0;
  bool probes_on = false;

#if MODRT_RUNTIME_GLES
  platform::GlFunctions gl;  // before backend: the GLES backend keeps a reference to it
#endif
  // The backend from the creator table (modrt/backends.h) and the frame sequence over it.
  std::unique_ptr<Backend> backend;
  std::optional<FramePipeline> pipeline;
#if MODRT_RUNTIME_GLES
  // set_light_gpu's pass, made on its first call and again after set_albedo.
  std::unique_ptr<gles::GlesDirectLight> gpu_direct;
#endif
  std::optional<cpu::CpuDirectLight> direct;
  ProbeSampler sampler;
  CameraVisibility camera;  // set_camera's walk (its flags go to the backend)

  // Frame buffers, from the hook. albedo: what the lights are reflected with (the level's, or
  // set_albedo's). probes, vector: the backend's of the last update, read once per update
  // (CPU: copied; GLES: read back); vector_plane: one coefficient per sample, for read_vector_atlas.
  HookVector<float> ld, probes, albedo, vector, vector_plane;
  // GLES: the ld source of the next updates when set_ld_texture named one (0: the CPU ld).
  std::uint32_t ld_texture = 0;
  bool vector_current = false;
  bool probes_current = false;
  // Per block whether `probes` holds its probes of the last update (modrt_context_probe_sh reads
  // one block's on a CPU context: with the camera skip a hidden block's are computed on demand).
  HookVector<std::uint8_t> probe_block_current;
  HookVector<cpu::CpuLight> lights;  // capacity max_lights

  // DRT: the clutter set on the backend (a reference kept: the backend borrows its operators).
  modrt_clutter* clutter = nullptr;

  modrt_timings timings{};
  std::uint64_t light_blocks_recomputed = 0, light_blocks_kept = 0;

  modrt_context(const Allocator& a, modrt_dictionary* d, modrt_level* l)
      : alloc(a),
        dictionary(d),
        level(l),
        ld(HookAllocator<float>(&alloc)),
        probes(HookAllocator<float>(&alloc)),
        albedo(HookAllocator<float>(&alloc)),
        vector(HookAllocator<float>(&alloc)),
        vector_plane(HookAllocator<float>(&alloc)),
        probe_block_current(HookAllocator<std::uint8_t>(&alloc)),
        lights(HookAllocator<cpu::CpuLight>(&alloc)) {
    retain(d);
    retain(l);
  }
  ~modrt_context() {
    pipeline.reset();
    backend.reset();  // GLES: deletes its GL objects through gl
    if (clutter) release(clutter);
    release(dictionary);
    release(level);
  }
  const Level& lv() const { return level->level; }
  const Dictionary& dict() const { return dictionary->dict; }
  bool is_gles() const { return options.backend == MODRT_BACKEND_GLES; }
};

namespace {

using Clock = std::chrono::steady_clock;

std::uint64_t ns_since(Clock::time_point t) {
  return std::uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t).count());
}

// Without std::string: also used outside guarded(), where nothing may throw.
modrt_status null_arg(const char* function, const char* what) {
  char text[160];
  std::snprintf(text, sizeof text, "%s: %s is null", function, what);
  return fail(MODRT_ERROR_INVALID_ARGUMENT, static_cast<const char*>(text));
}

modrt_status check_count(const char* function, const char* what, size_t count, size_t expected) {
  if (count == expected) return MODRT_OK;
  return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(function) + ": " + what + " has " +
                                                std::to_string(count) + " floats, the level needs " +
                                                std::to_string(expected));
}

// A backend's failure: a GLES internal error is a GL error.
modrt_status backend_fail(const modrt_context* c, const char* fn, const Status& s) {
  const modrt_status code =
      c->is_gles() && s.code() == ErrorCode::internal_error ? MODRT_ERROR_GL : from_error_code(s.code());
  return fail(code, std::string(fn) + ": " + s.message());
}

#if MODRT_RUNTIME_GLES
// The app's GL state that the passes change and a renderer relies on: restored after every
// call that runs passes.
struct GlStateGuard {
  const platform::GlFunctions& gl;
  GLint framebuffer = 0, viewport[4] = {0, 0, 0, 0}, program = 0, vao = 0, texture_unit = 0;
  explicit GlStateGuard(const platform::GlFunctions& g) : gl(g) {
    gl.glGetIntegerv(GL_FRAMEBUFFER_BINDING, &framebuffer);
    gl.glGetIntegerv(GL_VIEWPORT, viewport);
    gl.glGetIntegerv(GL_CURRENT_PROGRAM, &program);
    gl.glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &vao);
    gl.glGetIntegerv(GL_ACTIVE_TEXTURE, &texture_unit);
  }
  ~GlStateGuard() {
    gl.glBindFramebuffer(GL_FRAMEBUFFER, GLuint(framebuffer));
    gl.glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
    gl.glUseProgram(GLuint(program));
    gl.glBindVertexArray(GLuint(vao));
    gl.glActiveTexture(GLenum(texture_unit));
  }
};
// The guard around a call into the backend, for a GLES context only.
struct BackendCall {
  std::optional<GlStateGuard> guard;
  explicit BackendCall(const modrt_context* c) {
    if (c->is_gles()) guard.emplace(c->gl);
  }
};

// The GLES backend's creation info: the app's current context, through its loader.
modrt_status load_gl(modrt_context* c, BackendCreateInfo& info) {
  modrt_gl_loader loader = c->options.gl_loader;
  void* user = c->options.gl_loader_user;
  if (!loader) {
    if (!has_default_gl_loader())
      return fail(MODRT_ERROR_UNSUPPORTED,
                  "modrt_context_create: this library was built without EGL: pass options.gl_loader");
    loader = default_gl_loader;
  }
  if (Status s = platform::load_gl_functions(loader, user, &c->gl); !s.ok())
    return fail(MODRT_ERROR_GL, "modrt_context_create: the current GL context: " + s.message());
  const char* version = reinterpret_cast<const char*>(c->gl.glGetString(GL_VERSION));
  if (!version)
    return fail(MODRT_ERROR_GL,
                "modrt_context_create: glGetString(GL_VERSION) returned null: is a GL "
                "context current on this thread?");
  info.gl = &c->gl;
  info.gles_context = std::strncmp(version, "OpenGL ES", 9) == 0;
  return MODRT_OK;
}
#else
struct BackendCall {
  explicit BackendCall(const modrt_context*) {}
};
#endif

// The backend of options.backend through the creator table, and the frame pipeline over it.
modrt_status create_backend(modrt_context* c) {
  constexpr const char* fn = "modrt_context_create";
  const modrt_context_options& o = c->options;
  if (o.vector_irradiance != 0)
    if (Status s = check_level_vector_operators(c->lv(), c->dict()); !s.ok())
      return fail(MODRT_ERROR_UNSUPPORTED,
                  std::string(fn) + ": options.vector_irradiance is on, but " + s.message() +
                      " (bake the dictionary with its vector operators or turn vector_irradiance off)");
  BackendCreateInfo info;
  info.level = &c->lv();
  info.dict = &c->dict();
  info.threads = o.threads;
  info.skip_unchanged = o.skip_unchanged != 0;
  info.probes = o.probes != 0;
  info.vector_irradiance = o.vector_irradiance != 0;
  info.timing = o.timing != 0;
  BackendKind kind = BackendKind::cpu;
#if MODRT_RUNTIME_GLES
  if (c->is_gles()) {
    kind = BackendKind::gles;
    if (modrt_status s = load_gl(c, info); s != MODRT_OK) return s;
  }
#endif
  Result<std::unique_ptr<Backend>> backend = [&] {
    BackendCall call(c);
    return modrt::create_backend(kind, info);
  }();
  if (!backend.ok()) return backend_fail(c, fn, backend.status());
  c->backend = std::move(backend).value();
  c->description = c->backend->description();
  FrameOptions frame;
  frame.bounces = o.bounces;
  frame.skip_unchanged = o.skip_unchanged != 0;
  Result<FramePipeline> pipeline = FramePipeline::create(*c->backend, frame);
  if (!pipeline.ok())
    return fail(from_error_code(pipeline.status().code()),
                std::string(fn) + ": " + pipeline.status().message());
  c->pipeline.emplace(std::move(pipeline).value());
  c->probes_on = o.probes != 0 && c->sizes.probes > 0;
  if (o.vector_irradiance != 0) {
    c->vector.assign(c->sizes.vector_lightmap, 0.0f);
    c->vector_plane.assign(c->sizes.lightmap, 0.0f);
  }
  return MODRT_OK;
}

// The multi-bounce feedback's albedo (clamped to options.max_albedo by the backend). Checks
// what CpuDirectLight checks and more (<= kMaxLightValue), so call it first.
modrt_status set_feedback_albedo(modrt_context* c, std::span<const float> albedo) {
  BackendCall call(c);
  if (Status s = c->pipeline->set_albedo(albedo, c->options.max_albedo); !s.ok())
    return backend_fail(c, "modrt_context_set_albedo", s);
  return MODRT_OK;
}

modrt_status check_updated(const modrt_context* c, const char* fn) {
  if (c->pipeline->stats().frames > 0) return MODRT_OK;
  return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": no update has run yet");
}

// The context's vector irradiance of the last update (read from the backend once per update).
modrt_status current_vector(modrt_context* c, const char* fn) {
  if (c->vector.empty())
    return fail(
        MODRT_ERROR_UNSUPPORTED,
        std::string(fn) + ": no vector irradiance: the context was created with options.vector_irradiance 0");
  if (modrt_status s = check_updated(c, fn); s != MODRT_OK) return s;
  if (!c->vector_current) {
    BackendCall call(c);
    if (Status s = c->backend->read_vector_lightmap(c->vector); !s.ok()) return backend_fail(c, fn, s);
    c->vector_current = true;
  }
  return MODRT_OK;
}
modrt_status check_clutter(const modrt_context* c, const char* fn) {
  if (c->clutter) return MODRT_OK;
  return fail(MODRT_ERROR_INVALID_ARGUMENT,
              std::string(fn) + ": the context has no clutter (modrt_context_set_clutter)");
}
std::size_t clutter_floats(const modrt_context* c) { return 3 * std::size_t(c->clutter->first_texel.back()); }

modrt_status check_probe_kind(const char* fn, int kind) {
  if (kind == MODRT_PROBE_RADIANCE || kind == MODRT_PROBE_IRRADIANCE_OVER_PI) return MODRT_OK;
  return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": unknown probe kind " + std::to_string(kind));
}

modrt_status check_probes_on(const modrt_context* c, const char* fn) {
  if (c->probes_on) return MODRT_OK;
  return fail(MODRT_ERROR_UNSUPPORTED,
              std::string(fn) + ": no probes: the dictionary has no volume probes or options.probes was 0");
}

// The probe volume of the last update in c->probes (read from the backend once per update;
// zeros before the first).
modrt_status current_probes(modrt_context* c, const char* fn) {
  if (modrt_status s = check_probes_on(c, fn); s != MODRT_OK) return s;
  if (!c->probes_current && c->pipeline->stats().frames > 0) {
    BackendCall call(c);
    if (Status s = c->backend->read_probes(c->probes); !s.ok()) return backend_fail(c, fn, s);
    c->probes_current = true;
  }
  return MODRT_OK;
}

// The probes of `block` in c->probes: one block's read from a CPU or reference backend (a GLES
// backend reads its probe texture back whole, so every block's at once).
modrt_status current_block_probes(modrt_context* c, std::size_t block, const char* fn) {
  if (c->backend->kind() == BackendKind::gles) return current_probes(c, fn);
  if (modrt_status s = check_probes_on(c, fn); s != MODRT_OK) return s;
  if (c->probes_current || c->probe_block_current[block] || c->pipeline->stats().frames == 0) return MODRT_OK;
  const std::size_t per_block = c->probes.size() / c->probe_block_current.size();
  BackendCall call(c);
  if (Status s = c->backend->read_block_probes(
          block, std::span<float>(c->probes.data() + per_block * block, per_block));
      !s.ok())
    return backend_fail(c, fn, s);
  c->probe_block_current[block] = 1;
  return MODRT_OK;
}

}  // namespace

extern "C" {

void modrt_context_options_init(modrt_context_options* options) {
  if (!options) return;
  *options = modrt_context_options{};
  options->struct_size = sizeof(modrt_context_options);
  options->backend = MODRT_BACKEND_CPU;
  options->threads = 1;
  options->probes = 1;
  options->timing = 0;
  options->skip_unchanged = 1;
  options->max_lights = 8;
  options->shadows = 1;
  // Since 0.4 the light is fully bounced by default (issue 20): one bounce (0) underlit every
  // interior by the whole series' remainder, and an app had to know to ask for more.
  options->bounces = MODRT_BOUNCES_CONVERGED;
  options->max_albedo = kDefaultMaxAlbedo;
  options->vector_irradiance = 0;
}

void modrt_light_init(modrt_light* light) {
  if (!light) return;
  *light = modrt_light{};
  light->struct_size = sizeof(modrt_light);
  light->type = MODRT_LIGHT_POINT;
  for (float& c : light->color) c = 1.0f;
  light->direction[1] = -1.0f;  // down in a y-up scene (glTF's convention)
  light->intensity = 1.0f;
  light->shadows = 1;
}

modrt_status modrt_context_create(modrt_dictionary* dictionary, modrt_level* level,
                                  const modrt_context_options* options, const modrt_allocator* allocator,
                                  modrt_context** out) {
  return guarded("modrt_context_create", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_create";
    if (!out) return null_arg(fn, "out");
    *out = nullptr;
    if (!dictionary) return null_arg(fn, "dictionary");
    if (!level) return null_arg(fn, "level");
    modrt_context_options o;
    modrt_context_options_init(&o);
    if (options) {
      if (modrt_status s = check_struct_size(fn, "options", *options, "modrt_context_options",
                                             "modrt_context_options_init");
          s != MODRT_OK)
        return s;
      // A 0.2 caller's struct ends before bounces and max_albedo: they keep 0.2's behaviour, one
      // bounce, and the default max_albedo.
      if (options->struct_size <= offsetof(modrt_context_options, bounces)) o.bounces = 0;
      o = read_sized(*options, o);
    }
    if (const int backend = c_enum_value(o.backend);
        backend != MODRT_BACKEND_CPU && backend != MODRT_BACKEND_GLES)
      return fail(MODRT_ERROR_INVALID_ARGUMENT,
                  std::string(fn) + ": options.backend " + std::to_string(backend) + " is not a backend");
    if (o.threads < 1 || o.threads > 256)
      return fail(MODRT_ERROR_INVALID_ARGUMENT,
                  std::string(fn) + ": options.threads " + std::to_string(o.threads) + " is not in 1..256");
    if (o.max_lights < 1 || o.max_lights > 4096)
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": options.max_lights " +
                                                    std::to_string(o.max_lights) + " is not in 1..4096");
    if (o.bounces > kMaxFrameBounces && o.bounces != MODRT_BOUNCES_CONVERGED)
      return fail(MODRT_ERROR_INVALID_ARGUMENT,
                  std::string(fn) + ": options.bounces " + std::to_string(o.bounces) + " is not in 0.." +
                      std::to_string(kMaxFrameBounces) + " nor MODRT_BOUNCES_CONVERGED");
    if (!check_max_albedo(o.max_albedo, fn).ok())
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": options.max_albedo " +
                                                    std::to_string(o.max_albedo) + " is not in [0, 1)");
    if (Status s = check_level_matches(level->level, dictionary->dict); !s.ok())
      return fail(MODRT_ERROR_MISMATCH, std::string(fn) + ": " + s.message());
#if !MODRT_RUNTIME_GLES
    if (o.backend == MODRT_BACKEND_GLES)
      return fail(MODRT_ERROR_UNSUPPORTED,
                  std::string(fn) + ": this library was built without the GLES backend");
#endif
    Allocator a;
    if (modrt_status s = Allocator::from(fn, allocator, &a); s != MODRT_OK) return s;
    modrt_context* c = make_handle<modrt_context>(a, dictionary, level);
    struct Undo {
      modrt_context* c;
      ~Undo() {
        if (c) destroy_handle(c);
      }
    } undo{c};
    c->options = o;
    c->sizes = level_buffer_sizes(c->lv(), c->dict());
    c->probe_grid = c->sizes.probes > 0 ? int(c->dict().settings.probe_grid) : 0;
    c->ld.assign(c->sizes.ld, 0.0f);
    c->lights.reserve(o.max_lights);
    if (modrt_status st = create_backend(c); st != MODRT_OK) return st;
    // The lights are reflected with the level's own albedo until set_albedo overrides it.
    c->albedo.assign(c->sizes.ld, 0.0f);
    level_sample_albedo(c->lv(), c->albedo);
    cpu::CpuDirectLightOptions lo;
    lo.max_lights = o.max_lights;
    lo.shadows = o.shadows != 0;
    Result<cpu::CpuDirectLight> direct = cpu::CpuDirectLight::create(c->lv(), c->albedo, lo);
    if (!direct.ok())
      return fail(from_error_code(direct.status().code()),
                  std::string(fn) + ": " + direct.status().message());
    c->direct.emplace(std::move(direct).value());
    if (modrt_status s = set_feedback_albedo(c, c->albedo); s != MODRT_OK) return s;
    if (c->probes_on) {
      c->probes.assign(c->sizes.probes, 0.0f);
      c->probe_block_current.assign(c->lv().blocks.size(), 0);
      c->sampler = ProbeSampler(c->lv(), c->probe_grid);
      c->camera = CameraVisibility(c->lv());
    }
    *out = c;
    undo.c = nullptr;
    return MODRT_OK;
  });
}

void modrt_context_destroy(modrt_context* context) {
  if (context) destroy_handle(context);
}

modrt_status modrt_context_get_sizes(const modrt_context* context, modrt_sizes* out) {
  if (!context) return null_arg("modrt_context_get_sizes", "context");
  if (!out) return null_arg("modrt_context_get_sizes", "out");
  if (modrt_status st = check_struct_size("modrt_context_get_sizes", "out", *out, "modrt_sizes");
      st != MODRT_OK)
    return st;
  modrt_sizes s{};
  s.struct_size = sizeof s;
  s.ld = context->sizes.ld;
  s.lightmap = context->sizes.lightmap;
  s.atlas = context->sizes.atlas;
  s.probes = context->probes_on ? context->sizes.probes : 0;
  s.atlas_width = std::uint32_t(context->lv().atlas.width);
  s.atlas_height = std::uint32_t(context->lv().atlas.height);
  s.probe_grid = context->probes_on ? std::uint32_t(context->probe_grid) : 0;
  *out = s;
  return MODRT_OK;
}

const char* modrt_context_description(const modrt_context* context) {
  return context ? context->description.c_str() : "";
}

modrt_status modrt_context_set_albedo(modrt_context* context, const float* albedo, size_t count) {
  return guarded("modrt_context_set_albedo", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_set_albedo";
    if (!context) return null_arg(fn, "context");
    if (!albedo) return null_arg(fn, "albedo");
    if (modrt_status s = check_count(fn, "albedo", count, context->sizes.ld); s != MODRT_OK) return s;
    const std::span<const float> a(albedo, count);
    if (modrt_status s = set_feedback_albedo(context, a); s != MODRT_OK) return s;
    if (Status s = context->direct->set_albedo(a); !s.ok())  // cannot fail after the feedback's check
      return fail(from_error_code(s.code()), std::string(fn) + ": " + s.message());
    std::copy(a.begin(), a.end(), context->albedo.begin());
#if MODRT_RUNTIME_GLES
    if (context->gpu_direct) {  // its sample images hold the old albedo: made again on the next call
      BackendCall call(context);
      if (context->ld_texture == context->gpu_direct->ld_texture()) context->ld_texture = 0;
      context->gpu_direct.reset();
    }
#endif
    return MODRT_OK;
  });
}

modrt_status modrt_context_read_albedo(const modrt_context* context, float* out, size_t count) {
  constexpr const char* fn = "modrt_context_read_albedo";
  if (!context) return null_arg(fn, "context");
  if (!out) return null_arg(fn, "out");
  return guarded(fn, [&]() -> modrt_status {
    if (modrt_status s = check_count(fn, "out", count, context->albedo.size()); s != MODRT_OK) return s;
    std::copy(context->albedo.begin(), context->albedo.end(), out);
    return MODRT_OK;
  });
}

// A modrt_light (its struct_size checked by the caller) as modrt::cpu's light; fails for an
// unknown type, naming light `index`.
static modrt_status to_cpu_light(const char* fn, std::size_t index, const modrt_light& in, cpu::CpuLight& l) {
  const int type = c_enum_value(in.type);
  if (type != MODRT_LIGHT_POINT && type != MODRT_LIGHT_SPOT && type != MODRT_LIGHT_DIRECTIONAL)
    return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": light " + std::to_string(index) +
                                                  ": unknown type " + std::to_string(type));
  l.type = cpu::LightType(std::uint8_t(type));
  l.position = glm::vec3(in.position[0], in.position[1], in.position[2]);
  l.direction = glm::vec3(in.direction[0], in.direction[1], in.direction[2]);
  l.color = glm::vec3(in.color[0], in.color[1], in.color[2]);
  l.intensity = in.intensity;
  l.radius = in.radius;
  l.inner_angle = in.inner_angle;
  l.outer_angle = in.outer_angle;
  l.shadows = in.shadows != 0;
  return MODRT_OK;
}

modrt_status modrt_context_set_lights(modrt_context* context, const modrt_light* lights, size_t count) {
  return guarded("modrt_context_set_lights", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_set_lights";
    if (!context) return null_arg(fn, "context");
    if (!lights && count > 0) return null_arg(fn, "lights");
    if (count > context->lights.capacity())
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": " + std::to_string(count) +
                                                    " lights, more than options.max_lights = " +
                                                    std::to_string(context->lights.capacity()));
    context->lights.clear();  // keeps the capacity: no allocation
    for (size_t i = 0; i < count; ++i) {
      const modrt_light& in = lights[i];
      if (modrt_status st = check_struct_size(fn, "lights[" + std::to_string(i) + "]", in, "modrt_light",
                                              "modrt_light_init");
          st != MODRT_OK)
        return st;
      cpu::CpuLight l;
      if (modrt_status st = to_cpu_light(fn, i, in, l); st != MODRT_OK) return st;
      context->lights.push_back(l);
    }
    const Clock::time_point t0 = Clock::now();
    if (Status s = context->direct->evaluate({context->lights.data(), context->lights.size()}, context->ld);
        !s.ok())
      return fail(from_error_code(s.code()), std::string(fn) + ": " + s.message());
    context->timings.light_ns = ns_since(t0);
    context->ld_texture = 0;
    const cpu::CpuDirectLightStats& st = context->direct->stats();
    context->light_blocks_recomputed += st.blocks_recomputed;
    context->light_blocks_kept += st.blocks_kept;
    return MODRT_OK;
  });
}

modrt_status modrt_context_set_ld(modrt_context* context, const float* ld, size_t count) {
  return guarded("modrt_context_set_ld", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_set_ld";
    if (!context) return null_arg(fn, "context");
    if (!ld) return null_arg(fn, "ld");
    if (modrt_status s = check_count(fn, "ld", count, context->sizes.ld); s != MODRT_OK) return s;
    // Checked here, with the rule every update applies (finite, >= 0, <= kMaxLightValue), so
    // that a bad ld is refused at the call and leaves the previous one in place.
    if (Status s = validate_light_signal({ld, count}, count / 3, "ld"); !s.ok())
      return fail(from_error_code(s.code()), std::string(fn) + ": " + s.message());
    std::copy(ld, ld + count, context->ld.begin());
    context->direct->invalidate();  // its incremental update assumed its own ld
    context->ld_texture = 0;
    return MODRT_OK;
  });
}

modrt_status modrt_context_set_ld_texture(modrt_context* context, uint32_t texture) {
  constexpr const char* fn = "modrt_context_set_ld_texture";
  if (!context) return null_arg(fn, "context");
  return guarded(fn, [&]() -> modrt_status {
    if (!context->is_gles())
      return fail(MODRT_ERROR_UNSUPPORTED,
                  std::string(fn) + ": a CPU context reads ld from memory: use modrt_context_set_ld");
#if MODRT_RUNTIME_GLES
    if (texture == 0 || context->gl.glIsTexture(texture) != GL_TRUE)
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": texture " + std::to_string(texture) +
                                                    " is not a texture name of the current GL context");
#else
    (void)texture;
#endif
    context->ld_texture = texture;
    return MODRT_OK;
  });
}

void modrt_shadow_cube_init(modrt_shadow_cube* shadow) {
  if (!shadow) return;
  *shadow = modrt_shadow_cube{};
  shadow->struct_size = sizeof(modrt_shadow_cube);
  shadow->near_plane = 0.01f;
  shadow->far_plane = 30.0f;
  for (int i = 0; i < 4; ++i) shadow->directional_view_proj[5 * i] = 1.0f;
}

modrt_status modrt_context_set_light_gpu(modrt_context* context, const modrt_light* light,
                                         const modrt_shadow_cube* shadow) {
  constexpr const char* fn = "modrt_context_set_light_gpu";
  if (!context) return null_arg(fn, "context");
  if (!light) return null_arg(fn, "light");
  return guarded(fn, [&]() -> modrt_status {
    if (!context->is_gles())
      return fail(
          MODRT_ERROR_UNSUPPORTED,
          std::string(fn) + ": a CPU context evaluates lights on the CPU: use modrt_context_set_lights");
#if MODRT_RUNTIME_GLES
    if (modrt_status st = check_struct_size(fn, "light", *light, "modrt_light", "modrt_light_init");
        st != MODRT_OK)
      return st;
    cpu::CpuLight l;
    if (modrt_status st = to_cpu_light(fn, 0, *light, l); st != MODRT_OK) return st;
    if (Status s = cpu::CpuDirectLight::check_light(0, l); !s.ok())
      return fail(from_error_code(s.code()), std::string(fn) + ": " + s.message());
    gles::GpuShadowCube cube;
    if (shadow) {
      if (modrt_status st =
              check_struct_size(fn, "shadow", *shadow, "modrt_shadow_cube", "modrt_shadow_cube_init");
          st != MODRT_OK)
        return st;
      modrt_shadow_cube defaults;
      modrt_shadow_cube_init(&defaults);
      const modrt_shadow_cube sc = read_sized(*shadow, defaults);
      if (sc.texture != 0 && context->gl.glIsTexture(sc.texture) != GL_TRUE)
        return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": shadow.texture " +
                                                      std::to_string(sc.texture) +
                                                      " is not a texture name of the current GL context");
      if (!(std::isfinite(sc.near_plane) && std::isfinite(sc.far_plane) && sc.near_plane > 0.0f &&
            sc.far_plane > sc.near_plane))
        return fail(MODRT_ERROR_INVALID_ARGUMENT,
                    std::string(fn) + ": shadow.near_plane " + std::to_string(sc.near_plane) +
                        " and far_plane " + std::to_string(sc.far_plane) + " must be finite, 0 < near < far");
      if (!(std::isfinite(sc.normal_offset) && sc.normal_offset >= 0.0f))
        return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": shadow.normal_offset " +
                                                      std::to_string(sc.normal_offset) +
                                                      " must be finite and >= 0");
      for (int i = 0; i < 16; ++i)
        if (!std::isfinite(sc.directional_view_proj[i]))
          return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": shadow.directional_view_proj[" +
                                                        std::to_string(i) + "] is not finite");
      cube.texture = sc.texture;
      cube.near_plane = sc.near_plane;
      cube.far_plane = sc.far_plane;
      cube.normal_offset = sc.normal_offset;
      std::memcpy(glm::value_ptr(cube.directional_view_proj), sc.directional_view_proj,
                  sizeof sc.directional_view_proj);
    }
    gles::GpuLight g;
    g.position = l.position;
    g.rgb = l.color * l.intensity;
    g.radius = l.radius;
    if (l.type == cpu::LightType::spot) {
      g.spot_direction = glm::normalize(l.direction);
      g.spot_inner = l.inner_angle;
      g.spot_outer = l.outer_angle;
    } else if (l.type == cpu::LightType::directional) {
      g.directional = true;
      g.spot_direction = glm::normalize(l.direction);
    }
    BackendCall call(context);
    if (!context->gpu_direct) {
      Result<std::unique_ptr<gles::GlesDirectLight>> made = gles::GlesDirectLight::create(
          context->gl, context->lv(), {context->albedo.data(), context->albedo.size()});
      if (!made.ok()) return backend_fail(context, fn, made.status());
      context->gpu_direct = std::move(made).value();
    }
    if (Status s = context->gpu_direct->render(g, cube); !s.ok()) return backend_fail(context, fn, s);
    context->ld_texture = context->gpu_direct->ld_texture();
    return MODRT_OK;
#else
    (void)shadow;
    return fail(MODRT_ERROR_UNSUPPORTED, std::string(fn) + ": this library was built without GLES");
#endif
  });
}

modrt_status modrt_context_get_ld_layout(const modrt_context* context, uint32_t* width, uint32_t* height) {
  constexpr const char* fn = "modrt_context_get_ld_layout";
  if (!context) return null_arg(fn, "context");
  if (!width) return null_arg(fn, "width");
  if (!height) return null_arg(fn, "height");
  if (const TextureSize size = context->backend->ld_texture_size(); size.width > 0) {
    *width = std::uint32_t(size.width);
    *height = std::uint32_t(size.height);
    return MODRT_OK;
  }
  return fail(MODRT_ERROR_UNSUPPORTED,
              static_cast<const char*>("modrt_context_get_ld_layout: a CPU context has no ld texture"));
}

modrt_status modrt_context_read_ld(const modrt_context* context, float* out, size_t count) {
  constexpr const char* fn = "modrt_context_read_ld";
  if (!context) return null_arg(fn, "context");
  if (!out) return null_arg(fn, "out");
  return guarded(fn, [&]() -> modrt_status {
    if (context->ld_texture)
      return fail(MODRT_ERROR_UNSUPPORTED, std::string(fn) + ": ld comes from GL texture " +
                                               std::to_string(context->ld_texture) + " (set_ld_texture)");
    if (modrt_status s = check_count(fn, "out", count, context->ld.size()); s != MODRT_OK) return s;
    std::copy(context->ld.begin(), context->ld.end(), out);
    return MODRT_OK;
  });
}

modrt_status modrt_context_update(modrt_context* context) {
  return guarded("modrt_context_update", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_update";
    if (!context) return null_arg(fn, "context");
    const Clock::time_point t0 = Clock::now();
    FramePipeline& pipeline = *context->pipeline;
    {
      BackendCall call(context);
      const std::uint32_t bounces = context->options.bounces;  // set_bounces' or options.bounces
      const Status s = context->ld_texture ? pipeline.run_from_texture(context->ld_texture, bounces)
                                           : pipeline.run({context->ld.data(), context->ld.size()}, bounces);
      if (!s.ok()) return backend_fail(context, fn, s);
    }
    modrt_timings& t = context->timings;
    const std::uint64_t light_ns = t.light_ns;
    t = modrt_timings{};
    t.struct_size = sizeof t;
    t.light_ns = light_ns;
    if (!pipeline.last_frame_skipped()) {
      const BackendStageTimes& st = pipeline.times();
      t.upload_ns = st.upload, t.b_ns = st.b, t.r_ns = st.r, t.feedback_ns = st.feedback;
      t.lightmap_ns = st.lightmap + st.drt;  // cpu: r and the tiles fused, with the DRT delta
      t.atlas_ns = st.atlas + st.clutter;    // with the clutter atlas
      t.probes_ns = st.probes + st.vector;   // with the vector irradiance
      context->probes_current = false;
      std::fill(context->probe_block_current.begin(), context->probe_block_current.end(), std::uint8_t(0));
      context->vector_current = false;
    }
    t.update_ns = ns_since(t0);
    return MODRT_OK;
  });
}

modrt_status modrt_context_set_bounces(modrt_context* context, uint32_t bounces) {
  constexpr const char* fn = "modrt_context_set_bounces";
  if (!context) return null_arg(fn, "context");
  if (bounces > kMaxFrameBounces && bounces != MODRT_BOUNCES_CONVERGED) {
    char text[160];
    std::snprintf(text, sizeof text, "%s: bounces %u is not in 0..%u nor MODRT_BOUNCES_CONVERGED", fn,
                  unsigned(bounces), unsigned(kMaxFrameBounces));
    return fail(MODRT_ERROR_INVALID_ARGUMENT, static_cast<const char*>(text));
  }
  context->options.bounces = bounces;
  return MODRT_OK;
}

modrt_status modrt_context_get_bounces(const modrt_context* context, uint32_t* bounces) {
  constexpr const char* fn = "modrt_context_get_bounces";
  if (!context) return null_arg(fn, "context");
  if (!bounces) return null_arg(fn, "bounces");
  *bounces = context->options.bounces;
  return MODRT_OK;
}

modrt_status modrt_context_get_atlas_texture(const modrt_context* context, uint32_t* texture, int* format) {
  constexpr const char* fn = "modrt_context_get_atlas_texture";
  if (!context) return null_arg(fn, "context");
  if (!texture) return null_arg(fn, "texture");
  if (const std::uint32_t name = context->backend->output_texture(BackendOutput::atlas); name != 0) {
    *texture = name;
    if (format) *format = context->backend->output_texture_format();
    return MODRT_OK;
  }
  return fail(MODRT_ERROR_UNSUPPORTED,
              static_cast<const char*>("modrt_context_get_atlas_texture: a CPU context has no GL texture: "
                                       "use modrt_context_get_atlas_data"));
}

modrt_status modrt_context_get_atlas_data(const modrt_context* context, const float** data, size_t* count) {
  constexpr const char* fn = "modrt_context_get_atlas_data";
  if (!context) return null_arg(fn, "context");
  if (!data) return null_arg(fn, "data");
  if (!count) return null_arg(fn, "count");
  const std::span<const float> atlas = context->backend->output_data(BackendOutput::atlas);
  if (atlas.empty())
    return fail(MODRT_ERROR_UNSUPPORTED,
                static_cast<const char*>(
                    "modrt_context_get_atlas_data: a GLES context keeps the atlas on the GPU: use "
                    "modrt_context_get_atlas_texture or modrt_context_read_atlas"));
  *data = atlas.data();
  *count = atlas.size();
  return MODRT_OK;
}

modrt_status modrt_context_read_lightmap(modrt_context* context, float* out, size_t count) {
  return guarded("modrt_context_read_lightmap", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_read_lightmap";
    if (!context) return null_arg(fn, "context");
    if (!out) return null_arg(fn, "out");
    if (modrt_status s = check_count(fn, "out", count, context->sizes.lightmap); s != MODRT_OK) return s;
    if (modrt_status s = check_updated(context, fn); s != MODRT_OK) return s;
    BackendCall call(context);
    if (Status s = context->backend->read_lightmap({out, count}); !s.ok())
      return backend_fail(context, fn, s);
    return MODRT_OK;
  });
}

modrt_status modrt_context_read_atlas(modrt_context* context, float* out, size_t count) {
  return guarded("modrt_context_read_atlas", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_read_atlas";
    if (!context) return null_arg(fn, "context");
    if (!out) return null_arg(fn, "out");
    if (modrt_status s = check_count(fn, "out", count, context->sizes.atlas); s != MODRT_OK) return s;
    if (modrt_status s = check_updated(context, fn); s != MODRT_OK) return s;
    BackendCall call(context);
    if (Status s = context->backend->read_atlas({out, count}); !s.ok()) return backend_fail(context, fn, s);
    return MODRT_OK;
  });
}

modrt_status modrt_context_read_vector_lightmap(modrt_context* context, float* out, size_t count) {
  return guarded("modrt_context_read_vector_lightmap", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_read_vector_lightmap";
    if (!context) return null_arg(fn, "context");
    if (!out) return null_arg(fn, "out");
    if (modrt_status s = current_vector(context, fn); s != MODRT_OK) return s;
    if (modrt_status s = check_count(fn, "out", count, context->vector.size()); s != MODRT_OK) return s;
    std::copy(context->vector.begin(), context->vector.end(), out);
    return MODRT_OK;
  });
}

modrt_status modrt_context_read_vector_atlas(modrt_context* context, int coefficient, float* out,
                                             size_t count) {
  return guarded("modrt_context_read_vector_atlas", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_read_vector_atlas";
    if (!context) return null_arg(fn, "context");
    if (!out) return null_arg(fn, "out");
    if (coefficient < 0 || coefficient > 3)
      return fail(MODRT_ERROR_INVALID_ARGUMENT,
                  std::string(fn) + ": coefficient " + std::to_string(coefficient) + " is not in 0..3");
    if (modrt_status s = current_vector(context, fn); s != MODRT_OK) return s;
    if (modrt_status s = check_count(fn, "out", count, context->sizes.atlas); s != MODRT_OK) return s;
    const std::size_t samples = context->lv().sample_count;
    for (std::size_t i = 0; i < samples; ++i)
      for (std::size_t c = 0; c < 3; ++c)
        context->vector_plane[3 * i + c] = context->vector[3 * (4 * i + std::size_t(coefficient)) + c];
    level_fill_atlas(context->lv(), context->vector_plane, {out, count});
    return MODRT_OK;
  });
}

modrt_status modrt_context_get_vector_textures(const modrt_context* context, uint32_t textures[4],
                                               int* format) {
  constexpr const char* fn = "modrt_context_get_vector_textures";
  if (!context) return null_arg(fn, "context");
  if (!textures) return null_arg(fn, "textures");
  if (context->is_gles()) {
    if (context->vector.empty())
      return fail(MODRT_ERROR_UNSUPPORTED,
                  static_cast<const char*>("modrt_context_get_vector_textures: no vector irradiance: the "
                                           "context was created with options.vector_irradiance 0"));
    constexpr BackendOutput kVector[4] = {BackendOutput::vector0, BackendOutput::vector1,
                                          BackendOutput::vector2, BackendOutput::vector3};
    for (int i = 0; i < 4; ++i) textures[i] = context->backend->output_texture(kVector[i]);
    if (format) *format = context->backend->output_texture_format();
    return MODRT_OK;
  }
  return fail(MODRT_ERROR_UNSUPPORTED,
              static_cast<const char*>("modrt_context_get_vector_textures: a CPU context has no GL textures: "
                                       "use modrt_context_read_vector_atlas"));
}

modrt_status modrt_context_probe_sh(modrt_context* context, const float position[3], modrt_probe_kind kind,
                                    float out[27]) {
  return guarded("modrt_context_probe_sh", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_probe_sh";
    if (!context) return null_arg(fn, "context");
    if (!position) return null_arg(fn, "position");
    if (!out) return null_arg(fn, "out");
    const int kind_value = c_enum_value(kind);
    if (modrt_status s = check_probe_kind(fn, kind_value); s != MODRT_OK) return s;
    if (modrt_status s = check_probes_on(context, fn); s != MODRT_OK) return s;
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(position[a]))
        return fail(MODRT_ERROR_NON_FINITE,
                    std::string(fn) + ": position[" + std::to_string(a) + "] is not finite");
    const glm::dvec3 x(position[0], position[1], position[2]);
    const Result<ProbeCell> cell = context->sampler.locate(x);
    if (!cell.ok())
      return fail(from_error_code(cell.status().code()), std::string(fn) + ": " + cell.status().message());
    if (modrt_status s = current_block_probes(context, cell.value().block, fn); s != MODRT_OK) return s;
    if (Status s =
            context->sampler.sample(context->probes, x, kind_value == MODRT_PROBE_IRRADIANCE_OVER_PI, out);
        !s.ok())
      return fail(from_error_code(s.code()), std::string(fn) + ": " + s.message());
    return MODRT_OK;
  });
}

modrt_status modrt_context_locate_probe(const modrt_context* context, const float position[3],
                                        modrt_probe_cell* out) {
  return guarded("modrt_context_locate_probe", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_locate_probe";
    if (!context) return null_arg(fn, "context");
    if (!position) return null_arg(fn, "position");
    if (!out) return null_arg(fn, "out");
    if (modrt_status s = check_struct_size(fn, "out", *out, "modrt_probe_cell"); s != MODRT_OK) return s;
    if (modrt_status s = check_probes_on(context, fn); s != MODRT_OK) return s;
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(position[a]))
        return fail(MODRT_ERROR_NON_FINITE,
                    std::string(fn) + ": position[" + std::to_string(a) + "] is not finite");
    const Result<ProbeCell> located = context->sampler.locate(
        glm::dvec3(position[0], position[1], position[2]), "modrt_context_locate_probe: position");
    if (!located.ok()) return fail(from_error_code(located.status().code()), located.status().message());
    const ProbeCell& cell = located.value();
    const int g = context->probe_grid;
    modrt_probe_cell r{};
    r.struct_size = sizeof r;
    r.block = std::uint32_t(cell.block);
    r.quarter_turns = std::uint32_t(context->lv().blocks[cell.block].quarter_turns & 3);
    r.grid = std::uint32_t(g);
    for (int a = 0; a < 3; ++a) {
      r.lower[a] = cell.i0[a];
      r.weight[a] = float(cell.f[a]);
    }
    const std::size_t base = cell.block * std::size_t(g) * std::size_t(g) * std::size_t(g);
    for (int c = 0; c < 8; ++c) {  // as ProbeSampler::sample mixes them
      const glm::ivec3 o(c & 1, (c >> 1) & 1, (c >> 2) & 1);
      const glm::ivec3 q = glm::min(cell.i0 + o, glm::ivec3(g - 1));
      r.probe[c] = std::uint32_t(base + std::size_t(q.x + g * (q.y + g * q.z)));
      r.corner_weight[c] = float((o.x ? cell.f.x : 1 - cell.f.x) * (o.y ? cell.f.y : 1 - cell.f.y) *
                                 (o.z ? cell.f.z : 1 - cell.f.z));
    }
    *out = r;
    return MODRT_OK;
  });
}

modrt_status modrt_context_read_probes(modrt_context* context, modrt_probe_kind kind, float* out,
                                       size_t count) {
  return guarded("modrt_context_read_probes", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_read_probes";
    if (!context) return null_arg(fn, "context");
    if (!out) return null_arg(fn, "out");
    if (modrt_status s = check_probe_kind(fn, c_enum_value(kind)); s != MODRT_OK) return s;
    if (modrt_status s = check_probes_on(context, fn); s != MODRT_OK) return s;
    if (modrt_status s = check_count(fn, "out", count, context->probes.size()); s != MODRT_OK) return s;
    if (modrt_status s = current_probes(context, fn); s != MODRT_OK) return s;
    context->sampler.world_probes(context->probes, c_enum_value(kind) == MODRT_PROBE_IRRADIANCE_OVER_PI,
                                  {out, count});
    return MODRT_OK;
  });
}

modrt_status modrt_context_get_probe_texture(modrt_context* context, uint32_t* texture, int* format,
                                             uint32_t* width, uint32_t* height) {
  constexpr const char* fn = "modrt_context_get_probe_texture";
  if (!context) return null_arg(fn, "context");
  if (!texture) return null_arg(fn, "texture");
  return guarded(fn, [&]() -> modrt_status {
    if (modrt_status s = check_probes_on(context, fn); s != MODRT_OK) return s;
    if (!context->is_gles())
      return fail(MODRT_ERROR_UNSUPPORTED,
                  std::string(fn) + ": a CPU context has no GL textures: use modrt_context_read_probes");
    if (modrt_status s = check_updated(context, fn); s != MODRT_OK) return s;
    BackendCall call(context);
    Result<std::uint32_t> name = context->backend->world_probe_texture();
    if (!name.ok()) return backend_fail(context, fn, name.status());
    *texture = name.value();
    if (format) *format = context->backend->output_texture_format();
    // The runtime's linear layout, as the ld texture's (gles/README.md).
    const std::size_t texels = context->sizes.probes / 3,
                      row = std::size_t(context->backend->ld_texture_size().width);
    if (width) *width = std::uint32_t(row);
    if (height) *height = std::uint32_t((texels + row - 1) / row);
    return MODRT_OK;
  });
}

modrt_status modrt_context_get_probe_positions(const modrt_context* context, float* out, size_t count) {
  return guarded("modrt_context_get_probe_positions", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_get_probe_positions";
    if (!context) return null_arg(fn, "context");
    if (!out) return null_arg(fn, "out");
    if (modrt_status s = check_probes_on(context, fn); s != MODRT_OK) return s;
    const std::size_t per_block =
        std::size_t(context->probe_grid) * context->probe_grid * context->probe_grid;
    const std::size_t probes = per_block * context->lv().blocks.size();
    if (count != 3 * probes)
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out has " + std::to_string(count) +
                                                    " floats, the probes need " + std::to_string(3 * probes));
    for (std::size_t b = 0; b < context->lv().blocks.size(); ++b)
      for (std::size_t p = 0; p < per_block; ++p) {
        const glm::dvec3 x = context->sampler.probe_position(b, int(p));
        for (int a = 0; a < 3; ++a) out[3 * (b * per_block + p) + std::size_t(a)] = float(x[a]);
      }
    return MODRT_OK;
  });
}

modrt_status modrt_context_get_timings(const modrt_context* context, modrt_timings* out) {
  if (!context) return null_arg("modrt_context_get_timings", "context");
  if (!out) return null_arg("modrt_context_get_timings", "out");
  if (modrt_status s = check_struct_size("modrt_context_get_timings", "out", *out, "modrt_timings");
      s != MODRT_OK)
    return s;
  write_sized(out, context->timings);
  return MODRT_OK;
}

modrt_status modrt_context_get_skip_stats(const modrt_context* context, modrt_skip_stats* out) {
  if (!context) return null_arg("modrt_context_get_skip_stats", "context");
  if (!out) return null_arg("modrt_context_get_skip_stats", "out");
  if (modrt_status s = check_struct_size("modrt_context_get_skip_stats", "out", *out, "modrt_skip_stats");
      s != MODRT_OK)
    return s;
  const FrameStats f = context->pipeline->stats();
  modrt_skip_stats k{};
  k.struct_size = sizeof k;
  k.frames = f.frames;
  k.frames_skipped = f.frames_skipped;
  k.blocks_computed = f.evaluations.blocks_computed;
  k.blocks_kept = f.evaluations.blocks_kept;
  k.slots_computed = f.evaluations.slots_computed;
  k.slots_kept = f.evaluations.slots_kept;
  k.tiles_written = f.evaluations.tiles_written;
  k.tiles_kept = f.evaluations.tiles_kept;
  k.light_blocks_recomputed = context->light_blocks_recomputed;
  k.light_blocks_kept = context->light_blocks_kept;
  k.tiles_hidden = f.evaluations.tiles_hidden;
  k.tiles_caught_up = f.evaluations.tiles_caught_up;
  write_sized(out, k);
  return MODRT_OK;
}

modrt_status modrt_context_get_solve_stats(const modrt_context* context, modrt_solve_stats* out) {
  constexpr const char* fn = "modrt_context_get_solve_stats";
  if (!context) return null_arg(fn, "context");
  if (!out) return null_arg(fn, "out");
  if (modrt_status s = check_struct_size(fn, "out", *out, "modrt_solve_stats"); s != MODRT_OK) return s;
  const ConvergedStats st = context->backend->converged_stats();
  modrt_solve_stats k{};
  k.struct_size = sizeof k;
  k.converged = st.solves > 0 && st.last.converged ? 1u : 0u;
  k.solves = st.solves;
  k.iterations = st.iterations;
  k.last_iterations = std::uint32_t(std::max(st.last.iterations, 0));
  k.last_residual = st.last.residual;
  k.last_error_bound = st.last.error_bound;
  k.damping = st.solves > 0 ? st.damping : 0.0f;
  k.spectral_radius = st.spectral_radius;
  k.contraction = st.contraction;
  k.build_ns = st.build_ns;
  k.fallback_updates = context->pipeline->stats().frames_fallback;
  k.blocks_applied = st.blocks_applied;
  *out = k;
  return MODRT_OK;
}

modrt_status modrt_context_set_visible_blocks(modrt_context* context, const uint8_t* flags, size_t count) {
  return guarded("modrt_context_set_visible_blocks", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_set_visible_blocks";
    if (!context) return null_arg(fn, "context");
    if (!flags && count != 0) return null_arg(fn, "flags");
    const std::size_t blocks = context->lv().blocks.size();
    if (count != 0 && count != blocks)
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": count is " + std::to_string(count) +
                                                    ", expected " + std::to_string(blocks) +
                                                    " (one flag per block) or 0 (every block)");
    BackendCall call(context);
    if (Status s = context->backend->set_visible_blocks({flags, count}); !s.ok())
      return backend_fail(context, fn, s);
    return MODRT_OK;
  });
}

modrt_status modrt_context_set_camera(modrt_context* context, const float view_projection[16],
                                      const float eye[3]) {
  return guarded("modrt_context_set_camera", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_set_camera";
    if (!context) return null_arg(fn, "context");
    if (!view_projection) return null_arg(fn, "view_projection");
    if (!eye) return null_arg(fn, "eye");
    glm::dmat4 vp(1.0);
    for (int k = 0; k < 16; ++k) vp[k / 4][k % 4] = double(view_projection[k]);  // column-major
    const glm::dvec3 e(eye[0], eye[1], eye[2]);
    // NaN or Inf is refused by the walk, naming view_projection[column][row] or eye[k].
    const Result<VisibilityStats> seen = context->camera.update(vp, e);
    if (!seen.ok()) return backend_fail(context, fn, seen.status());
    BackendCall call(context);
    if (Status s = context->backend->set_visible_blocks(context->camera.visible()); !s.ok())
      return backend_fail(context, fn, s);
    return MODRT_OK;
  });
}

modrt_status modrt_context_set_clutter(modrt_context* context, modrt_clutter* clutter) {
  return guarded("modrt_context_set_clutter", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_set_clutter";
    if (!context) return null_arg(fn, "context");
    if (clutter)
      if (Status s = check_drt_operators(context->lv(), clutter->drt); !s.ok())
        return fail(MODRT_ERROR_MISMATCH,
                    std::string(fn) + ": the clutter does not fit the context's level: " + s.message());
    {
      BackendCall call(context);
      if (Status s = context->pipeline->set_clutter(clutter ? &clutter->drt : nullptr); !s.ok())
        return backend_fail(context, fn, s);
    }
    if (clutter) retain(clutter);
    if (context->clutter) release(context->clutter);
    context->clutter = clutter;
    return MODRT_OK;
  });
}

modrt_status modrt_context_set_clutter_light(modrt_context* context, const float* clutter_ld,
                                             const float* clutter_direct, size_t count) {
  return guarded("modrt_context_set_clutter_light", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_set_clutter_light";
    if (!context) return null_arg(fn, "context");
    if (modrt_status s = check_clutter(context, fn); s != MODRT_OK) return s;
    if (!clutter_ld) return null_arg(fn, "clutter_ld");
    if (count != clutter_floats(context))
      return fail(MODRT_ERROR_INVALID_ARGUMENT,
                  std::string(fn) + ": count is " + std::to_string(count) + ", the clutter has " +
                      std::to_string(clutter_floats(context)) + " floats (3 per texel)");
    BackendCall call(context);
    const std::span<const float> direct =
        clutter_direct ? std::span<const float>(clutter_direct, count) : std::span<const float>();
    if (Status s = context->pipeline->set_clutter_light({clutter_ld, count}, direct); !s.ok())
      return backend_fail(context, fn, s);
    return MODRT_OK;
  });
}

modrt_status modrt_context_set_clutter_albedo(modrt_context* context, const float* albedo, size_t count) {
  return guarded("modrt_context_set_clutter_albedo", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_set_clutter_albedo";
    if (!context) return null_arg(fn, "context");
    if (modrt_status s = check_clutter(context, fn); s != MODRT_OK) return s;
    if (!albedo && count > 0) return null_arg(fn, "albedo");
    if (count != 0 && count != clutter_floats(context))
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": count is " + std::to_string(count) +
                                                    ", the clutter has " +
                                                    std::to_string(clutter_floats(context)) +
                                                    " floats (3 per texel; 0: no clutter feedback)");
    BackendCall call(context);
    const std::span<const float> a = count ? std::span<const float>(albedo, count) : std::span<const float>();
    if (Status s = context->pipeline->set_clutter_albedo(a, context->options.max_albedo); !s.ok())
      return backend_fail(context, fn, s);
    return MODRT_OK;
  });
}

modrt_status modrt_context_read_clutter_lightmap(modrt_context* context, float* out, size_t count) {
  return guarded("modrt_context_read_clutter_lightmap", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_context_read_clutter_lightmap";
    if (!context) return null_arg(fn, "context");
    if (!out) return null_arg(fn, "out");
    if (modrt_status s = check_clutter(context, fn); s != MODRT_OK) return s;
    if (modrt_status s = check_count(fn, "out", count, clutter_floats(context)); s != MODRT_OK) return s;
    BackendCall call(context);
    if (Status s = context->backend->read_clutter_lightmap({out, count}); !s.ok())
      return backend_fail(context, fn, s);
    return MODRT_OK;
  });
}

modrt_status modrt_context_get_clutter_texture(const modrt_context* context, uint32_t* texture, int* format,
                                               uint32_t* width, uint32_t* height) {
  constexpr const char* fn = "modrt_context_get_clutter_texture";
  if (!context) return null_arg(fn, "context");
  if (!texture) return null_arg(fn, "texture");
  return guarded(fn, [&]() -> modrt_status {
    if (modrt_status s = check_clutter(context, fn); s != MODRT_OK) return s;
    const std::uint32_t name = context->backend->output_texture(BackendOutput::clutter_atlas);
    if (name == 0)
      return fail(
          MODRT_ERROR_UNSUPPORTED,
          std::string(fn) + ": a CPU context has no GL textures: use modrt_context_read_clutter_lightmap");
    const TextureSize size = context->backend->clutter_atlas_size();
    *texture = name;
    if (format) *format = context->backend->output_texture_format();
    if (width) *width = std::uint32_t(size.width);
    if (height) *height = std::uint32_t(size.height);
    return MODRT_OK;
  });
}

modrt_status modrt_context_get_clutter_texel_coords(const modrt_context* context, uint32_t* xy,
                                                    size_t count) {
  constexpr const char* fn = "modrt_context_get_clutter_texel_coords";
  if (!context) return null_arg(fn, "context");
  if (!xy) return null_arg(fn, "xy");
  return guarded(fn, [&]() -> modrt_status {
    if (modrt_status s = check_clutter(context, fn); s != MODRT_OK) return s;
    const modrt_clutter& c = *context->clutter;
    if (count != 2 * std::size_t(c.first_texel.back()))
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": xy has " + std::to_string(count) +
                                                    " values, the clutter needs " +
                                                    std::to_string(2 * std::size_t(c.first_texel.back())));
    if (context->backend->output_texture(BackendOutput::clutter_atlas) == 0)
      return fail(MODRT_ERROR_UNSUPPORTED, std::string(fn) + ": a CPU context has no clutter atlas texture");
    for (std::size_t k = 0; k < c.drt.objects.size(); ++k)
      for (std::uint32_t t = 0; t < c.drt.objects[k].texel_count; ++t) {
        const std::array<int, 2> p = context->backend->clutter_atlas_texel(k, t);
        const std::size_t i = 2 * (std::size_t(c.first_texel[k]) + t);
        xy[i] = std::uint32_t(p[0]);
        xy[i + 1] = std::uint32_t(p[1]);
      }
    return MODRT_OK;
  });
}

}  // extern "C"
