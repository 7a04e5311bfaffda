// SPDX-License-Identifier: MIT
// modrt tests — the clutter scene the backend tests run DRT on, and core's scalar reference of
// one frame of it: three blocks in a row, a box on the first block's floor and a rotated pillar
// in the middle one, whose shadows reach the neighbours through the openings and which see each
// other (Cc c). Built once per test program with vector and probe operators (64 rays).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <span>
#include <vector>

#include "compare_support.h"
#include "modrt/drt.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "modrt/reference_runtime.h"
#include "test_support.h"

namespace modrt::test {

struct DrtFixture {
  Level level;
  DrtOperators drt;
  std::vector<float> ld, clutter_ld, clutter_direct, albedo;
};

// gather: the same scene with the real-radiance gather (DrtBuildSettings::gather: Gs, Gt, Hs,
// Ht in place of Cb, Cc and the traced dUb / dUc rows).
inline DrtFixture make_drt_fixture(bool gather) {
  {
    const Dictionary& dict = small_test_dictionary();
    DrtFixture s;
    LevelDescription description;
    for (int x = 0; x < 3; ++x) {
      BlockDescription b;
      b.cell = glm::ivec3(x, 0, 0);
      b.faces = kAllFaces;
      if (x > 0) b.faces &= FaceMask(~(1u << kFaceNegX));
      if (x < 2) b.faces &= FaceMask(~(1u << kFacePosX));
      for (auto& a : b.albedo) a = glm::dvec3(0.6);
      description.blocks.push_back(b);
    }
    s.level = precompute::build_level(description, dict).value();
    ClutterObject box;
    box.block = 0;
    box.box.center = glm::dvec3(0.4, 0.15, 0.45);
    box.box.half_extent = glm::dvec3(0.12, 0.15, 0.1);
    box.albedo = glm::dvec3(0.8, 0.7, 0.3);
    box.res = 8;
    ClutterObject pillar;
    pillar.block = 1;
    pillar.box.center = glm::dvec3(1.5, 0.5, 0.5);
    pillar.box.half_extent = glm::dvec3(0.08, 0.5, 0.05);
    const double a = 0.4;
    pillar.box.rotation = glm::dmat3(std::cos(a), 0, -std::sin(a), 0, 1, 0, std::sin(a), 0, std::cos(a));
    pillar.res = 8;
    pillar.faces = FaceMask(kAllFaces & ~(1u << kFaceNegY) & ~(1u << kFacePosY));
    precompute::DrtBuildSettings settings;
    settings.rays = 64;
    settings.vector = true;  // dUb_vec / dUc_vec and U_dyn: the vector and probe stages get deltas
    settings.probes = true;
    settings.gather = gather;
    Result<DrtOperators> drt =
        precompute::DrtBuilder(s.level, dict, settings).build(std::vector<ClutterObject>{box, pillar});
    if (!drt.ok()) {
      std::fprintf(stderr, "drt build: %s\n", drt.status().to_string().c_str());
      std::abort();
    }
    s.drt = std::move(drt).value();
    std::mt19937 rng(8);
    const DrtBufferSizes sizes = drt_buffer_sizes(s.drt);
    s.ld = random_vector(rng, 3 * std::size_t(s.level.sample_count), 0.0f, 1.0f);
    s.clutter_ld = random_vector(rng, sizes.clutter_ld, 0.0f, 2.0f);
    s.clutter_direct = random_vector(rng, sizes.clutter_lightmap, 0.0f, 0.5f);
    s.albedo = random_vector(rng, s.ld.size(), 0.2f, 0.9f);
    return s;
  }
}

inline const DrtFixture& drt_fixture(bool gather = false) {
  static const DrtFixture f = make_drt_fixture(false);
  if (!gather) return f;
  static const DrtFixture g = make_drt_fixture(true);
  return g;
}

// Core's scalar reference of one frame with clutter (no feedback); *_mrt without the clutter.
struct DrtReference {
  std::vector<float> b, r, mrt, lightmap, atlas, clutter, clutter_without_cc;
  std::vector<float> probes, probes_mrt, vector, vector_mrt;
};
inline DrtReference drt_reference(const DrtFixture& f, std::span<const float> ld,
                                  std::span<const float> clutter_ld) {
  const Dictionary& dict = small_test_dictionary();
  const LevelBufferSizes s = level_buffer_sizes(f.level, dict);
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  DrtReference ref;
  ref.b.resize(s.b), ref.r.resize(s.r), ref.mrt.resize(s.lightmap), ref.atlas.resize(s.atlas);
  ref.clutter.resize(d.clutter_lightmap);
  EXPECT_TRUE(level_evaluate(f.level, dict, ld, ref.b, ref.r, ref.mrt).ok());
  std::vector<float> c(d.c);
  EXPECT_TRUE(drt_compute_c(f.drt, clutter_ld, c).ok());
  ref.lightmap = ref.mrt;
  drt_apply(f.level, f.drt, ref.b, c, ref.lightmap);
  drt_apply_gather(f.drt, ld, clutter_ld, ref.lightmap);
  clamp_lightmap(ref.lightmap);  // the corrected lightmap's clamp (reference_runtime.h), as drt_multi_bounce
  level_fill_atlas(f.level, ref.lightmap, ref.atlas);
  drt_clutter_lightmap(f.drt, ref.b, f.clutter_direct, ref.clutter);
  // The gather's Gs x_s, then (after clutter_without_cc) the light of the other clutter: Cc c,
  // or the gather's Gt x_t.
  DrtOperators gs_only = f.drt, gt_only = f.drt;
  for (DrtObjectOperators& o : gs_only.objects) o.Gt = DrtSparseRows{};
  for (DrtObjectOperators& o : gt_only.objects) o.Gs = DrtSparseRows{};
  drt_clutter_add_gather(gs_only, ld, clutter_ld, ref.clutter);
  ref.clutter_without_cc = ref.clutter;
  drt_clutter_add_cc(f.drt, c, ref.clutter);
  drt_clutter_add_gather(gt_only, ld, clutter_ld, ref.clutter);
  clamp_lightmap(ref.clutter);  // the clutter lightmap's clamp (drt_evaluate_clutter_lightmap)
  ref.probes_mrt.resize(s.probes);
  level_compute_probes(f.level, dict, ref.b, ref.r, ref.probes_mrt);
  ref.probes = ref.probes_mrt;
  drt_apply_probes(f.drt, ref.b, c, ref.probes);
  ref.vector_mrt.resize(s.vector_lightmap);
  EXPECT_TRUE(level_compute_vector_irradiance(f.level, dict, ref.b, ref.r, ref.vector_mrt).ok());
  ref.vector = ref.vector_mrt;
  drt_apply_vector(f.level, f.drt, ref.b, c, ref.vector);
  return ref;
}

}  // namespace modrt::test
