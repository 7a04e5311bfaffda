// SPDX-License-Identifier: MIT
// The embeddable runtime's C API (runtime/include/modrt/modrt.h): loading from memory and
// files, CPU and GLES contexts against the C++ backends and core's reference, probes against
// the reference probes rotated into the world, lights against CpuDirectLight, the allocator
// hook, no allocation per frame, and every error path returning a code and a message naming
// the problem.
//
// Tolerances (relative L2 over all values): CPU context against create_cpu_backend 0 (the
// same runtime, same ISA: bit-identical), against core's reference 1e-5 (float sums in
// another order, as test_cpu_backend); GLES context against the reference 1e-4 (float32
// targets, as test_gles_backend). Probe SH in the world frame: evaluated along 64 directions,
// within 1e-5 of the canonical probe evaluated along the turned directions (relative to the
// probe's largest coefficient).
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "c_api_test_support.h"
#include "counting_allocator.h"
#include "gl_test_context.h"
#include "level_fixtures.h"
#include "modrt/backends.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/cpu/direct_light.h"
#include "modrt/cube.h"
#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"
#include "modrt/frame_pipeline.h"
#include "modrt/level_geometry.h"
#include "modrt/level_io.h"
#include "modrt/level_runtime.h"
#include "modrt/level_visibility.h"
#include "modrt/modrt.h"
#include "modrt/modrt.hpp"
#include "modrt/platform/gl_context.h"
#include "modrt/probe_sampler.h"
#include "modrt/reduced_feedback.h"
#include "modrt/reference_runtime.h"
#include "modrt/sh.h"
#include "test_support.h"

namespace modrt {
namespace {

using test::expect_error;
using test::level_reference;
using test::rel_l2;
using test::small_test_dictionary;
using test::test_level;

struct Assets {
  std::vector<std::byte> dictionary, level;
};
const Assets& assets(const std::string& name = "maze11") {
  static std::map<std::string, Assets> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    Assets a;
    a.dictionary = serialize_dictionary(small_test_dictionary()).value();
    a.level = serialize_level(test_level(name).level).value();
    it = cache.emplace(name, std::move(a)).first;
  }
  return it->second;
}

modrt_dictionary* load_dictionary_handle() {
  modrt_dictionary* d = nullptr;
  EXPECT_EQ(modrt_dictionary_load_memory(assets().dictionary.data(), assets().dictionary.size(), "dict",
                                         nullptr, &d),
            MODRT_OK)
      << modrt_last_error();
  return d;
}
modrt_level* load_level_handle(const std::string& name = "maze11") {
  modrt_level* l = nullptr;
  EXPECT_EQ(modrt_level_load_memory(assets(name).level.data(), assets(name).level.size(), name.c_str(),
                                    nullptr, &l),
            MODRT_OK)
      << modrt_last_error();
  return l;
}
// The defaults with one bounce (bounces 0), for the comparisons with one-bounce references
// (level_reference, CpuLevelRuntime::evaluate). The default is the converged multi-bounce
// (CApi.ConvergedBouncesAreCoresConvergedSolve).
modrt_context_options one_bounce_options(modrt_backend backend = MODRT_BACKEND_CPU) {
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  o.bounces = 0;
  return o;
}

std::vector<float> read_lightmap(modrt_context* c) {
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  EXPECT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  std::vector<float> out(s.lightmap);
  EXPECT_EQ(modrt_context_read_lightmap(c, out.data(), out.size()), MODRT_OK) << modrt_last_error();
  return out;
}
std::vector<float> read_atlas(modrt_context* c) {
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  EXPECT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  std::vector<float> out(s.atlas);
  EXPECT_EQ(modrt_context_read_atlas(c, out.data(), out.size()), MODRT_OK) << modrt_last_error();
  return out;
}

TEST(CApi, VersionAndStatusNames) {
  EXPECT_EQ(modrt_version(), std::uint32_t(MODRT_VERSION));
  EXPECT_STREQ(modrt_version_string(), "0.3.0");
  EXPECT_STREQ(modrt_status_name(MODRT_ERROR_FORMAT), "MODRT_ERROR_FORMAT");
  EXPECT_STREQ(modrt_status_name(modrt_status(99)), "MODRT_ERROR_UNKNOWN");
}

TEST(CApi, LoadsFromMemoryAndFileAlike) {
  const std::filesystem::path dir = std::filesystem::path(MODRT_TEST_CACHE_DIR) / "c_api";
  std::filesystem::create_directories(dir);
  const std::string dict_path = (dir / "dict.modrt").string(),
                    level_path = (dir / "maze11.modrtlevel").string();
  ASSERT_TRUE(write_file_atomic(dict_path, assets().dictionary).ok());
  ASSERT_TRUE(write_file_atomic(level_path, assets().level).ok());

  modrt_dictionary* d = nullptr;
  modrt_level* l = nullptr;
  ASSERT_EQ(modrt_dictionary_load_file(dict_path.c_str(), nullptr, &d), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_level_load_file(level_path.c_str(), nullptr, &l), MODRT_OK) << modrt_last_error();
  modrt_level_info info = modrt::rt::sized<modrt_level_info>();
  ASSERT_EQ(modrt_level_get_info(l, &info), MODRT_OK);
  const Level& ref = test_level("maze11").level;
  EXPECT_EQ(info.block_count, ref.blocks.size());
  EXPECT_EQ(info.sample_count, ref.sample_count);
  EXPECT_EQ(info.atlas_width, std::uint32_t(ref.atlas.width));
  EXPECT_EQ(info.atlas_height, std::uint32_t(ref.atlas.height));
  EXPECT_LT(info.bounds_min[0], info.bounds_max[0]);

  // The file and memory paths give the same results.
  modrt_dictionary* dm = load_dictionary_handle();
  modrt_level* lm = load_level_handle();
  modrt_context *cf = nullptr, *cm = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, nullptr, nullptr, &cf), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_create(dm, lm, nullptr, nullptr, &cm), MODRT_OK) << modrt_last_error();
  const std::vector<float>& ld = test_level("maze11").ld;
  for (modrt_context* c : {cf, cm}) {
    ASSERT_EQ(modrt_context_set_ld(c, ld.data(), ld.size()), MODRT_OK) << modrt_last_error();
    ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  }
  EXPECT_EQ(read_lightmap(cf), read_lightmap(cm));
  // Contexts hold references: the handles can go first.
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(dm);
  modrt_level_destroy(lm);
  ASSERT_EQ(modrt_context_update(cf), MODRT_OK) << modrt_last_error();
  modrt_context_destroy(cf);
  modrt_context_destroy(cm);
}

TEST(CApi, CpuContextEqualsTheCpuBackendAndTheReference) {
  // "stretched": a level file with shaped operators (Level::shaped, format version 3) through
  // the installed runtime's load and context.
  for (const char* name : {"single", "corridor", "maze11", "stretched"}) {
    SCOPED_TRACE(name);
    const test::TestLevel& t = test_level(name);
    modrt_dictionary* d = load_dictionary_handle();
    modrt_level* l = load_level_handle(name);
    modrt_context_options o;
    modrt_context_options_init(&o);
    o.skip_unchanged = 0;
    o.bounces = 0;  // one bounce, as the reference and the CPU backend's evaluate
    modrt_context* c = nullptr;
    ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
    EXPECT_EQ(std::string(modrt_context_description(c)).rfind("cpu ", 0), 0u);
    ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
    ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();

    std::unique_ptr<Backend> be = cpu::create_cpu_backend(t.level, small_test_dictionary()).value();
    ASSERT_TRUE(be->update(t.ld).ok());
    std::vector<float> lightmap(be->sizes().lightmap), atlas(be->sizes().atlas);
    ASSERT_TRUE(be->read_lightmap(lightmap).ok());
    ASSERT_TRUE(be->read_atlas(atlas).ok());
    EXPECT_EQ(read_lightmap(c), lightmap);
    const float* data = nullptr;
    size_t count = 0;
    ASSERT_EQ(modrt_context_get_atlas_data(c, &data, &count), MODRT_OK);
    EXPECT_EQ(std::vector<float>(data, data + count), atlas);
    EXPECT_EQ(read_atlas(c), atlas);

    const test::LevelReference ref = level_reference(t.level, t.ld);
    EXPECT_LT(rel_l2(read_lightmap(c), ref.lightmap), 1e-5);
    EXPECT_LT(rel_l2(atlas, ref.atlas), 1e-5);
    modrt_context_destroy(c);
    modrt_dictionary_destroy(d);
    modrt_level_destroy(l);
  }
}

// Probe SH at each probe centre is that probe, rotated into the world frame.
void check_probes_at_centres(modrt_context* c, const Level& level, std::span<const float> ref_probes) {
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  ASSERT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  const int g = int(s.probe_grid);
  ASSERT_GT(g, 0);
  ASSERT_EQ(s.probes, ref_probes.size());
  double worst = 0.0;
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& blk = level.blocks[bi];
    for (int iz = 0; iz < g; ++iz)
      for (int iy = 0; iy < g; ++iy)
        for (int ix = 0; ix < g; ++ix) {
          const glm::dvec3 p((ix + 0.5) / g, (iy + 0.5) / g, (iz + 0.5) / g);
          const glm::dvec3 x = block_to_world(blk, p);
          const float pos[3] = {float(x.x), float(x.y), float(x.z)};
          float world[27];
          ASSERT_EQ(modrt_context_probe_sh(c, pos, MODRT_PROBE_RADIANCE, world), MODRT_OK)
              << modrt_last_error();
          const float* canonical =
              ref_probes.data() + 27 * (std::size_t(ix + g * (iy + g * iz)) + std::size_t(g * g * g) * bi);
          double scale = 1e-12;
          for (int k = 0; k < 27; ++k) scale = std::max(scale, double(std::abs(canonical[k])));
          for (int j = 0; j < 64; ++j) {
            const double z = 1.0 - (j + 0.5) / 32.0, r = std::sqrt(1.0 - z * z), phi = 2.399963 * j;
            const glm::dvec3 dir(r * std::cos(phi), r * std::sin(phi), z);
            double yw[9], yc[9];
            sh9_eval(dir, yw);
            sh9_eval(rotate_direction(dir, -blk.quarter_turns), yc);
            for (int ch = 0; ch < 3; ++ch) {
              double vw = 0.0, vc = 0.0;
              for (int k = 0; k < 9; ++k)
                vw += yw[k] * world[3 * k + ch], vc += yc[k] * canonical[3 * k + ch];
              worst = std::max(worst, std::abs(vw - vc) / scale);
            }
          }
        }
  }
  EXPECT_LT(worst, 1e-5);
}

TEST(CApi, ProbesAreTheReferenceProbesInTheWorldFrame) {
  const test::TestLevel& t = test_level("maze11");
  bool turned = false;
  for (const LevelBlock& b : t.level.blocks) turned |= (b.quarter_turns & 3) != 0;
  EXPECT_TRUE(turned) << "the maze should hold turned blocks, or the rotation is untested";
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  const modrt_context_options o = one_bounce_options();
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  const test::LevelReference ref = level_reference(t.level, t.ld);
  check_probes_at_centres(c, t.level, ref.probes);

  // Between two probe centres along x the value is their average (trilinear); E/pi scales the
  // bands by 1, 2/3, 1/4.
  const LevelBlock& blk = t.level.blocks[0];
  const glm::dvec3 a = block_to_world(blk, glm::dvec3(0.25, 0.25, 0.25)),
                   b = block_to_world(blk, glm::dvec3(0.75, 0.25, 0.25)),
                   m = block_to_world(blk, glm::dvec3(0.5, 0.25, 0.25));
  float sa[27], sb[27], sm[27], em[27];
  const float pa[3] = {float(a.x), float(a.y), float(a.z)}, pb[3] = {float(b.x), float(b.y), float(b.z)},
              pm[3] = {float(m.x), float(m.y), float(m.z)};
  ASSERT_EQ(modrt_context_probe_sh(c, pa, MODRT_PROBE_RADIANCE, sa), MODRT_OK);
  ASSERT_EQ(modrt_context_probe_sh(c, pb, MODRT_PROBE_RADIANCE, sb), MODRT_OK);
  ASSERT_EQ(modrt_context_probe_sh(c, pm, MODRT_PROBE_RADIANCE, sm), MODRT_OK);
  ASSERT_EQ(modrt_context_probe_sh(c, pm, MODRT_PROBE_IRRADIANCE_OVER_PI, em), MODRT_OK);
  for (int k = 0; k < 27; ++k) {
    const double tol = 1e-5 * (std::abs(sa[k]) + std::abs(sb[k]) + 1e-6);
    EXPECT_NEAR(sm[k], 0.5 * (sa[k] + sb[k]), tol) << k;
    const int band = k / 3 == 0 ? 0 : k / 3 < 4 ? 1 : 2;
    EXPECT_NEAR(em[k],
                sm[k] * (band == 0   ? 1.0
                         : band == 1 ? 2.0 / 3.0
                                     : 0.25),
                1e-6 * (std::abs(sm[k]) + 1e-6));
  }
  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

modrt_light to_c(const cpu::CpuLight& l) {
  modrt_light c;
  modrt_light_init(&c);
  c.type = modrt_light_type(int(l.type));
  for (int a = 0; a < 3; ++a) {
    c.position[a] = l.position[a];
    c.direction[a] = l.direction[a];
    c.color[a] = l.color[a];
  }
  c.intensity = l.intensity;
  c.radius = l.radius;
  c.inner_angle = l.inner_angle;
  c.outer_angle = l.outer_angle;
  c.shadows = l.shadows;
  return c;
}

std::vector<cpu::CpuLight> frame_lights(const Level& level, int frame) {
  glm::dvec3 lo(1e30), hi(-1e30);
  for (const LevelBlock& b : level.blocks)
    for (const glm::dvec3& c : b.corners) lo = glm::min(lo, c), hi = glm::max(hi, c);
  const glm::vec3 centre = glm::vec3(0.5 * (lo + hi));
  cpu::CpuLight point;
  point.position = level.blocks.empty()
                       ? centre
                       : glm::vec3(block_to_world(level.blocks[std::size_t(frame) % level.blocks.size()],
                                                  glm::dvec3(0.5, 0.6, 0.45)));
  point.color = glm::vec3(1.0f, 0.8f, 0.6f);
  point.intensity = 2.0f;
  cpu::CpuLight spot;
  spot.type = cpu::LightType::spot;
  spot.position = glm::vec3(block_to_world(level.blocks[0], glm::dvec3(0.4, 0.9, 0.5)));
  spot.direction = glm::vec3(0.1f * float(frame), -1.0f, 0.2f);
  spot.intensity = 3.0f;
  cpu::CpuLight sun;
  sun.type = cpu::LightType::directional;
  sun.direction = glm::vec3(0.3f, -1.0f, 0.2f);
  sun.intensity = 0.5f;
  return {point, spot, sun};
}

TEST(CApi, LightsGiveTheDirectLightEvaluatorsLd) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  const modrt_context_options o = one_bounce_options();
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_albedo(c, t.albedo.data(), t.albedo.size()), MODRT_OK) << modrt_last_error();
  cpu::CpuDirectLight direct = cpu::CpuDirectLight::create(t.level, t.albedo).value();
  std::vector<float> ld(t.ld.size());
  for (int frame = 0; frame < 3; ++frame) {
    const std::vector<cpu::CpuLight> lights = frame_lights(t.level, frame);
    std::vector<modrt_light> cl;
    for (const cpu::CpuLight& x : lights) cl.push_back(to_c(x));
    ASSERT_EQ(modrt_context_set_lights(c, cl.data(), cl.size()), MODRT_OK) << modrt_last_error();
    ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
    ASSERT_TRUE(direct.evaluate(lights, ld).ok());
    const test::LevelReference ref = level_reference(t.level, ld);
    EXPECT_LT(rel_l2(read_lightmap(c), ref.lightmap), 1e-5) << frame;
  }
  modrt_skip_stats k = modrt::rt::sized<modrt_skip_stats>();
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k), MODRT_OK);
  EXPECT_EQ(k.frames, 3u);
  EXPECT_GT(k.light_blocks_recomputed, 0u);
  // Frames 1 and 2 move the point and the spot only: some blocks keep their ld.
  EXPECT_GT(k.light_blocks_kept, 0u);
  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

