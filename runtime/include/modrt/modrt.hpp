// SPDX-License-Identifier: MIT
// modrt — a thin C++ wrapper over the C API (modrt.h): move-only owners of the handles, and
// calls that return a modrt::rt::Error (code + message) instead of a bare status. Header-only
// and exception-free, so an app built with -fno-exceptions can use it; nothing here is part
// of the library's ABI.
//
//   modrt::rt::Dictionary dict;
//   if (modrt::rt::Error e = modrt::rt::Dictionary::load_file("dict.modrt", dict)) { log(e.message); }
//   modrt::rt::Level level;  ... Level::load_memory(bytes, size, "level", level)
//   modrt::rt::Context ctx;  ... Context::create(dict, level, options, ctx)
//   ctx.set_lights(lights, n); ctx.update(); GLuint tex = ctx.atlas_texture();
#pragma once

#include <string>
#include <utility>

#include "modrt/modrt.h"

namespace modrt::rt {

struct Error {
  modrt_status code = MODRT_OK;
  std::string message;  // modrt_last_error() at the time of the failure
  explicit operator bool() const { return code != MODRT_OK; }  // true on failure
};

// A C API struct, zeroed, with its struct_size set (modrt.h, "Structs"):
//   modrt_sizes s = modrt::rt::sized<modrt_sizes>();
template <class T>
T sized() {
  T t{};
  t.struct_size = sizeof(T);
  return t;
}

inline Error check(modrt_status s) {
  if (s == MODRT_OK) return {};
  return {s, modrt_last_error()};
}

// Owner of one handle type H, destroyed by D.
template <class H, void (*D)(H*)>
class Handle {
 public:
  Handle() = default;
  explicit Handle(H* h) : h_(h) {}
  Handle(Handle&& o) noexcept : h_(std::exchange(o.h_, nullptr)) {}
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) reset(std::exchange(o.h_, nullptr));
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }
  void reset(H* h = nullptr) {
    if (h_) D(h_);
    h_ = h;
  }
  H* get() const { return h_; }
  explicit operator bool() const { return h_ != nullptr; }

 protected:
  H* h_ = nullptr;
};

class Dictionary : public Handle<modrt_dictionary, modrt_dictionary_destroy> {
 public:
  static Error load_file(const char* path, Dictionary& out, const modrt_allocator* allocator = nullptr) {
    modrt_dictionary* h = nullptr;
    Error e = check(modrt_dictionary_load_file(path, allocator, &h));
    if (!e) out.reset(h);
    return e;
  }
  static Error load_memory(const void* data, size_t size, const char* name, Dictionary& out,
                           const modrt_allocator* allocator = nullptr) {
    modrt_dictionary* h = nullptr;
    Error e = check(modrt_dictionary_load_memory(data, size, name, allocator, &h));
    if (!e) out.reset(h);
    return e;
  }
};

class Level : public Handle<modrt_level, modrt_level_destroy> {
 public:
  static Error load_file(const char* path, Level& out, const modrt_allocator* allocator = nullptr) {
    modrt_level* h = nullptr;
    Error e = check(modrt_level_load_file(path, allocator, &h));
    if (!e) out.reset(h);
    return e;
  }
  static Error load_memory(const void* data, size_t size, const char* name, Level& out,
                           const modrt_allocator* allocator = nullptr) {
    modrt_level* h = nullptr;
    Error e = check(modrt_level_load_memory(data, size, name, allocator, &h));
    if (!e) out.reset(h);
    return e;
  }
  modrt_level_info info() const {
    modrt_level_info i = sized<modrt_level_info>();
    modrt_level_get_info(h_, &i);
    return i;
  }
  Error albedo(float* out, size_t count) const { return check(modrt_level_get_albedo(h_, out, count)); }
  Error samples(modrt_level_sample* out, size_t count) const {
    return check(modrt_level_get_samples(h_, out, count));
  }
  Error block(uint32_t index, modrt_level_block& out) const {
    out = sized<modrt_level_block>();
    return check(modrt_level_get_block(h_, index, &out));
  }
};

// DRT clutter operators (a .modrtdrt file), set on a context of their level.
class Clutter : public Handle<modrt_clutter, modrt_clutter_destroy> {
 public:
  static Error load_file(const char* path, Clutter& out, const modrt_allocator* allocator = nullptr) {
    modrt_clutter* h = nullptr;
    Error e = check(modrt_clutter_load_file(path, allocator, &h));
    if (!e) out.reset(h);
    return e;
  }
  static Error load_memory(const void* data, size_t size, const char* name, Clutter& out,
                           const modrt_allocator* allocator = nullptr) {
    modrt_clutter* h = nullptr;
    Error e = check(modrt_clutter_load_memory(data, size, name, allocator, &h));
    if (!e) out.reset(h);
    return e;
  }
  modrt_clutter_info info() const {
    modrt_clutter_info i = sized<modrt_clutter_info>();
    modrt_clutter_get_info(h_, &i);
    return i;
  }
  Error texels(modrt_clutter_texel* out, size_t count) const {
    return check(modrt_clutter_get_texels(h_, out, count));
  }
  // Each texel's lightmap cell (object, face, u, v, res; modrt_clutter_get_texel_cells).
  Error texel_cells(modrt_clutter_cell* out, size_t count) const {
    return check(modrt_clutter_get_texel_cells(h_, out, count));
  }
};

inline modrt_context_options default_options(modrt_backend backend = MODRT_BACKEND_CPU) {
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  return o;
}

