// SPDX-License-Identifier: MIT
// modrt-hostile-tool: the hostile runner's helper (tests/hostile/README.md).
//
//   modrt-hostile-tool stats FILE...
//     Reads each image (PNG, EXR, ... through OpenImageIO, loaded for this subcommand only:
//     demo/image_io/image_io.h) and prints one line per file:
//       STATS <file> values=<n> nonfinite=<n> negative=<n> nonzero=<n> min=<v> max=<v>
//     (min / max over the finite values). Exit 1 when a file cannot be read.
//
//   modrt-hostile-tool capi --dictionary D --level L [options]
//     A C API host (runtime/include/modrt/modrt.h, CPU context): loads D and L, creates a
//     context, sets the albedo, the lights or ld, runs the updates and prints STATS lines for
//     the lightmap, the atlas and the probes it reads back. Every argument is passed on as a C
//     caller would: floats through strtof ("nan", "inf", "1e308" -> inf), ints through a cast
//     of a long long (4294967295 -> -1). A failing call prints
//       modrt-hostile-tool: <call>: <status name>: <message>
//     and exits 1; a bad command line exits 64 (a broken case, not a library error).
//     Options: --threads N, --max-lights N, --shadows N, --probes N, --skip N, --bounces N,
//     --max-albedo V, --vector N (context options); --albedo V (every sample, default 0.7); --ld V (set_ld
//     with V everywhere instead of lights); --ld-count N (the count passed to set_ld); --light TYPE starts a
//     light (point, spot, directional or a number) whose fields follow: --pos x,y,z,
//     --dir x,y,z, --color r,g,b, --intensity V, --radius V, --inner V, --outer V,
//     --light-shadows N; --probe x,y,z (probe_sh at that point after the updates, both
//     kinds); --updates N (default 2: set, update, set, update).
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "image_io.h"
#include "modrt/modrt.h"
#include "modrt/modrt.hpp"

namespace {

struct Stats {
  std::size_t values = 0, nonfinite = 0, negative = 0, nonzero = 0;
  double min = std::numeric_limits<double>::infinity(), max = -std::numeric_limits<double>::infinity();
  void add(float v) {
    ++values;
    if (!std::isfinite(v)) {
      ++nonfinite;
      return;
    }
    if (v < 0.0f) ++negative;
    if (v != 0.0f) ++nonzero;
    min = std::min(min, double(v));
    max = std::max(max, double(v));
  }
  void print(const std::string& what) const {
    std::printf("STATS %s values=%zu nonfinite=%zu negative=%zu nonzero=%zu min=%.9g max=%.9g\n",
                what.c_str(), values, nonfinite, negative, nonzero, values ? min : 0.0, values ? max : 0.0);
  }
};

int stats_main(int argc, char** argv) {
  int status = 0;
  for (int i = 2; i < argc; ++i) {
    modrt::image_io::FloatImage image;
    if (const std::string error = modrt::image_io::read_float(argv[i], image); !error.empty()) {
      std::fprintf(stderr, "modrt-hostile-tool: %s: %s\n", argv[i], error.c_str());
      status = 1;
      continue;
    }
    Stats s;
    for (float v : image.pixels) s.add(v);
    s.print(argv[i]);
  }
  return status;
}

bool parse_floats(const char* text, float* out, int n) {
  const char* p = text;
  for (int i = 0; i < n; ++i) {
    char* end = nullptr;
    out[i] = std::strtof(p, &end);  // ERANGE: +-inf or 0, as a C caller's literal would be
    if (end == p) return false;
    p = end;
    if (i + 1 < n) {
      if (*p != ',') return false;
      ++p;
    }
  }
  return *p == '\0';
}

bool parse_int(const char* text, int* out) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text, &end, 10);
  if (end == text || *end != '\0' || errno != 0) return false;
  *out = static_cast<int>(static_cast<long long>(static_cast<unsigned>(v)));  // 4294967295 -> -1
  return true;
}

int fail(const char* call, modrt_status s) {
  std::fprintf(stderr, "modrt-hostile-tool: %s: %s: %s\n", call, modrt_status_name(s), modrt_last_error());
  return 1;
}

int usage(const char* what) {
  std::fprintf(stderr, "modrt-hostile-tool capi: %s (see the comment at the top of hostile_tool.cpp)\n",
               what);
  return 64;  // the runner reports 64 as a broken case, not as the library's error
}

