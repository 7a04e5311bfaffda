// SPDX-License-Identifier: MIT
// Backend conformance (architecture.md §5, §8): every backend configuration this machine runs,
// through the Backend interface only, against core's scalar reference, stage by stage: the
// lightmap and padded atlas (b, r, tiles, padding), the volume probes, the vector irradiance,
// the multi-bounce feedback, exact skipping, bad input, and with clutter the DRT deltas, the
// clutter lightmap, its vector irradiance and the clutter's own feedback.
//
// Built twice from this file: test_conformance_cpu runs core's reference backend
// (reference_backend.h) and the CPU backend on every ISA this CPU (or qemu) supports with 1
// and 2 threads (also in the scalar-only build: the scalar twins);
// test_conformance_gles runs the GLES backend on every GL context kind (EGL surfaceless,
// OSMesa, EGL device; a kind that cannot be created is skipped with the reason) with every
// target and operator format. Backend-specific options and internals (CPU approximate
// skipping and float16 operators, GLES partial passes and timers) stay in test_cpu_backend and
// test_gles_backend; the SIMD DRT kernels alone in test_cpu_drt.
//
// Tolerances, relative L2 over all values: CPU 1e-5 on the levels, 2e-6 on the DRT scene and
// 1e-5 on its delta alone (lightmap with clutter minus without, a difference of two float32
// results); GLES float32 and bits32 targets 1e-4 on the levels (the 41-block maze's longest
// sums), DRT as the CPU; float16 targets 2e-3 (half precision, 2^-11) and 1e-2 on the delta (a
// difference of two half-rounded lightmaps, ~10x smaller than either); float16 operators 2e-3.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "compare_support.h"
#include "counting_allocator.h"
#include "drt_backend_fixture.h"
#include "level_fixtures.h"
#include "modrt/backend.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/cpu/isa.h"
#include "modrt/level_runtime.h"
#include "modrt/level_visibility.h"
#include "modrt/reference_backend.h"
#if MODRT_TEST_GLES
#include "gl_test_context.h"
#include "modrt/gles/gles_level_runtime.h"
#endif

namespace modrt::test {
namespace {

const Dictionary& dict() { return small_test_dictionary(); }

struct Tolerance {
  double level = 1e-5;  // lightmap, atlas, probes, vector irradiance of the test levels
  double drt = 2e-6;    // the same and the clutter lightmap on the DRT scene
  double delta = 1e-5;  // the DRT delta alone
};

// A part of the result a test checks (Cc c, the delta's effect on the feedback) must be far
// above float32 error and several times the case's tolerance, so that leaving it out fails.
double effect_floor(const Tolerance& t) { return std::max(100 * 2e-6, 4 * t.drt); }

// One backend configuration: its kind and how it is created; everything else goes through Backend.
struct BackendCase {
  BackendKind kind = BackendKind::cpu;
  cpu::Isa isa = cpu::Isa::scalar;
  int threads = 1;
#if MODRT_TEST_GLES
  platform::ContextRequest context = platform::ContextRequest::egl_surfaceless;
  gles::TargetFormat target = gles::TargetFormat::float32;
  gles::OperatorFormat operators = gles::OperatorFormat::float32;
#endif
  Tolerance tolerance;
  std::string name;  // the test-name suffix
};

// gtest prints a failing case's parameter: its name, not its bytes.
void PrintTo(const BackendCase& c, std::ostream* os) { *os << c.name; }

// What every test may switch per backend.
struct Config {
  bool skip_unchanged = true;
  bool probes = true;
  bool vector = true;  // gles: render the four vector atlases (cpu: computed on read)
};

std::vector<BackendCase> backend_cases() {
  std::vector<BackendCase> cases;
#if MODRT_TEST_GLES
  using gles::OperatorFormat;
  using gles::TargetFormat;
  using platform::ContextRequest;
  struct Format {
    TargetFormat target;
    OperatorFormat operators;
    Tolerance tolerance;
    const char* name;
  };
  const Format formats[] = {
      {TargetFormat::float32, OperatorFormat::float32, {1e-4, 2e-6, 1e-5}, "float32"},
      {TargetFormat::bits32, OperatorFormat::float32, {1e-4, 2e-6, 1e-5}, "bits32"},
      {TargetFormat::float16, OperatorFormat::float32, {2e-3, 2e-3, 1e-2}, "float16_targets"},
      // Half-rounded operators: 6 feedback steps measured 1.8e-3 on the cube levels, 2.0e-3 on
      // "stretched" (its long boxes feed more light back per step).
      {TargetFormat::float32, OperatorFormat::float16, {2.5e-3, 2e-3, 2e-3}, "float16_operators"},
  };
  for (ContextRequest context :
       {ContextRequest::egl_surfaceless, ContextRequest::osmesa, ContextRequest::egl_device})
    for (const Format& f : formats) {
      BackendCase c;
      c.kind = BackendKind::gles;
      c.context = context;
      c.target = f.target;
      c.operators = f.operators;
      c.tolerance = f.tolerance;
      c.name = std::string(platform::context_request_name(context)) + "_" + f.name;
      cases.push_back(c);
    }
#else
  BackendCase reference;  // core's scalar reference behind Backend: every test holds it too
  reference.kind = BackendKind::reference;
  reference.tolerance = {1e-6, 1e-6, 1e-6};
  reference.name = "reference";
  cases.push_back(reference);
  for (cpu::Isa isa : cpu::supported_isas())
    for (int threads : {1, 2}) {
      BackendCase c;
      c.isa = isa;
      c.threads = threads;
      c.name = std::string(cpu::isa_name(isa)) + "_" + std::to_string(threads) + "_thread" +
               (threads > 1 ? "s" : "");
      cases.push_back(c);
    }
#endif
  return cases;
}

class BackendConformance : public ::testing::TestWithParam<BackendCase> {
 protected:
  void SetUp() override {
#if MODRT_TEST_GLES
    GlContextSlot& slot = gl_context_for(GetParam().context);
    if (!slot.context)
      GTEST_SKIP() << "no " << platform::context_request_name(GetParam().context)
                   << " context here: " << slot.status.to_string();
    context_ = slot.context.get();
#endif
  }

  const Tolerance& tolerance() const { return GetParam().tolerance; }

  // The clutter tests' bodies, run with and without the real-radiance gather.
  void check_clutter_matches_scalar_reference(bool gather);
  void check_clutter_light_and_ld_reach_every_delta(bool gather);
  void check_clutter_multi_bounce(bool gather);
  void check_clutter_feedback(bool gather);
  void check_converged_with_clutter(bool gather);

  std::unique_ptr<Backend> make(const Level& level, const Config& config = {}) {
    const BackendCase& c = GetParam();
    Result<std::unique_ptr<Backend>> created = create(level, c, config);
    EXPECT_TRUE(created.ok()) << c.name << ": " << created.status().to_string();
    if (!created.ok()) return nullptr;
    EXPECT_EQ(created.value()->kind(), c.kind);
    return std::move(created).value();
  }