// The level tells an app what it needs to light its samples itself: the authored per-face
// albedo (checked against the level description's world faces, through the block's turn), each
// sample's position, normal, block and face (against level_sample_geometry), and every block.
TEST(CApi, LevelGivesAlbedoSamplesAndBlocks) {
  const test::TestLevel& t = test_level("maze11");
  modrt_level* l = load_level_handle();
  const std::size_t n = t.level.sample_count;

  std::vector<float> albedo(3 * n, -1.0f);
  ASSERT_EQ(modrt_level_get_albedo(l, albedo.data(), albedo.size()), MODRT_OK) << modrt_last_error();
  const LevelSampleGeometry g = level_sample_geometry(t.level);
  bool coloured = false;
  for (std::size_t s = 0; s < n; ++s) {
    const LevelBlock& b = t.level.blocks[std::size_t(g.block[s])];
    const glm::dvec3& want = t.description.blocks[std::size_t(g.block[s])]
                                 .albedo[std::size_t(rotate_face(g.face[s], b.quarter_turns))];
    for (int c = 0; c < 3; ++c) ASSERT_EQ(albedo[3 * s + std::size_t(c)], float(want[c])) << "sample " << s;
    coloured = coloured || want.r != want.g;
  }
  EXPECT_TRUE(coloured) << "maze11 has red, green and blue walls";

  std::vector<modrt_level_sample> samples(n);
  ASSERT_EQ(modrt_level_get_samples(l, samples.data(), samples.size()), MODRT_OK) << modrt_last_error();
  for (std::size_t s = 0; s < n; ++s) {
    for (int a = 0; a < 3; ++a) {
      ASSERT_EQ(samples[s].position[a], float(g.position[s][a])) << s;
      ASSERT_EQ(samples[s].normal[a], float(g.normal[s][a])) << s;
    }
    ASSERT_EQ(samples[s].block, std::uint32_t(g.block[s]));
    ASSERT_EQ(samples[s].face, std::uint32_t(g.face[s]));
  }

  for (std::uint32_t i = 0; i < t.level.blocks.size(); ++i) {
    const LevelBlock& b = t.level.blocks[i];
    modrt_level_block out = modrt::rt::sized<modrt_level_block>();
    ASSERT_EQ(modrt_level_get_block(l, i, &out), MODRT_OK) << modrt_last_error();
    EXPECT_EQ(out.shape, std::uint32_t(b.shape));
    EXPECT_EQ(out.quarter_turns, std::uint32_t(b.quarter_turns));
    EXPECT_EQ(out.face_mask, std::uint32_t(dictionary_shape_mask(b.shape)));
    EXPECT_EQ(out.cell[0], b.cell.x);
    EXPECT_EQ(out.cell[2], b.cell.z);
    EXPECT_EQ(out.corners[7][1], float(b.corners[7].y));
    EXPECT_EQ(out.sample_offset, b.sample_offset);
    EXPECT_EQ(out.sample_count, b.sample_count);
    for (int f = 0; f < kFaceCount; ++f) {
      EXPECT_EQ(out.world_face[f], std::uint32_t(rotate_face(f, b.quarter_turns)));
      EXPECT_EQ(out.neighbour[f], b.neighbour[std::size_t(f)]);
      EXPECT_EQ(out.tile_x[f], t.level.atlas.tile_origin_x[i][std::size_t(f)]);
      EXPECT_EQ(out.tile_y[f], t.level.atlas.tile_origin_y[i][std::size_t(f)]);
      EXPECT_EQ(out.tile_x[f] < 0, !face_present(dictionary_shape_mask(b.shape), f));
      EXPECT_EQ(out.albedo[f][1], b.albedo[std::size_t(f)].g);
    }
  }

  // Bad arguments are named and write nothing.
  std::vector<float> untouched(3 * n, -1.0f);
  expect_error(modrt_level_get_albedo(l, untouched.data(), 3 * n - 1), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_level_get_albedo", "out has " + std::to_string(3 * n - 1) + " floats"});
  EXPECT_EQ(untouched, std::vector<float>(3 * n, -1.0f));
  expect_error(modrt_level_get_albedo(nullptr, untouched.data(), 3 * n), MODRT_ERROR_INVALID_ARGUMENT,
               {"level is null"});
  expect_error(modrt_level_get_samples(l, samples.data(), n + 1), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_level_get_samples", "records"});
  expect_error(modrt_level_get_samples(l, nullptr, n), MODRT_ERROR_INVALID_ARGUMENT, {"out is null"});
  modrt_level_block blk = modrt::rt::sized<modrt_level_block>();
  expect_error(modrt_level_get_block(l, std::uint32_t(t.level.blocks.size()), &blk),
               MODRT_ERROR_INVALID_ARGUMENT, {"index 11", "block count 11"});
  EXPECT_EQ(blk.shape, 0u);
  blk.struct_size = 8;
  expect_error(modrt_level_get_block(l, 0, &blk), MODRT_ERROR_INVALID_ARGUMENT,
               {"out.struct_size is 8", "sizeof(modrt_level_block)"});
  modrt_level_destroy(l);
}

// A context reflects its lights with the level's albedo without being told; set_albedo
// overrides it; read_ld returns the ld the next update uses; an app that computes ld itself
// from the samples (a directional light without shadows: E = I max(0, -n.dir)) gets what
// set_lights gives.
TEST(CApi, ContextLightsWithTheLevelsAlbedoUntilOverridden) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, nullptr, nullptr, &c), MODRT_OK) << modrt_last_error();
  const std::size_t n = t.level.sample_count;
  std::vector<float> albedo(3 * n);
  ASSERT_EQ(modrt_context_read_albedo(c, albedo.data(), albedo.size()), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(albedo, level_sample_albedo(t.level));

  const std::vector<cpu::CpuLight> lights = frame_lights(t.level, 0);
  std::vector<modrt_light> cl;
  for (const cpu::CpuLight& x : lights) cl.push_back(to_c(x));
  ASSERT_EQ(modrt_context_set_lights(c, cl.data(), cl.size()), MODRT_OK) << modrt_last_error();
  std::vector<float> got(3 * n), want(3 * n);
  ASSERT_EQ(modrt_context_read_ld(c, got.data(), got.size()), MODRT_OK) << modrt_last_error();
  cpu::CpuDirectLight direct = cpu::CpuDirectLight::create(t.level, level_sample_albedo(t.level)).value();
  ASSERT_TRUE(direct.evaluate(lights, want).ok());
  EXPECT_EQ(got, want);

  // Override: grey everywhere; the next set_lights recomputes every block with it.
  const std::vector<float> grey(3 * n, 0.25f);
  ASSERT_EQ(modrt_context_set_albedo(c, grey.data(), grey.size()), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_lights(c, cl.data(), cl.size()), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_read_ld(c, got.data(), got.size()), MODRT_OK);
  ASSERT_TRUE(direct.set_albedo(grey).ok());
  ASSERT_TRUE(direct.evaluate(lights, want).ok());
  EXPECT_EQ(got, want);
  // A bad override is named and changes nothing.
  std::vector<float> bad = grey;
  bad[3 * 7 + 1] = std::numeric_limits<float>::quiet_NaN();
  expect_error(modrt_context_set_albedo(c, bad.data(), bad.size()), MODRT_ERROR_NON_FINITE,
               {"modrt_context_set_albedo", "sample 7 channel G is NaN"});
  ASSERT_EQ(modrt_context_read_albedo(c, albedo.data(), albedo.size()), MODRT_OK);
  EXPECT_EQ(albedo, grey);
  expect_error(modrt_context_read_ld(c, got.data(), 5), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_read_ld"});

  // The app's own ld from the level's samples and albedo equals the context's.
  std::vector<modrt_level_sample> samples(n);
  std::vector<float> level_albedo(3 * n);
  ASSERT_EQ(modrt_level_get_samples(l, samples.data(), n), MODRT_OK);
  ASSERT_EQ(modrt_level_get_albedo(l, level_albedo.data(), level_albedo.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_set_albedo(c, level_albedo.data(), level_albedo.size()), MODRT_OK);
  modrt_light sun;
  modrt_light_init(&sun);
  sun.type = MODRT_LIGHT_DIRECTIONAL;
  const glm::vec3 dir = glm::normalize(glm::vec3(0.4f, -1.0f, 0.3f));
  for (int a = 0; a < 3; ++a) sun.direction[a] = dir[a];
  sun.color[0] = 1.0f, sun.color[1] = 0.8f, sun.color[2] = 0.6f;
  sun.intensity = 2.0f;
  sun.shadows = 0;
  ASSERT_EQ(modrt_context_set_lights(c, &sun, 1), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_read_ld(c, got.data(), got.size()), MODRT_OK);
  double err = 0.0, norm = 0.0;
  for (std::size_t s = 0; s < n; ++s) {
    const glm::vec3 nrm(samples[s].normal[0], samples[s].normal[1], samples[s].normal[2]);
    const float e = sun.intensity * std::max(0.0f, -glm::dot(nrm, dir));
    for (int ch = 0; ch < 3; ++ch) {
      const double app =
          double(level_albedo[3 * s + std::size_t(ch)]) * sun.color[ch] * e / 3.14159265358979323846;
      err = std::max(err, std::abs(app - double(got[3 * s + std::size_t(ch)])));
      norm = std::max(norm, app);
    }
  }
  EXPECT_GT(norm, 0.1);
  EXPECT_LT(err, 1e-6 * norm);
  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

TEST(CApi, SkipCountersAndTimings) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o = one_bounce_options();  // the one-bounce skip counters, block by block
  o.timing = 1;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  const std::vector<float> first = read_lightmap(c);
  // Only block 0's ld changes: every other block keeps its b.
  std::vector<float> ld = t.ld;
  const LevelBlock& b0 = t.level.blocks[0];
  for (std::uint32_t i = 0; i < 3 * b0.sample_count; ++i) ld[3 * b0.sample_offset + i] *= 2.0f;
  ASSERT_EQ(modrt_context_set_ld(c, ld.data(), ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  modrt_skip_stats k = modrt::rt::sized<modrt_skip_stats>();
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k), MODRT_OK);
  const std::size_t blocks = t.level.blocks.size();
  EXPECT_EQ(k.frames, 2u);
  EXPECT_EQ(k.blocks_computed + k.blocks_kept, 2 * blocks);
  EXPECT_EQ(k.blocks_kept, blocks - 1);  // block 0 changed, the others are kept
  EXPECT_EQ(k.frames_skipped, 0u);
  modrt_timings tm = modrt::rt::sized<modrt_timings>();
  ASSERT_EQ(modrt_context_get_timings(c, &tm), MODRT_OK);
  EXPECT_GT(tm.update_ns, 0u);
  EXPECT_GT(tm.lightmap_ns, 0u);
  EXPECT_GE(tm.update_ns, tm.b_ns + tm.lightmap_ns + tm.atlas_ns + tm.probes_ns);
  // The same ld again: every tile is kept, and the frame is a skipped one (nothing recomputed).
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  modrt_skip_stats k3 = modrt::rt::sized<modrt_skip_stats>();
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k3), MODRT_OK);
  EXPECT_EQ(k3.tiles_kept - k.tiles_kept, blocks);
  EXPECT_EQ(k3.blocks_kept - k.blocks_kept, blocks);
  EXPECT_EQ(k3.slots_kept - k.slots_kept, t.level.slots.size());
  EXPECT_EQ(k3.frames_skipped, 1u);
  // Exact: the skipping result equals the full evaluation.
  const test::LevelReference ref = level_reference(t.level, ld);
  EXPECT_LT(rel_l2(read_lightmap(c), ref.lightmap), 1e-5);
  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

// The camera skip through the C API (modrt_context_set_camera): the blocks the walk marks from
// an eye inside the 41-block maze (core's CameraVisibility, computed here too) have the atlas
// rectangles of a context without the camera, bit for bit, over frames in which the light
// moves; the hidden blocks' changed tiles are counted, and every block is current again after
// set_visible_blocks(NULL, 0). Bad input is named and changes nothing; an 0.3 skip-stats
// struct is still filled. CPU with the converged solve, GLES with one bounce (its skip of the
// atlas rectangles is the same with either).
void expect_camera_skip_keeps_the_visible_atlas(modrt_backend backend) {
  const test::TestLevel& t = test_level("maze41");
  const Level& level = t.level;
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle("maze41");
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  o.bounces = backend == MODRT_BACKEND_CPU ? MODRT_BOUNCES_CONVERGED : 0;
  modrt_context *c = nullptr, *full = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &full), MODRT_OK) << modrt_last_error();
  // A camera in block 0 looking along each axis in turn: the first that does not see every block.
  glm::dvec3 eye(0.0);
  for (const glm::dvec3& corner : level.blocks[0].corners) eye += corner / 8.0;
  CameraVisibility walk(level);
  glm::dmat4 vp(1.0);
  std::size_t seen = level.blocks.size();
  for (const glm::dvec3& dir :
       {glm::dvec3(1, 0, 0), glm::dvec3(-1, 0, 0), glm::dvec3(0, 0, 1), glm::dvec3(0, 0, -1)}) {
    vp = glm::perspective(1.2, 1.0, 0.01, 100.0) * glm::lookAt(eye, eye + dir, glm::dvec3(0, 1, 0));
    Result<VisibilityStats> st = walk.update(vp, eye);
    ASSERT_TRUE(st.ok());
    if (st->visible < level.blocks.size()) {
      seen = st->visible;
      break;
    }
  }
  ASSERT_LT(seen, level.blocks.size()) << "some direction hides a block";
  const std::vector<std::uint8_t> visible(walk.visible().begin(), walk.visible().end());
  float vpf[16], eyef[3] = {float(eye.x), float(eye.y), float(eye.z)};
  for (int k = 0; k < 16; ++k) vpf[k] = float(vp[k / 4][k % 4]);
  ASSERT_EQ(modrt_context_set_camera(c, vpf, eyef), MODRT_OK) << modrt_last_error();
  const LightmapAtlas& atlas = level.atlas;
  const auto rects_equal = [&](const std::vector<float>& a, const std::vector<float>& b, std::size_t i) {
    for (int f = 0; f < kFaceCount; ++f) {
      const std::int32_t ox = atlas.tile_origin_x[i][std::size_t(f)],
                         oy = atlas.tile_origin_y[i][std::size_t(f)];
      if (ox < 0) continue;
      for (int y = oy; y < oy + atlas.tile; ++y) {
        const std::size_t row = 3 * (std::size_t(y) * std::size_t(atlas.width) + std::size_t(ox));
        if (!std::equal(a.begin() + row, a.begin() + row + 3 * std::size_t(atlas.tile), b.begin() + row))
          return false;
      }
    }
    return true;
  };
  std::vector<float> ld = t.ld;
  for (int frame = 0; frame < 4; ++frame) {
    for (std::size_t i = std::size_t(frame); i < ld.size(); i += 4) ld[i] *= 1.3f;  // every block's light
    for (modrt_context* ctx : {c, full}) {
      ASSERT_EQ(modrt_context_set_ld(ctx, ld.data(), ld.size()), MODRT_OK);
      ASSERT_EQ(modrt_context_update(ctx), MODRT_OK) << modrt_last_error();
    }
    const std::vector<float> a = read_atlas(c), b = read_atlas(full);
    for (std::size_t i = 0; i < level.blocks.size(); ++i)
      if (visible[i]) {
        ASSERT_TRUE(rects_equal(a, b, i)) << "frame " << frame << " visible block " << i;
      }
    // The probe volume anywhere, hidden blocks included (computed when sampled on a CPU context).
    for (std::size_t i = frame % 3; i < level.blocks.size(); i += 3) {
      glm::dvec3 centre(0.0);
      for (const glm::dvec3& corner : level.blocks[i].corners) centre += corner / 8.0;
      const float x[3] = {float(centre.x), float(centre.y + 0.1), float(centre.z)};
      float sa[27], sb[27];
      ASSERT_EQ(modrt_context_probe_sh(c, x, MODRT_PROBE_RADIANCE, sa), MODRT_OK) << modrt_last_error();
      ASSERT_EQ(modrt_context_probe_sh(full, x, MODRT_PROBE_RADIANCE, sb), MODRT_OK) << modrt_last_error();
      ASSERT_TRUE(std::equal(sa, sa + 27, sb))
          << "frame " << frame << (visible[i] ? " visible" : " hidden") << " block " << i;
    }
  }
  modrt_skip_stats k = modrt::rt::sized<modrt_skip_stats>();
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k), MODRT_OK);
  EXPECT_EQ(k.tiles_written + k.tiles_kept + k.tiles_hidden, 4 * level.blocks.size());
  EXPECT_GT(k.tiles_hidden, 0u) << seen << " of " << level.blocks.size() << " blocks seen";
  modrt_skip_stats old{};
  old.struct_size = std::uint32_t(offsetof(modrt_skip_stats, tiles_hidden));  // an 0.3 caller
  ASSERT_EQ(modrt_context_get_skip_stats(c, &old), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(old.tiles_written, k.tiles_written);
  EXPECT_EQ(old.tiles_hidden, 0u) << "not written past the caller's struct";

  // Bad input: named, and the set stays as it was.
  float bad_vp[16];
  std::copy(vpf, vpf + 16, bad_vp);
  bad_vp[6] = std::numeric_limits<float>::quiet_NaN();
  expect_error(modrt_context_set_camera(c, bad_vp, eyef), MODRT_ERROR_NON_FINITE,
               {"modrt_context_set_camera", "view_projection[1][2]"});
  const float bad_eye[3] = {eyef[0], std::numeric_limits<float>::infinity(), eyef[2]};
  expect_error(modrt_context_set_camera(c, vpf, bad_eye), MODRT_ERROR_NON_FINITE, {"eye[1]"});
  expect_error(modrt_context_set_camera(c, nullptr, eyef), MODRT_ERROR_INVALID_ARGUMENT, {"view_projection"});
  expect_error(modrt_context_set_visible_blocks(c, visible.data(), visible.size() - 1),
               MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_set_visible_blocks", "count is 40", "expected 41"});
  expect_error(modrt_context_set_visible_blocks(c, nullptr, 3), MODRT_ERROR_INVALID_ARGUMENT, {"flags"});
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k), MODRT_OK);
  const std::uint64_t hidden = k.tiles_hidden;
  ld[0] *= 2.0f;
  for (modrt_context* ctx : {c, full}) {
    ASSERT_EQ(modrt_context_set_ld(ctx, ld.data(), ld.size()), MODRT_OK);
    ASSERT_EQ(modrt_context_update(ctx), MODRT_OK);
  }
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k), MODRT_OK);
  EXPECT_GT(k.tiles_hidden, hidden) << "the camera set stands after the refused calls";

  // Every block again: the whole atlas is the full context's.
  ASSERT_EQ(modrt_context_set_visible_blocks(c, nullptr, 0), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(read_atlas(c), read_atlas(full));
  EXPECT_EQ(read_lightmap(c), read_lightmap(full));
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k), MODRT_OK);
  EXPECT_GT(k.tiles_caught_up, 0u);
  modrt_context_destroy(full);
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

