// SIMD CPU backend (cpu_neon/): every kernel and the level runtime against core's scalar
// reference, for every ISA this CPU supports (Embree verify style: for (isa : isas)); no
// allocation per frame; bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "level_fixtures.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/cpu/kernels.h"
#include "modrt/level_runtime.h"
#include "modrt/reference_runtime.h"

// ---- counting replaceable global allocation functions (this test binary only) ----
namespace {
std::atomic<bool> g_count_allocations{false};
std::atomic<long> g_allocations{0};

void* counted_alloc(std::size_t n) {
  if (g_count_allocations.load(std::memory_order_relaxed))
    g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n ? n : 1);
}
void* counted_aligned_alloc(std::size_t n, std::align_val_t al) {
  if (g_count_allocations.load(std::memory_order_relaxed))
    g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t a = std::max(std::size_t(al), sizeof(void*));
  return std::aligned_alloc(a, (std::max<std::size_t>(n, 1) + a - 1) / a * a);
}
// Out of line so that GCC, inlining a delete next to its new, does not see malloc/free pairs
// cross operator new/delete (-Wmismatched-new-delete).
[[gnu::noinline]] void counted_free(void* p) noexcept { std::free(p); }
}  // namespace

void* operator new(std::size_t n) {
  if (void* p = counted_alloc(n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  if (void* p = counted_alloc(n)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return counted_alloc(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return counted_alloc(n); }
void* operator new(std::size_t n, std::align_val_t al) {
  if (void* p = counted_aligned_alloc(n, al)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t al) {
  if (void* p = counted_aligned_alloc(n, al)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { counted_free(p); }
void operator delete[](void* p) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t) noexcept { counted_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { counted_free(p); }

namespace modrt::cpu {
namespace {

constexpr double kRelTolerance = 1e-5;
// Per-element floor as a fraction of the reference's RMS: an element that cancels to below
// it is judged against it (float accumulation cannot resolve deeper cancellation).
constexpr double kFloor = 0.1;

struct Error {
  double rel_l2 = 0.0;       // ||got - ref|| / ||ref||
  double max_element = 0.0;  // max |got - ref| / max(|ref|, floor)
};

// Per-element errors are relative to max(|ref_i|, kFloor x RMS(ref)).
// `scale` (optional, per element) raises the floor to kScaleFloor x scale_i; see the b check.
constexpr double kScaleFloor = 0.01;
Error compare(std::span<const float> got, std::span<const float> ref, std::span<const double> scale = {}) {
  EXPECT_EQ(got.size(), ref.size());
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    num += (double(got[i]) - ref[i]) * (double(got[i]) - ref[i]);
    den += double(ref[i]) * ref[i];
  }
  Error e;
  if (ref.empty()) return e;
  e.rel_l2 = den > 0.0 ? std::sqrt(num / den) : std::sqrt(num);
  const double floor = std::max(kFloor * std::sqrt(den / double(ref.size())), 1e-30);
  for (std::size_t i = 0; i < ref.size(); ++i)
    e.max_element = std::max(e.max_element, std::abs(double(got[i]) - ref[i]) /
                                                std::max({std::abs(double(ref[i])), floor,
                                                          scale.empty() ? 0.0 : kScaleFloor * scale[i]}));
  return e;
}

// Worst errors seen per ISA, printed at the end of each test for the record.
struct Worst {
  double rel_l2 = 0.0, max_element = 0.0;
  void add(const Error& e) {
    rel_l2 = std::max(rel_l2, e.rel_l2);
    max_element = std::max(max_element, e.max_element);
  }
  void print(const char* what, Isa isa) const {
    std::printf("  %-28s %-6s rel L2 %.3g, max element %.3g\n", what, isa_name(isa), rel_l2, max_element);
  }
};

void expect_close(std::span<const float> got, std::span<const float> ref, const std::string& what,
                  Worst* worst, std::span<const double> scale = {}) {
  const Error e = compare(got, ref, scale);
  if (worst) worst->add(e);
  EXPECT_LE(e.rel_l2, kRelTolerance) << what;
  EXPECT_LE(e.max_element, kRelTolerance) << what;
}

std::vector<float> random_vector(std::mt19937& rng, std::size_t n, float lo, float hi) {
  std::uniform_real_distribution<float> d(lo, hi);
  std::vector<float> v(n);
  for (float& x : v) x = d(rng);
  return v;
}

Matrix random_matrix(std::mt19937& rng, std::uint32_t rows, std::uint32_t cols) {
  Matrix m(rows, cols);
  m.data = random_vector(rng, m.data.size(), -1.0f, 1.0f);
  return m;
}

const std::vector<std::uint32_t> kRowSizes = {0, 1, 2, 3, 4, 5, 7, 8, 9, 12, 13, 16, 17, 31, 33, 64};
const std::vector<std::uint32_t> kColSizes = {0, 1, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 32, 33, 100, 1537};

TEST(CpuKernels, SupportedIsasStartWithScalarAndCanBeForced) {
  const std::vector<Isa> isas = supported_isas();
  ASSERT_FALSE(isas.empty());
  EXPECT_EQ(isas.front(), Isa::scalar);
  EXPECT_EQ(best_isa(), isas.back());
  std::printf("  supported ISAs:");
  for (Isa isa : isas) std::printf(" %s", isa_name(isa));
  std::printf("\n");
  const Isa before = active_isa();
  for (Isa isa : isas) {
    EXPECT_TRUE(set_isa(isa));
    EXPECT_EQ(active_isa(), isa);
  }
  for (Isa isa : {Isa::scalar, Isa::sse41, Isa::avx2, Isa::neon}) {
    if (!isa_supported(isa)) {
      EXPECT_FALSE(set_isa(isa)) << isa_name(isa);
    }
  }
  EXPECT_TRUE(set_isa(before));
#if defined(MODRT_NO_SIMD)
  EXPECT_EQ(isas.size(), 1u);
#endif
}

TEST(CpuKernels, GemvMatchesReferenceForEveryIsaAndSize) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(1234);
    Worst worst;
    for (std::uint32_t rows : kRowSizes)
      for (std::uint32_t cols : kColSizes)
        for (bool accumulate : {false, true}) {
          const Matrix A = random_matrix(rng, rows, cols);
          const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
          std::vector<float> ref = random_vector(rng, 3 * std::size_t(rows), 0.0f, 1.0f);
          std::vector<float> got = ref;
          reference_gemv_rgb(A, in.data(), ref.data(), accumulate);
          std::vector<float> scratch(gemv_scratch_bound(cols));
          gemv_rgb_interleaved(isa, A, in.data(), got.data(), accumulate, scratch);
          expect_close(got, ref,
                       std::string(isa_name(isa)) + " " + std::to_string(rows) + "x" + std::to_string(cols) +
                           (accumulate ? " accumulate" : ""),
                       &worst);
        }
    worst.print("gemv_rgb", isa);
  }
}

// Leading dimension > cols and a planar stride > cols (the padded layouts a caller may keep).
TEST(CpuKernels, GemvHonoursLeadingDimensionAndStride) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(99);
    for (std::uint32_t rows : {1u, 5u, 13u})
      for (std::uint32_t cols : {1u, 7u, 9u, 33u}) {
        const Matrix A = random_matrix(rng, rows, cols);
        const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
        const std::size_t lda = cols + 5, stride = cols + 3;
        std::vector<float> padded(rows * lda, std::numeric_limits<float>::quiet_NaN());
        for (std::uint32_t r = 0; r < rows; ++r)
          std::copy_n(&A.data[r * std::size_t(cols)], cols, &padded[r * lda]);
        std::vector<float> planar(3 * stride, std::numeric_limits<float>::quiet_NaN());
        deinterleave_rgb(in.data(), cols, planar.data(), stride);
        std::vector<float> ref(3 * std::size_t(rows)), got(ref.size());
        reference_gemv_rgb(A, in.data(), ref.data(), false);
        gemv_rgb(isa, padded.data(), rows, cols, lda, planar.data(), stride, got.data(), false);
        expect_close(got, ref, std::string(isa_name(isa)) + " padded", nullptr);
      }
  }
}

TEST(CpuKernels, ScatterMatchesReferenceForEveryIsaAndSize) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(77);
    Worst worst;
    for (std::uint32_t rows : kRowSizes)
      for (std::uint32_t cols : kColSizes) {
        if (cols > 100) continue;
        const Matrix A = random_matrix(rng, rows, cols);
        const std::vector<float> in = random_vector(rng, 3 * std::size_t(cols), 0.0f, 1.0f);
        // Rows land on a shuffled subset of 2 x rows destination samples; about a third are -1.
        const std::size_t samples = 2 * std::size_t(rows) + 1;
        std::vector<std::int32_t> perm(samples);
        for (std::size_t i = 0; i < samples; ++i) perm[i] = std::int32_t(i);
        std::shuffle(perm.begin(), perm.end(), rng);
        std::vector<std::int32_t> map(rows);
        for (std::uint32_t r = 0; r < rows; ++r) map[r] = rng() % 3 == 0 ? -1 : perm[r];
        if (rows >= 8) std::fill(map.begin(), map.begin() + 4, -1);  // a whole skipped 4-row group
        std::vector<float> ref = random_vector(rng, 3 * samples, 0.0f, 1.0f);
        std::vector<float> got = ref;
        for (std::uint32_t r = 0; r < rows; ++r) {
          if (map[r] < 0) continue;
          for (int c = 0; c < 3; ++c) {
            double acc = 0.0;
            for (std::uint32_t k = 0; k < cols; ++k) acc += double(A(r, k)) * in[3 * k + std::size_t(c)];
            ref[3 * std::size_t(map[r]) + std::size_t(c)] += float(acc);
          }
        }
        std::vector<float> planar(3 * std::size_t(cols));
        deinterleave_rgb(in.data(), cols, planar.data(), cols);
        gemv_rgb_scatter(isa, A.data.data(), rows, cols, cols, map.data(), planar.data(), cols, got.data());
        expect_close(
            got, ref,
            std::string(isa_name(isa)) + " scatter " + std::to_string(rows) + "x" + std::to_string(cols),
            &worst);
      }
    worst.print("gemv_rgb_scatter", isa);
  }
}

TEST(CpuKernels, FeedbackIsBitIdenticalToReference) {
  for (Isa isa : supported_isas()) {
    std::mt19937 rng(5);
    for (std::size_t samples : {0u, 1u, 2u, 3u, 5u, 11u, 16u, 33u, 1000u}) {
      const std::size_t n = 3 * samples;
      FeedbackClamp clamp;
      clamp.rho = random_vector(rng, n, 0.0f, 0.95f);
      clamp.energy_bound = 2.0f;
      const std::vector<float> ld_direct = random_vector(rng, n, 0.0f, 1.0f);
      for (const float hi : {1.5f, 4.0f}) {  // without and with values above the bound
        const std::vector<float> lightmap = random_vector(rng, n, -0.5f, hi);
        std::vector<float> ref(n), got(n);
        const bool ref_clamped = apply_feedback(clamp, ld_direct, lightmap, ref);
        const bool got_clamped = feedback_rgb(isa, ld_direct.data(), clamp.rho.data(), lightmap.data(),
                                              clamp.energy_bound, got.data(), n);
        EXPECT_EQ(got_clamped, ref_clamped) << isa_name(isa) << " " << samples;
#if defined(__x86_64__)
        EXPECT_EQ(got, ref) << isa_name(isa) << " " << samples;
#else  // core's apply_feedback may be FMA-contracted by the compiler here: one rounding apart
        for (std::size_t i = 0; i < n; ++i) EXPECT_NEAR(got[i], ref[i], 2.5e-7f * std::abs(ref[i])) << i;
#endif
      }
    }
  }
}

TEST(CpuKernels, PaddingCopiesInRecordOrder) {
  // 4 texels; record 2 reads texel 1, written by record 1: order matters.
  std::vector<float> atlas = {1, 2, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  const std::vector<PaddingRecord> records = {{1, 0}, {2, 1}, {3, 2}};
  copy_padding(records, atlas.data());
  for (int t = 0; t < 4; ++t)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(atlas[std::size_t(3 * t + c)], float(c + 1));
  std::vector<float> a2(12, 0.0f);
  const std::vector<std::uint32_t> texel = {3, 1};
  const std::vector<float> lm = {1, 2, 3, 4, 5, 6};
  scatter_texels(texel, lm.data(), a2.data());
  EXPECT_EQ(a2, (std::vector<float>{0, 0, 0, 4, 5, 6, 0, 0, 0, 1, 2, 3}));
}

// ---- the level runtime against core's level_evaluate ----

const Dictionary& dict() { return test::small_test_dictionary(); }

using test::level_reference;
using test::test_level;
using test::test_levels;
using test::TestLevel;
using Reference = test::LevelReference;

// (|Td_b| ld)_i per b element: the sum of the magnitudes that cancel into b_i.
std::vector<double> b_magnitudes(const Level& level, std::span<const float> ld) {
  std::vector<double> out;
  for (const LevelBlock& blk : level.blocks) {
    const Matrix& T = dict().shapes[std::size_t(blk.shape)].Td_b;
    for (std::uint32_t k = 0; k < T.rows; ++k)
      for (int c = 0; c < 3; ++c) {
        double acc = 0.0;
        for (std::uint32_t j = 0; j < T.cols; ++j)
          acc += std::abs(double(T(k, j))) * ld[3 * (std::size_t(blk.sample_offset) + j) + std::size_t(c)];
        out.push_back(acc);
      }
  }
  return out;
}

// b's high modes cancel heavily: (|Td_b| ld)_k reaches ~1e3 |b_k| (Td_b = Sm^-1 Um^T F P P^T
// has large, mixed-sign rows for small singular values), beyond what float accumulation
// resolves to 1e-5 per element. So b's per-element floor also includes 1e-2 (|Td_b| ld)_k
// (a backward-error bound of 1e-7 per element); its L2 error and every other output
// (r, lightmap, atlas, probes: b's high modes enter them scaled by their small singular
// values) are held to 1e-5 with the plain floor.
TEST(CpuLevelRuntime, EvaluateMatchesLevelEvaluateForEveryIsa) {
  for (const TestLevel& t : test_levels()) {
    const Reference ref = level_reference(t.level, t.ld);
    const std::vector<double> b_scale = b_magnitudes(t.level, t.ld);
    for (Isa isa : supported_isas()) {
      Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), {isa, 1});
      ASSERT_TRUE(rt.ok()) << rt.status().to_string();
      EXPECT_EQ(rt->isa(), isa);
      const LevelBufferSizes& s = rt->sizes();
      std::vector<float> lightmap(s.lightmap), atlas(s.atlas), probes(s.probes);
      for (int frame = 0; frame < 2; ++frame) {  // the second frame reuses every buffer
        const Status st = rt->evaluate(t.ld, lightmap);
        ASSERT_TRUE(st.ok()) << st.to_string();
      }
      ASSERT_TRUE(rt->fill_atlas(lightmap, atlas).ok());
      ASSERT_TRUE(rt->compute_probes(probes).ok());
      const std::string what = std::string(t.name) + " " + isa_name(isa);
      Worst wb, wr, wl, wa, wp;
      expect_close(rt->b(), ref.b, what + " b", &wb, b_scale);
      expect_close(rt->r(), ref.r, what + " r", &wr);
      expect_close(lightmap, ref.lightmap, what + " lightmap", &wl);
      expect_close(atlas, ref.atlas, what + " atlas", &wa);
      expect_close(probes, ref.probes, what + " probes", &wp);
      std::printf("  %s\n", t.name.c_str());
      wb.print("b", isa), wr.print("r", isa), wl.print("lightmap", isa), wa.print("atlas", isa),
          wp.print("probes", isa);
    }
  }
}

TEST(CpuLevelRuntime, ScalarAtlasIsExact) {
  const TestLevel& t = test_level("maze11");
  const Reference ref = level_reference(t.level, t.ld);
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), {Isa::scalar, 1});
  ASSERT_TRUE(rt.ok());
  std::vector<float> atlas(rt->sizes().atlas);
  ASSERT_TRUE(rt->fill_atlas(ref.lightmap, atlas).ok());
  EXPECT_EQ(atlas, ref.atlas);
}