 private:
  Result<std::unique_ptr<Backend>> create(const Level& level, const BackendCase& c, const Config& config) {
#if MODRT_TEST_GLES
    gles::GlesRuntimeOptions o;
    o.target = c.target;
    o.operators = c.operators;
    o.probes = config.probes;
    o.vector_irradiance = config.vector;
    o.skip_unchanged = config.skip_unchanged;
    Result<std::unique_ptr<gles::GlesLevelRuntime>> rt =
        gles::GlesLevelRuntime::create(context_->gl(), context_->info().gles, level, dict(), o);
    if (!rt.ok()) return rt.status();
    return std::unique_ptr<Backend>(std::move(rt).value());
#else
    if (c.kind == BackendKind::reference) {
      ReferenceBackendOptions o;
      o.probes = config.probes;
      o.skip_unchanged = config.skip_unchanged;
      return create_reference_backend(level, dict(), o);
    }
    cpu::CpuBackendOptions o;
    o.runtime.isa = c.isa;
    o.runtime.threads = c.threads;
    o.runtime.skip.enabled = config.skip_unchanged;  // every epsilon 0: exact
    o.probes = config.probes;
    return cpu::create_cpu_backend(level, dict(), o);
#endif
  }

#if MODRT_TEST_GLES
  platform::GlContext* context_ = nullptr;
#endif
};

// gtest names take letters, digits and '_' only ("egl-surfaceless" -> "egl_surfaceless").
std::string case_name(const ::testing::TestParamInfo<BackendCase>& info) {
  std::string name = info.param.name;
  std::replace_if(
      name.begin(), name.end(), [](char ch) { return !std::isalnum((unsigned char)ch); }, '_');
  return name;
}

struct Outputs {
  std::vector<float> lightmap, atlas, probes, vector;
};
Outputs read_outputs(Backend& be) {
  const LevelBufferSizes& s = be.sizes();
  Outputs o{std::vector<float>(s.lightmap), std::vector<float>(s.atlas), std::vector<float>(s.probes),
            std::vector<float>(s.vector_lightmap)};
  EXPECT_TRUE(be.read_lightmap(o.lightmap).ok()) << be.description();
  EXPECT_TRUE(be.read_atlas(o.atlas).ok()) << be.description();
  EXPECT_TRUE(be.read_probes(o.probes).ok()) << be.description();
  const Status s_vec = be.read_vector_lightmap(o.vector);
  EXPECT_TRUE(s_vec.ok()) << be.description() << ": " << s_vec.to_string();
  return o;
}

// ---- MRT: one update, feedback, skipping, bad input ----

// Steps 2-6 and 9 of architecture.md §5: lightmap, padded atlas, probes and vector irradiance
// of every test level equal level_evaluate and its fills; a repeated update gives the same.
TEST_P(BackendConformance, UpdateMatchesScalarReference) {
  for (const TestLevel& t : test_levels()) {
    const LevelReference ref = level_reference(t.level, t.ld);
    std::unique_ptr<Backend> be = make(t.level);
    ASSERT_TRUE(be);
    ASSERT_TRUE(be->update(t.ld).ok());
    const Outputs first = read_outputs(*be);
    ASSERT_TRUE(be->update(t.ld).ok());  // the same ld: skipped, the same results
    const Outputs o = read_outputs(*be);
    EXPECT_EQ(o.atlas, first.atlas) << t.name;
    EXPECT_EQ(o.probes, first.probes) << t.name;
    const double el = rel_l2(o.lightmap, ref.lightmap), ea = rel_l2(o.atlas, ref.atlas),
                 ep = rel_l2(o.probes, ref.probes), ev = rel_l2(o.vector, ref.vector_lightmap);
    const std::string what = t.name + " " + be->description();
    EXPECT_LE(el, tolerance().level) << what << " lightmap";
    EXPECT_LE(ea, tolerance().level) << what << " atlas";
    EXPECT_LE(ep, tolerance().level) << what << " probes";
    EXPECT_LE(ev, tolerance().level) << what << " vector irradiance";
    std::printf("  %-8s %-52s rel L2: lightmap %.2e atlas %.2e probes %.2e vector %.2e\n", t.name.c_str(),
                be->description(), el, ea, ep, ev);
  }
}

// The atlas a renderer samples is reachable without a copy: a GL texture on GLES (and the four
// vector textures), CPU memory equal to read_atlas on the CPU.
TEST_P(BackendConformance, OutputsAreReachableWithoutACopy) {
  const TestLevel& t = test_level("maze11");
  std::unique_ptr<Backend> be = make(t.level);
  ASSERT_TRUE(be);
  ASSERT_TRUE(be->update(t.ld).ok());
  const Outputs o = read_outputs(*be);
  if (be->kind() == BackendKind::gles) {
    EXPECT_GE(be->output_texture_format(), 0);
    std::vector<std::uint32_t> names;
    for (BackendOutput out : {BackendOutput::atlas, BackendOutput::vector0, BackendOutput::vector1,
                              BackendOutput::vector2, BackendOutput::vector3}) {
      names.push_back(be->output_texture(out));
      EXPECT_NE(names.back(), 0u) << int(out);
    }
    std::sort(names.begin(), names.end());
    EXPECT_EQ(std::unique(names.begin(), names.end()), names.end()) << "two outputs share a texture";
    EXPECT_TRUE(be->output_data(BackendOutput::atlas).empty());
  } else {
    const std::span<const float> atlas = be->output_data(BackendOutput::atlas);
    EXPECT_TRUE(std::equal(atlas.begin(), atlas.end(), o.atlas.begin(), o.atlas.end()));
    EXPECT_EQ(be->output_texture(BackendOutput::atlas), 0u);
    EXPECT_EQ(be->output_texture_format(), -1);
  }
  EXPECT_EQ(be->output_texture(BackendOutput::clutter_atlas), 0u);  // no clutter
}

// k multi_bounce_step()s after update(ld) equal level_multi_bounce after k iterations, some
// albedo clamped at max_albedo; the vector irradiance follows the last step's b and r.
TEST_P(BackendConformance, MultiBounceStepsMatchLevelMultiBounce) {
  constexpr int kSteps = 6;
  for (const TestLevel& t : test_levels()) {
    std::vector<float> albedo = t.albedo;
    for (std::size_t i = 0; i < albedo.size(); i += 7) albedo[i] = 0.99f;  // clamped to 0.95
    const LevelBufferSizes s = level_buffer_sizes(t.level, dict());
    std::vector<float> b(s.b), r(s.r), ref(s.lightmap), vec_ref(s.vector_lightmap);
    MultiBounceSettings settings;
    settings.max_iterations = kSteps;
    settings.tolerance = 0.0f;
    ASSERT_TRUE(level_multi_bounce(t.level, dict(), t.ld, albedo, settings, b, r, ref).ok());
    ASSERT_TRUE(level_compute_vector_irradiance(t.level, dict(), b, r, vec_ref).ok());
    std::unique_ptr<Backend> be = make(t.level);
    ASSERT_TRUE(be);
    ASSERT_TRUE(be->update(t.ld).ok());
    EXPECT_EQ(be->multi_bounce_step(t.ld).code(), ErrorCode::invalid_argument) << "no albedo yet";
    ASSERT_TRUE(be->set_albedo(albedo, settings.max_albedo).ok());
    ASSERT_TRUE(be->update(t.ld).ok());
    for (int k = 0; k < kSteps; ++k) {
      const Status st = be->multi_bounce_step(t.ld);
      ASSERT_TRUE(st.ok()) << st.to_string();
    }
    const Outputs o = read_outputs(*be);
    const double e = rel_l2(o.lightmap, ref), ev = rel_l2(o.vector, vec_ref);
    EXPECT_LE(e, tolerance().level) << t.name << " " << be->description();
    EXPECT_LE(ev, tolerance().level) << t.name << " " << be->description() << " vector irradiance";
    std::printf("  %-8s %-52s multi-bounce x%d rel L2 %.2e, vector irradiance %.2e\n", t.name.c_str(),
                be->description(), kSteps, e, ev);
  }
}

// The converged solve (update_converged) equals core's level_converged_bounce: lightmap, probes
// and vector irradiance from b*, at the solve's tolerance (1e-5 here, so the comparison is at the
// backend's usual tolerance); the statistics add up; a second frame with 2 % less light starts
// warm on the CPU and needs fewer applications of M than the first, while GLES (no warm start,
// staged_backend.h) runs the same a-priori count, reduced_solve_iterations's; with clutter the
// lightmap and the clutter lightmap equal drt_converged_bounce's (GLES too: b and c in its
// passes). Every backend refuses the solve before set_albedo.
TEST_P(BackendConformance, ConvergedUpdateMatchesLevelConvergedBounce) {
  for (const char* name : {"corridor", "maze41"}) {
    const TestLevel& t = test_level(name);
    std::unique_ptr<Backend> be = make(t.level);
    ASSERT_TRUE(be);
    ReducedSolveSettings solve;
    solve.tolerance = 1e-5f;
    EXPECT_EQ(be->update_converged(t.ld, solve).code(), ErrorCode::invalid_argument) << "no albedo yet";
    ASSERT_TRUE(be->set_albedo(t.albedo).ok());
    const Status st = be->update_converged(t.ld, solve);
    ASSERT_TRUE(st.ok()) << st.to_string();
    const LevelBufferSizes s = level_buffer_sizes(t.level, dict());
    std::vector<float> b(s.b), r(s.r), ref(s.lightmap), vec_ref(s.vector_lightmap), probes_ref(s.probes);
    ConvergedBounceSettings cs;
    cs.solve = solve;
    Result<ConvergedBounceReport> rep =
        level_converged_bounce(t.level, dict(), t.ld, t.albedo, cs, b, r, ref);
    ASSERT_TRUE(rep.ok());
    ASSERT_TRUE(level_compute_vector_irradiance(t.level, dict(), b, r, vec_ref).ok());
    level_compute_probes(t.level, dict(), b, r, probes_ref);
    const Outputs o = read_outputs(*be);
    const double e = rel_l2(o.lightmap, ref), ep = rel_l2(o.probes, probes_ref),
                 ev = rel_l2(o.vector, vec_ref);
    const ConvergedStats first = be->converged_stats();
    const bool gles = be->kind() == BackendKind::gles;
    EXPECT_TRUE(first.last.converged);
    EXPECT_EQ(first.last.measured, !gles) << "GLES reads nothing back unless timing is on";
    if (gles) {
      EXPECT_EQ(first.last.iterations,
                reduced_solve_iterations(first.contraction, solve.tolerance, solve.max_iterations));
    }
    EXPECT_EQ(first.solves, 1u);
    EXPECT_NEAR(first.spectral_radius, rep->spectral_radius, 1e-6 * rep->spectral_radius);
    EXPECT_GT(first.build_ns, 0u);
    // Two solves at tolerance 1e-5 of max |b| differ by about that much.
    const double tol = std::max(tolerance().level, 3e-5);
    EXPECT_LE(e, tol) << name << " " << be->description();
    EXPECT_LE(ep, tol) << name << " " << be->description() << " probes";
    EXPECT_LE(ev, tol) << name << " " << be->description() << " vector irradiance";
    std::vector<float> dimmer = t.ld;
    for (float& v : dimmer) v *= 0.98f;
    ASSERT_TRUE(be->update_converged(dimmer, solve).ok());
    const ConvergedStats second = be->converged_stats();
    if (gles) {
      EXPECT_EQ(second.last.iterations, first.last.iterations) << "the a-priori count";
    } else {
      EXPECT_LT(second.last.iterations, first.last.iterations) << "warm start";
    }
    EXPECT_EQ(second.solves, 2u);
    EXPECT_EQ(second.iterations, std::uint64_t(first.last.iterations + second.last.iterations));
    // GLES draws every block per pass; the CPU's incremental solve applies G to fewer.
    const std::uint64_t every = second.iterations * t.level.blocks.size();
    if (gles) {
      EXPECT_EQ(second.blocks_applied, every);
    } else {
      EXPECT_GT(second.blocks_applied, 0u);
      EXPECT_LE(second.blocks_applied, every);
    }
    std::printf("  %-8s %-52s converged rel L2 %.2e, probes %.2e, vector %.2e; %d then %d iterations\n", name,
                be->description(), e, ep, ev, first.last.iterations, second.last.iterations);
  }
  // With clutter: b and the clutter's c solved together (drt_converged_bounce), the clutter's
  // light fed back with its albedo; the lightmap and the clutter lightmap equal core's. With the
  // gather's operators: the level solved without them, then kGatherConvergedSteps feedback steps.
  for (const bool gather : {false, true}) {
    SCOPED_TRACE(gather ? "gather" : "Limp");
    check_converged_with_clutter(gather);
  }
}

void BackendConformance::check_converged_with_clutter(bool gather) {
  const DrtFixture& f = drt_fixture(gather);
  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  const Status set = be->set_clutter(&f.drt);
  ASSERT_TRUE(set.ok()) << set.to_string();
  ASSERT_TRUE(be->set_albedo(f.albedo).ok());
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  const std::vector<float> clutter_albedo(d.clutter_ld, 0.7f);
  ASSERT_TRUE(be->set_clutter_albedo(clutter_albedo).ok());
  ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ReducedSolveSettings solve;
  solve.tolerance = 1e-5f;
  EXPECT_TRUE(be->converged_available());
  const Status st = be->update_converged(f.ld, solve);
  ASSERT_TRUE(st.ok()) << st.to_string();
  const LevelBufferSizes s = level_buffer_sizes(f.level, dict());
  std::vector<float> b(s.b), r(s.r), ref(s.lightmap), c(d.c), clutter_ref(d.clutter_lightmap);
  ConvergedBounceSettings cs;
  cs.solve = solve;
  std::vector<float> last_ld(s.ld), last_x(d.clutter_ld);
  ASSERT_TRUE(drt_converged_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld, clutter_albedo, cs,
                                   b, r, ref, c, last_ld, last_x)
                  .ok());
  drt_evaluate_clutter_lightmap(f.drt, b, c, last_ld, last_x, f.clutter_direct, clutter_ref);
  std::vector<float> lightmap(s.lightmap), clutter(d.clutter_lightmap);
  ASSERT_TRUE(be->read_lightmap(lightmap).ok());
  ASSERT_TRUE(be->read_clutter_lightmap(clutter).ok());
  const double e = rel_l2(lightmap, ref), ec = rel_l2(clutter, clutter_ref);
  // Each solve stops within 1e-5 of max |b|; with the gather, the feedback steps after it carry
  // that difference into the clutter's light as well (GLES: 2.7e-5 and 4.2e-5 measured).
  const double tol = std::max(tolerance().drt, gather ? 1e-4 : 3e-5);
  EXPECT_LE(e, tol) << be->description();
  EXPECT_LE(ec, tol) << be->description() << " clutter lightmap";
  EXPECT_TRUE(be->converged_stats().last.converged);
  std::printf("  clutter  %-52s %s converged rel L2 %.2e, clutter lightmap %.2e, %d iterations\n",
              be->description(), gather ? "gather" : "Limp", e, ec, be->converged_stats().last.iterations);
}

// A spike in ld rings the unclamped lightmap below -1 (test_cpu_backend asserts it); every
// backend's lightmap and atlas are still never negative (core's lightmap policy) and every
// output is finite (a float16 target saturates at 65504).
TEST_P(BackendConformance, SpikeInLdGivesNoNegativeTexel) {
  const TestLevel& t = test_level("maze11");
  std::vector<float> ld(t.ld.size(), 0.0f);
  ld[3 * 40 + 0] = 1e6f;
  std::unique_ptr<Backend> be = make(t.level);
  ASSERT_TRUE(be);
  ASSERT_TRUE(be->update(ld).ok());
  const Outputs o = read_outputs(*be);
  EXPECT_GE(*std::min_element(o.lightmap.begin(), o.lightmap.end()), 0.0f) << be->description();
  EXPECT_GE(*std::min_element(o.atlas.begin(), o.atlas.end()), 0.0f) << be->description();
  for (const std::vector<float>* v : {&o.lightmap, &o.atlas, &o.probes, &o.vector})
    EXPECT_TRUE(std::all_of(v->begin(), v->end(), [](float x) { return std::isfinite(x); }))
        << be->description();
}

// NaN, Inf, negative and wrongly sized input is refused naming the sample and channel, and the
// previous results stay; reads before the first update and into wrong sizes are refused.
TEST_P(BackendConformance, BadInputIsNamedAndChangesNothing) {
  const TestLevel& t = test_level("maze11");
  std::unique_ptr<Backend> be = make(t.level);
  ASSERT_TRUE(be);
  std::vector<float> atlas(be->sizes().atlas), after(be->sizes().atlas);
  const std::size_t blocks = t.level.blocks.size(), per_block = be->sizes().probes / blocks;
  std::vector<float> block_probes(per_block);
  EXPECT_EQ(be->read_atlas(atlas).code(), ErrorCode::invalid_argument) << "nothing computed yet";
  EXPECT_EQ(be->read_block_probes(0, block_probes).code(), ErrorCode::invalid_argument);
  ASSERT_TRUE(be->update(t.ld).ok());
  ASSERT_TRUE(be->read_atlas(atlas).ok());
  // One block's probes: a block past the level's and a wrong size are refused by name.
  Status read = be->read_block_probes(blocks, block_probes);
  EXPECT_EQ(read.code(), ErrorCode::invalid_argument);
  EXPECT_NE(read.message().find("block " + std::to_string(blocks) + " of a level with"), std::string::npos)
      << read.message();
  std::vector<float> short_probes(per_block - 1);
  EXPECT_EQ(be->read_block_probes(0, short_probes).code(), ErrorCode::invalid_argument);
  ASSERT_TRUE(be->read_block_probes(blocks - 1, block_probes).ok());
  std::vector<float> ld = t.ld;
  ld[3 * 7 + 1] = std::numeric_limits<float>::quiet_NaN();
  Status s = be->update(ld);
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_NE(s.message().find("sample 7 channel G is NaN"), std::string::npos) << s.message();
  ld = t.ld;
  ld[3 * 12 + 2] = std::numeric_limits<float>::infinity();
  s = be->update(ld);
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_NE(s.message().find("sample 12 channel B is Inf"), std::string::npos) << s.message();
  ld = t.ld;
  ld[5] = -std::numeric_limits<float>::infinity();
  EXPECT_EQ(be->update(ld).code(), ErrorCode::non_finite);
  ld = t.ld;
  ld[0] = -1.0f;
  s = be->update(ld);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("sample 0 channel R is negative"), std::string::npos) << s.message();
  ld.pop_back();
  EXPECT_EQ(be->update(ld).code(), ErrorCode::invalid_argument);
  ASSERT_TRUE(be->read_atlas(after).ok());
  EXPECT_EQ(atlas, after);
  std::vector<float> short_atlas(atlas.size() - 1);
  EXPECT_EQ(be->read_atlas(short_atlas).code(), ErrorCode::invalid_argument);
  EXPECT_EQ(be->set_albedo(t.albedo, 1.0f).code(), ErrorCode::invalid_argument);  // max_albedo < 1
  std::vector<float> albedo = t.albedo;
  albedo[2] = std::numeric_limits<float>::infinity();
  EXPECT_EQ(be->set_albedo(albedo).code(), ErrorCode::non_finite);
}

