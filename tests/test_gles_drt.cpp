// SPDX-License-Identifier: MIT
// DRT in the backends (docs/drt.md, "Runtime in the backends"): the GLES passes (gles_drt.h)
// and the CPU backend's DRT stages against core's scalar reference (level_evaluate, then
// drt_compute_c / drt_apply / drt_clutter_lightmap; drt_multi_bounce for the feedback), in
// every GL context test_gles_backend covers (EGL surfaceless, OSMesa, EGL device); a context
// kind that cannot be created is skipped with the reason printed.
// Tolerances, relative L2 over all values: float32 and bits32 targets 2e-6 on the lightmap,
// atlas and clutter lightmap, 1e-5 on the DRT delta alone (lightmap with clutter minus without:
// a difference of two float32 results); float16 targets 2e-3 (half precision, 2^-11), and 1e-2
// on their delta (the difference of two half-rounded lightmaps, ~10x smaller than either);
// float16 operators 2e-3. No clutter leaves every result bit-identical and allocates nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "gl_test_context.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/drt.h"
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/level_runtime.h"
#include "modrt/platform/gl_context.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "test_support.h"

namespace modrt::gles {
namespace {

using platform::ContextRequest;

constexpr double kFloat32Tolerance = 2e-6;
constexpr double kDeltaTolerance = 1e-5;
constexpr double kFloat16Tolerance = 2e-3;
constexpr double kFloat16DeltaTolerance = 1e-2;

const Dictionary& dict() { return test::small_test_dictionary(); }

// Three blocks in a row (as test_cpu_drt): a box on the first block's floor and a rotated
// pillar in the middle one, whose shadows reach the neighbours through the openings.
struct DrtFixture {
  Level level;
  DrtOperators drt;
  std::vector<float> ld, clutter_ld, clutter_direct, albedo;
};

std::vector<float> random_vector(std::mt19937& rng, std::size_t n, float lo, float hi) {
  std::uniform_real_distribution<float> u(lo, hi);
  std::vector<float> v(n);
  for (float& x : v) x = u(rng);
  return v;
}

const DrtFixture& fixture() {
  static const DrtFixture f = [] {
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
    s.level = precompute::build_level(description, dict()).value();
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
    settings.vector = true;  // dUb_vec / dUc_vec and U_dyn, so that vector.frag and probes.frag get deltas
    settings.probes = true;
    Result<DrtOperators> drt =
        precompute::DrtBuilder(s.level, dict(), settings).build(std::vector<ClutterObject>{box, pillar});
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
  }();
  return f;
}

// Core's scalar reference of one frame with clutter.
struct Reference {
  std::vector<float> b, r, mrt, lightmap, atlas, clutter, clutter_without_cc;
  std::vector<float> probes, probes_mrt, vector, vector_mrt;
};
Reference reference(const DrtFixture& f, std::span<const float> ld, std::span<const float> clutter_ld) {
  const LevelBufferSizes s = level_buffer_sizes(f.level, dict());
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  Reference ref;
  ref.b.resize(s.b), ref.r.resize(s.r), ref.mrt.resize(s.lightmap), ref.atlas.resize(s.atlas);
  ref.clutter.resize(d.clutter_lightmap);
  EXPECT_TRUE(level_evaluate(f.level, dict(), ld, ref.b, ref.r, ref.mrt).ok());
  std::vector<float> c(d.c);
  EXPECT_TRUE(drt_compute_c(f.drt, clutter_ld, c).ok());
  ref.lightmap = ref.mrt;
  drt_apply(f.level, f.drt, ref.b, c, ref.lightmap);
  clamp_lightmap(ref.lightmap);  // the corrected lightmap's clamp (reference_runtime.h), as drt_multi_bounce
  level_fill_atlas(f.level, ref.lightmap, ref.atlas);
  drt_clutter_lightmap(f.drt, ref.b, f.clutter_direct, ref.clutter);
  ref.clutter_without_cc = ref.clutter;
  drt_clutter_add_cc(f.drt, c, ref.clutter);
  clamp_lightmap(ref.clutter);  // the clutter lightmap's clamp (drt_evaluate_clutter_lightmap)
  ref.probes_mrt.resize(s.probes);
  level_compute_probes(f.level, dict(), ref.b, ref.r, ref.probes_mrt);
  ref.probes = ref.probes_mrt;
  drt_apply_probes(f.drt, ref.b, c, ref.probes);
  ref.vector_mrt.resize(s.vector_lightmap);
  EXPECT_TRUE(level_compute_vector_irradiance(f.level, dict(), ref.b, ref.r, ref.vector_mrt).ok());
  ref.vector = ref.vector_mrt;
  drt_apply_vector(f.level, f.drt, ref.b, c, ref.vector);
  return ref;
}

double rel_l2(std::span<const float> got, std::span<const float> ref) {
  EXPECT_EQ(got.size(), ref.size());
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < ref.size() && i < got.size(); ++i) {
    const double d = double(got[i]) - double(ref[i]);
    num += d * d;
    den += double(ref[i]) * ref[i];
  }
  if (!std::isfinite(num)) return std::numeric_limits<double>::infinity();
  return den > 0.0 ? std::sqrt(num / den) : std::sqrt(num);
}

std::vector<float> minus(std::span<const float> a, std::span<const float> b) {
  std::vector<float> d(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) d[i] = a[i] - b[i];
  return d;
}

class GlesDrtTest : public test::GlContextTest {
 protected:
  std::unique_ptr<GlesLevelRuntime> make(const GlesRuntimeOptions& options = {}) {
    Result<std::unique_ptr<GlesLevelRuntime>> rt =
        GlesLevelRuntime::create(gl(), gles(), fixture().level, dict(), options);
    EXPECT_TRUE(rt.ok()) << rt.status().to_string();
    return rt.ok() ? std::move(rt).value() : nullptr;
  }
};

struct FormatCase {
  TargetFormat target;
  OperatorFormat operators;
  double tolerance, delta_tolerance;
};
const FormatCase kFormats[] = {
    {TargetFormat::float32, OperatorFormat::float32, kFloat32Tolerance, kDeltaTolerance},
    {TargetFormat::bits32, OperatorFormat::float32, kFloat32Tolerance, kDeltaTolerance},
    {TargetFormat::float16, OperatorFormat::float32, kFloat16Tolerance, kFloat16DeltaTolerance},
    {TargetFormat::float32, OperatorFormat::float16, kFloat16Tolerance, kFloat16Tolerance},
};

TEST_P(GlesDrtTest, MatchesScalarReference) {
  const DrtFixture& f = fixture();
  // The box sees the pillar and the pillar the box: Cc c is part of the clutter lightmap.
  ASSERT_FALSE(f.drt.objects[0].Cc.empty());
  ASSERT_FALSE(f.drt.objects[1].Cc.empty());
  const Reference ref = reference(f, f.ld, f.clutter_ld);
  const std::vector<float> delta_ref = minus(ref.lightmap, ref.mrt);
  const double cc_part = rel_l2(ref.clutter_without_cc, ref.clutter);
  std::printf("  Cc c is %.2e of the clutter lightmap (rel L2)\n", cc_part);
  EXPECT_GT(cc_part, 1000 * kFloat32Tolerance);  // a missing Cc c fails the float32 cases
  const double probe_part = rel_l2(ref.probes_mrt, ref.probes),
               vector_part = rel_l2(ref.vector_mrt, ref.vector);
  std::printf("  U_dyn is %.2e of the probes, dUb_vec b + dUc_vec c %.2e of the vector irradiance\n",
              probe_part, vector_part);
  EXPECT_GT(probe_part, 1000 * kFloat32Tolerance);
  EXPECT_GT(vector_part, 1000 * kFloat32Tolerance);
  for (const FormatCase& fc : kFormats) {
    std::unique_ptr<GlesLevelRuntime> rt =
        make({.target = fc.target, .operators = fc.operators, .vector_irradiance = true});
    ASSERT_TRUE(rt);
    const LevelBufferSizes& s = rt->sizes();
    std::vector<float> mrt(s.lightmap), lightmap(s.lightmap), atlas(s.atlas), probes(s.probes),
        vector(s.vector_lightmap);
    ASSERT_TRUE(rt->update(f.ld).ok());
    ASSERT_TRUE(rt->read_lightmap(mrt).ok());
    const Status st = rt->set_clutter(&f.drt);
    ASSERT_TRUE(st.ok()) << st.to_string();
    ASSERT_TRUE(rt->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
    std::vector<float> clutter(rt->clutter_sizes().clutter_lightmap);
    for (int frame = 0; frame < 2; ++frame) {  // the second frame is skipped: same results
      ASSERT_TRUE(rt->update(f.ld).ok());
      ASSERT_TRUE(rt->read_lightmap(lightmap).ok());
      ASSERT_TRUE(rt->read_atlas(atlas).ok());
      ASSERT_TRUE(rt->read_clutter_lightmap(clutter).ok());
      ASSERT_TRUE(rt->read_probes(probes).ok());
      ASSERT_TRUE(rt->read_vector_lightmap(vector).ok());
      const double ep = rel_l2(probes, ref.probes), ev = rel_l2(vector, ref.vector);
      EXPECT_LE(ep, fc.tolerance) << rt->description() << " probes";
      EXPECT_LE(ev, fc.tolerance) << rt->description() << " vector irradiance";
      const double el = rel_l2(lightmap, ref.lightmap), ea = rel_l2(atlas, ref.atlas),
                   ed = rel_l2(minus(lightmap, mrt), delta_ref), ec = rel_l2(clutter, ref.clutter);
      EXPECT_LE(el, fc.tolerance) << rt->description();
      EXPECT_LE(ea, fc.tolerance) << rt->description();
      EXPECT_LE(ed, fc.delta_tolerance) << rt->description();
      EXPECT_LE(ec, fc.tolerance) << rt->description();
      if (frame == 0)
        std::printf(
            "  %-52s rel L2: lightmap %.2e atlas %.2e delta %.2e clutter lightmap %.2e probes %.2e "
            "vector %.2e\n",
            rt->description(), el, ea, ed, ec, ep, ev);
    }
    EXPECT_NE(rt->clutter_texture(), 0u);
  }
}

// A new clutter light alone (same ld) must not be a skipped frame, and the atlas is redrawn
// whole with clutter even when a single block's ld changes (its delta reads other blocks' b).
TEST_P(GlesDrtTest, ClutterLightAndPartialUpdatesAreNotSkipped) {
  const DrtFixture& f = fixture();
  std::unique_ptr<GlesLevelRuntime> rt = make({.target = TargetFormat::float32, .partial_fraction = 1.0f});
  ASSERT_TRUE(rt);
  ASSERT_TRUE(rt->set_clutter(&f.drt).ok());
  ASSERT_TRUE(rt->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ASSERT_TRUE(rt->update(f.ld).ok());
  std::vector<float> clutter_ld2 = f.clutter_ld;
  for (float& v : clutter_ld2) v *= 0.25f;
  ASSERT_TRUE(rt->set_clutter_light(clutter_ld2, f.clutter_direct).ok());
  ASSERT_TRUE(rt->update(f.ld).ok());
  std::vector<float> atlas(rt->sizes().atlas);
  ASSERT_TRUE(rt->read_atlas(atlas).ok());
  EXPECT_LE(rel_l2(atlas, reference(f, f.ld, clutter_ld2).atlas), kFloat32Tolerance);
  // Only the middle block's light changes: b of one block, but deltas in all three.
  std::vector<float> ld2 = f.ld;
  const LevelBlock& mid = f.level.blocks[1];
  for (std::size_t i = 3 * mid.sample_offset; i < 3 * (mid.sample_offset + mid.sample_count); ++i)
    ld2[i] *= 3.0f;
  ASSERT_TRUE(rt->update(ld2).ok());
  ASSERT_TRUE(rt->read_atlas(atlas).ok());
  EXPECT_LE(rel_l2(atlas, reference(f, ld2, clutter_ld2).atlas), kFloat32Tolerance);
  EXPECT_GE(rt->skip_stats().frames_partial, 1u);
}

// No clutter: no DRT pass, no texture, results bit-identical to a runtime that never had any
// (also after clutter was set and removed).
TEST_P(GlesDrtTest, NoClutterIsBitIdenticalAndCostsNothing) {
  const DrtFixture& f = fixture();
  std::unique_ptr<GlesLevelRuntime> plain = make(), removed = make(), empty = make();
  ASSERT_TRUE(plain && removed && empty);
  plain->set_timing(true);
  ASSERT_TRUE(plain->update(f.ld).ok());
  EXPECT_EQ(plain->pass_times().drt, 0u);
  EXPECT_EQ(plain->pass_times().clutter, 0u);
  ASSERT_TRUE(removed->set_clutter(&f.drt).ok());
  ASSERT_TRUE(removed->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ASSERT_TRUE(removed->update(f.ld).ok());
  ASSERT_TRUE(removed->set_clutter(nullptr).ok());
  EXPECT_EQ(removed->clutter_texture(), 0u);
  ASSERT_TRUE(removed->update(f.ld).ok());
  const DrtOperators none;
  ASSERT_TRUE(empty->set_clutter(&none).ok());
  EXPECT_EQ(empty->clutter_texture(), 0u);
  EXPECT_EQ(empty->clutter_sizes().clutter_lightmap, 0u);
  ASSERT_TRUE(empty->update(f.ld).ok());
  std::vector<float> clutter(1);
  EXPECT_EQ(empty->read_clutter_lightmap(clutter).code(), ErrorCode::invalid_argument);
  EXPECT_EQ(empty->set_clutter_light({}, {}).code(), ErrorCode::invalid_argument);
  std::vector<float> a(plain->sizes().atlas), b(a.size()), c(a.size());
  ASSERT_TRUE(plain->read_atlas(a).ok());
  ASSERT_TRUE(removed->read_atlas(b).ok());
  ASSERT_TRUE(empty->read_atlas(c).ok());
  EXPECT_EQ(a, b);
  EXPECT_EQ(a, c);
}

TEST_P(GlesDrtTest, BadClutterInputIsRefused) {
  const DrtFixture& f = fixture();
  std::unique_ptr<GlesLevelRuntime> rt = make();
  ASSERT_TRUE(rt);
  DrtOperators wrong = f.drt;
  wrong.objects[0].dUb_sample[0] = f.level.sample_count;  // out of range
  const Status s = rt->set_clutter(&wrong);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("object 0"), std::string::npos) << s.message();
  ASSERT_TRUE(rt->set_clutter(&f.drt).ok());
  std::vector<float> bad = f.clutter_ld;
  bad[5] = std::nanf("");
  EXPECT_FALSE(rt->set_clutter_light(bad, {}).ok());
  bad.pop_back();
  EXPECT_EQ(rt->set_clutter_light(bad, {}).code(), ErrorCode::invalid_argument);
  EXPECT_EQ(rt->set_clutter_light(f.clutter_ld, std::vector<float>(3)).code(), ErrorCode::invalid_argument);
}

// Backend::multi_bounce_step with clutter equals drt_multi_bounce after k iterations, on the
// GLES and the CPU backend, and the two backends agree through the Backend interface.
TEST_P(GlesDrtTest, MultiBounceAndCpuAgreeThroughBackend) {
  constexpr int kSteps = 4;
  const DrtFixture& f = fixture();
  const LevelBufferSizes s = level_buffer_sizes(f.level, dict());
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  std::vector<float> b(s.b), r(s.r), ref(s.lightmap), c(d.c), clutter_ref(d.clutter_lightmap);
  MultiBounceSettings settings;
  settings.max_iterations = kSteps;
  settings.tolerance = 0.0f;
  const Result<MultiBounceReport> rep =
      drt_multi_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld, {}, settings, b, r, ref, c);
  ASSERT_TRUE(rep.ok()) << rep.status().to_string();
  ASSERT_EQ(rep->iterations, kSteps);
  drt_evaluate_clutter_lightmap(f.drt, b, c, f.clutter_direct, clutter_ref);
  // The delta matters: without it the feedback gives a different lightmap.
  std::vector<float> b0(s.b), r0(s.r), mrt(s.lightmap);
  ASSERT_TRUE(level_multi_bounce(f.level, dict(), f.ld, f.albedo, settings, b0, r0, mrt).ok());

  std::unique_ptr<GlesLevelRuntime> g = make({.target = TargetFormat::float32, .vector_irradiance = true});
  ASSERT_TRUE(g);
  Result<std::unique_ptr<Backend>> cpu = cpu::create_cpu_backend(f.level, dict());
  ASSERT_TRUE(cpu.ok()) << cpu.status().to_string();
  cpu::CpuRuntimeOptions skipping;
  skipping.skip.enabled = true;  // kept tiles must not keep last frame's delta
  Result<std::unique_ptr<Backend>> cpu_skip = cpu::create_cpu_backend(f.level, dict(), skipping);
  ASSERT_TRUE(cpu_skip.ok()) << cpu_skip.status().to_string();
  std::vector<std::vector<float>> lightmaps, atlases, clutters, probes, vectors;
  for (Backend* be : {static_cast<Backend*>(g.get()), cpu->get(), cpu_skip->get()}) {
    {
      const Status st = be->set_clutter(&f.drt);
      ASSERT_TRUE(st.ok()) << st.to_string();
    }
    {
      const Status st = be->set_clutter_light(f.clutter_ld, f.clutter_direct);
      ASSERT_TRUE(st.ok()) << st.to_string();
    }
    ASSERT_TRUE(be->set_albedo(f.albedo, settings.max_albedo).ok());
    ASSERT_TRUE(be->update(f.ld).ok());
    ASSERT_TRUE(be->update(f.ld).ok());  // a repeated frame changes nothing
    for (int k = 0; k < kSteps; ++k) ASSERT_TRUE(be->multi_bounce_step(f.ld).ok()) << be->description();
    lightmaps.emplace_back(s.lightmap);
    atlases.emplace_back(s.atlas);
    clutters.emplace_back(d.clutter_lightmap);
    ASSERT_TRUE(be->read_lightmap(lightmaps.back()).ok());
    ASSERT_TRUE(be->read_atlas(atlases.back()).ok());
    ASSERT_TRUE(be->read_clutter_lightmap(clutters.back()).ok());
    probes.emplace_back(s.probes);
    vectors.emplace_back(s.vector_lightmap);
    ASSERT_TRUE(be->read_probes(probes.back()).ok());
    ASSERT_TRUE(be->read_vector_lightmap(vectors.back()).ok()) << be->description();
    const double e = rel_l2(lightmaps.back(), ref), ec = rel_l2(clutters.back(), clutter_ref);
    EXPECT_LE(e, kFloat32Tolerance) << be->description();
    EXPECT_LE(ec, kFloat32Tolerance) << be->description();
    std::printf(
        "  %-40s multi-bounce x%d with DRT rel L2 %.2e, clutter lightmap %.2e (MRT-only feedback: %.2e)\n",
        be->description(), kSteps, e, ec, rel_l2(mrt, ref));
  }
  EXPECT_GT(rel_l2(mrt, ref), 100 * kFloat32Tolerance);
  EXPECT_LE(rel_l2(atlases[0], atlases[1]), kFloat32Tolerance);
  EXPECT_LE(rel_l2(clutters[0], clutters[1]), kFloat32Tolerance);
  // Probes and vector irradiance with their DRT deltas, against core after the same feedback.
  std::vector<float> probe_ref(s.probes), vector_ref(s.vector_lightmap);
  level_compute_probes(f.level, dict(), b, r, probe_ref);
  drt_apply_probes(f.drt, b, c, probe_ref);
  ASSERT_TRUE(level_compute_vector_irradiance(f.level, dict(), b, r, vector_ref).ok());
  drt_apply_vector(f.level, f.drt, b, c, vector_ref);
  for (std::size_t k = 0; k < probes.size(); ++k) {
    EXPECT_LE(rel_l2(probes[k], probe_ref), kFloat32Tolerance) << k;
    EXPECT_LE(rel_l2(vectors[k], vector_ref), kFloat32Tolerance) << k;
  }
  EXPECT_EQ(lightmaps[1], lightmaps[2]);  // skipping (exact with these options) changes nothing
  std::printf("  gles vs cpu: atlas %.2e, clutter lightmap %.2e, probes %.2e, vector irradiance %.2e\n",
              rel_l2(atlases[0], atlases[1]), rel_l2(clutters[0], clutters[1]), rel_l2(probes[0], probes[1]),
              rel_l2(vectors[0], vectors[1]));
}

// With the clutter's albedo, multi_bounce_step also feeds the clutter's indirect light back
// through c (core's drt_multi_bounce with clutter_albedo), on GLES and on the CPU; update()
// then starts again from the clutter's direct light.
TEST_P(GlesDrtTest, MultiBounceFeedsTheClutterLightBackAsCore) {
  constexpr int kSteps = 3;
  const DrtFixture& f = fixture();
  const LevelBufferSizes s = level_buffer_sizes(f.level, dict());
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  std::mt19937 rng(31);
  const std::vector<float> clutter_albedo = random_vector(rng, d.clutter_ld, 0.2f, 0.99f);  // some clamped
  MultiBounceSettings settings;
  settings.max_iterations = kSteps;
  settings.tolerance = 0.0f;
  std::vector<float> b(s.b), r(s.r), ref(s.lightmap), c(d.c), clutter_ref(d.clutter_lightmap);
  ASSERT_TRUE(drt_multi_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld, clutter_albedo, settings,
                               b, r, ref, c)
                  .ok());
  drt_evaluate_clutter_lightmap(f.drt, b, c, f.clutter_direct, clutter_ref);
  std::vector<float> plain(s.lightmap), c_plain(d.c);
  ASSERT_TRUE(drt_multi_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld, {}, settings, b, r,
                               plain, c_plain)
                  .ok());
  EXPECT_GT(rel_l2(plain, ref), 100 * kFloat32Tolerance);  // the clutter's bounce shows
  const Reference one = reference(f, f.ld, f.clutter_ld);

