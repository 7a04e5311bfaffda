// SPDX-License-Identifier: MIT
// libFuzzer harness (issue 18): the numbers behind the command-line options. modrt-bake's
// flags fill a DictionarySettings and modrt-level's level JSON a LevelDescription; this
// harness fills both from fuzz bytes (each number either raw bits or one of the hostile
// values: 0, 1, 2^31 - 1, 2^32 - 1, huge, tiny, NaN, Inf, negative) and runs the library's
// validation, then checks what an accepted value must guarantee downstream:
//   - settings: validate_settings accepts only counts that survive the int conversions of the
//     bake (bake.cpp passes rays, prior_grid, light_samples, sh_rays ... as int) and whose
//     prior lattice (6 res^2 samples x prior_grid^3 sphere lights, doubles) estimate_bake_bytes
//     counts, so that the memory budget is checked before the bake allocates;
//   - lights: a light validate_level accepts is traced (level_direct_light on a two-block
//     corridor built against the committed tiny dictionary) without a crash, and gives
//     finite, non-negative ld.
// Any violation aborts, and the input is the reproducer.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "modrt/dictionary.h"
#include "modrt/dictionary_io.h"
#include "modrt/level_description.h"
#include "modrt/precompute/bake.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"

namespace {

using namespace modrt;

std::uint32_t fuzz_count(FuzzedDataProvider& in) {
  static constexpr std::uint32_t kEdges[] = {
      0u, 1u, 2u, 3u, 16u, 255u, 65536u, 100000u, 0x7FFFFFFFu, 0x80000000u, 0xFFFFFFFEu, 0xFFFFFFFFu};
  if (in.ConsumeBool()) return in.PickValueInArray(kEdges);
  return in.ConsumeIntegral<std::uint32_t>();
}

double fuzz_number(FuzzedDataProvider& in) {
  static constexpr double kEdges[] = {0.0,
                                      -0.0,
                                      1.0,
                                      -1.0,
                                      0.5,
                                      1e-300,
                                      1e-45,
                                      1e-12,
                                      1e19,
                                      1e20,
                                      1e38,
                                      3.5e38,
                                      1e308,
                                      -1e20,
                                      4294967295.0,
                                      std::numeric_limits<double>::infinity(),
                                      -std::numeric_limits<double>::infinity(),
                                      std::numeric_limits<double>::quiet_NaN()};
  switch (in.ConsumeIntegralInRange<int>(0, 2)) {
    case 0: return in.PickValueInArray(kEdges);
    case 1: {
      const std::uint64_t bits = in.ConsumeIntegral<std::uint64_t>();
      double d;
      static_assert(sizeof d == sizeof bits);
      __builtin_memcpy(&d, &bits, sizeof d);
      return d;
    }
    default: return in.ConsumeFloatingPointInRange<double>(-4.0, 4.0);
  }
}

void check_settings(FuzzedDataProvider& in) {
  DictionarySettings s;
  std::uint32_t* counts[] = {&s.res,
                             &s.kd,
                             &s.kb,
                             &s.rays,
                             &s.enrichment_iterations,
                             &s.prior_grid,
                             &s.light_samples,
                             &s.sh_rays,
                             &s.probe_grid,
                             &s.lightfield_spatial,
                             &s.lightfield_directional,
                             &s.lightfield_supersample,
                             &s.krlf,
                             &s.kr,
                             &s.interface_enrichment_iterations,
                             &s.response_rays};
  const int changed = in.ConsumeIntegralInRange<int>(1, 4);  // a few flags per run, the rest defaults
  for (int i = 0; i < changed; ++i) {
    const std::size_t which = in.ConsumeIntegralInRange<std::size_t>(0, std::size(counts));
    if (which == std::size(counts))
      s.light_radius = float(fuzz_number(in));
    else
      *counts[which] = fuzz_count(in);
  }
  if (!validate_settings(s).ok()) return;
  if (std::getenv("MODRT_FUZZ_PRINT"))
    std::fprintf(
        stderr,
        "settings res %u kd %u kb %u rays %u prior_grid %u light_samples %u sh_rays %u probe_grid %u "
        "lightfield %u/%u/%u krlf %u kr %u response_rays %u light_radius %.9g\n",
        s.res, s.kd, s.kb, s.rays, s.prior_grid, s.light_samples, s.sh_rays, s.probe_grid,
        s.lightfield_spatial, s.lightfield_directional, s.lightfield_supersample, s.krlf, s.kr,
        s.response_rays, s.light_radius);
  // int() in the bake wraps. The interface counts (from lightfield_directional on) are read only
  // when interfaces are baked (lightfield_spatial > 0), and validated only then.
  constexpr std::size_t kInterfaceCountsFrom = 10;  // counts[10]: &s.lightfield_directional
  const std::size_t used = s.lightfield_spatial > 0 ? std::size(counts) : kInterfaceCountsFrom;
  for (std::size_t i = 0; i < used; ++i)
    if (*counts[i] > std::uint32_t(std::numeric_limits<int>::max())) std::abort();
  if (!std::isfinite(s.light_radius) || s.light_radius < 0.0f) std::abort();
  // The prior lattice: 6 res^2 samples x prior_grid^3 lights, in double.
  const long double lattice =
      8.0L * 6.0L * s.res * s.res * (long double)s.prior_grid * s.prior_grid * s.prior_grid;
  const std::uint64_t estimate = precompute::estimate_bake_bytes(s);
  if ((long double)estimate < lattice) std::abort();  // the budget check would miss the prior
}

struct Corridor {
  Dictionary dict;
  LevelDescription desc;
  Level level;
  std::vector<float> albedo;
};

const Corridor* corridor() {
  static const Corridor* c = [] {
    auto* out = new Corridor;
    Result<Dictionary> dict = load_dictionary(MODRT_FUZZ_DICTIONARY);
    if (!dict.ok()) std::abort();
    out->dict = std::move(dict.value());
    out->desc.name = "fuzz corridor";
    BlockDescription a, b;
    a.cell = {0, 0, 0};
    a.faces = kAllFaces & ~FaceMask(1u << kFacePosZ);
    b.cell = {0, 0, 1};
    b.faces = kAllFaces & ~FaceMask(1u << kFaceNegZ);
    for (BlockDescription* block : {&a, &b}) block->albedo.fill(glm::dvec3(0.6));
    out->desc.blocks = {a, b};
    Result<Level> level = precompute::build_level(out->desc, out->dict);
    if (!level.ok()) std::abort();
    out->level = std::move(level.value());
    out->albedo = level_sample_albedo(out->level);
    return out;
  }();
  return c;
}

void check_lights(FuzzedDataProvider& in) {
  const Corridor* c = corridor();
  LevelDescription desc = c->desc;
  LightDescription light;
  const int changed = in.ConsumeIntegralInRange<int>(1, 3);
  for (int i = 0; i < changed; ++i) {
    const double v = fuzz_number(in);
    switch (in.ConsumeIntegralInRange<int>(0, 8)) {
      case 0: light.position.x = v; break;
      case 1: light.position.y = v; break;
      case 2: light.position.z = v; break;
      case 3: light.radius = v; break;
      case 4: light.color.r = v; break;
      case 5: light.color.g = v; break;
      case 6: light.intensity = v; break;
      case 7:
        light.position = glm::dvec3(0.5, in.ConsumeBool() ? 0.0 : 1.0, 0.5) + glm::dvec3(0, v, 0);
        break;
      default: desc.cell_size = v; break;
    }
  }
  desc.lights = {light};
  if (!validate_level(desc).ok()) return;
  if (std::getenv("MODRT_FUZZ_PRINT"))  // replaying a reproducer: say what it is
    std::fprintf(
        stderr,
        "light position (%.17g, %.17g, %.17g) radius %.17g colour (%.17g, %.17g, %.17g) intensity %.17g\n",
        light.position.x, light.position.y, light.position.z, light.radius, light.color.r, light.color.g,
        light.color.b, light.intensity);
  if (desc.cell_size != c->desc.cell_size) return;  // the corridor is built at cell size 1
  std::vector<float> ld;
  try {  // a thrown error reaches the programs' "direct light: ..." message: not a crash
    const precompute::LevelScene scene(c->level, c->level.res);
    ld = precompute::level_direct_light(scene, desc.lights, c->albedo, 4);
  } catch (const std::exception&) {
    return;
  }
  for (float v : ld)
    if (!std::isfinite(v) || v < 0.0f) std::abort();  // an accepted light lights finitely
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  if (in.ConsumeBool())
    check_settings(in);
  else
    check_lights(in);
  return 0;
}