// Without probes the backend says so; its other results are unchanged.
TEST_P(BackendConformance, ProbesOffAreRefusedByName) {
  const TestLevel& t = test_level("corridor");
  std::unique_ptr<Backend> be = make(t.level, {.probes = false});
  ASSERT_TRUE(be);
  ASSERT_TRUE(be->update(t.ld).ok());
  std::vector<float> probes(be->sizes().probes), atlas(be->sizes().atlas);
  const Status s = be->read_probes(probes);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("no probes"), std::string::npos) << s.message();
  const Status one = be->read_block_probes(0, probes);
  EXPECT_EQ(one.code(), ErrorCode::invalid_argument);
  EXPECT_NE(one.message().find("no probes"), std::string::npos) << one.message();
  ASSERT_TRUE(be->read_atlas(atlas).ok());
  EXPECT_LE(rel_l2(atlas, level_reference(t.level, t.ld).atlas), tolerance().level);
}

// Skipping is exact: over an animated sequence on the 41-block maze in which one or three
// blocks' ld change per frame and every fifth frame repeats, the skipping backend's atlas,
// probes and vector irradiance equal the full path's bit for bit; a repeated ld is a skipped
// evaluation; the counters add up (computed + kept = evaluations x blocks) and show work kept.
TEST_P(BackendConformance, SkippingUnchangedWorkIsExact) {
  const TestLevel& t = test_level("maze41");
  std::unique_ptr<Backend> incremental = make(t.level), full = make(t.level, {.skip_unchanged = false});
  ASSERT_TRUE(incremental && full);
  const std::size_t blocks = t.level.blocks.size(), slots = t.level.slots.size();
  std::vector<float> ld = t.ld;
  constexpr int kFrames = 24;
  std::uint64_t unchanged_frames = 0, changed_blocks = blocks;  // the first frame computes all
  std::vector<float> previous;
  for (int frame = 0; frame < kFrames; ++frame) {
    animate_moving_light(t.level, t.ld, frame, ld);  // every fifth frame repeats
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
    const Outputs a = read_outputs(*incremental), b = read_outputs(*full);
    ASSERT_EQ(a.atlas, b.atlas) << "frame " << frame;
    ASSERT_EQ(a.probes, b.probes) << "frame " << frame;
    ASSERT_EQ(a.vector, b.vector) << "frame " << frame;
  }
  const BackendEvaluationStats st = incremental->evaluation_stats(), fs = full->evaluation_stats();
  EXPECT_EQ(st.evaluations, std::uint64_t(kFrames));
  EXPECT_GE(unchanged_frames, 4u);
  EXPECT_EQ(st.evaluations_skipped, unchanged_frames) << incremental->description();
  EXPECT_EQ(fs.evaluations_skipped, 0u);
  EXPECT_EQ(st.blocks_computed + st.blocks_kept, kFrames * blocks);
  EXPECT_EQ(st.slots_computed + st.slots_kept, kFrames * slots);
  EXPECT_EQ(st.tiles_written + st.tiles_kept, kFrames * blocks);
  EXPECT_GE(st.blocks_computed, changed_blocks);  // a block whose ld is 0 may count as computed
  EXPECT_LT(st.blocks_computed, kFrames * blocks / 2);
  EXPECT_LT(st.slots_computed, kFrames * slots);
  EXPECT_LT(st.tiles_written, kFrames * blocks);
  EXPECT_EQ(fs.blocks_computed, kFrames * blocks);
  std::printf(
      "  %s: %d frames, %llu skipped; b for %llu of %llu block-frames (ld changed: %llu), r for %llu of "
      "%llu slot-frames, tiles for %llu\n",
      incremental->description(), kFrames, (unsigned long long)st.evaluations_skipped,
      (unsigned long long)st.blocks_computed, (unsigned long long)(kFrames * blocks),
      (unsigned long long)changed_blocks, (unsigned long long)st.slots_computed,
      (unsigned long long)(kFrames * slots), (unsigned long long)st.tiles_written);

  // A feedback step changes every block's ld: the update after it starts from that step's
  // inputs and still equals the full path.
  ASSERT_TRUE(incremental->set_albedo(t.albedo).ok());
  ASSERT_TRUE(incremental->multi_bounce_step(ld).ok());
  ASSERT_TRUE(incremental->update(ld).ok());
  EXPECT_EQ(read_outputs(*incremental).atlas, read_outputs(*full).atlas);
}