int capi_main(int argc, char** argv) {
  const char* dictionary_path = nullptr;
  const char* level_path = nullptr;
  modrt_context_options options;
  modrt_context_options_init(&options);
  float albedo = 0.7f, ld_value = 0.0f;
  bool use_ld = false;
  bool ld_count_given = false;
  std::size_t ld_count = 0;
  int updates = 2;
  std::vector<modrt_light> lights;
  std::vector<float> probe;
  for (int i = 2; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) return usage(("missing value after " + flag).c_str());
    const char* v = argv[++i];
    bool ok = true;
    modrt_light* light = lights.empty() ? nullptr : &lights.back();
    auto needs_light = [&]() {
      if (!light) ok = false;
      return light != nullptr;
    };
    if (flag == "--dictionary") {
      dictionary_path = v;
    } else if (flag == "--level") {
      level_path = v;
    } else if (flag == "--threads") {
      ok = parse_int(v, &options.threads);
    } else if (flag == "--max-lights") {
      int n = 0;
      ok = parse_int(v, &n);
      options.max_lights = std::uint32_t(n);
    } else if (flag == "--shadows") {
      ok = parse_int(v, &options.shadows);
    } else if (flag == "--probes") {
      ok = parse_int(v, &options.probes);
    } else if (flag == "--skip") {
      ok = parse_int(v, &options.skip_unchanged);
    } else if (flag == "--bounces") {
      int n = 0;
      ok = parse_int(v, &n);
      options.bounces = std::uint32_t(n);
    } else if (flag == "--max-albedo") {
      ok = parse_floats(v, &options.max_albedo, 1);
    } else if (flag == "--vector") {
      ok = parse_int(v, &options.vector_irradiance);
    } else if (flag == "--albedo") {
      ok = parse_floats(v, &albedo, 1);
    } else if (flag == "--ld") {
      ok = parse_floats(v, &ld_value, 1);
      use_ld = true;
    } else if (flag == "--ld-count") {
      char* end = nullptr;
      ld_count = std::size_t(std::strtoll(v, &end, 10));  // -1 -> SIZE_MAX, as a C caller's cast
      ld_count_given = true;
      ok = end != v && *end == '\0';
    } else if (flag == "--updates") {
      ok = parse_int(v, &updates);
    } else if (flag == "--probe") {
      probe.resize(3);
      ok = parse_floats(v, probe.data(), 3);
    } else if (flag == "--light") {
      modrt_light l;
      modrt_light_init(&l);
      l.type = MODRT_LIGHT_POINT;
      l.position[0] = l.position[1] = l.position[2] = 0.5f;
      l.direction[1] = -1.0f;
      l.color[0] = l.color[1] = l.color[2] = 1.0f;
      l.intensity = 1.0f;
      l.radius = 0.05f;
      l.inner_angle = 0.3f;
      l.outer_angle = 0.6f;
      l.shadows = 1;
      const std::string type = v;
      if (type == "point") {
        l.type = MODRT_LIGHT_POINT;
      } else if (type == "spot") {
        l.type = MODRT_LIGHT_SPOT;
      } else if (type == "directional") {
        l.type = MODRT_LIGHT_DIRECTIONAL;
      } else {
        int t = 0;
        ok = parse_int(v, &t);
        l.type = static_cast<modrt_light_type>(t);
      }
      lights.push_back(l);
    } else if (flag == "--pos") {
      ok = needs_light() && parse_floats(v, light->position, 3);
    } else if (flag == "--dir") {
      ok = needs_light() && parse_floats(v, light->direction, 3);
    } else if (flag == "--color") {
      ok = needs_light() && parse_floats(v, light->color, 3);
    } else if (flag == "--intensity") {
      ok = needs_light() && parse_floats(v, &light->intensity, 1);
    } else if (flag == "--radius") {
      ok = needs_light() && parse_floats(v, &light->radius, 1);
    } else if (flag == "--inner") {
      ok = needs_light() && parse_floats(v, &light->inner_angle, 1);
    } else if (flag == "--outer") {
      ok = needs_light() && parse_floats(v, &light->outer_angle, 1);
    } else if (flag == "--light-shadows") {
      ok = needs_light() && parse_int(v, &light->shadows);
    } else {
      return usage(("unknown flag " + flag).c_str());
    }
    if (!ok) return usage((flag + " " + v + ": cannot parse (or no --light before it)").c_str());
  }
  if (!dictionary_path || !level_path) return usage("--dictionary and --level are required");

  modrt_dictionary* dictionary = nullptr;
  modrt_level* level = nullptr;
  modrt_context* context = nullptr;
  struct Cleanup {
    modrt_dictionary** d;
    modrt_level** l;
    modrt_context** c;
    ~Cleanup() {
      modrt_context_destroy(*c);
      modrt_level_destroy(*l);
      modrt_dictionary_destroy(*d);
    }
  } cleanup{&dictionary, &level, &context};
  if (modrt_status s = modrt_dictionary_load_file(dictionary_path, nullptr, &dictionary); s != MODRT_OK)
    return fail("modrt_dictionary_load_file", s);
  if (modrt_status s = modrt_level_load_file(level_path, nullptr, &level); s != MODRT_OK)
    return fail("modrt_level_load_file", s);
  if (modrt_status s = modrt_context_create(dictionary, level, &options, nullptr, &context); s != MODRT_OK)
    return fail("modrt_context_create", s);
  modrt_sizes sizes = modrt::rt::sized<modrt_sizes>();
  if (modrt_status s = modrt_context_get_sizes(context, &sizes); s != MODRT_OK)
    return fail("modrt_context_get_sizes", s);
  const std::vector<float> albedo_values(sizes.ld, albedo);
  if (modrt_status s = modrt_context_set_albedo(context, albedo_values.data(), albedo_values.size());
      s != MODRT_OK)
    return fail("modrt_context_set_albedo", s);
  // A count other than sizes.ld must be refused before the data is read; the buffer still
  // holds up to 2^24 floats so that a library that reads `count` floats stays in bounds.
  const std::size_t count = ld_count_given ? ld_count : sizes.ld;
  const std::vector<float> ld(std::max(sizes.ld, std::min(count, std::size_t(1) << 24)), ld_value);
  if (updates < 0 || updates > 100) return usage("--updates: 0 to 100");
  for (int u = 0; u < updates; ++u) {
    if (use_ld) {
      if (modrt_status s = modrt_context_set_ld(context, ld.data(), count); s != MODRT_OK)
        return fail("modrt_context_set_ld", s);
    } else if (!lights.empty()) {
      if (modrt_status s = modrt_context_set_lights(context, lights.data(), lights.size()); s != MODRT_OK)
        return fail("modrt_context_set_lights", s);
    }
    if (modrt_status s = modrt_context_update(context); s != MODRT_OK) return fail("modrt_context_update", s);
  }
  std::vector<float> lightmap(sizes.lightmap), atlas(sizes.atlas);
  if (modrt_status s = modrt_context_read_lightmap(context, lightmap.data(), lightmap.size()); s != MODRT_OK)
    return fail("modrt_context_read_lightmap", s);
  if (modrt_status s = modrt_context_read_atlas(context, atlas.data(), atlas.size()); s != MODRT_OK)
    return fail("modrt_context_read_atlas", s);
  Stats lm, at;
  for (float v : lightmap) lm.add(v);
  for (float v : atlas) at.add(v);
  lm.print("lightmap");
  at.print("atlas");
  if (options.vector_irradiance) {  // signed coefficients: finite only
    std::vector<float> vec(4 * sizes.lightmap);
    if (modrt_status s = modrt_context_read_vector_lightmap(context, vec.data(), vec.size()); s != MODRT_OK)
      return fail("modrt_context_read_vector_lightmap", s);
    for (float v : vec)
      if (!std::isfinite(v))
        return fail("modrt_context_read_vector_lightmap (a value is not finite)", MODRT_ERROR_NON_FINITE);
  }
  if (!probe.empty()) {
    for (modrt_probe_kind kind : {MODRT_PROBE_RADIANCE, MODRT_PROBE_IRRADIANCE_OVER_PI}) {
      float sh[27];
      if (modrt_status s = modrt_context_probe_sh(context, probe.data(), kind, sh); s != MODRT_OK)
        return fail("modrt_context_probe_sh", s);
      // SH coefficients other than the DC term are signed; the DC term (k = 0) is not.
      Stats dc, all;
      for (int k = 0; k < 27; ++k) (k < 3 ? dc : all).add(sh[k]);
      dc.print(kind == MODRT_PROBE_RADIANCE ? "probe_radiance_dc" : "probe_irradiance_dc");
      std::printf("STATS %s values=%zu nonfinite=%zu\n",
                  kind == MODRT_PROBE_RADIANCE ? "probe_radiance_sh" : "probe_irradiance_sh", all.values,
                  all.nonfinite);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string command = argc > 1 ? argv[1] : "";
  if (command == "stats") return stats_main(argc, argv);
  if (command == "capi") return capi_main(argc, argv);
  std::fprintf(stderr, "usage: modrt-hostile-tool stats FILE... | capi --dictionary D --level L [options]\n");
  return 64;
}