TEST(CApi, CameraSkipKeepsTheVisibleBlocksAtlas) {
  expect_camera_skip_keeps_the_visible_atlas(MODRT_BACKEND_CPU);
}

TEST(CApiGles, CameraSkipKeepsTheVisibleBlocksAtlas) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  expect_camera_skip_keeps_the_visible_atlas(MODRT_BACKEND_GLES);
}

TEST(CApi, NoAllocationPerFrame) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.timing = 1;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_albedo(c, t.albedo.data(), t.albedo.size()), MODRT_OK);
  std::vector<std::vector<modrt_light>> frames;
  for (int f = 0; f < 4; ++f) {
    frames.emplace_back();
    for (const cpu::CpuLight& x : frame_lights(t.level, f)) frames.back().push_back(to_c(x));
  }
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  ASSERT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  std::vector<float> lightmap(s.lightmap), atlas(s.atlas);
  const glm::dvec3 x = block_to_world(t.level.blocks[1], glm::dvec3(0.5));
  const float pos[3] = {float(x.x), float(x.y), float(x.z)};
  float sh[27];
  // The camera turns each frame (the skip's walk grows its stack on the first turn: warmed here).
  float cameras[4][16];
  for (int f = 0; f < 4; ++f) {
    const double a = 1.5707963 * f;
    const glm::dmat4 vp = glm::perspective(1.2, 1.0, 0.01, 100.0) *
                          glm::lookAt(x, x + glm::dvec3(std::cos(a), 0.0, std::sin(a)), glm::dvec3(0, 1, 0));
    for (int k = 0; k < 16; ++k) cameras[f][k] = float(vp[k / 4][k % 4]);
    ASSERT_EQ(modrt_context_set_camera(c, cameras[f], pos), MODRT_OK) << modrt_last_error();
  }
  // The first converged update (the default bounces) builds the solve's reduced operators, once
  // per context and albedo (modrt.h, "Memory"): at load time, here.
  ASSERT_EQ(modrt_context_set_lights(c, frames[0].data(), frames[0].size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  // The frames under the converged multi-bounce, then with one bounce and with 3 feedback steps.
  for (std::uint32_t bounces : {MODRT_BOUNCES_CONVERGED, 0u, 3u}) {
    SCOPED_TRACE("bounces " + std::to_string(bounces));
    ASSERT_EQ(modrt_context_set_bounces(c, bounces), MODRT_OK);
    bool ok = true;
    g_allocations = 0;
    g_count_allocations = true;
    int frame = 0;
    for (const auto& lights : frames) {
      ok &= modrt_context_set_camera(c, cameras[frame++], pos) == MODRT_OK;
      ok &= modrt_context_set_lights(c, lights.data(), lights.size()) == MODRT_OK;
      ok &= modrt_context_update(c) == MODRT_OK;
      ok &= modrt_context_read_lightmap(c, lightmap.data(), lightmap.size()) == MODRT_OK;
      ok &= modrt_context_read_atlas(c, atlas.data(), atlas.size()) == MODRT_OK;
      ok &= modrt_context_probe_sh(c, pos, MODRT_PROBE_IRRADIANCE_OVER_PI, sh) == MODRT_OK;
      modrt_timings tm = modrt::rt::sized<modrt_timings>();
      modrt_skip_stats k = modrt::rt::sized<modrt_skip_stats>();
      ok &= modrt_context_get_timings(c, &tm) == MODRT_OK && modrt_context_get_skip_stats(c, &k) == MODRT_OK;
    }
    ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
    ok &= modrt_context_update(c) == MODRT_OK;
    g_count_allocations = false;
    EXPECT_TRUE(ok) << modrt_last_error();
    EXPECT_EQ(g_allocations.load(), 0);
    ASSERT_EQ(modrt_context_set_lights(c, frames[0].data(), frames[0].size()), MODRT_OK);  // lights again
  }
  // The counter sees the API's allocations: loading allocates.
  g_allocations = 0;
  g_count_allocations = true;
  modrt_level* l2 = load_level_handle();
  g_count_allocations = false;
  EXPECT_GT(g_allocations.load(), 0);
  modrt_level_destroy(l2);
  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

struct HookCounter {
  long allocations = 0, frees = 0;
  std::size_t live_bytes = 0, peak_bytes = 0;
  long fail_after = -1;  // >= 0: refuse allocations after this many
};
void* hook_alloc(size_t size, size_t alignment, void* user) {
  HookCounter* h = static_cast<HookCounter*>(user);
  if (h->fail_after >= 0 && h->allocations >= h->fail_after) return nullptr;
  ++h->allocations;
  h->live_bytes += size;
  h->peak_bytes = std::max(h->peak_bytes, h->live_bytes);
  const size_t rounded = (size + alignment - 1) / alignment * alignment;
  return std::aligned_alloc(alignment, rounded == 0 ? alignment : rounded);
}
void hook_free(void* p, size_t size, void* user) {
  HookCounter* h = static_cast<HookCounter*>(user);
  ++h->frees;
  h->live_bytes -= size;
  std::free(p);
}

TEST(CApi, AllocatorHookReceivesTheRuntimesAllocations) {
  const test::TestLevel& t = test_level("maze11");
  const std::filesystem::path dir = std::filesystem::path(MODRT_TEST_CACHE_DIR) / "c_api";
  std::filesystem::create_directories(dir);
  const std::string level_path = (dir / "maze11_hook.modrtlevel").string();
  ASSERT_TRUE(write_file_atomic(level_path, assets().level).ok());
  HookCounter counter;
  const modrt_allocator hook{sizeof(modrt_allocator), hook_alloc, hook_free, &counter};
  // Heap in use (glibc: operator new and the hook both draw on malloc), to report how much the
  // hook sees of what loading and creation allocate (docs/embedding.md).
  const std::size_t heap_before = mallinfo2().uordblks;
  modrt_dictionary* d = nullptr;
  ASSERT_EQ(
      modrt_dictionary_load_memory(assets().dictionary.data(), assets().dictionary.size(), "dict", &hook, &d),
      MODRT_OK);
  modrt_level* l = nullptr;
  ASSERT_EQ(modrt_level_load_file(level_path.c_str(), &hook, &l), MODRT_OK) << modrt_last_error();
  // The file image passed through the hook.
  EXPECT_GE(counter.peak_bytes, assets().level.size());
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, nullptr, &hook, &c), MODRT_OK) << modrt_last_error();
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  ASSERT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  // The context's own frame buffers (ld, albedo, probes) live in the hook's memory.
  EXPECT_GE(counter.live_bytes, sizeof(float) * (2 * s.ld + s.probes));
  const std::size_t heap = mallinfo2().uordblks - heap_before;
  // (Under AddressSanitizer, which replaces malloc, mallinfo2 reports nothing.)
  if (heap >= counter.live_bytes)
    std::printf(
        "  maze11, small test dictionary: %zu bytes live after load + context, %zu through the hook "
        "(%.1f %%), peak through the hook %zu\n",
        heap, counter.live_bytes, 100.0 * double(counter.live_bytes) / double(heap), counter.peak_bytes);
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
  EXPECT_GT(counter.allocations, 0);
  EXPECT_EQ(counter.allocations, counter.frees);
  EXPECT_EQ(counter.live_bytes, 0u);

  // A hook that refuses memory: OUT_OF_MEMORY with a message, nothing leaked, at every point.
  for (long fail_after = 0; fail_after < 12; ++fail_after) {
    HookCounter failing;
    failing.fail_after = fail_after;
    const modrt_allocator bad{sizeof(modrt_allocator), hook_alloc, hook_free, &failing};
    modrt_dictionary* fd = load_dictionary_handle();
    modrt_level* fl = load_level_handle();
    modrt_context* fc = nullptr;
    const modrt_status st = modrt_context_create(fd, fl, nullptr, &bad, &fc);
    if (st == MODRT_OK) {
      modrt_context_destroy(fc);
    } else {
      expect_error(st, MODRT_ERROR_OUT_OF_MEMORY, {"modrt_context_create", "memory"});
      EXPECT_EQ(fc, nullptr);
    }
    EXPECT_EQ(failing.allocations, failing.frees) << fail_after;
    modrt_dictionary_destroy(fd);
    modrt_level_destroy(fl);
  }
  HookCounter none;
  none.fail_after = 0;
  const modrt_allocator refuse{sizeof(modrt_allocator), hook_alloc, hook_free, &none};
  modrt_level* fl = nullptr;
  expect_error(modrt_level_load_file(level_path.c_str(), &refuse, &fl), MODRT_ERROR_OUT_OF_MEMORY,
               {level_path.c_str(), "allocator refused"});
}

TEST(CApi, BadFilesReturnNamedErrors) {
  modrt_level* l = nullptr;
  modrt_dictionary* d = nullptr;
  std::vector<std::byte> bytes = assets().level;
  bytes[bytes.size() / 2] ^= std::byte{0x40};
  expect_error(modrt_level_load_memory(bytes.data(), bytes.size(), "bundle/level.modrtlevel", nullptr, &l),
               MODRT_ERROR_CHECKSUM_MISMATCH, {"bundle/level.modrtlevel"});
  EXPECT_EQ(l, nullptr);
  expect_error(modrt_level_load_memory(assets().level.data(), 40, "short.modrtlevel", nullptr, &l),
               MODRT_ERROR_FORMAT, {"short.modrtlevel"});
  bytes = assets().level;
  bytes[0] = std::byte{'X'};
  expect_error(modrt_level_load_memory(bytes.data(), bytes.size(), "magic.modrtlevel", nullptr, &l),
               MODRT_ERROR_FORMAT, {"magic.modrtlevel"});
  // A dictionary is not a level and the other way round.
  expect_error(modrt_level_load_memory(assets().dictionary.data(), assets().dictionary.size(),
                                       "dict-as-level", nullptr, &l),
               MODRT_ERROR_FORMAT, {"dict-as-level"});
  expect_error(modrt_dictionary_load_memory(assets().level.data(), assets().level.size(), "level-as-dict",
                                            nullptr, &d),
               MODRT_ERROR_FORMAT, {"level-as-dict"});
  std::vector<std::byte> dict = assets().dictionary;
  dict[dict.size() - 5] ^= std::byte{1};
  expect_error(modrt_dictionary_load_memory(dict.data(), dict.size(), "flipped.modrt", nullptr, &d),
               MODRT_ERROR_CHECKSUM_MISMATCH, {"flipped.modrt"});
  EXPECT_EQ(d, nullptr);
  expect_error(modrt_dictionary_load_file("/nonexistent/dir/x.modrt", nullptr, &d), MODRT_ERROR_IO,
               {"/nonexistent/dir/x.modrt", "cannot open"});
  expect_error(modrt_level_load_file("/nonexistent/l.modrtlevel", nullptr, &l), MODRT_ERROR_IO,
               {"/nonexistent/l.modrtlevel"});
  expect_error(modrt_level_load_memory(nullptr, 10, "x", nullptr, &l), MODRT_ERROR_INVALID_ARGUMENT,
               {"data is null"});
  expect_error(modrt_level_load_memory(assets().level.data(), assets().level.size(), "x", nullptr, nullptr),
               MODRT_ERROR_INVALID_ARGUMENT, {"out is null"});
  expect_error(modrt_dictionary_load_file(nullptr, nullptr, &d), MODRT_ERROR_INVALID_ARGUMENT,
               {"path is null"});
}

// Issue 18 item 11: a directory is not a dictionary (it reported "9223372036854775807 bytes").
TEST(CApi, LoadingADirectoryIsANamedError) {
  const std::filesystem::path dir = std::filesystem::path(MODRT_TEST_CACHE_DIR) / "c_api_directory.modrt";
  std::filesystem::create_directories(dir);
  modrt_dictionary* d = nullptr;
  modrt_level* l = nullptr;
  expect_error(modrt_dictionary_load_file(dir.c_str(), nullptr, &d), MODRT_ERROR_IO,
               {dir.c_str(), "a directory, not a regular file"});
  EXPECT_EQ(std::string(modrt_last_error()).find("9223372036854775807"), std::string::npos);
  std::printf("%s\n", modrt_last_error());
  EXPECT_EQ(d, nullptr);
  expect_error(modrt_level_load_file(dir.c_str(), nullptr, &l), MODRT_ERROR_IO,
               {dir.c_str(), "a directory, not a regular file"});
  EXPECT_EQ(l, nullptr);
}

// ld at the largest accepted value gives a finite lightmap (the loaders' and creation's
// operator bounds, operator_limits.h); a spike ringing negative gives no negative texel
// (issue 18 items 5 and 7), on the CPU context and, where EGL works, the GLES one.
void expect_spike_is_clean(modrt_backend backend) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  for (const auto& [spike, bounces] : {std::pair{1e6f, MODRT_BOUNCES_CONVERGED}, std::pair{1e6f, 0u},
                                       std::pair{1e30f, 0u}, std::pair{1e30f, MODRT_BOUNCES_CONVERGED}}) {
    std::vector<float> ld(t.ld.size(), 0.0f);
    ld[3 * 40] = spike;
    ASSERT_EQ(modrt_context_set_bounces(c, bounces), MODRT_OK);
    ASSERT_EQ(modrt_context_set_ld(c, ld.data(), ld.size()), MODRT_OK) << modrt_last_error();
    if (spike > 1e29f && bounces != 0) {
      // The bounces could carry this light past kMaxLightValue: refused, naming it, and the
      // results of the one-bounce update before stay.
      const std::vector<float> before = read_lightmap(c);
      expect_error(modrt_context_update(c), MODRT_ERROR_INVALID_ARGUMENT, {"kMaxLightValue"});
      EXPECT_EQ(read_lightmap(c), before);
      continue;
    }
    ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
    const std::vector<float> lightmap = read_lightmap(c), atlas = read_atlas(c);
    const std::string what = std::string(modrt_context_description(c)) + " spike " + std::to_string(spike);
    for (const std::vector<float>* v : {&lightmap, &atlas}) {
      EXPECT_GE(*std::min_element(v->begin(), v->end()), 0.0f) << what;
      EXPECT_TRUE(std::all_of(v->begin(), v->end(), [](float x) { return std::isfinite(x); })) << what;
    }
    EXPECT_GT(*std::max_element(lightmap.begin(), lightmap.end()), 0.0f) << what;
  }
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