// The converged solve's b0 = Td_b ld_direct depends on its block's ld only: a backend that keeps
// it between converged frames (the cpu) computes b0 of the blocks whose ld changed since the
// last one, and every output equals a backend that computes them all, bit for bit, across a
// repeated ld, a one-bounce update and a new albedo in between.
TEST_P(BackendConformance, ConvergedFramesRecomputeOnlyTheChangedB0Exactly) {
  const TestLevel& t = test_level("maze41");
  std::unique_ptr<Backend> incremental = make(t.level), full = make(t.level, {.skip_unchanged = false});
  ASSERT_TRUE(incremental && full);
  // The others compute every b0 in every converged frame (ConvergedUpdateMatchesLevelConvergedBounce).
  if (incremental->kind() != BackendKind::cpu) GTEST_SKIP() << incremental->description() << ": keeps no b0";
  ASSERT_TRUE(incremental->set_albedo(t.albedo).ok());
  ASSERT_TRUE(full->set_albedo(t.albedo).ok());
  const std::size_t blocks = t.level.blocks.size();
  std::vector<float> ld = t.ld, previous;
  std::vector<float> darker = t.albedo;
  for (float& v : darker) v *= 0.6f;
  std::uint64_t changed_blocks = 0, computed_before = 0;
  ReducedSolveSettings solve;
  solve.tolerance = 1e-5f;
  for (int frame = 0; frame < 12; ++frame) {
    animate_moving_light(t.level, t.ld, frame, ld);  // every fifth frame repeats
    if (frame == 6) {                                // a one-bounce frame between converged ones
      ASSERT_TRUE(incremental->update(ld).ok());
      ASSERT_TRUE(full->update(ld).ok());
    }
    if (frame == 9) {
      ASSERT_TRUE(incremental->set_albedo(darker).ok());
      ASSERT_TRUE(full->set_albedo(darker).ok());
    }
    if (frame >= 1 && frame <= 5) {  // the counters over converged frames only
      for (const LevelBlock& blk : t.level.blocks)
        changed_blocks += !std::equal(ld.begin() + 3 * blk.sample_offset,
                                      ld.begin() + 3 * (blk.sample_offset + blk.sample_count),
                                      previous.begin() + 3 * blk.sample_offset);
    }
    if (frame == 1) computed_before = incremental->evaluation_stats().blocks_computed;
    previous = ld;
    ASSERT_TRUE(incremental->update_converged(ld, solve).ok()) << "frame " << frame;
    ASSERT_TRUE(full->update_converged(ld, solve).ok()) << "frame " << frame;
    if (frame == 5) {
      const std::uint64_t computed = incremental->evaluation_stats().blocks_computed - computed_before;
      EXPECT_EQ(computed, changed_blocks) << incremental->description();
      EXPECT_LT(changed_blocks, 5 * blocks);
      std::printf("  %s: b0 for %llu of %llu block-frames over 5 converged frames\n",
                  incremental->description(), (unsigned long long)computed, (unsigned long long)(5 * blocks));
    }
    const Outputs a = read_outputs(*incremental), b = read_outputs(*full);
    ASSERT_EQ(a.lightmap, b.lightmap) << "frame " << frame;
    ASSERT_EQ(a.atlas, b.atlas) << "frame " << frame;
    ASSERT_EQ(a.probes, b.probes) << "frame " << frame;
    ASSERT_EQ(a.vector, b.vector) << "frame " << frame;
    if (frame == 5 || frame == 11) {  // and both are the converged bounce of this frame's ld
      const LevelBufferSizes sz = level_buffer_sizes(t.level, dict());
      std::vector<float> bs(sz.b), rs(sz.r), ref(sz.lightmap);
      ConvergedBounceSettings cs;
      cs.solve = solve;
      ASSERT_TRUE(
          level_converged_bounce(t.level, dict(), ld, frame < 9 ? t.albedo : darker, cs, bs, rs, ref).ok());
      EXPECT_LE(rel_l2(a.lightmap, ref), 1e-4) << "frame " << frame;  // two solves at 1e-5 of max |b|
    }
  }
}

// ---- The camera skip: only the visible blocks' tiles and rectangles ----

// The first block whose lightmap samples, atlas rectangles (padding included) or vector
// irradiance differ between a and b, among the blocks flagged in `blocks`; empty when none does.
std::string visible_block_mismatch(const Level& level, const Outputs& a, const Outputs& b,
                                   const std::vector<std::uint8_t>& blocks) {
  const LightmapAtlas& atlas = level.atlas;
  const std::size_t width = std::size_t(atlas.width), tile = std::size_t(atlas.tile);
  const std::size_t per_sample = level.sample_count ? a.vector.size() / level.sample_count : 0;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    if (!blocks[i]) continue;
    const LevelBlock& blk = level.blocks[i];
    const std::size_t first = std::size_t(blk.sample_offset), count = std::size_t(blk.sample_count);
    if (!std::equal(a.lightmap.begin() + 3 * first, a.lightmap.begin() + 3 * (first + count),
                    b.lightmap.begin() + 3 * first))
      return "block " + std::to_string(i) + " lightmap";
    if (!std::equal(a.vector.begin() + per_sample * first, a.vector.begin() + per_sample * (first + count),
                    b.vector.begin() + per_sample * first))
      return "block " + std::to_string(i) + " vector irradiance";
    for (int f = 0; f < kFaceCount; ++f) {
      const std::int32_t ox = atlas.tile_origin_x[i][std::size_t(f)],
                         oy = atlas.tile_origin_y[i][std::size_t(f)];
      if (ox < 0 || oy < 0) continue;
      for (std::size_t y = std::size_t(oy); y < std::size_t(oy) + tile; ++y) {
        const std::size_t row = 3 * (y * width + std::size_t(ox));
        if (!std::equal(a.atlas.begin() + row, a.atlas.begin() + row + 3 * tile, b.atlas.begin() + row))
          return "block " + std::to_string(i) + " face " + std::to_string(f) + " atlas row " +
                 std::to_string(y);
      }
    }
  }
  return {};
}

// About a third of the blocks, at least one.
std::vector<std::uint8_t> random_visible_set(std::size_t blocks, std::mt19937& rng) {
  std::vector<std::uint8_t> visible(blocks, 0);
  std::bernoulli_distribution coin(0.3);
  for (std::uint8_t& v : visible) v = coin(rng);
  visible[rng() % blocks] = 1;
  return visible;
}