TEST(CpuLevelRuntime, MultiBounceStepsMatchLevelMultiBounce) {
  constexpr int kSteps = 6;
  for (const TestLevel& t : test_levels()) {
    std::vector<float> albedo = t.albedo;
    for (std::size_t i = 0; i < albedo.size(); i += 7) albedo[i] = 0.99f;  // some get clamped to 0.95
    const LevelBufferSizes s = level_buffer_sizes(t.level, dict());
    std::vector<float> b(s.b), r(s.r), ref(s.lightmap);
    MultiBounceSettings settings;
    settings.max_iterations = kSteps;
    settings.tolerance = 0.0f;
    const Result<MultiBounceReport> rep =
        level_multi_bounce(t.level, dict(), t.ld, albedo, settings, b, r, ref);
    ASSERT_TRUE(rep.ok()) << rep.status().to_string();
    ASSERT_EQ(rep->iterations, kSteps);
    for (Isa isa : supported_isas()) {
      Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), {isa, 1});
      ASSERT_TRUE(rt.ok());
      ASSERT_TRUE(rt->set_albedo(albedo, settings.max_albedo).ok());
      std::vector<float> lightmap(s.lightmap);
      ASSERT_TRUE(rt->evaluate(t.ld, lightmap).ok());
      bool any_clamped = false;
      for (int k = 0; k < kSteps; ++k) {
        bool clamped = false;
        const Status st = rt->multi_bounce_step(t.ld, lightmap, &clamped);
        ASSERT_TRUE(st.ok()) << st.to_string();
        any_clamped |= clamped;
      }
      EXPECT_EQ(any_clamped, rep->value_clamped);
      Worst w;
      expect_close(lightmap, ref, std::string(t.name) + " " + isa_name(isa) + " multi-bounce", &w);
      w.print((std::string(t.name) + " multi-bounce").c_str(), isa);
    }
  }
}