  std::unique_ptr<GlesLevelRuntime> g = make({.target = TargetFormat::float32});
  ASSERT_TRUE(g);
  Result<std::unique_ptr<Backend>> cpu = cpu::create_cpu_backend(f.level, dict());
  ASSERT_TRUE(cpu.ok()) << cpu.status().to_string();
  for (Backend* be : {static_cast<Backend*>(g.get()), cpu->get()}) {
    EXPECT_EQ(be->set_clutter_albedo(clutter_albedo).code(), ErrorCode::invalid_argument);  // no clutter yet
    ASSERT_TRUE(be->set_clutter(&f.drt).ok()) << be->description();
    ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
    ASSERT_TRUE(be->set_albedo(f.albedo, settings.max_albedo).ok());
    std::vector<float> bad = clutter_albedo;
    bad[7] = std::nanf("");
    EXPECT_EQ(be->set_clutter_albedo(bad).code(), ErrorCode::non_finite) << be->description();
    bad.pop_back();
    EXPECT_EQ(be->set_clutter_albedo(bad).code(), ErrorCode::invalid_argument) << be->description();
    ASSERT_TRUE(be->set_clutter_albedo(clutter_albedo, settings.max_albedo).ok()) << be->description();
    ASSERT_TRUE(be->update(f.ld).ok());
    for (int k = 0; k < kSteps; ++k) ASSERT_TRUE(be->multi_bounce_step(f.ld).ok()) << be->description();
    std::vector<float> lightmap(s.lightmap), clutter(d.clutter_lightmap);
    ASSERT_TRUE(be->read_lightmap(lightmap).ok());
    ASSERT_TRUE(be->read_clutter_lightmap(clutter).ok());
    const double e = rel_l2(lightmap, ref), ec = rel_l2(clutter, clutter_ref);
    EXPECT_LE(e, kFloat32Tolerance) << be->description();
    EXPECT_LE(ec, kFloat32Tolerance) << be->description();
    // A new frame: one bounce from the clutter's direct light again.
    ASSERT_TRUE(be->update(f.ld).ok());
    ASSERT_TRUE(be->read_lightmap(lightmap).ok());
    ASSERT_TRUE(be->read_clutter_lightmap(clutter).ok());
    EXPECT_LE(rel_l2(lightmap, one.lightmap), kFloat32Tolerance) << be->description();
    EXPECT_LE(rel_l2(clutter, one.clutter), kFloat32Tolerance) << be->description();
    std::printf("  %-40s multi-bounce x%d with clutter feedback rel L2 %.2e, clutter lightmap %.2e\n",
                be->description(), kSteps, e, ec);
  }
}