// Over an animated sequence on the 41-block maze (one or three blocks' ld change per frame,
// every fifth frame repeats) with a new set of visible blocks every fourth frame, every visible
// block's lightmap, atlas rectangles and vector irradiance equal the full path's bit for bit,
// the probes everywhere; a block that becomes visible on a repeated frame (a skipped
// evaluation) shows the current light at once; the counters add up (written + kept + hidden =
// evaluations x blocks) and show tiles left unwritten; every block visible again equals the
// full path everywhere.
TEST_P(BackendConformance, CameraSkipKeepsEveryVisibleBlockExact) {
  const TestLevel& t = test_level("maze41");
  std::unique_ptr<Backend> be = make(t.level), full = make(t.level);
  ASSERT_TRUE(be && full);
  const std::size_t blocks = t.level.blocks.size();
  std::mt19937 rng(20);
  std::vector<std::uint8_t> visible = random_visible_set(blocks, rng);
  const Status set = be->set_visible_blocks(visible);
  ASSERT_TRUE(set.ok()) << set.to_string();
  std::vector<float> ld = t.ld;
  constexpr int kFrames = 30;
  std::uint64_t caught_up_on_repeats = 0;
  for (int frame = 0; frame < kFrames; ++frame) {
    animate_moving_light(t.level, t.ld, frame, ld);  // every fifth frame repeats
    if (frame % 4 == 0 && frame > 0) {
      visible = random_visible_set(blocks, rng);
      const std::uint64_t before = be->evaluation_stats().tiles_caught_up;
      ASSERT_TRUE(be->set_visible_blocks(visible).ok());
      if (frame % 5 == 4) caught_up_on_repeats += be->evaluation_stats().tiles_caught_up - before;
    }
    ASSERT_TRUE(be->update(ld).ok());
    ASSERT_TRUE(full->update(ld).ok());
    // One block's probes first (a hidden block's computed on this read), then all of them.
    const std::size_t probe_block = std::size_t(rng() % blocks);
    const std::size_t per_block = be->sizes().probes / blocks;
    std::vector<float> pa(per_block), pb(per_block);
    ASSERT_TRUE(be->read_block_probes(probe_block, pa).ok());
    ASSERT_TRUE(full->read_block_probes(probe_block, pb).ok());
    ASSERT_EQ(pa, pb) << "frame " << frame << " block " << probe_block
                      << (visible[probe_block] ? "" : " (hidden)");
    const Outputs a = read_outputs(*be), b = read_outputs(*full);
    const std::string mismatch = visible_block_mismatch(t.level, a, b, visible);
    ASSERT_TRUE(mismatch.empty()) << be->description() << " frame " << frame << ": " << mismatch;
    ASSERT_EQ(a.probes, b.probes) << "frame " << frame;
    ASSERT_TRUE(std::equal(pb.begin(), pb.end(), b.probes.begin() + std::ptrdiff_t(per_block * probe_block)))
        << "read_block_probes is read_probes' slice";
  }
  const BackendEvaluationStats st = be->evaluation_stats(), fs = full->evaluation_stats();
  EXPECT_EQ(st.evaluations, std::uint64_t(kFrames));
  EXPECT_EQ(st.evaluations_skipped, fs.evaluations_skipped) << "a repeated ld is still a skipped evaluation";
  EXPECT_EQ(st.tiles_written + st.tiles_kept + st.tiles_hidden, kFrames * blocks);
  EXPECT_EQ(st.tiles_written + st.tiles_hidden, fs.tiles_written) << "the same tiles changed";
  EXPECT_GT(st.tiles_hidden, 0u);
  EXPECT_GT(st.tiles_caught_up, 0u);
  EXPECT_GT(caught_up_on_repeats, 0u) << "frames 4 and 24 repeat the ld and change the visible set";
  EXPECT_LT(st.tiles_written + st.tiles_caught_up, fs.tiles_written);
  // Every changed block's probes computed once, by the evaluation where visible, else when read
  // (every frame reads them all here); GLES computes every block's (its renderer samples them).
  EXPECT_EQ(st.probe_blocks_computed + st.probe_blocks_caught_up, fs.probe_blocks_computed);
  EXPECT_EQ(fs.probe_blocks_caught_up, 0u);
  if (be->kind() == BackendKind::gles)
    EXPECT_EQ(st.probe_blocks_caught_up, 0u);
  else
    EXPECT_LT(2 * st.probe_blocks_computed, fs.probe_blocks_computed) << "the hidden blocks' probes waited";
#if MODRT_TEST_GLES
  // GLES draws the visible blocks' atlas rectangles only (its own count of redrawn blocks).
  const auto* g = dynamic_cast<const gles::GlesLevelRuntime*>(be.get());
  const auto* gf = dynamic_cast<const gles::GlesLevelRuntime*>(full.get());
  ASSERT_TRUE(g && gf);
  EXPECT_LT(2 * g->skip_stats().blocks_redrawn, gf->skip_stats().blocks_redrawn)
      << g->skip_stats().blocks_redrawn << " of " << gf->skip_stats().blocks_redrawn;
#endif
  std::printf("  %s: tiles written %llu + caught up %llu of the full path's %llu (hidden %llu)\n",
              be->description(), (unsigned long long)st.tiles_written, (unsigned long long)st.tiles_caught_up,
              (unsigned long long)fs.tiles_written, (unsigned long long)st.tiles_hidden);
  ASSERT_TRUE(be->set_visible_blocks({}).ok());
  const Outputs a = read_outputs(*be), b = read_outputs(*full);
  EXPECT_EQ(a.lightmap, b.lightmap) << "every block visible again";
  EXPECT_EQ(a.atlas, b.atlas);
  EXPECT_EQ(a.vector, b.vector);
}

// A feedback step reads the whole lightmap: the hidden blocks' light reaches the visible ones
// through r, so their tiles are produced first and the visible blocks equal the full path's
// after every step; the converged solve (where available) likewise, with a new visible set
// between two solves. Every block visible again equals the full path everywhere.
TEST_P(BackendConformance, CameraSkipUnderFeedbackAndConvergedSolveIsExact) {
  const TestLevel& t = test_level("maze41");
  std::unique_ptr<Backend> be = make(t.level), full = make(t.level);
  ASSERT_TRUE(be && full);
  const std::size_t blocks = t.level.blocks.size();
  std::mt19937 rng(21);
  std::vector<std::uint8_t> visible = random_visible_set(blocks, rng);
  ASSERT_TRUE(be->set_albedo(t.albedo).ok());
  ASSERT_TRUE(full->set_albedo(t.albedo).ok());
  ASSERT_TRUE(be->set_visible_blocks(visible).ok());
  std::vector<float> ld = t.ld;
  ASSERT_TRUE(be->update(t.ld).ok());
  ASSERT_TRUE(full->update(t.ld).ok());
  for (std::size_t i = 0; i < ld.size(); i += 5) ld[i] *= 1.5f;  // every block changes
  ASSERT_TRUE(be->update(ld).ok());
  ASSERT_TRUE(full->update(ld).ok());
  EXPECT_GT(be->evaluation_stats().tiles_hidden, 0u);
  for (int step = 0; step < 3; ++step) {
    ASSERT_TRUE(be->multi_bounce_step(ld).ok());
    ASSERT_TRUE(full->multi_bounce_step(ld).ok());
    const std::string mismatch =
        visible_block_mismatch(t.level, read_outputs(*be), read_outputs(*full), visible);
    ASSERT_TRUE(mismatch.empty()) << be->description() << " feedback step " << step << ": " << mismatch;
  }
  if (be->converged_available()) {
    ASSERT_TRUE(be->update_converged(t.ld).ok());
    ASSERT_TRUE(full->update_converged(t.ld).ok());
    std::string mismatch = visible_block_mismatch(t.level, read_outputs(*be), read_outputs(*full), visible);
    ASSERT_TRUE(mismatch.empty()) << be->description() << " converged: " << mismatch;
    visible = random_visible_set(blocks, rng);
    ASSERT_TRUE(be->set_visible_blocks(visible).ok());
    ASSERT_TRUE(be->update_converged(ld).ok());
    ASSERT_TRUE(full->update_converged(ld).ok());
    mismatch = visible_block_mismatch(t.level, read_outputs(*be), read_outputs(*full), visible);
    ASSERT_TRUE(mismatch.empty()) << be->description() << " second converged solve: " << mismatch;
    EXPECT_EQ(be->converged_stats().iterations, full->converged_stats().iterations);
  }
  ASSERT_TRUE(be->set_visible_blocks({}).ok());
  const Outputs a = read_outputs(*be), b = read_outputs(*full);
  EXPECT_EQ(a.lightmap, b.lightmap) << "every block visible again";
  EXPECT_EQ(a.atlas, b.atlas);
}

// A camera flight through maze41: the eye walks from block to block through open faces, looking
// at the next block, and each frame's visible set is the portal walk's (CameraVisibility), as an
// app would pass it. The light moves every frame; the converged solve (where available, else one
// bounce and two feedback steps) gives every visible block the full path's values bit for bit,
// and the walk hides tiles on most frames.
TEST_P(BackendConformance, CameraFlightThroughMaze41KeepsVisibleTilesExact) {
  const TestLevel& t = test_level("maze41");
  std::unique_ptr<Backend> be = make(t.level), full = make(t.level);
  ASSERT_TRUE(be && full);
  ASSERT_TRUE(be->set_albedo(t.albedo).ok());
  ASSERT_TRUE(full->set_albedo(t.albedo).ok());
  const bool converged = be->converged_available();
  auto centre = [&](std::size_t b) {
    glm::dvec3 c(0.0);
    for (int f = 0; f < 2; ++f)
      for (const glm::dvec3& corner : block_face_corners(t.level.blocks[b], f)) c += corner;
    return c / 8.0;
  };
  // The flight: from block 0, always on to the lowest-numbered open neighbour not yet visited
  // (back along the path at a dead end), 24 legs.
  std::vector<std::size_t> path{0};
  std::vector<std::uint8_t> visited(t.level.blocks.size(), 0);
  visited[0] = 1;
  std::vector<std::size_t> trail{0};
  while (path.size() < 25 && !trail.empty()) {
    int next = -1;
    for (int n : t.level.blocks[trail.back()].neighbour)
      if (n >= 0 && !visited[std::size_t(n)] && (next < 0 || n < next)) next = n;
    if (next < 0) {
      trail.pop_back();
      if (!trail.empty()) path.push_back(trail.back());
      continue;
    }
    visited[std::size_t(next)] = 1;
    trail.push_back(std::size_t(next));
    path.push_back(std::size_t(next));
  }
  ASSERT_GE(path.size(), 25u);
  CameraVisibility camera(t.level);
  std::vector<float> ld = t.ld;
  std::size_t hidden_frames = 0, visible_total = 0;
  for (std::size_t leg = 0; leg + 1 < path.size(); ++leg) {
    const glm::dvec3 from = centre(path[leg]), to = centre(path[leg + 1]);
    const glm::dvec3 eye = from + 0.3 * (to - from);  // inside the leg's first block
    glm::dvec3 up(0, 1, 0);
    if (std::abs(glm::normalize(to - from).y) > 0.9) up = glm::dvec3(1, 0, 0);
    const glm::dmat4 vp = glm::perspective(1.2, 16.0 / 9.0, 0.05, 100.0) * glm::lookAt(eye, to, up);
    const Result<VisibilityStats> st = camera.update(vp, eye);
    ASSERT_TRUE(st.ok()) << st.status().to_string();
    ASSERT_EQ(camera.camera_block(), int(path[leg])) << "leg " << leg;
    const std::vector<std::uint8_t> visible(camera.visible().begin(), camera.visible().end());
    ASSERT_TRUE(be->set_visible_blocks(visible).ok());
    hidden_frames += st.value().visible < visible.size();
    visible_total += st.value().visible;
    animate_moving_light(t.level, t.ld, int(leg), ld);
    if (converged) {
      ASSERT_TRUE(be->update_converged(ld).ok());
      ASSERT_TRUE(full->update_converged(ld).ok());
    } else {
      ASSERT_TRUE(be->update(ld).ok());
      ASSERT_TRUE(full->update(ld).ok());
      for (int step = 0; step < 2; ++step) {
        ASSERT_TRUE(be->multi_bounce_step(ld).ok());
        ASSERT_TRUE(full->multi_bounce_step(ld).ok());
      }
    }
    const std::string mismatch =
        visible_block_mismatch(t.level, read_outputs(*be), read_outputs(*full), visible);
    ASSERT_TRUE(mismatch.empty()) << be->description() << " leg " << leg << " (block " << path[leg]
                                  << "): " << mismatch;
  }
  const std::size_t legs = path.size() - 1;
  EXPECT_GT(2 * hidden_frames, legs) << "the walk hid tiles on " << hidden_frames << " of " << legs
                                     << " legs";
  EXPECT_GT(be->evaluation_stats().tiles_hidden, 0u);
  std::printf("  %s (%s): %zu legs, %.1f of %zu blocks visible on average, tiles hidden %llu\n",
              be->description(), converged ? "converged" : "3 bounces", legs,
              double(visible_total) / double(legs), t.level.blocks.size(),
              (unsigned long long)be->evaluation_stats().tiles_hidden);
}

