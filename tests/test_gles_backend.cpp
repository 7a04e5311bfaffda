// SPDX-License-Identifier: MIT
// What only the GLES backend (gles/) has, under every GL context kind (EGL surfaceless GLES 3.2,
// OSMesa GL 4.5 core running the ES 3.0 shaders, EGL device: a GPU where there is one, else
// Mesa's software device; a kind that cannot be created is skipped with the reason): b and r
// read back against core's scalar reference, partial passes (partial_fraction) bit-identical to
// the full path, with and without clutter, the GPU-side guard of the fed-back light, the
// vector-irradiance and probe options, shader errors and pass timers, the real-radiance gather
// in an operator set mixed with Limp objects and from a caller's ld texture. Every output every
// backend has is checked through Backend by test_backend_conformance.cpp. Tolerances (relative
// L2): 1e-4 for float32 and bits32 targets, 2e-3 for float16 targets or float16 operators.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "compare_support.h"
#include "drt_backend_fixture.h"
#include "gl_objects.h"
#include "gl_test_context.h"
#include "level_fixtures.h"
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/level_runtime.h"
#include "modrt/platform/gl_context.h"
#include "modrt/reference_backend.h"

namespace modrt::gles {
namespace {

using platform::ContextRequest;

constexpr double kFloat32Tolerance = 1e-4;
constexpr double kFloat16Tolerance = 2e-3;

const Dictionary& dict() { return test::small_test_dictionary(); }

using test::level_reference;
using test::test_level;
using test::test_levels;
using test::TestLevel;
using Reference = test::LevelReference;

using test::rel_l2;

class GlesBackend : public test::GlContextTest {
 protected:
  std::unique_ptr<GlesLevelRuntime> make(const Level& level, const GlesRuntimeOptions& options = {}) {
    Result<std::unique_ptr<GlesLevelRuntime>> rt =
        GlesLevelRuntime::create(gl(), gles(), level, dict(), options);
    EXPECT_TRUE(rt.ok()) << rt.status().to_string();
    return rt.ok() ? std::move(rt).value() : nullptr;
  }
  void check_skipping(float fraction);
};

struct FormatCase {
  TargetFormat target;
  OperatorFormat operators;
  double tolerance;
};
const FormatCase kFormats[] = {
    {TargetFormat::float32, OperatorFormat::float32, kFloat32Tolerance},
    {TargetFormat::bits32, OperatorFormat::float32, kFloat32Tolerance},
    {TargetFormat::float16, OperatorFormat::float32, kFloat16Tolerance},
    {TargetFormat::float32, OperatorFormat::float16, kFloat16Tolerance},
};

// b and r, which stay inside the backend (read_b / read_r, GLES only): every output built from
// them is checked through Backend by test_backend_conformance.cpp.
TEST_P(GlesBackend, BAndRMatchScalarReference) {
  for (const TestLevel& t : test_levels()) {
    const Reference ref = level_reference(t.level, t.ld);
    for (const FormatCase& f : kFormats) {
      std::unique_ptr<GlesLevelRuntime> rt = make(t.level, {.target = f.target, .operators = f.operators});
      ASSERT_TRUE(rt);
      std::vector<float> b(rt->sizes().b), r(rt->sizes().r);
      ASSERT_TRUE(rt->update(t.ld).ok());
      ASSERT_TRUE(rt->read_b(b).ok());
      ASSERT_TRUE(rt->read_r(r).ok());
      const double eb = rel_l2(b, ref.b), er = rel_l2(r, ref.r);
      // b's high modes cancel heavily (Td_b has large mixed-sign rows, see
      // test_cpu_backend.cpp), so b gets 10x the tolerance.
      EXPECT_LE(eb, 10 * f.tolerance) << t.name << " " << rt->description() << " b";
      if (!t.level.slots.empty()) {
        EXPECT_LE(er, f.tolerance) << t.name << " " << rt->description() << " r";
      }
      std::printf("  %-8s %-58s rel L2: b %.2e r %.2e\n", t.name.c_str(), rt->description(), eb, er);
    }
  }
}

// The fed-back ld is computed on the GPU, where nothing validates it: a step whose feedback
// could exceed kMaxLightValue (max_albedo just below 1, bright ld) is refused (issue 18 item
// 5: every update finite or an error), as the CPU runtime refuses such a fed-back ld.
TEST_P(GlesBackend, MultiBounceRefusesFeedbackAboveTheLargestLightValue) {
  const TestLevel& t = test_level("corridor");
  std::unique_ptr<GlesLevelRuntime> rt = make(t.level);
  ASSERT_TRUE(rt);
  const std::vector<float> albedo(t.albedo.size(), 1.0f);
  ASSERT_TRUE(rt->set_albedo(albedo, 0.9999999f).ok());
  std::vector<float> ld = t.ld;
  ld[4] = 1e25f;
  ASSERT_TRUE(rt->update(ld).ok());
  const Status s = rt->multi_bounce_step(ld);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("gles: multi_bounce_step: the fed-back light can reach "), std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find("kMaxLightValue"), std::string::npos) << s.message();
  std::printf("%s\n", s.message().c_str());
  EXPECT_TRUE(rt->multi_bounce_step(t.ld).ok());  // ordinary light is fine
}

TEST_P(GlesBackend, ProbesAndVectorIrradianceOffCostNothingAndSayWhy) {
  const TestLevel& t = test_level("corridor");
  std::unique_ptr<GlesLevelRuntime> rt = make(t.level, {.target = std::nullopt, .probes = false});
  ASSERT_TRUE(rt);
  ASSERT_TRUE(rt->update(t.ld).ok());
  std::vector<float> probes(rt->sizes().probes), vec(rt->sizes().vector_lightmap);
  Status s = rt->read_probes(probes);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("no probes"), std::string::npos) << s.message();
  s = rt->read_vector_lightmap(vec);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("vector_irradiance is off"), std::string::npos) << s.message();
  EXPECT_EQ(rt->vector_texture(0), 0u);
}