class Context : public Handle<modrt_context, modrt_context_destroy> {
 public:
  // A GLES context is created on the GL context current on this thread (see modrt.h).
  static Error create(const Dictionary& dict, const Level& level, const modrt_context_options& options,
                      Context& out, const modrt_allocator* allocator = nullptr) {
    modrt_context* h = nullptr;
    Error e = check(modrt_context_create(dict.get(), level.get(), &options, allocator, &h));
    if (!e) out.reset(h);
    return e;
  }
  modrt_sizes sizes() const {
    modrt_sizes s = sized<modrt_sizes>();
    modrt_context_get_sizes(h_, &s);
    return s;
  }
  const char* description() const { return modrt_context_description(h_); }
  Error set_albedo(const float* albedo, size_t count) {
    return check(modrt_context_set_albedo(h_, albedo, count));
  }
  Error set_lights(const modrt_light* lights, size_t count) {
    return check(modrt_context_set_lights(h_, lights, count));
  }
  Error set_ld(const float* ld, size_t count) { return check(modrt_context_set_ld(h_, ld, count)); }
  Error read_ld(float* out, size_t count) const { return check(modrt_context_read_ld(h_, out, count)); }
  // GLES: ld from the app's own texture in ld_layout() (see modrt_context_set_ld_texture).
  Error set_ld_texture(uint32_t texture) { return check(modrt_context_set_ld_texture(h_, texture)); }
  // GLES: ld of one point or spot light evaluated at the samples on the GPU, shadowed by the
  // app's cube shadow map when `shadow` names one (see modrt_context_set_light_gpu).
  Error set_light_gpu(const modrt_light& light, const modrt_shadow_cube* shadow = nullptr) {
    return check(modrt_context_set_light_gpu(h_, &light, shadow));
  }
  Error ld_layout(uint32_t& width, uint32_t& height) const {
    return check(modrt_context_get_ld_layout(h_, &width, &height));
  }
  // DRT clutter (see modrt_context_set_clutter); a null Clutter removes it.
  Error set_clutter(const Clutter& clutter) { return check(modrt_context_set_clutter(h_, clutter.get())); }
  Error set_clutter_light(const float* clutter_ld, const float* clutter_direct, size_t count) {
    return check(modrt_context_set_clutter_light(h_, clutter_ld, clutter_direct, count));
  }
  Error set_clutter_albedo(const float* albedo, size_t count) {
    return check(modrt_context_set_clutter_albedo(h_, albedo, count));
  }
  Error read_clutter_lightmap(float* out, size_t count) {
    return check(modrt_context_read_clutter_lightmap(h_, out, count));
  }
  // GLES: the probe volume in the world frame as a GL texture (modrt_context_get_probe_texture).
  Error probe_texture(uint32_t& texture, int* format = nullptr, uint32_t* width = nullptr,
                      uint32_t* height = nullptr) {
    return check(modrt_context_get_probe_texture(h_, &texture, format, width, height));
  }
  Error read_probes(float* out, size_t count, modrt_probe_kind kind = MODRT_PROBE_IRRADIANCE_OVER_PI) {
    return check(modrt_context_read_probes(h_, kind, out, count));
  }
  Error read_albedo(float* out, size_t count) const {
    return check(modrt_context_read_albedo(h_, out, count));
  }
  // The feedback steps of the following updates, 0 to 64, or MODRT_BOUNCES_CONVERGED (the
  // default; modrt_context_set_bounces).
  Error set_bounces(uint32_t bounces) { return check(modrt_context_set_bounces(h_, bounces)); }
  uint32_t bounces() const {
    uint32_t n = 0;
    modrt_context_get_bounces(h_, &n);
    return n;
  }
  Error update() { return check(modrt_context_update(h_)); }
  // 0 for a CPU context.
  uint32_t atlas_texture(int* format = nullptr) const {
    uint32_t t = 0;
    return modrt_context_get_atlas_texture(h_, &t, format) == MODRT_OK ? t : 0;
  }
  Error read_atlas(float* out, size_t count) { return check(modrt_context_read_atlas(h_, out, count)); }
  Error read_lightmap(float* out, size_t count) { return check(modrt_context_read_lightmap(h_, out, count)); }
  Error read_vector_lightmap(float* out, size_t count) {
    return check(modrt_context_read_vector_lightmap(h_, out, count));
  }
  Error read_vector_atlas(int coefficient, float* out, size_t count) {
    return check(modrt_context_read_vector_atlas(h_, coefficient, out, count));
  }
  Error probe_sh(const float position[3], float out[27],
                 modrt_probe_kind kind = MODRT_PROBE_IRRADIANCE_OVER_PI) {
    return check(modrt_context_probe_sh(h_, position, kind, out));
  }
  // The probe cell of a world point, for sampling the probe volume on the GPU
  // (modrt_context_locate_probe).
  Error locate_probe(const float position[3], modrt_probe_cell& out) const {
    out = sized<modrt_probe_cell>();
    return check(modrt_context_locate_probe(h_, position, &out));
  }
  modrt_timings timings() const {
    modrt_timings t = sized<modrt_timings>();
    modrt_context_get_timings(h_, &t);
    return t;
  }
  modrt_skip_stats skip_stats() const {
    modrt_skip_stats s = sized<modrt_skip_stats>();
    modrt_context_get_skip_stats(h_, &s);
    return s;
  }
  // The converged solve's statistics (modrt_context_get_solve_stats).
  modrt_solve_stats solve_stats() const {
    modrt_solve_stats s = sized<modrt_solve_stats>();
    modrt_context_get_solve_stats(h_, &s);
    return s;
  }
  // The camera skip (modrt_context_set_camera / modrt_context_set_visible_blocks; CPU contexts).
  Error set_camera(const float view_projection[16], const float eye[3]) {
    return check(modrt_context_set_camera(h_, view_projection, eye));
  }
  Error set_visible_blocks(const uint8_t* flags, size_t count) {
    return check(modrt_context_set_visible_blocks(h_, flags, count));
  }
};

}  // namespace modrt::rt