// With clutter the DRT deltas and the clutter lightmap are computed for every block as before
// (they are sums over the whole level); the visible blocks' outputs equal the full path's.
TEST_P(BackendConformance, CameraSkipWithClutterKeepsVisibleBlocksExact) {
  const DrtFixture& f = drt_fixture();
  std::unique_ptr<Backend> be = make(f.level), full = make(f.level);
  ASSERT_TRUE(be && full);
  ASSERT_TRUE(be->set_clutter(&f.drt).ok());
  ASSERT_TRUE(full->set_clutter(&f.drt).ok());
  std::vector<std::uint8_t> visible(f.level.blocks.size(), 0);
  visible[0] = 1;
  ASSERT_TRUE(be->set_visible_blocks(visible).ok());
  std::vector<float> ld = f.ld;
  for (int frame = 0; frame < 3; ++frame) {
    for (std::size_t i = std::size_t(frame); i < ld.size(); i += 3) ld[i] *= 1.2f;
    ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
    ASSERT_TRUE(full->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
    ASSERT_TRUE(be->update(ld).ok());
    ASSERT_TRUE(full->update(ld).ok());
    const std::string mismatch =
        visible_block_mismatch(f.level, read_outputs(*be), read_outputs(*full), visible);
    ASSERT_TRUE(mismatch.empty()) << be->description() << " frame " << frame << ": " << mismatch;
    const DrtBufferSizes d = drt_buffer_sizes(f.drt);
    std::vector<float> ca(d.clutter_lightmap), cb(d.clutter_lightmap);
    ASSERT_TRUE(be->read_clutter_lightmap(ca).ok());
    ASSERT_TRUE(full->read_clutter_lightmap(cb).ok());
    EXPECT_EQ(ca, cb) << "frame " << frame;
  }
  EXPECT_GT(be->evaluation_stats().tiles_hidden, 0u);
  ASSERT_TRUE(be->set_visible_blocks({}).ok());
  EXPECT_EQ(read_outputs(*be).atlas, read_outputs(*full).atlas) << "every block visible again";
}

// A visible set of the wrong size is refused naming both sizes, and nothing changes: the next
// frames still show every block as the full path does.
TEST_P(BackendConformance, BadVisibleSetIsRefusedAndChangesNothing) {
  const TestLevel& t = test_level("maze11");
  std::unique_ptr<Backend> be = make(t.level), full = make(t.level);
  ASSERT_TRUE(be && full);
  ASSERT_TRUE(be->update(t.ld).ok());
  const std::vector<std::uint8_t> short_set(t.level.blocks.size() - 1, 0),
      long_set(t.level.blocks.size() + 1, 0);
  for (const std::vector<std::uint8_t>* bad : {&short_set, &long_set}) {
    const Status s = be->set_visible_blocks(*bad);
    EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
    EXPECT_NE(s.message().find("visible has " + std::to_string(bad->size()) + " flags, expected " +
                               std::to_string(t.level.blocks.size())),
              std::string::npos)
        << s.message();
  }
  std::vector<float> ld = t.ld;
  for (float& v : ld) v *= 0.5f;
  ASSERT_TRUE(be->update(ld).ok());
  ASSERT_TRUE(full->update(ld).ok());
  EXPECT_EQ(read_outputs(*be).atlas, read_outputs(*full).atlas);
  EXPECT_EQ(be->evaluation_stats().tiles_hidden, 0u);
}

// ---- DRT: clutter inside the blocks ----

// With clutter every stage gets its delta (architecture.md §6): lightmap += dUb b + dUc c
// (atlas included), the probes Udyn b + Udyn_c c, the vector irradiance dUb_vec b + dUc_vec c;
// the clutter lightmap is Cb b + Cc c + direct. Each part is large enough to fail if missing.
// The same with the real-radiance gather (Gs x_s + Gt x_t, Ht x_t - Hs x_s).
TEST_P(BackendConformance, ClutterMatchesScalarReference) {
  for (const bool gather : {false, true}) {
    SCOPED_TRACE(gather ? "gather" : "Limp");
    check_clutter_matches_scalar_reference(gather);
  }
}

void BackendConformance::check_clutter_matches_scalar_reference(bool gather) {
  const DrtFixture& f = drt_fixture(gather);
  for (const DrtObjectOperators& o : f.drt.objects) {  // the box and the pillar see each other
    ASSERT_FALSE(gather ? o.Gt.empty() : o.Cc.empty());
    ASSERT_EQ(o.has_gather(), gather);
    ASSERT_EQ(o.Uc.empty(), gather);
  }
  const DrtReference ref = drt_reference(f, f.ld, f.clutter_ld);
  const std::vector<float> delta_ref = minus(ref.lightmap, ref.mrt);
  EXPECT_GT(rel_l2(ref.clutter_without_cc, ref.clutter), effect_floor(tolerance()))
      << "Cc c is too small to test";
  EXPECT_GT(rel_l2(ref.probes_mrt, ref.probes), effect_floor(tolerance())) << "U_dyn is too small to test";
  EXPECT_GT(rel_l2(ref.vector_mrt, ref.vector), effect_floor(tolerance())) << "dUb_vec is too small to test";
  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  ASSERT_TRUE(be->update(f.ld).ok());
  const std::vector<float> mrt = read_outputs(*be).lightmap;
  const Status st = be->set_clutter(&f.drt);
  ASSERT_TRUE(st.ok()) << st.to_string();
  ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  std::vector<float> clutter(be->clutter_sizes().clutter_lightmap);
  for (int frame = 0; frame < 2; ++frame) {  // the second frame repeats the first
    ASSERT_TRUE(be->update(f.ld).ok());
    const Outputs o = read_outputs(*be);
    ASSERT_TRUE(be->read_clutter_lightmap(clutter).ok());
    const double el = rel_l2(o.lightmap, ref.lightmap), ea = rel_l2(o.atlas, ref.atlas),
                 ed = rel_l2(minus(o.lightmap, mrt), delta_ref), ec = rel_l2(clutter, ref.clutter),
                 ep = rel_l2(o.probes, ref.probes), ev = rel_l2(o.vector, ref.vector);
    EXPECT_LE(el, tolerance().drt) << be->description() << " lightmap";
    EXPECT_LE(ea, tolerance().drt) << be->description() << " atlas";
    EXPECT_LE(ed, tolerance().delta) << be->description() << " delta";
    EXPECT_LE(ec, tolerance().drt) << be->description() << " clutter lightmap";
    EXPECT_LE(ep, tolerance().drt) << be->description() << " probes";
    EXPECT_LE(ev, tolerance().drt) << be->description() << " vector irradiance";
    if (frame == 0)
      std::printf(
          "  %-52s rel L2: lightmap %.2e atlas %.2e delta %.2e clutter lightmap %.2e probes %.2e "
          "vector %.2e\n",
          be->description(), el, ea, ed, ec, ep, ev);
  }
  if (be->kind() == BackendKind::gles) {
    EXPECT_NE(be->output_texture(BackendOutput::clutter_atlas), 0u);
    const TextureSize size = be->clutter_atlas_size();
    EXPECT_GT(size.width, 0);
    const std::array<int, 2> texel = be->clutter_atlas_texel(1, 0);
    EXPECT_TRUE(texel[0] >= 0 && texel[0] < size.width && texel[1] >= 0 && texel[1] < size.height);
  }
}

// A new clutter light alone (same ld) is not a skipped frame, and a change of one block's ld
// reaches the deltas of the others (a delta reads other blocks' b through the openings).
TEST_P(BackendConformance, ClutterLightAndOneBlocksLdReachEveryDelta) {
  for (const bool gather : {false, true}) {
    SCOPED_TRACE(gather ? "gather" : "Limp");
    check_clutter_light_and_ld_reach_every_delta(gather);
  }
}

void BackendConformance::check_clutter_light_and_ld_reach_every_delta(bool gather) {
  const DrtFixture& f = drt_fixture(gather);
  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  ASSERT_TRUE(be->set_clutter(&f.drt).ok());
  ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ASSERT_TRUE(be->update(f.ld).ok());
  std::vector<float> clutter_ld2 = f.clutter_ld;
  for (float& v : clutter_ld2) v *= 0.25f;
  ASSERT_TRUE(be->set_clutter_light(clutter_ld2, f.clutter_direct).ok());
  ASSERT_TRUE(be->update(f.ld).ok());
  std::vector<float> atlas(be->sizes().atlas), clutter(be->clutter_sizes().clutter_lightmap);
  ASSERT_TRUE(be->read_atlas(atlas).ok());
  ASSERT_TRUE(be->read_clutter_lightmap(clutter).ok());
  const DrtReference ref2 = drt_reference(f, f.ld, clutter_ld2);
  EXPECT_LE(rel_l2(atlas, ref2.atlas), tolerance().drt) << be->description();
  EXPECT_LE(rel_l2(clutter, ref2.clutter), tolerance().drt) << be->description();
  std::vector<float> ld2 = f.ld;
  const LevelBlock& mid = f.level.blocks[1];
  for (std::size_t i = 3 * mid.sample_offset; i < 3 * (mid.sample_offset + mid.sample_count); ++i)
    ld2[i] *= 3.0f;
  ASSERT_TRUE(be->update(ld2).ok());
  ASSERT_TRUE(be->read_atlas(atlas).ok());
  EXPECT_LE(rel_l2(atlas, drt_reference(f, ld2, clutter_ld2).atlas), tolerance().drt) << be->description();
}

// multi_bounce_step with clutter equals core's drt_multi_bounce after k iterations (the
// feedback reads the lightmap with its delta); the probes and vector irradiance carry their
// deltas after the same feedback.
TEST_P(BackendConformance, ClutterMultiBounceMatchesDrtMultiBounce) {
  for (const bool gather : {false, true}) {
    SCOPED_TRACE(gather ? "gather" : "Limp");
    check_clutter_multi_bounce(gather);
  }
}

void BackendConformance::check_clutter_multi_bounce(bool gather) {
  constexpr int kSteps = 4;
  const DrtFixture& f = drt_fixture(gather);
  const LevelBufferSizes s = level_buffer_sizes(f.level, dict());
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  std::vector<float> b(s.b), r(s.r), ref(s.lightmap), c(d.c), clutter_ref(d.clutter_lightmap);
  MultiBounceSettings settings;
  settings.max_iterations = kSteps;
  settings.tolerance = 0.0f;
  std::vector<float> last_ld(s.ld), last_x(d.clutter_ld);
  const Result<MultiBounceReport> rep = drt_multi_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld,
                                                         {}, settings, b, r, ref, c, last_ld, last_x);
  ASSERT_TRUE(rep.ok()) << rep.status().to_string();
  ASSERT_EQ(rep->iterations, kSteps);
  drt_evaluate_clutter_lightmap(f.drt, b, c, last_ld, last_x, f.clutter_direct, clutter_ref);
  std::vector<float> b0(s.b), r0(s.r), mrt(s.lightmap);
  ASSERT_TRUE(level_multi_bounce(f.level, dict(), f.ld, f.albedo, settings, b0, r0, mrt).ok());
  EXPECT_GT(rel_l2(mrt, ref), effect_floor(tolerance())) << "the delta should change the feedback";
  std::vector<float> probe_ref(s.probes), vector_ref(s.vector_lightmap);
  level_compute_probes(f.level, dict(), b, r, probe_ref);
  drt_apply_probes(f.drt, b, c, probe_ref);
  ASSERT_TRUE(level_compute_vector_irradiance(f.level, dict(), b, r, vector_ref).ok());
  drt_apply_vector(f.level, f.drt, b, c, vector_ref);

  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  ASSERT_TRUE(be->set_clutter(&f.drt).ok());
  ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ASSERT_TRUE(be->set_albedo(f.albedo, settings.max_albedo).ok());
  ASSERT_TRUE(be->update(f.ld).ok());
  ASSERT_TRUE(be->update(f.ld).ok());  // a repeated frame changes nothing
  for (int k = 0; k < kSteps; ++k) ASSERT_TRUE(be->multi_bounce_step(f.ld).ok()) << be->description();
  const Outputs o = read_outputs(*be);
  std::vector<float> clutter(d.clutter_lightmap);
  ASSERT_TRUE(be->read_clutter_lightmap(clutter).ok());
  const double e = rel_l2(o.lightmap, ref), ec = rel_l2(clutter, clutter_ref),
               ep = rel_l2(o.probes, probe_ref), ev = rel_l2(o.vector, vector_ref);
  EXPECT_LE(e, tolerance().drt) << be->description();
  EXPECT_LE(ec, tolerance().drt) << be->description();
  EXPECT_LE(ep, tolerance().drt) << be->description();
  EXPECT_LE(ev, tolerance().drt) << be->description();
  std::printf(
      "  %-52s multi-bounce x%d with DRT rel L2 %.2e, clutter lightmap %.2e, probes %.2e, vector %.2e\n",
      be->description(), kSteps, e, ec, ep, ev);
}