// Vector irradiance asked of a dictionary without Ub_vec (format version 1): create() fails
// and names what is missing; without the option the same dictionary works.
TEST_P(GlesBackend, VectorIrradianceNeedsVectorOperators) {
  const TestLevel& t = test_level("maze11");
  Dictionary old = dict();
  for (ShapeOperators& op : old.shapes) op.Ub_vec = Matrix();
  Result<std::unique_ptr<GlesLevelRuntime>> rt = GlesLevelRuntime::create(
      gl(), gles(), t.level, old, {.target = std::nullopt, .vector_irradiance = true});
  ASSERT_FALSE(rt.ok());
  EXPECT_EQ(rt.status().code(), ErrorCode::invalid_argument);
  EXPECT_NE(rt.status().message().find("no Ub_vec"), std::string::npos) << rt.status().message();
  EXPECT_TRUE(GlesLevelRuntime::create(gl(), gles(), t.level, old).ok());
}

TEST_P(GlesBackend, RejectsMismatchedDictionary) {
  const TestLevel& t = test_level("maze11");
  Dictionary other = dict();
  other.settings.res = 4;
  Result<std::unique_ptr<GlesLevelRuntime>> rt = GlesLevelRuntime::create(gl(), gles(), t.level, other);
  ASSERT_FALSE(rt.ok());
  EXPECT_NE(rt.status().message().find("rebuild the level"), std::string::npos) << rt.status().message();
}

TEST_P(GlesBackend, ShaderErrorsNameTheShaderAndCarryTheLog) {
  const char* vertex = "#version 300 es\nvoid main() { gl_Position = vec4(0.0); }\n";
  Result<GLuint> p = build_program(gl(), "broken.frag", {vertex},
                                   {"#version 300 es\nprecision highp float;\nout vec4 o;\n"
                                    "void main() { o = vec4(undeclared_thing); }\n"});
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().code(), ErrorCode::internal_error);
  EXPECT_NE(p.status().message().find("broken.frag (fragment) failed to compile"), std::string::npos)
      << p.status().message();
  EXPECT_NE(p.status().message().find("undeclared_thing"), std::string::npos) << p.status().message();
  EXPECT_EQ(gl().glGetError(), GLenum(GL_NO_ERROR));
}

TEST_P(GlesBackend, PassTimesAreReportedWhenTimingIsOn) {
  const TestLevel& t = test_level("maze41");
  GlesRuntimeOptions options;
  options.skip_unchanged = false;  // the same ld every frame: time the full path
  options.vector_irradiance = true;
  std::unique_ptr<GlesLevelRuntime> rt = make(t.level, options);
  ASSERT_TRUE(rt);
  rt->set_timing(true);
  // llvmpipe answers a process's first GL_TIME_ELAPSED query with a timestamp, which the
  // timer rejects as implausible (reported as 0): time a few frames and check the last.
  for (int frame = 0; frame < 3; ++frame) ASSERT_TRUE(rt->update(t.ld).ok());
  const GlesPassTimes& times = rt->pass_times();
  EXPECT_GT(times.b, 0u);
  EXPECT_GT(times.r, 0u);
  EXPECT_GT(times.atlas, 0u);
  EXPECT_GT(times.probes, 0u);
  EXPECT_GT(times.vector, 0u);
  EXPECT_EQ(times.feedback, 0u);
}