TEST(CApi, SpikeInLdGivesAFiniteNonNegativeLightmap) { expect_spike_is_clean(MODRT_BACKEND_CPU); }

TEST(CApiGles, SpikeInLdGivesAFiniteNonNegativeLightmap) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  expect_spike_is_clean(MODRT_BACKEND_GLES);
}

// options.bounces: every update is the one-bounce evaluation plus N feedback steps with the
// level's albedo. CPU: bit-identical to CpuLevelRuntime doing the same; CPU and GLES within
// 1e-5 / 1e-4 of core's level_multi_bounce after N iterations. Unchanged ld and albedo skip the
// whole update (no allocation, same results); a new albedo does not.
void expect_bounces_match(modrt_backend backend, double tolerance) {
  const test::TestLevel& t = test_level("maze11");
  const std::vector<float> albedo = level_sample_albedo(t.level);
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  o.bounces = 3;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  const std::vector<float> lightmap = read_lightmap(c), atlas = read_atlas(c);

  MultiBounceSettings settings;
  settings.max_iterations = 3;
  settings.tolerance = 0.0f;
  std::vector<float> b(t.level.blocks.size() * t.level.kb * 3), r(t.level.slots.size() * t.level.kr * 3),
      ref(lightmap.size());
  Result<MultiBounceReport> rep =
      level_multi_bounce(t.level, small_test_dictionary(), t.ld, albedo, settings, b, r, ref);
  ASSERT_TRUE(rep.ok()) << rep.status().to_string();
  EXPECT_LT(rel_l2(lightmap, ref), tolerance);
  std::vector<float> ref_atlas(atlas.size());
  level_fill_atlas(t.level, ref, ref_atlas);
  EXPECT_LT(rel_l2(atlas, ref_atlas), tolerance);
  // Three more bounces add light: the lightmap's sum grows over the one-bounce one.
  const test::LevelReference one = level_reference(t.level, t.ld);
  double sum = 0.0, sum_one = 0.0;
  for (std::size_t i = 0; i < ref.size(); ++i) sum += lightmap[i], sum_one += one.lightmap[i];
  EXPECT_GT(sum, 1.1 * sum_one);

  if (backend == MODRT_BACKEND_CPU) {
    cpu::CpuRuntimeOptions co;
    co.skip.enabled = true;
    cpu::CpuLevelRuntime rt = cpu::CpuLevelRuntime::create(t.level, small_test_dictionary(), co).value();
    ASSERT_TRUE(rt.set_albedo(albedo).ok());
    std::vector<float> cpp(lightmap.size());
    ASSERT_TRUE(rt.evaluate(t.ld, cpp).ok());
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(rt.multi_bounce_step(t.ld, cpp).ok());
    EXPECT_EQ(lightmap, cpp);
  }

  // The same ld again: skipped, bit for bit, without allocating.
  modrt_skip_stats k0 = modrt::rt::sized<modrt_skip_stats>(), k1 = k0;
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k0), MODRT_OK);
  g_allocations = 0;
  g_count_allocations = true;
  const modrt_status again = modrt_context_update(c);
  g_count_allocations = false;
  ASSERT_EQ(again, MODRT_OK) << modrt_last_error();
  EXPECT_EQ(g_allocations.load(), 0);
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k1), MODRT_OK);
  EXPECT_EQ(k1.frames, k0.frames + 1);
  EXPECT_EQ(k1.frames_skipped, k0.frames_skipped + 1);
  EXPECT_EQ(read_lightmap(c), lightmap);
  // A darker albedo: recomputed, less light.
  const std::vector<float> grey(albedo.size(), 0.2f);
  ASSERT_EQ(modrt_context_set_albedo(c, grey.data(), grey.size()), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  const std::vector<float> darker = read_lightmap(c);
  double sum_grey = 0.0;
  for (float v : darker) sum_grey += v;
  EXPECT_LT(sum_grey, sum);
  // A light whose bounces could pass kMaxLightValue is refused before anything runs.
  std::vector<float> hot(t.ld.size(), 0.0f);
  hot[3 * 40] = 1e30f;
  ASSERT_EQ(modrt_context_set_ld(c, hot.data(), hot.size()), MODRT_OK);
  expect_error(modrt_context_update(c), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_update", "kMaxLightValue"});
  EXPECT_EQ(read_lightmap(c), darker);
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

TEST(CApi, BouncesAreTheFeedbackSteps) { expect_bounces_match(MODRT_BACKEND_CPU, 1e-5); }

// MODRT_BOUNCES_CONVERGED: a CPU context's update is core's level_converged_bounce at the
// default tolerance 1e-3 (within 2e-3 rel L2, the lightmap brighter than three feedback steps'),
// a repeated update is skipped bit for bit, and set_bounces switches to and from it without
// recreating the context.
TEST(CApi, ConvergedBouncesAreCoresConvergedSolve) {
  static_assert(MODRT_BOUNCES_CONVERGED == kConvergedBounces);
  const test::TestLevel& t = test_level("maze11");
  const std::vector<float> albedo = level_sample_albedo(t.level);
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.bounces = MODRT_BOUNCES_CONVERGED;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  const std::vector<float> lightmap = read_lightmap(c);
  const LevelBufferSizes sz = level_buffer_sizes(t.level, small_test_dictionary());
  std::vector<float> b(sz.b), r(sz.r), ref(sz.lightmap);
  modrt_solve_stats none = modrt::rt::sized<modrt_solve_stats>();
  const Result<ConvergedBounceReport> rep =
      level_converged_bounce(t.level, small_test_dictionary(), t.ld, albedo, {}, b, r, ref);
  ASSERT_TRUE(rep.ok());
  EXPECT_LT(rel_l2(lightmap, ref), 2e-3);
  // It is the default since 0.4: options_init's, and null options', bit for bit.
  {
    modrt_context_options defaults;
    modrt_context_options_init(&defaults);
    EXPECT_EQ(defaults.bounces, MODRT_BOUNCES_CONVERGED);
    modrt_context* by_default = nullptr;
    ASSERT_EQ(modrt_context_create(d, l, nullptr, nullptr, &by_default), MODRT_OK) << modrt_last_error();
    ASSERT_EQ(modrt_context_set_ld(by_default, t.ld.data(), t.ld.size()), MODRT_OK);
    ASSERT_EQ(modrt_context_update(by_default), MODRT_OK) << modrt_last_error();
    EXPECT_EQ(read_lightmap(by_default), lightmap);
    modrt_context_destroy(by_default);
  }
  // The solve's statistics: core's spectral radius, the default tolerance met.
  modrt_solve_stats st = modrt::rt::sized<modrt_solve_stats>();
  ASSERT_EQ(modrt_context_get_solve_stats(c, &st), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(st.solves, 1u);
  EXPECT_EQ(st.converged, 1u);
  EXPECT_GT(st.last_iterations, 0u);
  EXPECT_EQ(st.iterations, st.last_iterations);
  EXPECT_LE(st.last_error_bound, 1e-3f);
  EXPECT_TRUE(std::isfinite(st.last_residual) && st.last_residual >= 0.0f);
  EXPECT_NEAR(st.spectral_radius, rep->spectral_radius, 1e-6 * rep->spectral_radius);
  EXPECT_GT(st.contraction, 0.0);
  EXPECT_LT(st.contraction, 1.0);
  EXPECT_EQ(st.damping, 1.0f) << "albedo below 0.98: no damping";
  EXPECT_GT(st.build_ns, 0u);
  // The CPU context's incremental solve: at most every block per pass.
  EXPECT_GT(st.blocks_applied, 0u);
  EXPECT_LE(st.blocks_applied, st.iterations * t.level.blocks.size());
  none.struct_size = 4;
  expect_error(modrt_context_get_solve_stats(c, &none), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_get_solve_stats", "out.struct_size is 4"});
  expect_error(modrt_context_get_solve_stats(c, nullptr), MODRT_ERROR_INVALID_ARGUMENT, {"out"});
  uint32_t got = 0;
  ASSERT_EQ(modrt_context_get_bounces(c, &got), MODRT_OK);
  EXPECT_EQ(got, MODRT_BOUNCES_CONVERGED);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  EXPECT_EQ(read_lightmap(c), lightmap);  // skipped: the same ld and albedo
  ASSERT_EQ(modrt_context_get_solve_stats(c, &st), MODRT_OK);
  EXPECT_EQ(st.solves, 1u) << "a skipped update solves nothing";
  ASSERT_EQ(modrt_context_set_bounces(c, 3), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  const std::vector<float> three = read_lightmap(c);
  double sum = 0.0, sum3 = 0.0;
  for (std::size_t i = 0; i < three.size(); ++i) sum += lightmap[i], sum3 += three[i];
  EXPECT_GT(sum, sum3);
  ASSERT_EQ(modrt_context_set_bounces(c, MODRT_BOUNCES_CONVERGED), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  EXPECT_LT(rel_l2(read_lightmap(c), ref), 2e-3);
  // The light did not change since the last solve (the 3-bounce update between left it as it
  // was): the incremental solve applies nothing.
  const std::uint64_t applied = st.blocks_applied;
  ASSERT_EQ(modrt_context_get_solve_stats(c, &st), MODRT_OK);
  EXPECT_EQ(st.solves, 2u);
  EXPECT_EQ(st.last_iterations, 0u);
  EXPECT_EQ(st.blocks_applied, applied);
  expect_error(modrt_context_set_bounces(c, 65), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_set_bounces", "65"});
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

// MODRT_BOUNCES_CONVERGED on a GLES context: the solve runs on the GPU (gles_reduced_solve.cpp)
// and its update is core's level_converged_bounce at the default tolerance 1e-3 (within 2e-3 rel
// L2, as the CPU context's); the statistics report the a-priori iteration count, not read back.
TEST(CApiGles, ConvergedBouncesAreCoresConvergedSolve) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  const test::TestLevel& t = test_level("maze11");
  const std::vector<float> albedo = level_sample_albedo(t.level);
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = MODRT_BACKEND_GLES;
  o.bounces = MODRT_BOUNCES_CONVERGED;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  const LevelBufferSizes sz = level_buffer_sizes(t.level, small_test_dictionary());
  std::vector<float> b(sz.b), r(sz.r), ref(sz.lightmap);
  const Result<ConvergedBounceReport> rep =
      level_converged_bounce(t.level, small_test_dictionary(), t.ld, albedo, {}, b, r, ref);
  ASSERT_TRUE(rep.ok());
  EXPECT_LT(rel_l2(read_lightmap(c), ref), 2e-3);
  modrt_solve_stats st = modrt::rt::sized<modrt_solve_stats>();
  ASSERT_EQ(modrt_context_get_solve_stats(c, &st), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(st.solves, 1u);
  EXPECT_EQ(st.converged, 1u);
  EXPECT_EQ(int(st.last_iterations), reduced_solve_iterations(st.contraction, 1e-3f, 256));
  EXPECT_LE(st.last_error_bound, 1e-3f);
  EXPECT_NEAR(st.spectral_radius, rep->spectral_radius, 1e-6 * rep->spectral_radius);
  uint32_t got = 0;
  ASSERT_EQ(modrt_context_get_bounces(c, &got), MODRT_OK);
  EXPECT_EQ(got, MODRT_BOUNCES_CONVERGED);
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

TEST(CApiGles, BouncesAreTheFeedbackSteps) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  expect_bounces_match(MODRT_BACKEND_GLES, 1e-4);
}

// 64 bounces converge (maze11's albedo is at most 0.8: 0.8^64 = 6e-7 of the series is left):
// within 1e-5 of core's converged level_multi_bounce. Bad bounce options are named; a caller
// built against 0.2's modrt_context_options (no bounces, max_albedo) gets their defaults.
TEST(CApi, SixtyFourBouncesConvergeAndOptionsAreChecked) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  EXPECT_EQ(o.bounces, MODRT_BOUNCES_CONVERGED);
  EXPECT_EQ(o.max_albedo, kDefaultMaxAlbedo);
  o.bounces = 64;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  std::vector<float> b(t.level.blocks.size() * t.level.kb * 3), r(t.level.slots.size() * t.level.kr * 3),
      ref(t.level.sample_count * 3);
  Result<MultiBounceReport> rep = level_multi_bounce(
      t.level, small_test_dictionary(), t.ld, level_sample_albedo(t.level), MultiBounceSettings{}, b, r, ref);
  ASSERT_TRUE(rep.ok() && rep->converged) << rep.status().to_string();
  EXPECT_LT(rel_l2(read_lightmap(c), ref), 1e-5);
  modrt_context_destroy(c);

  o.bounces = 65;
  expect_error(modrt_context_create(d, l, &o, nullptr, &c), MODRT_ERROR_INVALID_ARGUMENT,
               {"options.bounces 65", "0..64"});
  o.bounces = 1;
  o.max_albedo = 1.0f;
  expect_error(modrt_context_create(d, l, &o, nullptr, &c), MODRT_ERROR_INVALID_ARGUMENT,
               {"options.max_albedo", "[0, 1)"});
  o.max_albedo = std::numeric_limits<float>::quiet_NaN();
  expect_error(modrt_context_create(d, l, &o, nullptr, &c), MODRT_ERROR_INVALID_ARGUMENT,
               {"options.max_albedo"});
  EXPECT_EQ(c, nullptr);

  // 0.2's layout ends before `bounces`: accepted, one bounce, and timings in 0.2's layout are
  // written without touching the bytes after them.
  modrt_context_options old = o;
  old.bounces = 7;  // beyond the caller's struct: must not be read
  old.struct_size = std::uint32_t(offsetof(modrt_context_options, bounces));
  ASSERT_EQ(modrt_context_create(d, l, &old, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  EXPECT_LT(rel_l2(read_lightmap(c), level_reference(t.level, t.ld).lightmap), 1e-5);
  modrt_timings tm = modrt::rt::sized<modrt_timings>();
  tm.struct_size = std::uint32_t(offsetof(modrt_timings, feedback_ns));
  tm.feedback_ns = 12345;
  ASSERT_EQ(modrt_context_get_timings(c, &tm), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(tm.struct_size, offsetof(modrt_timings, feedback_ns));
  EXPECT_EQ(tm.feedback_ns, 12345u);
  EXPECT_GT(tm.update_ns, 0u);
  tm.struct_size = std::uint32_t(offsetof(modrt_timings, feedback_ns)) + 4;
  expect_error(modrt_context_get_timings(c, &tm), MODRT_ERROR_INVALID_ARGUMENT, {"out.struct_size"});
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

// modrt_context_set_bounces: the bounce count changes between updates of one context, each
// update the C++ FramePipeline::run(ld, N) over the same CPU backend (bit-identical on the CPU,
// relative L2 1e-4 for GLES), without allocating (CPU); the same ld with another count is not
// skipped, the same count again is; a count above 64 and null arguments are named errors that
// change nothing.
void expect_bounces_per_update(modrt_backend backend, double tolerance) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  o.bounces = 2;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  std::uint32_t n = 99;
  ASSERT_EQ(modrt_context_get_bounces(c, &n), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(n, 2u);

  // The C++ side: the CPU backend of the creator table and the frame pipeline over it, with
  // the context's options (one thread, skipping, probes) and the level's albedo.
  BackendCreateInfo info;
  info.level = &t.level;
  info.dict = &small_test_dictionary();
  std::unique_ptr<Backend> be = create_backend(BackendKind::cpu, info).value();
  FramePipeline pipeline = FramePipeline::create(*be).value();
  ASSERT_TRUE(pipeline.set_albedo(level_sample_albedo(t.level), kDefaultMaxAlbedo).ok());
  std::vector<float> expected(be->sizes().lightmap);

  std::vector<float> ld2 = t.ld;
  for (std::size_t i = 0; i < ld2.size(); ++i) ld2[i] *= 0.5f + float(i % 7) / 7.0f;
  struct Step {
    std::uint32_t bounces;
    const std::vector<float>* ld;
    bool skipped;  // with skip_unchanged: the last update's ld, albedo and count
  };
  const Step steps[] = {{2, &t.ld, false}, {5, &t.ld, false}, {5, &t.ld, true}, {0, &t.ld, false},
                        {1, &t.ld, false}, {64, &ld2, false}, {3, &ld2, false}};
  const std::vector<float>* previous_ld = nullptr;
  std::uint32_t previous_bounces = 0;
  double sum_previous = 0.0;
  for (const Step& step : steps) {
    SCOPED_TRACE("bounces " + std::to_string(step.bounces));
    modrt_skip_stats k0 = modrt::rt::sized<modrt_skip_stats>(), k1 = k0;
    ASSERT_EQ(modrt_context_get_skip_stats(c, &k0), MODRT_OK);
    ASSERT_EQ(modrt_context_set_ld(c, step.ld->data(), step.ld->size()), MODRT_OK) << modrt_last_error();
    g_allocations = 0;
    g_count_allocations = true;
    const modrt_status set = modrt_context_set_bounces(c, step.bounces);
    const modrt_status updated = modrt_context_update(c);
    g_count_allocations = false;
    ASSERT_EQ(set, MODRT_OK) << modrt_last_error();
    ASSERT_EQ(updated, MODRT_OK) << modrt_last_error();
    if (backend == MODRT_BACKEND_CPU) {  // a GL driver (Mesa) allocates inside its own calls
      EXPECT_EQ(g_allocations.load(), 0);
    }
    ASSERT_EQ(modrt_context_get_bounces(c, &n), MODRT_OK);
    EXPECT_EQ(n, step.bounces);
    ASSERT_EQ(modrt_context_get_skip_stats(c, &k1), MODRT_OK);
    EXPECT_EQ(k1.frames_skipped - k0.frames_skipped, step.skipped ? 1u : 0u);
    if (step.skipped) {  // a skipped frame keeps every block and tile (computed + kept per frame)
      EXPECT_EQ(k1.blocks_computed, k0.blocks_computed);
      EXPECT_EQ(k1.blocks_kept - k0.blocks_kept, t.level.blocks.size());
      EXPECT_EQ(k1.tiles_kept - k0.tiles_kept, t.level.blocks.size());
    }

    ASSERT_TRUE(pipeline.run(*step.ld, step.bounces).ok());
    EXPECT_EQ(pipeline.last_frame_skipped(), step.skipped);
    ASSERT_TRUE(be->read_lightmap(expected).ok());
    const std::vector<float> got = read_lightmap(c);
    if (tolerance == 0.0) {
      EXPECT_EQ(got, expected);
    } else {
      EXPECT_LT(rel_l2(got, expected), tolerance);
    }
    // More bounces on the same ld: more light; fewer: less.
    double sum = 0.0;
    for (float v : got) sum += v;
    if (previous_ld == step.ld && step.bounces > previous_bounces) {
      EXPECT_GT(sum, sum_previous);
    }
    if (previous_ld == step.ld && step.bounces < previous_bounces) {
      EXPECT_LT(sum, sum_previous);
    }
    previous_ld = step.ld;
    previous_bounces = step.bounces;
    sum_previous = sum;
  }

  // Refused, naming the argument; nothing changes: the count stays, the next update is the
  // last one again (skipped: same ld, albedo and count).
  const std::vector<float> before = read_lightmap(c);
  expect_error(modrt_context_set_bounces(c, 65), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_set_bounces", "bounces 65", "0..64"});
  expect_error(modrt_context_set_bounces(c, 0xfffffffeu), MODRT_ERROR_INVALID_ARGUMENT,
               {"bounces 4294967294", "0..64", "MODRT_BOUNCES_CONVERGED"});
  ASSERT_EQ(modrt_context_get_bounces(c, &n), MODRT_OK);
  EXPECT_EQ(n, 3u);
  modrt_skip_stats k0 = modrt::rt::sized<modrt_skip_stats>(), k1 = k0;
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k0), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k1), MODRT_OK);
  EXPECT_EQ(k1.frames_skipped, k0.frames_skipped + 1);
  EXPECT_EQ(read_lightmap(c), before);
  expect_error(modrt_context_set_bounces(nullptr, 1), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_set_bounces", "context is null"});
  expect_error(modrt_context_get_bounces(nullptr, &n), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_get_bounces", "context is null"});
  expect_error(modrt_context_get_bounces(c, nullptr), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_get_bounces", "bounces is null"});
  ASSERT_EQ(modrt_context_get_bounces(c, &n), MODRT_OK);
  EXPECT_EQ(n, 3u);

  // The C++ wrapper.
  {
    modrt::rt::Dictionary dw;
    modrt::rt::Level lw;
    ASSERT_FALSE(modrt::rt::Dictionary::load_memory(assets().dictionary.data(), assets().dictionary.size(),
                                                    "dict", dw));
    ASSERT_FALSE(modrt::rt::Level::load_memory(assets().level.data(), assets().level.size(), "maze11", lw));
    modrt::rt::Context cw;
    ASSERT_FALSE(modrt::rt::Context::create(dw, lw, modrt::rt::default_options(backend), cw));
    EXPECT_EQ(cw.bounces(), MODRT_BOUNCES_CONVERGED);  // the default
    EXPECT_FALSE(cw.set_bounces(7));
    EXPECT_EQ(cw.bounces(), 7u);
    EXPECT_TRUE(cw.set_bounces(65));
    EXPECT_EQ(cw.bounces(), 7u);
  }
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

TEST(CApi, BouncesChangePerUpdateAsTheFramePipelineRuns) {
  expect_bounces_per_update(MODRT_BACKEND_CPU, 0.0);
}

TEST(CApiGles, BouncesChangePerUpdateAsTheFramePipelineRuns) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  expect_bounces_per_update(MODRT_BACKEND_GLES, 1e-4);
}

// options.vector_irradiance: the four OHLSH coefficients per sample against core's
// level_compute_vector_irradiance, each coefficient's padded atlas against level_fill_atlas of
// that coefficient, the GLES textures, and the errors of a context without it.
void expect_vector_irradiance_matches(modrt_backend backend, double tolerance) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  o.bounces = 0;  // one bounce, as the reference
  o.vector_irradiance = 1;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  const std::size_t n = t.level.sample_count;
  std::vector<float> vec(12 * n), atlas(3 * std::size_t(t.level.atlas.width) * t.level.atlas.height);
  expect_error(modrt_context_read_vector_lightmap(c, vec.data(), vec.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"no update has run yet"});
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  const test::LevelReference ref = level_reference(t.level, t.ld);
  ASSERT_EQ(modrt_context_read_vector_lightmap(c, vec.data(), vec.size()), MODRT_OK) << modrt_last_error();
  EXPECT_LT(rel_l2(vec, ref.vector_lightmap), tolerance);
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(modrt_context_read_vector_atlas(c, i, atlas.data(), atlas.size()), MODRT_OK)
        << modrt_last_error();
    std::vector<float> plane(3 * n), want(atlas.size());
    for (std::size_t s = 0; s < n; ++s)
      for (std::size_t ch = 0; ch < 3; ++ch)
        plane[3 * s + ch] = ref.vector_lightmap[3 * (4 * s + std::size_t(i)) + ch];
    level_fill_atlas(t.level, plane, want);
    EXPECT_LT(rel_l2(atlas, want), tolerance) << "coefficient " << i;
  }
  uint32_t tex[4] = {0, 0, 0, 0};
  if (backend == MODRT_BACKEND_GLES) {
    ASSERT_EQ(modrt_context_get_vector_textures(c, tex, nullptr), MODRT_OK) << modrt_last_error();
    for (int i = 0; i < 4; ++i) EXPECT_NE(tex[i], 0u);
    EXPECT_NE(tex[0], tex[3]);
  } else {
    expect_error(modrt_context_get_vector_textures(c, tex, nullptr), MODRT_ERROR_UNSUPPORTED,
                 {"CPU", "read_vector_atlas"});
    // A CPU frame with vector irradiance allocates nothing.
    std::vector<float> ld = t.ld;
    for (float& v : ld) v *= 0.5f;
    g_allocations = 0;
    g_count_allocations = true;
    bool ok = modrt_context_set_ld(c, ld.data(), ld.size()) == MODRT_OK;
    ok &= modrt_context_update(c) == MODRT_OK;
    ok &= modrt_context_read_vector_lightmap(c, vec.data(), vec.size()) == MODRT_OK;
    ok &= modrt_context_read_vector_atlas(c, 1, atlas.data(), atlas.size()) == MODRT_OK;
    g_count_allocations = false;
    EXPECT_TRUE(ok) << modrt_last_error();
    EXPECT_EQ(g_allocations.load(), 0);
  }
  expect_error(modrt_context_read_vector_atlas(c, 4, atlas.data(), atlas.size()),
               MODRT_ERROR_INVALID_ARGUMENT, {"coefficient 4", "0..3"});
  expect_error(modrt_context_read_vector_lightmap(c, vec.data(), 3 * n), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_read_vector_lightmap", "out has"});
  modrt_context_destroy(c);

  o.vector_irradiance = 0;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  expect_error(modrt_context_read_vector_lightmap(c, vec.data(), vec.size()), MODRT_ERROR_UNSUPPORTED,
               {"options.vector_irradiance 0"});
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

TEST(CApi, VectorIrradianceMatchesTheReference) { expect_vector_irradiance_matches(MODRT_BACKEND_CPU, 1e-5); }

TEST(CApiGles, VectorIrradianceMatchesTheReference) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  expect_vector_irradiance_matches(MODRT_BACKEND_GLES, 1e-4);
}

// The probe volume as one world-frame array (for a GPU buffer or 3D texture): each probe's SH9
// is what modrt_context_probe_sh gives at its position (which test_c_api checks against core's
// reference rotated into the world), E/pi is radiance with bands scaled by 1, 2/3, 1/4.
void expect_probe_volume_matches_queries(modrt_backend backend) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  ASSERT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  ASSERT_GT(s.probes, 0u);
  const std::size_t probes = s.probes / 27;
  ASSERT_EQ(probes, t.level.blocks.size() * s.probe_grid * s.probe_grid * s.probe_grid);
  std::vector<float> e(s.probes), rad(s.probes), pos(3 * probes);
  ASSERT_EQ(modrt_context_read_probes(c, MODRT_PROBE_IRRADIANCE_OVER_PI, e.data(), e.size()), MODRT_OK)
      << modrt_last_error();
  ASSERT_EQ(modrt_context_read_probes(c, MODRT_PROBE_RADIANCE, rad.data(), rad.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_get_probe_positions(c, pos.data(), pos.size()), MODRT_OK) << modrt_last_error();
  float peak = 0.0f;
  for (float v : e) peak = std::max(peak, std::abs(v));
  ASSERT_GT(peak, 0.0f);
  for (std::size_t p = 0; p < probes; p += 5) {
    float q[27];
    ASSERT_EQ(modrt_context_probe_sh(c, &pos[3 * p], MODRT_PROBE_IRRADIANCE_OVER_PI, q), MODRT_OK)
        << modrt_last_error();
    for (int k = 0; k < 27; ++k) ASSERT_NEAR(e[27 * p + std::size_t(k)], q[k], 1e-5f * peak) << "probe " << p;
    for (int k = 0; k < 27; ++k) {
      const float band = k < 3 ? 1.0f : k < 12 ? 2.0f / 3.0f : 0.25f;
      ASSERT_NEAR(e[27 * p + std::size_t(k)], band * rad[27 * p + std::size_t(k)], 1e-6f * peak);
    }
    // The position lies inside block p / g^3.
    const std::size_t block = p / (probes / t.level.blocks.size());
    const glm::dvec3 canonical =
        world_to_block(t.level.blocks[block], glm::dvec3(pos[3 * p], pos[3 * p + 1], pos[3 * p + 2]));
    for (int a = 0; a < 3; ++a) ASSERT_TRUE(canonical[a] > 0.0 && canonical[a] < 1.0) << p;
  }
  expect_error(modrt_context_read_probes(c, MODRT_PROBE_RADIANCE, e.data(), e.size() - 1),
               MODRT_ERROR_INVALID_ARGUMENT, {"modrt_context_read_probes", "out has"});
  expect_error(modrt_context_read_probes(c, modrt_probe_kind(5), e.data(), e.size()),
               MODRT_ERROR_INVALID_ARGUMENT, {"unknown probe kind 5"});
  expect_error(modrt_context_get_probe_positions(c, pos.data(), 3), MODRT_ERROR_INVALID_ARGUMENT,
               {"the probes need " + std::to_string(3 * probes)});
  modrt_context_destroy(c);
  o.probes = 0;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  expect_error(modrt_context_read_probes(c, MODRT_PROBE_RADIANCE, e.data(), e.size()),
               MODRT_ERROR_UNSUPPORTED, {"options.probes was 0"});
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

// modrt_context_locate_probe: the cell of a world point is core's ProbeSampler::locate (block,
// lower corner, weights as floats), the 8 probe indices and corner weights mix the world-frame
// volume of read_probes into modrt_context_probe_sh's value (within 1e-5 of the largest
// coefficient) at points all over the maze (turned blocks, near faces, beyond the outermost
// probe centres, 0.5% outside a block); bad input is named and leaves *out as it was.
void expect_probe_cells_match_the_sampler(modrt_backend backend) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = backend;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  ASSERT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  const int g = int(s.probe_grid);
  ASSERT_GT(g, 1);
  // Before any update: the cell is geometry only.
  const LevelBlock& first = t.level.blocks[0];
  const glm::dvec3 x0 = block_to_world(first, glm::dvec3(0.3, 0.4, 0.6));
  const float p0[3] = {float(x0.x), float(x0.y), float(x0.z)};
  modrt_probe_cell cell = modrt::rt::sized<modrt_probe_cell>();
  ASSERT_EQ(modrt_context_locate_probe(c, p0, &cell), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(cell.struct_size, sizeof cell);
  EXPECT_EQ(cell.block, 0u);

  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  std::vector<float> world(s.probes);
  ASSERT_EQ(modrt_context_read_probes(c, MODRT_PROBE_RADIANCE, world.data(), world.size()), MODRT_OK)
      << modrt_last_error();
  float peak = 0.0f;
  for (float v : world) peak = std::max(peak, std::abs(v));
  ASSERT_GT(peak, 0.0f);

  const ProbeSampler sampler(t.level, g);
  std::vector<glm::dvec3> canonical_points = {{0.5, 0.5, 0.5},  {0.01, 0.5, 0.99},  {0.999, 0.001, 0.5},
                                              {0.5, 0.02, 0.5}, {-0.005, 0.5, 0.5}, {0.25, 0.75, 0.125},
                                              {0.2, 0.2, 1.004}};
  std::uint32_t seed = 12345;
  auto next = [&] {
    seed = seed * 1664525u + 1013904223u;
    return double(seed >> 8) / double(1u << 24);
  };
  for (int i = 0; i < 12; ++i) canonical_points.push_back({next(), next(), next()});
  int turned = 0, held = 0, checked = 0;
  for (std::size_t b = 0; b < t.level.blocks.size(); ++b)
    for (const glm::dvec3& q : canonical_points) {
      const glm::dvec3 x = block_to_world(t.level.blocks[b], q);
      const float pos[3] = {float(x.x), float(x.y), float(x.z)};
      SCOPED_TRACE("block " + std::to_string(b) + " at (" + std::to_string(q.x) + ", " + std::to_string(q.y) +
                   ", " + std::to_string(q.z) + ")");
      const Result<ProbeCell> ref = sampler.locate(glm::dvec3(pos[0], pos[1], pos[2]));
      ASSERT_TRUE(ref.ok()) << ref.status().to_string();
      cell = modrt::rt::sized<modrt_probe_cell>();
      g_allocations = 0;
      g_count_allocations = true;
      const modrt_status located = modrt_context_locate_probe(c, pos, &cell);
      g_count_allocations = false;
      ASSERT_EQ(located, MODRT_OK) << modrt_last_error();
      EXPECT_EQ(g_allocations.load(), 0);
      const ProbeCell& r = ref.value();
      ASSERT_EQ(cell.block, r.block);
      EXPECT_EQ(cell.quarter_turns, std::uint32_t(t.level.blocks[r.block].quarter_turns & 3));
      EXPECT_EQ(cell.grid, std::uint32_t(g));
      float total = 0.0f;
      for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(cell.lower[a], r.i0[a]);
        EXPECT_EQ(cell.weight[a], float(r.f[a]));
        held += cell.weight[a] == 0.0f || cell.weight[a] == 1.0f;
      }
      for (int k = 0; k < 8; ++k) {
        const glm::ivec3 corner =
            glm::min(r.i0 + glm::ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1), glm::ivec3(g - 1));
        EXPECT_EQ(cell.probe[k], std::uint32_t(r.block * std::size_t(g * g * g) +
                                               std::size_t(corner.x + g * (corner.y + g * corner.z))));
        total += cell.corner_weight[k];
      }
      EXPECT_NEAR(total, 1.0f, 1e-6f);
      turned += cell.quarter_turns != 0;
      // What a shader does with the cell: mix the 8 world-frame probes.
      float sh[27];
      ASSERT_EQ(modrt_context_probe_sh(c, pos, MODRT_PROBE_RADIANCE, sh), MODRT_OK) << modrt_last_error();
      for (int k = 0; k < 27; ++k) {
        double mixed = 0.0;
        for (int corner = 0; corner < 8; ++corner)
          mixed += double(cell.corner_weight[corner]) *
                   world[27 * std::size_t(cell.probe[corner]) + std::size_t(k)];
        ASSERT_NEAR(mixed, sh[k], 1e-5 * peak) << "coefficient " << k;
      }
      ++checked;
    }
  EXPECT_GT(turned, 0) << "no turned block: the frame is untested";
  EXPECT_GT(held, 0) << "no point beyond the outermost probe centres";
  EXPECT_EQ(checked, int(t.level.blocks.size() * canonical_points.size()));

  // Bad input: named, *out unchanged.
  modrt_probe_cell keep;
  std::memset(&keep, 0xab, sizeof keep);
  keep.struct_size = sizeof keep;
  modrt_probe_cell bad = keep;
  const auto unchanged = [&] { EXPECT_EQ(std::memcmp(&bad, &keep, sizeof keep), 0); };
  expect_error(modrt_context_locate_probe(nullptr, p0, &bad), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_locate_probe", "context is null"});
  expect_error(modrt_context_locate_probe(c, nullptr, &bad), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_locate_probe", "position is null"});
  expect_error(modrt_context_locate_probe(c, p0, nullptr), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_locate_probe", "out is null"});
  unchanged();
  bad.struct_size = sizeof bad - 4;
  keep.struct_size = bad.struct_size;
  expect_error(modrt_context_locate_probe(c, p0, &bad), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_locate_probe", "out.struct_size is " + std::to_string(sizeof bad - 4),
                "expected " + std::to_string(sizeof bad), "sizeof(modrt_probe_cell)"});
  unchanged();
  bad.struct_size = keep.struct_size = sizeof bad;
  const float nan_y[3] = {p0[0], std::numeric_limits<float>::quiet_NaN(), p0[2]};
  expect_error(modrt_context_locate_probe(c, nan_y, &bad), MODRT_ERROR_NON_FINITE,
               {"position[1]", "not finite"});
  const float inf_z[3] = {p0[0], p0[1], std::numeric_limits<float>::infinity()};
  expect_error(modrt_context_locate_probe(c, inf_z, &bad), MODRT_ERROR_NON_FINITE, {"position[2]"});
  const float far[3] = {1e4f, 1e4f, 1e4f};
  expect_error(modrt_context_locate_probe(c, far, &bad), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_locate_probe: position", "outside every block"});
  unchanged();
  // The C++ wrapper.
  {
    modrt::rt::Dictionary dw;
    modrt::rt::Level lw;
    ASSERT_FALSE(modrt::rt::Dictionary::load_memory(assets().dictionary.data(), assets().dictionary.size(),
                                                    "dict", dw));
    ASSERT_FALSE(modrt::rt::Level::load_memory(assets().level.data(), assets().level.size(), "maze11", lw));
    modrt::rt::Context cw;
    ASSERT_FALSE(modrt::rt::Context::create(dw, lw, modrt::rt::default_options(backend), cw));
    modrt_probe_cell wc;
    ASSERT_FALSE(cw.locate_probe(p0, wc));
    EXPECT_EQ(wc.block, 0u);
    EXPECT_TRUE(cw.locate_probe(far, wc));
  }
  modrt_context_destroy(c);
  // Without probes.
  o.probes = 0;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  expect_error(modrt_context_locate_probe(c, p0, &bad), MODRT_ERROR_UNSUPPORTED,
               {"modrt_context_locate_probe", "no probes"});
  unchanged();
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

TEST(CApi, ProbeCellIsTheSamplersCell) { expect_probe_cells_match_the_sampler(MODRT_BACKEND_CPU); }

TEST(CApiGles, ProbeCellIsTheSamplersCell) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  expect_probe_cells_match_the_sampler(MODRT_BACKEND_GLES);
}

TEST(CApi, ProbeVolumeIsTheQueriesAtEveryProbe) { expect_probe_volume_matches_queries(MODRT_BACKEND_CPU); }

TEST(CApiGles, ProbeVolumeIsTheQueriesAtEveryProbe) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  expect_probe_volume_matches_queries(MODRT_BACKEND_GLES);
}

// ld from the app's own GPU pass: a texture in the context's ld layout is read on the GPU, with
// no glReadPixels in the frame (counted through the app's loader); NaN and negative texels read
// as 0; the lightmap equals the one from the same ld set as floats; errors are named.
std::atomic<int> g_read_pixels{0};
PFNGLREADPIXELSPROC g_real_read_pixels = nullptr;
void GL_APIENTRY counting_read_pixels(GLint x, GLint y, GLsizei w, GLsizei h, GLenum format, GLenum type,
                                      void* pixels) {
  ++g_read_pixels;
  g_real_read_pixels(x, y, w, h, format, type, pixels);
}
void* counting_loader(const char* name, void* user) {
  void* real = reinterpret_cast<void* (*)(const char*)>(user)(name);
  if (real && std::strcmp(name, "glReadPixels") == 0) {
    g_real_read_pixels = reinterpret_cast<PFNGLREADPIXELSPROC>(real);
    return reinterpret_cast<void*>(&counting_read_pixels);
  }
  return real;
}

TEST(CApiGles, LdFromTheAppsTextureNeedsNoReadback) {
  MODRT_GL_CONTEXT_OR_SKIP(context, platform::ContextRequest::egl_surfaceless);
  void* get_proc = dlsym(RTLD_DEFAULT, "eglGetProcAddress");
  ASSERT_NE(get_proc, nullptr);
  const platform::GlFunctions& gl = context->gl();
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = MODRT_BACKEND_GLES;
  o.gl_loader = counting_loader;
  o.bounces = 0;  // one bounce: compared with one-bounce references, linear in ld
  o.gl_loader_user = get_proc;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  std::uint32_t width = 0, height = 0;
  ASSERT_EQ(modrt_context_get_ld_layout(c, &width, &height), MODRT_OK) << modrt_last_error();
  const std::size_t n = t.level.sample_count;
  ASSERT_GE(std::size_t(width) * height, n);

  // The app's ld texture (its GPU pass simulated by an upload), with NaN and a negative value.
  std::vector<float> texels(4 * std::size_t(width) * height, 0.0f), sanitized = t.ld;
  for (std::size_t s = 0; s < n; ++s)
    for (std::size_t ch = 0; ch < 3; ++ch) texels[4 * s + ch] = t.ld[3 * s + ch];
  texels[4 * 3 + 1] = std::numeric_limits<float>::quiet_NaN();
  texels[4 * 9 + 0] = -5.0f;
  sanitized[3 * 3 + 1] = 0.0f;
  sanitized[3 * 9 + 0] = 0.0f;
  GLuint tex = 0;
  gl.glGenTextures(1, &tex);
  gl.glBindTexture(GL_TEXTURE_2D, tex);
  // Mutable storage, one level, the default GL_NEAREST_MIPMAP_LINEAR: incomplete by its own
  // sampling state (texelFetch would read 0); the runtime's sampler object makes it complete.
  const auto tex_image_2d = reinterpret_cast<PFNGLTEXIMAGE2DPROC>(
      reinterpret_cast<void* (*)(const char*)>(get_proc)("glTexImage2D"));
  ASSERT_NE(tex_image_2d, nullptr);
  tex_image_2d(GL_TEXTURE_2D, 0, GL_RGBA32F, GLsizei(width), GLsizei(height), 0, GL_RGBA, GL_FLOAT,
               texels.data());
  ASSERT_EQ(gl.glGetError(), GLenum(GL_NO_ERROR));

  g_read_pixels = 0;
  ASSERT_EQ(modrt_context_set_ld_texture(c, tex), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(g_read_pixels.load(), 0) << "the GPU-ld frames read back";
  const std::vector<float> from_texture = read_lightmap(c);
  EXPECT_GT(g_read_pixels.load(), 0) << "the loader wrapper does not see the reads";
  EXPECT_LT(rel_l2(from_texture, level_reference(t.level, sanitized).lightmap), 1e-4);
  modrt_skip_stats k = modrt::rt::sized<modrt_skip_stats>();
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k), MODRT_OK);
  EXPECT_EQ(k.frames, 2u);
  EXPECT_EQ(k.frames_skipped, 0u);
  std::vector<float> ld_copy(3 * n);
  expect_error(modrt_context_read_ld(c, ld_copy.data(), ld_copy.size()), MODRT_ERROR_UNSUPPORTED,
               {"GL texture " + std::to_string(tex)});
  // The same ld as floats: the same lightmap.
  ASSERT_EQ(modrt_context_set_ld(c, sanitized.data(), sanitized.size()), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  EXPECT_LT(rel_l2(read_lightmap(c), from_texture), 1e-7);

  expect_error(modrt_context_set_ld_texture(c, 0), MODRT_ERROR_INVALID_ARGUMENT, {"texture 0"});
  expect_error(modrt_context_set_ld_texture(c, 987654), MODRT_ERROR_INVALID_ARGUMENT,
               {"texture 987654", "not a texture name"});
  modrt_context_destroy(c);
  // Multi-bounce from the texture: the bound comes from a GPU reduction, nothing is read back,
  // and the frame is the one of the same ld as floats (a wrong largest ld, e.g. 0, would clamp
  // every fed-back texel and leave one bounce).
  o.bounces = 2;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  g_read_pixels = 0;
  ASSERT_EQ(modrt_context_set_ld_texture(c, tex), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(g_read_pixels.load(), 0) << "the GPU-ld multi-bounce frames read back";
  const std::vector<float> bounced_from_texture = read_lightmap(c);
  ASSERT_EQ(modrt_context_set_ld(c, sanitized.data(), sanitized.size()), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  const std::vector<float> bounced = read_lightmap(c);
  EXPECT_LT(rel_l2(bounced_from_texture, bounced), 1e-6);
  EXPECT_GT(rel_l2(bounced, from_texture), 1e-2);  // the bounces add light
  modrt_context_destroy(c);
  o = modrt::rt::default_options(MODRT_BACKEND_CPU);
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  expect_error(modrt_context_set_ld_texture(c, tex), MODRT_ERROR_UNSUPPORTED, {"CPU context"});
  expect_error(modrt_context_get_ld_layout(c, &width, &height), MODRT_ERROR_UNSUPPORTED, {"CPU context"});
  modrt_context_destroy(c);
  gl.glDeleteTextures(1, &tex);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

// The probe volume as a GL texture (world frame, for GPU sampling): no readback in the update or
// in the call; its texels are read_probes' radiance (relative L2 <= 1e-6: the same rotation in
// float on the GPU, in double on the CPU); the level has turned blocks, so the rotation is tested.
// set_light_gpu: the GPU pass (gles::GlesDirectLight) gives the lightmap set_lights gives for
// the same unshadowed point and spot light, the updates read its texture without a readback,
// set_albedo reaches it, and bad input is refused naming the field with the ld source kept.
TEST(CApiGles, LightOnTheGpuIsSetLightsLight) {
  MODRT_GL_CONTEXT_OR_SKIP(context, platform::ContextRequest::egl_surfaceless);
  void* get_proc = dlsym(RTLD_DEFAULT, "eglGetProcAddress");
  ASSERT_NE(get_proc, nullptr);
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = MODRT_BACKEND_GLES;
  o.gl_loader = counting_loader;
  o.bounces = 0;  // one bounce: compared with one-bounce references, linear in ld
  o.gl_loader_user = get_proc;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  modrt_level_info info = modrt::rt::sized<modrt_level_info>();
  ASSERT_EQ(modrt_level_get_info(l, &info), MODRT_OK) << modrt_last_error();
  modrt_light light;
  modrt_light_init(&light);
  for (int a = 0; a < 3; ++a) light.position[a] = 0.5f * (info.bounds_min[a] + info.bounds_max[a]);
  light.color[1] = 0.6f;
  light.intensity = 2.0f;
  light.radius = 0.2f;  // above every block's texel floor, so both clamp 1/d^2 alike
  light.shadows = 0;    // set_lights would shadow by the proxy walls, the GPU pass only by a shadow map
  auto lightmap_of = [&](bool gpu) {
    g_read_pixels = 0;
    EXPECT_EQ(gpu ? modrt_context_set_light_gpu(c, &light, nullptr) : modrt_context_set_lights(c, &light, 1),
              MODRT_OK)
        << modrt_last_error();
    EXPECT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
    if (gpu) {
      EXPECT_EQ(g_read_pixels.load(), 0) << "the GPU light's frame read back";
    }
    return read_lightmap(c);
  };
  const std::vector<float> point_gpu = lightmap_of(true), point_cpu = lightmap_of(false);
  EXPECT_GT(*std::max_element(point_cpu.begin(), point_cpu.end()), 0.0f);
  // The same light model in float on both sides: rounding only.
  EXPECT_LT(rel_l2(point_gpu, point_cpu), 1e-4);
  light.type = MODRT_LIGHT_SPOT;
  light.direction[0] = 0.3f;  // not normalised: both normalise it
  light.inner_angle = 0.5f, light.outer_angle = 0.9f;
  const std::vector<float> spot_gpu = lightmap_of(true), spot_cpu = lightmap_of(false);
  EXPECT_LT(rel_l2(spot_gpu, spot_cpu), 1e-4);
  EXPECT_GT(rel_l2(spot_gpu, point_gpu), 0.05);  // the cone matters
  // A directional light (the sun, since 0.4): irradiance along `direction`, no falloff.
  modrt_light sun = light;
  light.type = MODRT_LIGHT_DIRECTIONAL;
  light.direction[0] = 0.4f, light.direction[1] = -1.0f, light.direction[2] = 0.25f;
  light.intensity = 3.0f;
  const std::vector<float> sun_gpu = lightmap_of(true), sun_cpu = lightmap_of(false);
  EXPECT_GT(*std::max_element(sun_cpu.begin(), sun_cpu.end()), 0.0f);
  EXPECT_LT(rel_l2(sun_gpu, sun_cpu), 1e-4);
  EXPECT_GT(rel_l2(sun_gpu, point_gpu), 0.05);
  std::swap(light, sun);
  // A new albedo reaches the GPU pass: half the albedo, half the direct light of the first bounce.
  std::vector<float> half = t.albedo;
  for (float& a : half) a *= 0.5f;
  ASSERT_EQ(modrt_context_set_albedo(c, half.data(), half.size()), MODRT_OK) << modrt_last_error();
  std::vector<float> spot_half = lightmap_of(true);
  for (float& v : spot_half) v *= 2.0f;
  EXPECT_LT(rel_l2(spot_half, spot_gpu), 1e-4);
  std::printf("  GPU vs CPU light: point rel L2 %.2e, spot %.2e, directional %.2e; half albedo %.2e\n",
              rel_l2(point_gpu, point_cpu), rel_l2(spot_gpu, spot_cpu), rel_l2(sun_gpu, sun_cpu),
              rel_l2(spot_half, spot_gpu));

  // Bad input: refused, naming the field; the ld source stays set_light_gpu's texture.
  const std::vector<float> before = read_lightmap(c);
  modrt_light bad = light;
  bad.type = MODRT_LIGHT_DIRECTIONAL;
  bad.direction[0] = bad.direction[1] = bad.direction[2] = 0.0f;
  expect_error(modrt_context_set_light_gpu(c, &bad, nullptr), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_set_light_gpu", "direction"});
  bad = light;
  bad.position[1] = std::numeric_limits<float>::quiet_NaN();
  expect_error(modrt_context_set_light_gpu(c, &bad, nullptr), MODRT_ERROR_INVALID_ARGUMENT, {"position"});
  bad = light;
  bad.outer_angle = 4.0f;
  expect_error(modrt_context_set_light_gpu(c, &bad, nullptr), MODRT_ERROR_INVALID_ARGUMENT, {"outer_angle"});
  bad.struct_size = 0;
  expect_error(modrt_context_set_light_gpu(c, &bad, nullptr), MODRT_ERROR_INVALID_ARGUMENT,
               {"light.struct_size is 0"});
  expect_error(modrt_context_set_light_gpu(c, nullptr, nullptr), MODRT_ERROR_INVALID_ARGUMENT, {"light"});
  modrt_shadow_cube shadow;
  modrt_shadow_cube_init(&shadow);
  EXPECT_EQ(shadow.struct_size, sizeof shadow);
  shadow.texture = 987654;
  expect_error(modrt_context_set_light_gpu(c, &light, &shadow), MODRT_ERROR_INVALID_ARGUMENT,
               {"shadow.texture 987654", "not a texture name"});
  shadow.texture = 0;
  shadow.near_plane = 0.0f;
  expect_error(modrt_context_set_light_gpu(c, &light, &shadow), MODRT_ERROR_INVALID_ARGUMENT, {"near_plane"});
  shadow.near_plane = 0.01f;
  shadow.normal_offset = -0.1f;
  expect_error(modrt_context_set_light_gpu(c, &light, &shadow), MODRT_ERROR_INVALID_ARGUMENT,
               {"shadow.normal_offset"});
  shadow.normal_offset = 0.0f;
  shadow.directional_view_proj[7] = std::numeric_limits<float>::infinity();
  expect_error(modrt_context_set_light_gpu(c, &light, &shadow), MODRT_ERROR_INVALID_ARGUMENT,
               {"shadow.directional_view_proj[7]"});
  // An 0.3 caller's struct (up to far_plane) is read with the defaults after it: the infinite
  // matrix entry beyond its size is not read.
  shadow.struct_size = std::uint32_t(offsetof(modrt_shadow_cube, normal_offset));
  EXPECT_EQ(modrt_context_set_light_gpu(c, &light, &shadow), MODRT_OK) << modrt_last_error();
  shadow.struct_size = 0;
  expect_error(modrt_context_set_light_gpu(c, &light, &shadow), MODRT_ERROR_INVALID_ARGUMENT,
               {"shadow.struct_size is 0"});
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(read_lightmap(c), before);
  // Without a shadow map (texture 0 in a valid modrt_shadow_cube): unshadowed, as with null.
  modrt_shadow_cube_init(&shadow);
  ASSERT_EQ(modrt_context_set_light_gpu(c, &light, &shadow), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(read_lightmap(c), before);
  modrt_context_destroy(c);

  o.backend = MODRT_BACKEND_CPU;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  expect_error(modrt_context_set_light_gpu(c, &light, nullptr), MODRT_ERROR_UNSUPPORTED,
               {"CPU context", "modrt_context_set_lights"});
  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

TEST(CApiGles, ProbeTextureIsTheWorldFrameVolumeWithoutReadback) {
  MODRT_GL_CONTEXT_OR_SKIP(context, platform::ContextRequest::egl_surfaceless);
  void* get_proc = dlsym(RTLD_DEFAULT, "eglGetProcAddress");
  ASSERT_NE(get_proc, nullptr);
  const platform::GlFunctions& gl = context->gl();
  const test::TestLevel& t = test_level("maze11");
  std::size_t turned = 0;
  for (const LevelBlock& b : t.level.blocks) turned += (b.quarter_turns & 3) != 0;
  ASSERT_GT(turned, 0u);
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = MODRT_BACKEND_GLES;
  o.gl_loader = counting_loader;
  o.gl_loader_user = get_proc;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  uint32_t texture = 0, width = 0, height = 0;
  int format = -1;
  expect_error(modrt_context_get_probe_texture(c, &texture, &format, &width, &height),
               MODRT_ERROR_INVALID_ARGUMENT, {"no update has run yet"});
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  g_read_pixels = 0;
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_get_probe_texture(c, &texture, &format, &width, &height), MODRT_OK)
      << modrt_last_error();
  ASSERT_EQ(modrt_context_get_probe_texture(c, &texture, nullptr, nullptr, nullptr), MODRT_OK);
  EXPECT_EQ(g_read_pixels.load(), 0) << "the probe texture was read back";
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  ASSERT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  ASSERT_GT(s.probes, 0u);
  ASSERT_GE(std::size_t(width) * height, s.probes / 3);
  std::vector<float> world(s.probes);
  ASSERT_EQ(modrt_context_read_probes(c, MODRT_PROBE_RADIANCE, world.data(), world.size()), MODRT_OK);
  // The texture's texels, read by the test (not through the runtime).
  GLuint fb = 0;
  gl.glGenFramebuffers(1, &fb);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, fb);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
  ASSERT_EQ(gl.glCheckFramebufferStatus(GL_FRAMEBUFFER), GLenum(GL_FRAMEBUFFER_COMPLETE));
  std::vector<float> texels(4 * std::size_t(width) * height);
  gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
  if (format == 2)  // RGBA32UI holding float bits
    gl.glReadPixels(0, 0, GLsizei(width), GLsizei(height), GL_RGBA_INTEGER, GL_UNSIGNED_INT, texels.data());
  else
    gl.glReadPixels(0, 0, GLsizei(width), GLsizei(height), GL_RGBA, GL_FLOAT, texels.data());
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl.glDeleteFramebuffers(1, &fb);
  ASSERT_EQ(gl.glGetError(), GLenum(GL_NO_ERROR));
  std::vector<float> from_texture(s.probes);
  for (std::size_t i = 0; i < s.probes / 3; ++i)
    for (std::size_t ch = 0; ch < 3; ++ch) from_texture[3 * i + ch] = texels[4 * i + ch];
  EXPECT_LT(rel_l2(from_texture, world), 1e-6);
  modrt_context_destroy(c);
  o = modrt::rt::default_options(MODRT_BACKEND_CPU);
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  expect_error(modrt_context_get_probe_texture(c, &texture, &format, &width, &height),
               MODRT_ERROR_UNSUPPORTED, {"a CPU context has no GL textures"});
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

// The creator table (modrt/backends.h): each kind creates its backend, which evaluates the level
// as core's reference does; bad requests are named.
TEST(BackendTable, EveryKindCreatesItsBackend) {
  const test::TestLevel& t = test_level("maze11");
  BackendCreateInfo info;
  info.level = &t.level;
  info.dict = &small_test_dictionary();
  const test::LevelReference ref = level_reference(t.level, t.ld);
  const platform::GlContext* gl =
      test::gl_context_for(platform::ContextRequest::egl_surfaceless).context.get();
  if (gl) {
    info.gl = &gl->gl();
    info.gles_context = gl->info().gles;
  }
  for (BackendKind kind : {BackendKind::cpu, BackendKind::gles, BackendKind::reference}) {
    SCOPED_TRACE(backend_kind_name(kind));
    if (kind == BackendKind::gles && !gl) continue;
    Result<std::unique_ptr<Backend>> be = create_backend(kind, info);
    ASSERT_TRUE(be.ok()) << be.status().to_string();
    EXPECT_EQ(be.value()->kind(), kind);
    ASSERT_TRUE(be.value()->update(t.ld).ok());
    std::vector<float> lightmap(be.value()->sizes().lightmap);
    ASSERT_TRUE(be.value()->read_lightmap(lightmap).ok());
    EXPECT_LT(rel_l2(lightmap, ref.lightmap), kind == BackendKind::gles ? 1e-4 : 1e-5);
    // Outputs as textures through the interface (no downcast): the GLES atlas; nothing the
    // backend does not compute (no vector irradiance, no clutter here); none on the CPU.
    const std::uint32_t atlas = be.value()->output_texture(BackendOutput::atlas);
    EXPECT_EQ(atlas != 0, kind == BackendKind::gles);
    for (BackendOutput o :
         {BackendOutput::vector0, BackendOutput::vector3, BackendOutput::clutter_atlas, BackendOutput::count})
      EXPECT_EQ(be.value()->output_texture(o), 0u) << int(o);
  }
  // With vector irradiance the four coefficient atlases are textures too.
  if (gl) {
    BackendCreateInfo vec = info;
    vec.vector_irradiance = true;
    Result<std::unique_ptr<Backend>> be = create_backend(BackendKind::gles, vec);
    ASSERT_TRUE(be.ok()) << be.status().to_string();
    ASSERT_TRUE(be.value()->update(t.ld).ok());
    for (int i = 0; i < 4; ++i)
      EXPECT_NE(be.value()->output_texture(BackendOutput(int(BackendOutput::vector0) + i)), 0u) << i;
  }
  const auto expect_refused = [&](BackendKind kind, const BackendCreateInfo& bad, const std::string& words) {
    Result<std::unique_ptr<Backend>> be = create_backend(kind, bad);
    ASSERT_FALSE(be.ok());
    EXPECT_EQ(be.status().code(), ErrorCode::invalid_argument);
    EXPECT_NE(be.status().message().find(words), std::string::npos) << be.status().message();
  };
  BackendCreateInfo no_gl = info;
  no_gl.gl = nullptr;
  expect_refused(BackendKind::gles, no_gl, "BackendCreateInfo::gl is null");
  expect_refused(BackendKind::count, info, "kind 3 is not a backend");
  expect_refused(BackendKind(-1), info, "kind -1 is not a backend");
  BackendCreateInfo no_level = info;
  no_level.level = nullptr;
  expect_refused(BackendKind::cpu, no_level, "create_backend(cpu): the level or dictionary is null");
}

TEST(CApi, BadCallsReturnNamedErrors) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context* c = nullptr;
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.struct_size = 4;
  expect_error(modrt_context_create(d, l, &o, nullptr, &c), MODRT_ERROR_INVALID_ARGUMENT, {"struct_size"});
  modrt_context_options_init(&o);
  o.threads = 0;
  expect_error(modrt_context_create(d, l, &o, nullptr, &c), MODRT_ERROR_INVALID_ARGUMENT, {"threads"});
  modrt_context_options_init(&o);
  o.backend = modrt_backend(7);
  expect_error(modrt_context_create(d, l, &o, nullptr, &c), MODRT_ERROR_INVALID_ARGUMENT, {"backend"});
  expect_error(modrt_context_create(nullptr, l, nullptr, nullptr, &c), MODRT_ERROR_INVALID_ARGUMENT,
               {"dictionary is null"});
  expect_error(modrt_context_create(d, nullptr, nullptr, nullptr, &c), MODRT_ERROR_INVALID_ARGUMENT,
               {"level is null"});
  // A level built against another dictionary (res changed consistently is not possible
  // without a rebuild, so a level whose kb differs from the dictionary's).
  {
    Level other = t.level;
    other.kb += 1;
    for (ResponseRecord& r : other.records) {
      Matrix T(r.T.rows, r.T.cols + 1);
      for (std::uint32_t i = 0; i < r.T.rows; ++i)
        for (std::uint32_t j = 0; j < r.T.cols; ++j) T.data[i * T.cols + j] = r.T.data[i * r.T.cols + j];
      r.T = std::move(T);
    }
    Result<std::vector<std::byte>> bytes = serialize_level(other);
    if (bytes.ok()) {
      modrt_level* lo = nullptr;
      ASSERT_EQ(modrt_level_load_memory(bytes->data(), bytes->size(), "other", nullptr, &lo), MODRT_OK)
          << modrt_last_error();
      expect_error(modrt_context_create(d, lo, nullptr, nullptr, &c), MODRT_ERROR_MISMATCH, {"kb"});
      modrt_level_destroy(lo);
    } else {
      ADD_FAILURE() << "could not build the mismatched level: " << bytes.status().to_string();
    }
  }
  ASSERT_EQ(modrt_context_create(d, l, nullptr, nullptr, &c), MODRT_OK) << modrt_last_error();

  std::vector<float> ld = t.ld;
  expect_error(modrt_context_set_ld(c, ld.data(), ld.size() - 1), MODRT_ERROR_INVALID_ARGUMENT,
               {"ld", std::to_string(ld.size() - 1).c_str(), std::to_string(ld.size()).c_str()});
  ld[3 * 7 + 1] = std::numeric_limits<float>::quiet_NaN();
  expect_error(modrt_context_set_ld(c, ld.data(), ld.size()), MODRT_ERROR_NON_FINITE,
               {"sample 7", "channel G", "NaN"});
  ld = t.ld;
  ld[3 * 5 + 2] = -1.0f;
  expect_error(modrt_context_set_ld(c, ld.data(), ld.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"sample 5", "channel B", "negative"});
  // Above kMaxLightValue: refused at the call (issue 18 item 11: it used to be accepted here
  // and refused by the next update).
  ld = t.ld;
  ld[3 * 6] = 2e30f;
  expect_error(modrt_context_set_ld(c, ld.data(), ld.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_set_ld", "sample 6 channel R is 2e+30", "kMaxLightValue"});
  expect_error(modrt_context_set_ld(c, nullptr, ld.size()), MODRT_ERROR_INVALID_ARGUMENT, {"ld is null"});

  modrt_light light;
  modrt_light_init(&light);
  light.type = MODRT_LIGHT_POINT;
  light.color[0] = light.color[1] = light.color[2] = 1.0f;
  light.intensity = 1.0f;
  std::vector<float> albedo = t.albedo;
  albedo[4] = std::numeric_limits<float>::infinity();
  EXPECT_NE(modrt_context_set_albedo(c, albedo.data(), albedo.size()), MODRT_OK);
  EXPECT_NE(std::string(modrt_last_error()).find("modrt_context_set_albedo"), std::string::npos);
  expect_error(modrt_context_set_albedo(c, t.albedo.data(), 3), MODRT_ERROR_INVALID_ARGUMENT, {"albedo"});
  ASSERT_EQ(modrt_context_set_albedo(c, t.albedo.data(), t.albedo.size()), MODRT_OK) << modrt_last_error();
  light.intensity = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(modrt_context_set_lights(c, &light, 1), MODRT_OK);
  EXPECT_NE(std::string(modrt_last_error()).find("light 0"), std::string::npos) << modrt_last_error();
  light.intensity = 1.0f;
  light.type = modrt_light_type(9);
  expect_error(modrt_context_set_lights(c, &light, 1), MODRT_ERROR_INVALID_ARGUMENT, {"light 0", "type"});
  std::vector<modrt_light> many(9, light);
  expect_error(modrt_context_set_lights(c, many.data(), many.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"max_lights"});

  // A failed set_ld left the previous (zero) ld: update works, the lightmap is dark.
  ASSERT_EQ(modrt_context_update(c), MODRT_OK);
  for (float v : read_lightmap(c)) ASSERT_EQ(v, 0.0f);

  uint32_t tex = 0;
  expect_error(modrt_context_get_atlas_texture(c, &tex, nullptr), MODRT_ERROR_UNSUPPORTED, {"CPU"});
  std::vector<float> small(3);
  expect_error(modrt_context_read_atlas(c, small.data(), small.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"out"});
  expect_error(modrt_context_read_lightmap(c, small.data(), small.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"out"});
  const float far[3] = {1e4f, 1e4f, 1e4f};
  float sh[27];
  expect_error(modrt_context_probe_sh(c, far, MODRT_PROBE_RADIANCE, sh), MODRT_ERROR_INVALID_ARGUMENT,
               {"outside every block"});
  const float nan_pos[3] = {0.0f, std::numeric_limits<float>::quiet_NaN(), 0.0f};
  expect_error(modrt_context_probe_sh(c, nan_pos, MODRT_PROBE_RADIANCE, sh), MODRT_ERROR_NON_FINITE,
               {"position[1]"});
  // Any int a C caller may pass as the enum (reading it as the C++ enum was UB: fuzz_c_api, UBSan).
  const float inside[3] = {0.5f, 0.5f, 0.5f};
  expect_error(modrt_context_probe_sh(c, inside, modrt_probe_kind(1000), sh), MODRT_ERROR_INVALID_ARGUMENT,
               {"unknown probe kind 1000"});

  // Null handles, everywhere.
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  modrt_timings tm = modrt::rt::sized<modrt_timings>();
  modrt_skip_stats k = modrt::rt::sized<modrt_skip_stats>();
  const float* data = nullptr;
  size_t count = 0;
  expect_error(modrt_context_update(nullptr), MODRT_ERROR_INVALID_ARGUMENT, {"context is null"});
  expect_error(modrt_context_get_sizes(nullptr, &s), MODRT_ERROR_INVALID_ARGUMENT, {"context is null"});
  expect_error(modrt_context_get_sizes(c, nullptr), MODRT_ERROR_INVALID_ARGUMENT, {"out is null"});
  expect_error(modrt_context_set_ld(nullptr, t.ld.data(), t.ld.size()), MODRT_ERROR_INVALID_ARGUMENT,
               {"context is null"});
  expect_error(modrt_context_set_lights(nullptr, &light, 1), MODRT_ERROR_INVALID_ARGUMENT,
               {"context is null"});
  expect_error(modrt_context_set_albedo(nullptr, t.albedo.data(), t.albedo.size()),
               MODRT_ERROR_INVALID_ARGUMENT, {"context is null"});
  expect_error(modrt_context_get_timings(nullptr, &tm), MODRT_ERROR_INVALID_ARGUMENT, {"context is null"});
  expect_error(modrt_context_get_skip_stats(nullptr, &k), MODRT_ERROR_INVALID_ARGUMENT, {"context is null"});
  expect_error(modrt_context_get_atlas_data(nullptr, &data, &count), MODRT_ERROR_INVALID_ARGUMENT,
               {"context is null"});
  expect_error(modrt_context_get_atlas_texture(nullptr, &tex, nullptr), MODRT_ERROR_INVALID_ARGUMENT,
               {"context is null"});
  expect_error(modrt_context_probe_sh(nullptr, far, MODRT_PROBE_RADIANCE, sh), MODRT_ERROR_INVALID_ARGUMENT,
               {"context is null"});
  expect_error(modrt_context_read_atlas(nullptr, small.data(), 3), MODRT_ERROR_INVALID_ARGUMENT,
               {"context is null"});
  expect_error(modrt_level_get_info(nullptr, nullptr), MODRT_ERROR_INVALID_ARGUMENT, {"null"});
  modrt_context_destroy(nullptr);
  modrt_level_destroy(nullptr);
  modrt_dictionary_destroy(nullptr);
  EXPECT_STREQ(modrt_context_description(nullptr), "");

  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

// Every struct passed in or out carries struct_size (modrt.h, "Structs"): a wrong size is an
// error naming the argument and the expected size, and the call changes nothing (the out
// struct is not written, the lights and ld stay as they were).
TEST(CApi, EveryStructChecksItsStructSize) {
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  EXPECT_EQ(sizeof(modrt_light), 64u);  // the size docs/embedding.md quotes

  modrt_allocator hook{};
  modrt_context* c = nullptr;
  expect_error(modrt_context_create(d, l, nullptr, &hook, &c), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_create", "allocator.struct_size is 0", "sizeof(modrt_allocator)"});
  EXPECT_EQ(c, nullptr);
  modrt_level* l2 = nullptr;
  expect_error(modrt_level_load_memory(assets().level.data(), assets().level.size(), "x", &hook, &l2),
               MODRT_ERROR_INVALID_ARGUMENT, {"allocator.struct_size"});
  EXPECT_EQ(l2, nullptr);
  hook.struct_size = sizeof hook;  // null alloc / free: malloc and free
  ASSERT_EQ(modrt_context_create(d, l, nullptr, &hook, &c), MODRT_OK) << modrt_last_error();

  modrt_level_info info{};
  info.block_count = 12345;
  expect_error(modrt_level_get_info(l, &info), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_level_get_info", "out.struct_size is 0", "sizeof(modrt_level_info)"});
  EXPECT_EQ(info.block_count, 12345u);
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  s.struct_size += 8;
  s.ld = 777;
  expect_error(modrt_context_get_sizes(c, &s), MODRT_ERROR_INVALID_ARGUMENT,
               {"out.struct_size is " + std::to_string(sizeof(modrt_sizes) + 8) + ", expected"});
  EXPECT_EQ(s.ld, 777u);
  modrt_timings tm{};
  expect_error(modrt_context_get_timings(c, &tm), MODRT_ERROR_INVALID_ARGUMENT, {"sizeof(modrt_timings)"});
  modrt_skip_stats k{};
  expect_error(modrt_context_get_skip_stats(c, &k), MODRT_ERROR_INVALID_ARGUMENT,
               {"sizeof(modrt_skip_stats)"});
  modrt_probe_cell cell{};
  cell.block = 4321;
  const float centre[3] = {0.5f, 0.5f, 0.5f};
  expect_error(modrt_context_locate_probe(c, centre, &cell), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_locate_probe", "out.struct_size is 0", "sizeof(modrt_probe_cell)"});
  EXPECT_EQ(cell.block, 4321u);
  s.struct_size = sizeof s;
  ASSERT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  EXPECT_EQ(s.struct_size, sizeof s);
  EXPECT_EQ(s.ld, t.ld.size());

  // Lights: the second of two has no struct_size; ld stays what the first call made.
  ASSERT_EQ(modrt_context_set_albedo(c, t.albedo.data(), t.albedo.size()), MODRT_OK) << modrt_last_error();
  modrt_light lights[2];
  modrt_light_init(&lights[0]);
  modrt_light_init(&lights[1]);
  EXPECT_EQ(lights[0].struct_size, sizeof(modrt_light));
  EXPECT_EQ(lights[0].type, MODRT_LIGHT_POINT);
  EXPECT_EQ(lights[0].intensity, 1.0f);
  info = modrt::rt::sized<modrt_level_info>();
  ASSERT_EQ(modrt_level_get_info(l, &info), MODRT_OK) << modrt_last_error();
  for (int a = 0; a < 3; ++a) lights[0].position[a] = 0.5f * (info.bounds_min[a] + info.bounds_max[a]);
  ASSERT_EQ(modrt_context_set_lights(c, lights, 1), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  const std::vector<float> before = read_lightmap(c);
  EXPECT_GT(*std::max_element(before.begin(), before.end()), 0.0f);
  lights[1].struct_size = 0;
  lights[0].intensity = 5.0f;
  expect_error(modrt_context_set_lights(c, lights, 2), MODRT_ERROR_INVALID_ARGUMENT,
               {"modrt_context_set_lights", "lights[1].struct_size is 0", "modrt_light_init"});
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(read_lightmap(c), before);

  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

TEST(CApi, CppWrapper) {
  const test::TestLevel& t = test_level("corridor");
  rt::Dictionary dict;
  ASSERT_FALSE(
      rt::Dictionary::load_memory(assets().dictionary.data(), assets().dictionary.size(), "dict", dict));
  rt::Level level;
  rt::Error e = rt::Level::load_memory(assets().level.data(), 3, "tiny", level);
  EXPECT_TRUE(e);
  EXPECT_EQ(e.code, MODRT_ERROR_FORMAT);
  EXPECT_NE(e.message.find("tiny"), std::string::npos);
  ASSERT_FALSE(rt::Level::load_memory(assets("corridor").level.data(), assets("corridor").level.size(),
                                      "corridor", level));
  EXPECT_EQ(level.info().sample_count, t.level.sample_count);
  rt::Context ctx;
  ASSERT_FALSE(rt::Context::create(dict, level, rt::default_options(), ctx));
  ASSERT_FALSE(ctx.set_ld(t.ld.data(), t.ld.size()));
  ASSERT_FALSE(ctx.update());
  std::vector<float> lightmap(ctx.sizes().lightmap);
  ASSERT_FALSE(ctx.read_lightmap(lightmap.data(), lightmap.size()));
  {  // default_options: the converged multi-bounce (CApi.ConvergedBouncesAreCoresConvergedSolve)
    const LevelBufferSizes sz = level_buffer_sizes(t.level, small_test_dictionary());
    std::vector<float> b(sz.b), r(sz.r), ref(sz.lightmap);
    ASSERT_TRUE(level_converged_bounce(t.level, small_test_dictionary(), t.ld, level_sample_albedo(t.level),
                                       {}, b, r, ref)
                    .ok());
    EXPECT_LT(rel_l2(lightmap, ref), 2e-3);
  }
  EXPECT_EQ(ctx.solve_stats().solves, 1u);
  EXPECT_EQ(ctx.atlas_texture(), 0u);
  // The camera skip and the solve statistics through the wrapper: a wrong count is named; every
  // block visible is the full path (the lightmap above).
  const std::vector<std::uint8_t> flags(t.level.blocks.size() + 1, 1);
  e = ctx.set_visible_blocks(flags.data(), flags.size());
  EXPECT_EQ(e.code, MODRT_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(e.message.find("count is " + std::to_string(flags.size())), std::string::npos) << e.message;
  ASSERT_FALSE(ctx.set_visible_blocks(flags.data(), flags.size() - 1));
  ASSERT_FALSE(ctx.update());
  std::vector<float> again(lightmap.size());
  ASSERT_FALSE(ctx.read_lightmap(again.data(), again.size()));
  EXPECT_EQ(again, lightmap);
  EXPECT_EQ(ctx.solve_stats().solves, 1u) << "the same input: skipped, no second solve";
  modrt_light light;
  modrt_light_init(&light);
  e = ctx.set_light_gpu(light);  // the GPU light pass needs a GLES context
  EXPECT_EQ(e.code, MODRT_ERROR_UNSUPPORTED);
  EXPECT_NE(e.message.find("set_lights"), std::string::npos) << e.message;
}

// GLES through the C API on a context the test program creates itself (EGL surfaceless, as an
// app owns its EGL context); modrt loads the entry points with eglGetProcAddress.
TEST(CApiGles, ContextOnTheCallersEglContext) {
  MODRT_GL_CONTEXT_OR_SKIP(gl, platform::ContextRequest::egl_surfaceless);
  const test::TestLevel& t = test_level("maze11");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = MODRT_BACKEND_GLES;
  o.bounces = 0;  // one bounce, as the reference
  o.timing = 1;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  EXPECT_EQ(std::string(modrt_context_description(c)).rfind("gles", 0), 0u) << modrt_context_description(c);
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  uint32_t tex = 0;
  int format = -1;
  ASSERT_EQ(modrt_context_get_atlas_texture(c, &tex, &format), MODRT_OK) << modrt_last_error();
  EXPECT_NE(tex, 0u);
  EXPECT_GE(format, 0);
  const test::LevelReference ref = level_reference(t.level, t.ld);
  if (format != 1) {  // float16 targets are held to 1e-3 elsewhere; llvmpipe gives float32
    EXPECT_LT(rel_l2(read_lightmap(c), ref.lightmap), 1e-4);
    EXPECT_LT(rel_l2(read_atlas(c), ref.atlas), 1e-4);
    check_probes_at_centres(c, t.level, ref.probes);
  }
  const float* data = nullptr;
  size_t count = 0;
  expect_error(modrt_context_get_atlas_data(c, &data, &count), MODRT_ERROR_UNSUPPORTED, {"GPU"});

  // Identical ld: the frame is skipped; no allocation per frame.
  modrt_sizes s = modrt::rt::sized<modrt_sizes>();
  ASSERT_EQ(modrt_context_get_sizes(c, &s), MODRT_OK);
  std::vector<float> ld = t.ld, atlas(s.atlas);
  bool ok = true;
  g_allocations = 0;
  g_count_allocations = true;
  ok &= modrt_context_set_ld(c, ld.data(), ld.size()) == MODRT_OK;
  ok &= modrt_context_update(c) == MODRT_OK;
  for (float& v : ld) v *= 0.5f;
  ok &= modrt_context_set_ld(c, ld.data(), ld.size()) == MODRT_OK;
  ok &= modrt_context_update(c) == MODRT_OK;
  ok &= modrt_context_read_atlas(c, atlas.data(), atlas.size()) == MODRT_OK;
  g_count_allocations = false;
  EXPECT_TRUE(ok) << modrt_last_error();
  EXPECT_EQ(g_allocations.load(), 0);
  modrt_skip_stats k = modrt::rt::sized<modrt_skip_stats>();
  ASSERT_EQ(modrt_context_get_skip_stats(c, &k), MODRT_OK);
  EXPECT_EQ(k.frames, 3u);
  EXPECT_EQ(k.frames_skipped, 1u);
  EXPECT_LT(rel_l2(atlas, level_reference(t.level, ld).atlas), 1e-4);
  modrt_timings tm = modrt::rt::sized<modrt_timings>();
  ASSERT_EQ(modrt_context_get_timings(c, &tm), MODRT_OK);
  EXPECT_GT(tm.update_ns, 0u);
  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

// The app passes its own loader (options.gl_loader), here OSMesa's get-proc-address on an OSMesa
// desktop GL core context (the "#version 300 es" shaders run through ARB_ES3_compatibility).
void* osmesa_loader(const char* name, void* user) {
  using GetProc = void* (*)(const char*);
  return reinterpret_cast<GetProc>(user)(name);
}

TEST(CApiGles, ContextThroughTheAppsLoaderOnOsmesa) {
  // Its own OSMesa context, not gl_context_for's: the test dlopens and dlcloses the libOSMesa it loaded.
  Result<std::unique_ptr<platform::GlContext>> gl =
      platform::create_context(platform::ContextRequest::osmesa);
  if (!gl.ok()) GTEST_SKIP() << "no OSMesa context here: " << gl.status().to_string();
  // The library platform loaded; RTLD_NOLOAD finds it without loading another copy.
  void* lib = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_NOLOAD);
  if (!lib) GTEST_SKIP() << "libOSMesa.so.8 is not the loaded OSMesa";
  void* get_proc = dlsym(lib, "OSMesaGetProcAddress");
  ASSERT_NE(get_proc, nullptr);
  const test::TestLevel& t = test_level("corridor");
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle("corridor");
  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = MODRT_BACKEND_GLES;
  o.gl_loader = osmesa_loader;
  o.bounces = 0;  // one bounce: compared with one-bounce references, linear in ld
  o.gl_loader_user = get_proc;
  modrt_context* c = nullptr;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_EQ(modrt_context_set_ld(c, t.ld.data(), t.ld.size()), MODRT_OK);
  ASSERT_EQ(modrt_context_update(c), MODRT_OK) << modrt_last_error();
  const test::LevelReference ref = level_reference(t.level, t.ld);
  EXPECT_LT(rel_l2(read_atlas(c), ref.atlas), 1e-4);
  // A loader that finds nothing: a GL error naming the missing entry point.
  modrt_context* bad = nullptr;
  o.gl_loader = [](const char*, void*) -> void* { return nullptr; };
  expect_error(modrt_context_create(d, l, &o, nullptr, &bad), MODRT_ERROR_GL, {"modrt_context_create", "gl"});
  EXPECT_EQ(bad, nullptr);
  modrt_context_destroy(c);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
  dlclose(lib);
}

TEST(CApiGles, NoCurrentContextIsANamedError) {
  // Without any current GL context (a fresh thread), creation fails with a GL error.
  modrt_dictionary* d = load_dictionary_handle();
  modrt_level* l = load_level_handle();
  modrt_status st = MODRT_OK;
  std::string message;
  std::thread([&] {
    modrt_context_options o;
    modrt_context_options_init(&o);
    o.backend = MODRT_BACKEND_GLES;
    modrt_context* c = nullptr;
    st = modrt_context_create(d, l, &o, nullptr, &c);
    message = modrt_last_error();
    if (c) modrt_context_destroy(c);
  }).join();
  EXPECT_EQ(st, MODRT_ERROR_GL) << modrt_status_name(st) << ": " << message;
  EXPECT_NE(message.find("modrt_context_create"), std::string::npos) << message;
  // The message is per thread: this thread's last error is not that one.
  EXPECT_EQ(std::string(modrt_last_error()).find("GL_VERSION"), std::string::npos);
  modrt_dictionary_destroy(d);
  modrt_level_destroy(l);
}

}  // namespace
}  // namespace modrt
