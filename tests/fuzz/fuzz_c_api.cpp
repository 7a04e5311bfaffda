// SPDX-License-Identifier: MIT
// libFuzzer harness (issue 18): the C API (runtime/include/modrt/modrt.h) driven by fuzz bytes.
// The committed tiny dictionary and maze11 level are loaded once; each input is a program of
// calls on a CPU context: create (fuzzed options), set_albedo, set_lights (fuzzed types,
// positions, directions, colours, intensities, radii, cone angles, counts), set_ld, update,
// the reads, probe_sh at fuzzed points, sizes / timings / skip stats, destroy. Every float is
// either raw bits or one of the hostile values (huge, tiny, denormal, NaN, Inf, negative).
// Beyond "no crash, no leak", the harness checks the contract of every output it reads back:
// after a successful update the lightmap and the atlas are finite and non-negative, probes
// are finite, a failing call returns a non-OK status with a message, and a failed update
// leaves the previous results in place. A violation aborts; the input is the reproducer.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "modrt/modrt.h"
#include "modrt/modrt.hpp"

namespace {

struct Assets {
  modrt_dictionary* dictionary = nullptr;
  modrt_level* level = nullptr;
  modrt_level_info info = modrt::rt::sized<modrt_level_info>();
};

const Assets& assets() {
  static const Assets a = [] {
    Assets out;
    if (modrt_dictionary_load_file(MODRT_FUZZ_DICTIONARY, nullptr, &out.dictionary) != MODRT_OK ||
        modrt_level_load_file(MODRT_FUZZ_LEVEL_FILE, nullptr, &out.level) != MODRT_OK ||
        modrt_level_get_info(out.level, &out.info) != MODRT_OK)
      std::abort();
    return out;
  }();
  return a;
}

float fuzz_float(FuzzedDataProvider& in) {
  static constexpr float kEdges[] = {0.0f,
                                     -0.0f,
                                     1.0f,
                                     -1.0f,
                                     0.5f,
                                     0.25f,
                                     1e-7f,
                                     1e-12f,
                                     1e-45f,
                                     1e-38f,
                                     1e6f,
                                     1e19f,
                                     1e20f,
                                     1e30f,
                                     3.4e38f,
                                     -1e20f,
                                     std::numeric_limits<float>::infinity(),
                                     -std::numeric_limits<float>::infinity(),
                                     std::numeric_limits<float>::quiet_NaN()};
  switch (in.ConsumeIntegralInRange<int>(0, 2)) {
    case 0: return in.PickValueInArray(kEdges);
    case 1: {
      const std::uint32_t bits = in.ConsumeIntegral<std::uint32_t>();
      float f;
      std::memcpy(&f, &bits, sizeof f);
      return f;
    }
    default: return in.ConsumeFloatingPointInRange<float>(-0.5f, 3.5f);  // inside and around the maze
  }
}

int fuzz_int(FuzzedDataProvider& in, int lo, int hi) {
  static constexpr int kEdges[] = {
      -1, 0, 1, 2, 257, 4097, 65536, std::numeric_limits<int>::max(), std::numeric_limits<int>::min()};
  return in.ConsumeBool() ? in.PickValueInArray(kEdges) : in.ConsumeIntegralInRange<int>(lo, hi);
}

modrt_light fuzz_light(FuzzedDataProvider& in) {
  modrt_light l;
  modrt_light_init(&l);
  l.type = static_cast<modrt_light_type>(in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(0, 2)
                                                          : fuzz_int(in, -1, 3));
  for (float& v : l.position) v = fuzz_float(in);
  for (float& v : l.direction) v = fuzz_float(in);
  for (float& v : l.color) v = fuzz_float(in);
  l.intensity = fuzz_float(in);
  l.radius = fuzz_float(in);
  l.inner_angle = fuzz_float(in);
  l.outer_angle = fuzz_float(in);
  l.shadows = in.ConsumeBool();
  return l;
}

void require_finite(const std::vector<float>& v, bool non_negative) {
  for (float x : v)
    if (!std::isfinite(x) || (non_negative && x < 0.0f)) std::abort();
}

void expect_failed(modrt_status s) {
  if (s != MODRT_OK && modrt_last_error()[0] == '\0') std::abort();  // a failure names its problem
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const Assets& a = assets();
  FuzzedDataProvider in(data, size);
  modrt_context_options options;
  modrt_context_options_init(&options);
  options.backend = MODRT_BACKEND_CPU;
  options.threads = in.ConsumeBool() ? 1 : fuzz_int(in, 1, 2);
  if (options.threads > 4 && options.threads <= 256) options.threads = 4;  // bounded work per input
  options.probes = in.ConsumeBool();
  options.skip_unchanged = in.ConsumeBool();
  options.shadows = in.ConsumeBool();
  options.timing = in.ConsumeBool();
  options.max_lights =
      std::uint32_t(in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(0, 9) : fuzz_int(in, 0, 9));
  options.bounces =
      std::uint32_t(in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(0, 3) : fuzz_int(in, 0, 3));
  if (in.ConsumeBool()) options.bounces = MODRT_BOUNCES_CONVERGED;  // the default
  if (in.ConsumeBool()) options.max_albedo = fuzz_float(in);
  options.vector_irradiance = in.ConsumeBool();
  modrt_context* context = nullptr;
  const modrt_status created = modrt_context_create(a.dictionary, a.level, &options, nullptr, &context);
  expect_failed(created);
  if (created != MODRT_OK) {
    if (context != nullptr) std::abort();  // a failed call writes no output
    return 0;
  }
  modrt_sizes sizes = modrt::rt::sized<modrt_sizes>();
  if (modrt_context_get_sizes(context, &sizes) != MODRT_OK ||
      sizes.ld != 3 * std::size_t(a.info.sample_count))
    std::abort();
  std::vector<float> lightmap(sizes.lightmap), atlas(sizes.atlas), previous;
  bool updated = false;
  for (int step = 0; step < 24 && in.remaining_bytes() > 0; ++step) {
    switch (in.ConsumeIntegralInRange<int>(0, 8)) {
      case 0: {  // albedo: one value everywhere, or one sample poked
        std::vector<float> albedo(sizes.ld, in.ConsumeBool() ? 0.7f : fuzz_float(in));
        if (in.ConsumeBool())
          albedo[in.ConsumeIntegralInRange<std::size_t>(0, albedo.size() - 1)] = fuzz_float(in);
        const std::size_t count =
            in.ConsumeBool() ? albedo.size() : in.ConsumeIntegralInRange<std::size_t>(0, albedo.size());
        expect_failed(modrt_context_set_albedo(context, albedo.data(), count));
        break;
      }
      case 1: {  // lights
        std::vector<modrt_light> lights(in.ConsumeIntegralInRange<std::size_t>(0, 9));
        for (modrt_light& l : lights) l = fuzz_light(in);
        expect_failed(modrt_context_set_lights(context, lights.data(), lights.size()));
        break;
      }
      case 2: {  // raw ld
        std::vector<float> ld(sizes.ld, in.ConsumeBool() ? 0.1f : fuzz_float(in));
        if (in.ConsumeBool()) ld[in.ConsumeIntegralInRange<std::size_t>(0, ld.size() - 1)] = fuzz_float(in);
        expect_failed(modrt_context_set_ld(context, ld.data(), in.ConsumeBool() ? ld.size() : ld.size() - 1));
        break;
      }
      case 3:
      case 4: {  // update, then every output read back must be finite and non-negative
        const modrt_status s = modrt_context_update(context);
        expect_failed(s);
        if (s != MODRT_OK && !updated) break;
        if (modrt_context_read_lightmap(context, lightmap.data(), lightmap.size()) != MODRT_OK ||
            modrt_context_read_atlas(context, atlas.data(), atlas.size()) != MODRT_OK)
          std::abort();
        if (s == MODRT_OK) {
          require_finite(lightmap, true);
          require_finite(atlas, true);
          const float* direct = nullptr;
          std::size_t count = 0;
          if (modrt_context_get_atlas_data(context, &direct, &count) != MODRT_OK || count != atlas.size() ||
              std::memcmp(direct, atlas.data(), count * sizeof(float)) != 0)
            std::abort();
          previous = lightmap;
          updated = true;
        } else if (std::memcmp(previous.data(), lightmap.data(), lightmap.size() * sizeof(float)) != 0) {
          std::abort();  // "on failure the previous results stay"
        }
        break;
      }
      case 5: {  // probes
        float position[3], sh[27];
        for (float& v : position) v = fuzz_float(in);
        const modrt_probe_kind kind =
            in.ConsumeBool() ? MODRT_PROBE_RADIANCE : MODRT_PROBE_IRRADIANCE_OVER_PI;
        const modrt_status s = modrt_context_probe_sh(context, position, kind, sh);
        expect_failed(s);
        if (s == MODRT_OK)
          for (float v : sh)
            if (!std::isfinite(v)) std::abort();
        break;
      }
      case 6: {
        modrt_timings t = modrt::rt::sized<modrt_timings>();
        modrt_skip_stats k = modrt::rt::sized<modrt_skip_stats>();
        if (modrt_context_get_timings(context, &t) != MODRT_OK ||
            modrt_context_get_skip_stats(context, &k) != MODRT_OK)
          std::abort();
        if (k.blocks_computed + k.blocks_kept < k.frames) std::abort();
        break;
      }
      case 7: {  // the vector irradiance and the probe volume of the last update: finite
        std::vector<float> v(4 * sizes.lightmap), volume(sizes.probes);
        const modrt_status sv = modrt_context_read_vector_lightmap(context, v.data(), v.size());
        expect_failed(sv);
        if (sv == MODRT_OK) require_finite(v, false);
        if (sizes.probes > 0) {
          const modrt_status sp = modrt_context_read_probes(context, MODRT_PROBE_IRRADIANCE_OVER_PI,
                                                            volume.data(), volume.size());
          expect_failed(sp);
          if (sp == MODRT_OK) require_finite(volume, false);
        }
        break;
      }
      default: {  // an unknown probe kind and a null output must be refused, not crash
        float position[3] = {0.5f, 0.5f, 0.5f}, sh[27];
        expect_failed(
            modrt_context_probe_sh(context, position, static_cast<modrt_probe_kind>(fuzz_int(in, 2, 9)), sh));
        expect_failed(modrt_context_read_lightmap(context, nullptr, lightmap.size()));
        break;
      }
    }
  }
  modrt_context_destroy(context);
  return 0;
}