// The converged solve on the GPU (gles_reduced_solve.cpp) with timing on reads its last step's
// residual back: measured, and the a-priori count met the tolerance. At albedo 0.999 on the
// 41-block maze (M damped to 0.98, the longest count) it still equals core's
// level_converged_bounce, and every lightmap value is finite and non-negative.
TEST_P(GlesBackend, ConvergedSolveMeasuresItsResidualAndHoldsNearAlbedoOne) {
  const TestLevel& t = test_level("maze41");
  for (const float albedo : {0.0f, 0.999f}) {  // 0: the level's own albedo
    SCOPED_TRACE(albedo);
    const std::vector<float> rho =
        albedo > 0.0f ? std::vector<float>(t.albedo.size(), albedo) : std::vector<float>(t.albedo);
    std::unique_ptr<GlesLevelRuntime> rt = make(t.level);
    ASSERT_TRUE(rt);
    rt->set_timing(true);
    ASSERT_TRUE(rt->set_albedo(rho, 0.999f).ok());
    ReducedSolveSettings solve;
    solve.max_iterations = 4000;
    ASSERT_TRUE(rt->update_converged(t.ld, solve).ok());
    const ConvergedStats st = rt->converged_stats();
    EXPECT_TRUE(st.last.measured);
    EXPECT_EQ(st.last.iterations,
              reduced_solve_iterations(st.contraction, solve.tolerance, solve.max_iterations));
    EXPECT_TRUE(st.last.converged) << "error bound " << st.last.error_bound;
    EXPECT_GT(st.last.residual, 0.0f);
    const LevelBufferSizes s = level_buffer_sizes(t.level, dict());
    std::vector<float> b(s.b), r(s.r), ref(s.lightmap), lightmap(s.lightmap);
    ConvergedBounceSettings cs;
    cs.max_albedo = 0.999f;
    cs.solve = solve;
    cs.solve.tolerance = 1e-5f;  // the reference well inside the backend's 1e-3
    ASSERT_TRUE(level_converged_bounce(t.level, dict(), t.ld, rho, cs, b, r, ref).ok());
    ASSERT_TRUE(rt->read_lightmap(lightmap).ok());
    EXPECT_LE(rel_l2(lightmap, ref), 2e-3);
    EXPECT_TRUE(
        std::all_of(lightmap.begin(), lightmap.end(), [](float v) { return std::isfinite(v) && v >= 0.0f; }));
    std::printf(
        "  %-52s albedo %s: %s contraction %.4f, damping %.4f, %d iterations, residual %.2e, error "
        "bound %.2e, rel L2 %.2e\n",
        rt->description(), albedo > 0.0f ? "0.999" : "level", st.block_jacobi ? "block Jacobi" : "plain",
        st.contraction, double(st.damping), st.last.iterations, double(st.last.residual),
        double(st.last.error_bound), rel_l2(lightmap, ref));
  }
}

// Partial passes are exact: over an animated sequence on the 41-block maze in which one or
// three blocks' ld change per frame and some frames repeat, with partial_fraction 1 (the
// partial path in every pass, whatever changed) the atlas, probes and vector irradiance equal
// the full path's bit for bit, and the counters show which passes ran partially. The default
// fraction, which mixes partial and full passes, is test_backend_conformance's
// SkippingUnchangedWorkIsExact. After a multi-bounce frame the next update is full again.
TEST_P(GlesBackend, PartialPassesAreExact) { check_skipping(1.0f); }