TEST(CpuLevelRuntime, NoAllocationPerFrame) {
  const TestLevel& t = test_level("maze41");
  for (Isa isa : supported_isas()) {
    Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict(), {isa, 1});
    ASSERT_TRUE(rt.ok());
    const LevelBufferSizes& s = rt->sizes();
    std::vector<float> lightmap(s.lightmap), atlas(s.atlas), probes(s.probes);
    ASSERT_TRUE(rt->set_albedo(t.albedo).ok());
    bool ok = true;
    g_allocations = 0;
    g_count_allocations = true;
    for (int frame = 0; frame < 10; ++frame) ok &= rt->evaluate(t.ld, lightmap).ok();
    const long evaluate_allocations = g_allocations.load();
    for (int frame = 0; frame < 10; ++frame) {
      ok &= rt->multi_bounce_step(t.ld, lightmap).ok();
      ok &= rt->fill_atlas(lightmap, atlas).ok();
      ok &= rt->compute_probes(probes).ok();
    }
    g_count_allocations = false;
    const long other_allocations = g_allocations.load() - evaluate_allocations;
    EXPECT_EQ(evaluate_allocations, 0) << isa_name(isa);
    EXPECT_EQ(other_allocations, 0) << isa_name(isa);
    EXPECT_TRUE(ok);
    // The counter works: a failing call builds its error message on the heap.
    std::vector<float> bad = t.ld;
    bad[0] = -1.0f;
    g_count_allocations = true;
    const bool failed = !rt->evaluate(bad, lightmap).ok();
    g_count_allocations = false;
    EXPECT_TRUE(failed);
    EXPECT_GT(g_allocations.load(), 0);
    g_allocations = 0;
  }
}