// With the clutter's albedo each step also feeds the clutter's indirect light back through c
// (drt_multi_bounce with clutter_albedo); update() then starts again from its direct light.
TEST_P(BackendConformance, ClutterFeedbackMatchesDrtMultiBounce) {
  for (const bool gather : {false, true}) {
    SCOPED_TRACE(gather ? "gather" : "Limp");
    check_clutter_feedback(gather);
  }
}

void BackendConformance::check_clutter_feedback(bool gather) {
  constexpr int kSteps = 3;
  const DrtFixture& f = drt_fixture(gather);
  const LevelBufferSizes s = level_buffer_sizes(f.level, dict());
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  std::mt19937 rng(31);
  const std::vector<float> clutter_albedo = random_vector(rng, d.clutter_ld, 0.2f, 0.99f);  // some clamped
  MultiBounceSettings settings;
  settings.max_iterations = kSteps;
  settings.tolerance = 0.0f;
  std::vector<float> b(s.b), r(s.r), ref(s.lightmap), c(d.c), clutter_ref(d.clutter_lightmap);
  std::vector<float> last_ld(s.ld), last_x(d.clutter_ld);
  ASSERT_TRUE(drt_multi_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld, clutter_albedo, settings,
                               b, r, ref, c, last_ld, last_x)
                  .ok());
  drt_evaluate_clutter_lightmap(f.drt, b, c, last_ld, last_x, f.clutter_direct, clutter_ref);
  std::vector<float> plain(s.lightmap), c_plain(d.c);
  ASSERT_TRUE(drt_multi_bounce(f.level, dict(), f.drt, f.ld, f.albedo, f.clutter_ld, {}, settings, b, r,
                               plain, c_plain)
                  .ok());
  EXPECT_GT(rel_l2(plain, ref), effect_floor(tolerance())) << "the clutter's bounce should show";
  const DrtReference one = drt_reference(f, f.ld, f.clutter_ld);

  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  EXPECT_EQ(be->set_clutter_albedo(clutter_albedo).code(), ErrorCode::invalid_argument) << "no clutter yet";
  ASSERT_TRUE(be->set_clutter(&f.drt).ok());
  ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ASSERT_TRUE(be->set_albedo(f.albedo, settings.max_albedo).ok());
  std::vector<float> bad = clutter_albedo;
  bad[7] = std::nanf("");
  EXPECT_EQ(be->set_clutter_albedo(bad).code(), ErrorCode::non_finite);
  bad.pop_back();
  EXPECT_EQ(be->set_clutter_albedo(bad).code(), ErrorCode::invalid_argument);
  ASSERT_TRUE(be->set_clutter_albedo(clutter_albedo, settings.max_albedo).ok());
  ASSERT_TRUE(be->update(f.ld).ok());
  for (int k = 0; k < kSteps; ++k) ASSERT_TRUE(be->multi_bounce_step(f.ld).ok()) << be->description();
  std::vector<float> lightmap(s.lightmap), clutter(d.clutter_lightmap);
  ASSERT_TRUE(be->read_lightmap(lightmap).ok());
  ASSERT_TRUE(be->read_clutter_lightmap(clutter).ok());
  const double e = rel_l2(lightmap, ref), ec = rel_l2(clutter, clutter_ref);
  EXPECT_LE(e, tolerance().drt) << be->description();
  EXPECT_LE(ec, tolerance().drt) << be->description();
  ASSERT_TRUE(be->update(f.ld).ok());  // a new frame: one bounce from the clutter's direct light
  ASSERT_TRUE(be->read_lightmap(lightmap).ok());
  ASSERT_TRUE(be->read_clutter_lightmap(clutter).ok());
  EXPECT_LE(rel_l2(lightmap, one.lightmap), tolerance().drt) << be->description();
  EXPECT_LE(rel_l2(clutter, one.clutter), tolerance().drt) << be->description();
  std::printf("  %-52s multi-bounce x%d with clutter feedback rel L2 %.2e, clutter lightmap %.2e\n",
              be->description(), kSteps, e, ec);
}