void GlesBackend::check_skipping(float fraction) {
  const TestLevel& t = test_level("maze41");
  GlesRuntimeOptions full_options, options;
  full_options.skip_unchanged = false;
  full_options.vector_irradiance = options.vector_irradiance = true;
  options.partial_fraction = fraction;
  std::unique_ptr<GlesLevelRuntime> incremental = make(t.level, options), full = make(t.level, full_options);
  ASSERT_TRUE(incremental && full);
  const LevelBufferSizes& s = full->sizes();
  std::vector<float> a_inc(s.atlas), a_full(s.atlas), p_inc(s.probes), p_full(s.probes),
      v_inc(s.vector_lightmap), v_full(s.vector_lightmap);
  const std::size_t blocks = t.level.blocks.size();
  std::vector<float> ld = t.ld;
  constexpr int kFrames = 24;
  std::uint64_t unchanged_frames = 0, changed_blocks = blocks;  // the first frame is full
  std::vector<float> previous;
  for (int frame = 0; frame < kFrames; ++frame) {
    test::animate_moving_light(t.level, t.ld, frame, ld);  // every fifth frame repeats
    if (frame > 0) {
      std::uint64_t changed = 0;
      for (const LevelBlock& blk : t.level.blocks)
        changed += !std::equal(ld.begin() + 3 * blk.sample_offset,
                               ld.begin() + 3 * (blk.sample_offset + blk.sample_count),
                               previous.begin() + 3 * blk.sample_offset);
      unchanged_frames += changed == 0;
      changed_blocks += changed;
    }
    previous = ld;
    ASSERT_TRUE(incremental->update(ld).ok());
    ASSERT_TRUE(full->update(ld).ok());
    ASSERT_TRUE(incremental->read_atlas(a_inc).ok() && full->read_atlas(a_full).ok());
    ASSERT_TRUE(incremental->read_probes(p_inc).ok() && full->read_probes(p_full).ok());
    ASSERT_EQ(a_inc, a_full) << "frame " << frame;
    ASSERT_EQ(p_inc, p_full) << "frame " << frame;
    ASSERT_TRUE(incremental->read_vector_lightmap(v_inc).ok() && full->read_vector_lightmap(v_full).ok());
    ASSERT_EQ(v_inc, v_full) << "frame " << frame;
  }
  const Reference ref = level_reference(t.level, ld);
  EXPECT_LE(rel_l2(a_inc, ref.atlas), kFloat32Tolerance);
  const GlesSkipStats& st = incremental->skip_stats();
  EXPECT_EQ(st.frames, std::uint64_t(kFrames));
  EXPECT_GE(unchanged_frames, 4u);
  EXPECT_EQ(st.frames_skipped, unchanged_frames);
  if (fraction == 1.0f) {
    EXPECT_EQ(st.frames_partial, kFrames - unchanged_frames - 1);  // all but the first and the unchanged
    EXPECT_EQ(st.blocks_b, changed_blocks);
    // Light reaches blocks beyond the changed ones through Tb->r, but not all of them.
    EXPECT_LT(st.blocks_b, st.blocks_redrawn);
    EXPECT_LT(st.blocks_redrawn, (kFrames - unchanged_frames) * blocks);
  }
  EXPECT_EQ(full->skip_stats().frames_partial, 0u);
  std::printf(
      "  %s: %llu frames, %llu skipped, %llu partial; b recomputed for %llu block-frames, r for %llu "
      "slot-frames, tiles redrawn for %llu block-frames (full path: %llu)\n",
      incremental->description(), (unsigned long long)st.frames, (unsigned long long)st.frames_skipped,
      (unsigned long long)st.frames_partial, (unsigned long long)st.blocks_b, (unsigned long long)st.slots_r,
      (unsigned long long)st.blocks_redrawn, (unsigned long long)(std::uint64_t(kFrames) * blocks));

  // A multi-bounce frame changes every block's ld: the next update is a full one.
  ASSERT_TRUE(incremental->set_albedo(t.albedo).ok());
  ASSERT_TRUE(incremental->multi_bounce_step(ld).ok());
  ASSERT_TRUE(incremental->update(ld).ok());
  ASSERT_TRUE(incremental->read_atlas(a_inc).ok());
  EXPECT_EQ(a_inc, a_full);
}

// With clutter, partial passes must not keep a delta: a new clutter light alone (same ld) is
// not a skipped frame, and when one block's ld changes the atlas is redrawn whole (the delta of
// a sample reads other blocks' b through the openings) while b runs partially.
TEST_P(GlesBackend, ClutterLightAndPartialUpdatesAreNotSkipped) {
  const test::DrtFixture& f = test::drt_fixture();
  std::unique_ptr<GlesLevelRuntime> rt =
      make(f.level, {.target = TargetFormat::float32, .partial_fraction = 1.0f});
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
  EXPECT_LE(rel_l2(atlas, test::drt_reference(f, f.ld, clutter_ld2).atlas), 2e-6);
  std::vector<float> ld2 = f.ld;
  const LevelBlock& mid = f.level.blocks[1];
  for (std::size_t i = 3 * mid.sample_offset; i < 3 * (mid.sample_offset + mid.sample_count); ++i)
    ld2[i] *= 3.0f;
  const std::uint64_t partial_before = rt->skip_stats().frames_partial;
  ASSERT_TRUE(rt->update(ld2).ok());
  ASSERT_TRUE(rt->read_atlas(atlas).ok());
  EXPECT_LE(rel_l2(atlas, test::drt_reference(f, ld2, clutter_ld2).atlas), 2e-6);
  EXPECT_EQ(rt->skip_stats().frames_partial, partial_before + 1);
}