// The clutter's vector irradiance (Uc_vec (Vc_vec b) + Cc_vec c, DRT §5), rendered on
// request, against core for every target / operator format, and equal to the CPU backend's.
TEST_P(GlesDrtTest, ClutterVectorLightmapMatchesCore) {
  const DrtFixture& f = fixture();
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  ASSERT_FALSE(f.drt.objects[0].Uc_vec.empty());
  const Reference one = reference(f, f.ld, f.clutter_ld);
  std::vector<float> c(d.c), ref(d.clutter_vector_lightmap);
  ASSERT_TRUE(drt_compute_c(f.drt, f.clutter_ld, c).ok());
  drt_clutter_vector_lightmap(f.drt, one.b, c, ref);
  for (const FormatCase& fc : kFormats) {
    std::unique_ptr<GlesLevelRuntime> rt = make({.target = fc.target, .operators = fc.operators});
    ASSERT_TRUE(rt);
    std::vector<float> out(d.clutter_vector_lightmap);
    EXPECT_EQ(rt->read_clutter_vector_lightmap(out).code(), ErrorCode::invalid_argument);  // no clutter yet
    ASSERT_TRUE(rt->set_clutter(&f.drt).ok());
    ASSERT_TRUE(rt->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
    ASSERT_TRUE(rt->update(f.ld).ok());
    ASSERT_TRUE(rt->read_clutter_vector_lightmap(out).ok()) << rt->description();
    const double e = rel_l2(out, ref);
    EXPECT_LE(e, fc.tolerance) << rt->description();
    std::printf("  %-60s clutter vector lightmap rel L2 %.2e\n", rt->description(), e);
    std::vector<float> wrong(d.clutter_vector_lightmap + 1);
    EXPECT_EQ(rt->read_clutter_vector_lightmap(wrong).code(), ErrorCode::invalid_argument);
  }
}

// The clutter lightmap is a lightmap: never negative, as CpuDrt.ClutterLightmapIsNeverNegative
// (Uc negated, so most texels of Cb b + Cc c + direct are negative before the clamp).
TEST_P(GlesDrtTest, ClutterLightmapIsNeverNegative) {
  const DrtFixture& f = fixture();
  DrtOperators negated = f.drt;
  for (DrtObjectOperators& o : negated.objects)
    for (float& v : o.Uc.data) v = -v;
  const DrtBufferSizes d = drt_buffer_sizes(negated);
  const LevelBufferSizes ls = level_buffer_sizes(fixture().level, dict());
  std::vector<float> b(ls.b), r(ls.r), lm(ls.lightmap), c(d.c), raw(d.clutter_lightmap),
      ref(d.clutter_lightmap);
  ASSERT_TRUE(level_evaluate(f.level, dict(), f.ld, b, r, lm).ok());
  ASSERT_TRUE(drt_compute_c(negated, f.clutter_ld, c).ok());
  drt_clutter_lightmap(negated, b, f.clutter_direct, raw);
  drt_clutter_add_cc(negated, c, raw);
  std::size_t negative = 0;
  for (float v : raw) negative += v < 0.0f;
  ASSERT_GT(negative, raw.size() / 4) << "the negated operators should ring negative";
  drt_evaluate_clutter_lightmap(negated, b, c, f.clutter_direct, ref);
  for (const FormatCase& fc : kFormats) {
    std::unique_ptr<GlesLevelRuntime> rt = make({.target = fc.target, .operators = fc.operators});
    ASSERT_TRUE(rt);
    ASSERT_TRUE(rt->set_clutter(&negated).ok());
    ASSERT_TRUE(rt->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
    ASSERT_TRUE(rt->update(f.ld).ok());
    std::vector<float> out(d.clutter_lightmap);
    ASSERT_TRUE(rt->read_clutter_lightmap(out).ok());
    for (float v : out) ASSERT_GE(v, 0.0f) << rt->description();
    EXPECT_LE(rel_l2(out, ref), fc.tolerance) << rt->description();
  }
}

INSTANTIATE_TEST_SUITE_P(Contexts, GlesDrtTest,
                         ::testing::Values(ContextRequest::egl_surfaceless, ContextRequest::osmesa,
                                           ContextRequest::egl_device),
                         test::gl_context_test_name);

}  // namespace
}  // namespace modrt::gles