// No frame allocates (operator new), on any path of the pipeline: an update that changes ld,
// one that repeats it (skipped), a feedback step, reads; with clutter also its light, albedo,
// the clutter feedback and the clutter lightmap's read. The first round warms up (shaders).
TEST_P(BackendConformance, FramesAllocateNothing) {
  const DrtFixture& f = drt_fixture();
  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  std::vector<float> ld2 = f.ld;
  for (std::size_t i = 0; i < ld2.size() / 7; ++i) ld2[i] *= 1.5f;  // the first block(s) change
  const std::vector<float> clutter_albedo(d.clutter_ld, 0.5f);
  std::vector<float> lightmap(be->sizes().lightmap), clutter(d.clutter_lightmap);
  const auto frames = [&](bool with_clutter) {
    bool ok = be->update(f.ld).ok() && be->update(ld2).ok() && be->update(ld2).ok() &&
              be->multi_bounce_step(ld2).ok() && be->read_lightmap(lightmap).ok();
    if (with_clutter)
      ok = ok && be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok() &&
           be->set_clutter_albedo(clutter_albedo).ok() && be->update(f.ld).ok() &&
           be->multi_bounce_step(f.ld).ok() && be->read_clutter_lightmap(clutter).ok();
    // The converged solve (with and without clutter) once its operators are built (warm-up).
    if (be->converged_available())
      ok = ok && be->update_converged(ld2).ok() && be->update_converged(f.ld).ok();
    return ok;
  };
  const auto allocations = [&](bool with_clutter) {
    g_allocations = 0;
    g_count_allocations = true;
    const bool ok = frames(with_clutter);
    g_count_allocations = false;
    EXPECT_TRUE(ok) << be->description();
    return g_allocations.load();
  };
  ASSERT_TRUE(be->set_albedo(f.albedo).ok());
  ASSERT_TRUE(frames(false));
  EXPECT_EQ(allocations(false), 0) << be->description() << ": without clutter";
  ASSERT_TRUE(be->set_clutter(&f.drt).ok());
  ASSERT_TRUE(frames(true));
  // The reference's DRT stages are core's drt.h functions, which keep per-call scratch vectors
  // (reference_backend.h); the backends an app runs allocate nothing.
  if (be->kind() != BackendKind::reference) {
    EXPECT_EQ(allocations(true), 0) << be->description() << ": with clutter";
  }
  // And with the real-radiance gather (same scene; its converged update's feedback steps).
  ASSERT_TRUE(be->set_clutter(&drt_fixture(true).drt).ok());
  ASSERT_TRUE(frames(true));
  if (be->kind() != BackendKind::reference) {
    EXPECT_EQ(allocations(true), 0) << be->description() << ": with the gather";
  }
}

// The clutter's vector irradiance (Uc_vec (Vc_vec b) + Cc_vec c, DRT §5) from the last
// update's b and c.
TEST_P(BackendConformance, ClutterVectorLightmapMatchesCore) {
  const DrtFixture& f = drt_fixture();
  const DrtBufferSizes d = drt_buffer_sizes(f.drt);
  ASSERT_FALSE(f.drt.objects[0].Uc_vec.empty());
  const DrtReference one = drt_reference(f, f.ld, f.clutter_ld);
  std::vector<float> c(d.c), ref(d.clutter_vector_lightmap);
  ASSERT_TRUE(drt_compute_c(f.drt, f.clutter_ld, c).ok());
  drt_clutter_vector_lightmap(f.drt, one.b, c, ref);
  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  std::vector<float> out(d.clutter_vector_lightmap);
  EXPECT_EQ(be->read_clutter_vector_lightmap(out).code(), ErrorCode::invalid_argument) << "no clutter yet";
  ASSERT_TRUE(be->set_clutter(&f.drt).ok());
  ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ASSERT_TRUE(be->update(f.ld).ok());
  ASSERT_TRUE(be->read_clutter_vector_lightmap(out).ok()) << be->description();
  const double e = rel_l2(out, ref);
  EXPECT_LE(e, tolerance().drt) << be->description();
  std::printf("  %-52s clutter vector lightmap rel L2 %.2e\n", be->description(), e);
  std::vector<float> wrong(d.clutter_vector_lightmap + 1);
  EXPECT_EQ(be->read_clutter_vector_lightmap(wrong).code(), ErrorCode::invalid_argument);
}

// The clutter lightmap is a lightmap: never negative. With Uc negated most texels of
// Cb b + Cc c + direct are negative before the clamp (asserted, so the test can fail).
TEST_P(BackendConformance, ClutterLightmapIsNeverNegative) {
  const DrtFixture& f = drt_fixture();
  DrtOperators negated = f.drt;
  for (DrtObjectOperators& o : negated.objects)
    for (float& v : o.Uc.data) v = -v;
  const DrtBufferSizes d = drt_buffer_sizes(negated);
  const LevelBufferSizes ls = level_buffer_sizes(f.level, dict());
  std::vector<float> b(ls.b), r(ls.r), lm(ls.lightmap), c(d.c), raw(d.clutter_lightmap),
      ref(d.clutter_lightmap);
  ASSERT_TRUE(level_evaluate(f.level, dict(), f.ld, b, r, lm).ok());
  ASSERT_TRUE(drt_compute_c(negated, f.clutter_ld, c).ok());
  drt_clutter_lightmap(negated, b, f.clutter_direct, raw);
  drt_clutter_add_cc(negated, c, raw);
  std::size_t negative = 0;
  for (float v : raw) negative += v < 0.0f;
  ASSERT_GT(negative, raw.size() / 4) << "the negated operators should ring negative";
  drt_evaluate_clutter_lightmap(negated, b, c, f.ld, f.clutter_ld, f.clutter_direct, ref);
  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  ASSERT_TRUE(be->set_clutter(&negated).ok());
  ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ASSERT_TRUE(be->update(f.ld).ok());
  std::vector<float> out(d.clutter_lightmap);
  ASSERT_TRUE(be->read_clutter_lightmap(out).ok());
  for (float v : out) ASSERT_GE(v, 0.0f) << be->description();
  EXPECT_LE(rel_l2(out, ref), tolerance().drt) << be->description();
}

// Operators built without U_dyn add nothing to the probes, whatever probe grid their file names
// (a .modrtdrt from another dictionary's grid): set_clutter and the frames succeed, the probes
// are the MRT ones and the lightmap still gets its delta.
TEST_P(BackendConformance, ClutterWithoutUdynLeavesTheProbesOfAnyGrid) {
  const DrtFixture& f = drt_fixture();
  DrtOperators no_udyn = f.drt;
  for (DrtObjectOperators& o : no_udyn.objects) {
    o.Udyn_probe.clear(), o.Udyn_block.clear(), o.Udyn_c_probe.clear();
    o.Udyn = {}, o.Udyn_c = {};
  }
  no_udyn.probes_per_block = 27;  // not the dictionary's 2^3
  const DrtReference ref = drt_reference(f, f.ld, f.clutter_ld);
  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  const Status st = be->set_clutter(&no_udyn);
  ASSERT_TRUE(st.ok()) << be->description() << ": " << st.to_string();
  ASSERT_TRUE(be->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  const Status su = be->update(f.ld);
  ASSERT_TRUE(su.ok()) << be->description() << ": " << su.to_string();
  const Outputs o = read_outputs(*be);
  EXPECT_LE(rel_l2(o.probes, ref.probes_mrt), tolerance().drt) << be->description();
  EXPECT_LE(rel_l2(o.lightmap, ref.lightmap), tolerance().drt) << be->description();
}

// No clutter (never set, removed, or empty operators) runs no DRT stage and leaves every result
// bit-identical to a backend that never had any.
TEST_P(BackendConformance, NoClutterIsBitIdenticalAndCostsNothing) {
  const DrtFixture& f = drt_fixture();
  std::unique_ptr<Backend> plain = make(f.level), removed = make(f.level), empty = make(f.level);
  ASSERT_TRUE(plain && removed && empty);
  plain->set_timing(true);
  ASSERT_TRUE(plain->update(f.ld).ok());
  EXPECT_EQ(plain->stage_times().drt, 0u);
  EXPECT_EQ(plain->stage_times().clutter, 0u);
  ASSERT_TRUE(removed->set_clutter(&f.drt).ok());
  ASSERT_TRUE(removed->set_clutter_light(f.clutter_ld, f.clutter_direct).ok());
  ASSERT_TRUE(removed->update(f.ld).ok());
  ASSERT_TRUE(removed->set_clutter(nullptr).ok());
  EXPECT_EQ(removed->output_texture(BackendOutput::clutter_atlas), 0u);
  EXPECT_EQ(removed->clutter_sizes().clutter_lightmap, 0u);
  ASSERT_TRUE(removed->update(f.ld).ok());
  const DrtOperators none;
  ASSERT_TRUE(empty->set_clutter(&none).ok());
  EXPECT_EQ(empty->output_texture(BackendOutput::clutter_atlas), 0u);
  EXPECT_EQ(empty->clutter_sizes().clutter_lightmap, 0u);
  ASSERT_TRUE(empty->update(f.ld).ok());
  std::vector<float> clutter(1);
  EXPECT_EQ(empty->read_clutter_lightmap(clutter).code(), ErrorCode::invalid_argument);
  EXPECT_EQ(empty->set_clutter_light({}, {}).code(), ErrorCode::invalid_argument);
  EXPECT_EQ(read_outputs(*plain).atlas, read_outputs(*removed).atlas);
  EXPECT_EQ(read_outputs(*plain).atlas, read_outputs(*empty).atlas);
  EXPECT_EQ(read_outputs(*plain).probes, read_outputs(*removed).probes);
}

// Operators that do not fit the level and clutter light with NaN or the wrong size are refused.
TEST_P(BackendConformance, BadClutterInputIsRefused) {
  const DrtFixture& f = drt_fixture();
  std::unique_ptr<Backend> be = make(f.level);
  ASSERT_TRUE(be);
  DrtOperators wrong = f.drt;
  wrong.objects[0].dUb_sample[0] = f.level.sample_count;  // out of range
  const Status s = be->set_clutter(&wrong);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("object 0"), std::string::npos) << s.message();
  EXPECT_EQ(be->set_clutter_light(f.clutter_ld, f.clutter_direct).code(), ErrorCode::invalid_argument)
      << "no clutter set";
  ASSERT_TRUE(be->set_clutter(&f.drt).ok());
  std::vector<float> bad = f.clutter_ld;
  bad[5] = std::nanf("");
  EXPECT_EQ(be->set_clutter_light(bad, {}).code(), ErrorCode::non_finite);
  bad.pop_back();
  EXPECT_EQ(be->set_clutter_light(bad, {}).code(), ErrorCode::invalid_argument);
  EXPECT_EQ(be->set_clutter_light(f.clutter_ld, std::vector<float>(3)).code(), ErrorCode::invalid_argument);
}

INSTANTIATE_TEST_SUITE_P(Backends, BackendConformance, ::testing::ValuesIn(backend_cases()), case_name);

}  // namespace
}  // namespace modrt::test