// The real-radiance gather (DrtObjectOperators::Gs ... Ht) in an operator set that mixes it
// with the Limp operators (the box keeps Cb, Cc and its traced dUb / dUc rows, the pillar
// gathers), against core's reference backend: a frame, clutter feedback steps (x_s the fed-back
// ld, x_t the fed-back clutter light), and ld from the caller's GL texture (x_s copied from it by
// drt_light.frag; another ld than the last frame's), which gives the frame of the same ld in
// CPU memory.
TEST_P(GlesBackend, GatherMixedWithLimpOperatorsMatchesTheReference) {
  const test::DrtFixture& f = test::drt_fixture(false);
  DrtOperators mixed = f.drt;
  mixed.objects[1] = test::drt_fixture(true).drt.objects[1];  // the same scene, built with the gather
  ASSERT_TRUE(check_drt_operators(f.level, mixed).ok());
  ASSERT_TRUE(!mixed.objects[0].has_gather() && !mixed.objects[0].Cc.empty());
  ASSERT_TRUE(mixed.objects[1].has_gather() && mixed.objects[1].Uc.empty());
  Result<std::unique_ptr<Backend>> ref = create_reference_backend(f.level, dict());
  ASSERT_TRUE(ref.ok());
  std::unique_ptr<GlesLevelRuntime> rt = make(f.level, {.target = TargetFormat::float32});
  ASSERT_TRUE(rt);
  const std::vector<float> clutter_albedo(drt_buffer_sizes(mixed).clutter_ld, 0.6f);
  for (Backend* be : {ref.value().get(), static_cast<Backend*>(rt.get())}) {
    ASSERT_TRUE(be->set_clutter(&mixed).ok());
    ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
    ASSERT_TRUE(be->set_albedo(f.albedo).ok());
  }
  std::vector<float> lightmap(rt->sizes().lightmap), lightmap_ref(lightmap.size());
  std::vector<float> clutter(rt->clutter_sizes().clutter_lightmap), clutter_ref(clutter.size());
  const auto compare = [&](const char* what) {
    ASSERT_TRUE(rt->read_lightmap(lightmap).ok());
    ASSERT_TRUE(rt->read_clutter_lightmap(clutter).ok());
    ASSERT_TRUE(ref.value()->read_lightmap(lightmap_ref).ok());
    ASSERT_TRUE(ref.value()->read_clutter_lightmap(clutter_ref).ok());
    const double e = rel_l2(lightmap, lightmap_ref), ec = rel_l2(clutter, clutter_ref);
    EXPECT_LE(e, 2e-6) << what;
    EXPECT_LE(ec, 2e-6) << what;
    std::printf("  %s, mixed gather and Limp, %s: rel L2 lightmap %.2e, clutter lightmap %.2e\n",
                rt->description(), what, e, ec);
  };
  ASSERT_TRUE(rt->update(f.ld).ok());
  ASSERT_TRUE(ref.value()->update(f.ld).ok());
  compare("a frame");
  for (Backend* be : {ref.value().get(), static_cast<Backend*>(rt.get())}) {
    ASSERT_TRUE(be->set_clutter_albedo(clutter_albedo).ok());
    for (int k = 0; k < 2; ++k) ASSERT_TRUE(be->multi_bounce_step(f.ld).ok());
  }
  compare("two steps with clutter feedback");
  std::vector<float> ld2 = f.ld;
  for (std::size_t i = 0; i < ld2.size() / 3; ++i) ld2[i] *= 1.5f;
  const std::size_t samples = f.level.sample_count;
  const GLuint ld_texture = create_texture(gl(), GL_RGB32F, kLinearWidth, linear_rows(samples));
  upload_linear(gl(), ld_texture, GL_RGB, GL_FLOAT, 3, ld2.data(), samples, sizeof(float));
  const Status from_texture = rt->update_from_texture(ld_texture);
  gl().glDeleteTextures(1, &ld_texture);
  ASSERT_TRUE(from_texture.ok()) << from_texture.to_string();
  ASSERT_TRUE(ref.value()->update(ld2).ok());
  compare("ld from a texture");
}

INSTANTIATE_TEST_SUITE_P(Contexts, GlesBackend,
                         ::testing::Values(ContextRequest::egl_surfaceless, ContextRequest::osmesa,
                                           ContextRequest::egl_device),
                         test::gl_context_test_name);

}  // namespace
}  // namespace modrt::gles