TEST(CpuLevelRuntime, RejectsBadLightSignal) {
  const TestLevel& t = test_level("maze11");
  Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, dict());
  ASSERT_TRUE(rt.ok());
  std::vector<float> lightmap(rt->sizes().lightmap, 0.0f);
  std::vector<float> ld = t.ld;
  ld[3 * 7 + 1] = std::numeric_limits<float>::quiet_NaN();
  Status s = rt->evaluate(ld, lightmap);
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_NE(s.message().find("sample 7 channel G is NaN"), std::string::npos) << s.message();
  EXPECT_TRUE(std::all_of(lightmap.begin(), lightmap.end(), [](float v) { return v == 0.0f; }));
  ld = t.ld;
  ld[3 * 12 + 2] = std::numeric_limits<float>::infinity();
  s = rt->evaluate(ld, lightmap);
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_NE(s.message().find("sample 12 channel B is Inf"), std::string::npos) << s.message();
  ld = t.ld;
  ld[0] = -1.0f;
  s = rt->evaluate(ld, lightmap);
  EXPECT_EQ(s.code(), ErrorCode::invalid_argument);
  EXPECT_NE(s.message().find("sample 0 channel R is negative"), std::string::npos) << s.message();
  ld.pop_back();
  EXPECT_EQ(rt->evaluate(ld, lightmap).code(), ErrorCode::invalid_argument);
  std::vector<float> short_lightmap(lightmap.size() - 1);
  EXPECT_EQ(rt->evaluate(t.ld, short_lightmap).code(), ErrorCode::invalid_argument);
  EXPECT_EQ(rt->multi_bounce_step(t.ld, lightmap).code(), ErrorCode::invalid_argument);  // no albedo yet
}

TEST(CpuLevelRuntime, RejectsMismatchedDictionaryAndOptions) {
  const TestLevel& t = test_level("maze11");
  {
    Dictionary other = dict();
    other.settings.res = 4;
    const Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, other);
    ASSERT_FALSE(rt.ok());
    EXPECT_EQ(rt.status().code(), ErrorCode::invalid_argument);
    EXPECT_NE(rt.status().message().find("rebuild the level"), std::string::npos) << rt.status().message();
  }
  {
    Dictionary other = dict();
    ShapeOperators& op = other.shapes[std::size_t(t.level.blocks[0].shape)];
    op.Ub = Matrix(op.Ub.rows - 1, op.Ub.cols);
    const Result<CpuLevelRuntime> rt = CpuLevelRuntime::create(t.level, other);
    ASSERT_FALSE(rt.ok());
    EXPECT_NE(rt.status().message().find("block 0"), std::string::npos) << rt.status().message();
  }
  {
    Dictionary other = dict();
    other.interfaces.Ur = Matrix(other.interfaces.Ur.rows + 1, other.interfaces.Ur.cols);
    EXPECT_FALSE(CpuLevelRuntime::create(t.level, other).ok());
  }
  for (Isa isa : {Isa::scalar, Isa::sse41, Isa::avx2, Isa::neon})
    EXPECT_EQ(CpuLevelRuntime::create(t.level, dict(), {isa, 1}).ok(), isa_supported(isa)) << isa_name(isa);
  EXPECT_FALSE(CpuLevelRuntime::create(t.level, dict(), {Isa::scalar, 2}).ok());
}

}  // namespace
}  // namespace modrt::cpu
