// SPDX-License-Identifier: MIT
// DRT on the SIMD CPU path (cpu_neon/cpu_drt.h) against core's scalar reference (drt.h):
// c = Td_c clutter_ld, lightmap += dUb b + dUc c, the clutter lightmap Uc Vc b + direct and its
// clutter-to-clutter light Cc c, every ISA this CPU (or qemu) supports, within 1e-5 relative L2;
// the rows of overlapping objects merged (four pillars) and still equal to the reference; no
// clutter costs nothing. The CPU backend's DRT stages through Backend (deltas in every output,
// the clutter lightmap never negative, the feedback): test_backend_conformance.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include "cpu_test_support.h"
#include "drt_scenes.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/cpu/cpu_drt.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "test_support.h"

namespace modrt::cpu {
namespace {

using namespace cpu_test;

const Dictionary& dict() { return test::small_test_dictionary(); }

// Three blocks in a row, a box on the first block's floor and a rotated pillar in the
// middle one (its shadows reach the neighbours through the openings).
struct DrtFixture {
  LevelDescription description;
  Level level;
  std::vector<ClutterObject> clutter;
  DrtOperators drt;
};

// gather: the real-radiance gather's operators (Gs, Gt, Hs, Ht) in place of the paper's Cb, Cc
// and the traced samples' dUb / dUc rows.
DrtFixture make_fixture(bool gather) {
  {
    DrtFixture s;
    for (int x = 0; x < 3; ++x) {
      BlockDescription b;
      b.cell = glm::ivec3(x, 0, 0);
      b.faces = kAllFaces;
      if (x > 0) b.faces &= FaceMask(~(1u << kFaceNegX));
      if (x < 2) b.faces &= FaceMask(~(1u << kFacePosX));
      for (auto& a : b.albedo) a = glm::dvec3(0.6);
      s.description.blocks.push_back(b);
    }
    s.level = precompute::build_level(s.description, dict()).value();
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
    s.clutter = {box, pillar};
    precompute::DrtBuildSettings settings;
    settings.rays = 128;
    settings.vector = settings.probes = !gather;  // the gather's test needs its rows alone
    settings.gather = gather;
    Result<DrtOperators> drt = precompute::DrtBuilder(s.level, dict(), settings).build(s.clutter);
    if (!drt.ok()) {
      std::fprintf(stderr, "drt build: %s\n", drt.status().to_string().c_str());
      std::abort();
    }
    s.drt = std::move(drt).value();
    return s;
  }
}

const DrtFixture& fixture(bool gather = false) {
  static const DrtFixture paper = make_fixture(false);
  if (!gather) return paper;
  static const DrtFixture with_gather = make_fixture(true);
  return with_gather;
}

// The real-radiance gather: lightmap += Ht x_t - Hs x_s and clutter += Gs x_s + Gt x_t, against
// core's drt_apply_gather / drt_clutter_add_gather (double accumulation) for every ISA; wrong
// sizes are refused.
TEST(CpuDrt, GatherMatchesScalarReferenceForEveryIsa) {
  const DrtFixture& f = fixture(true);
  const DrtBufferSizes sizes = drt_buffer_sizes(f.drt);
  ASSERT_TRUE(f.drt.has_gather());
  ASSERT_FALSE(f.drt.objects[0].Gt.index.empty());  // the box and the pillar see each other
  std::mt19937 rng(13);
  const std::vector<float> ld = random_vector(rng, 3 * std::size_t(f.level.sample_count), 0.0f, 1.0f);
  const std::vector<float> x_t = random_vector(rng, sizes.clutter_ld, 0.0f, 2.0f);
  const std::vector<float> base = random_vector(rng, ld.size(), 0.0f, 1.0f);
  const std::vector<float> clutter_base = random_vector(rng, sizes.clutter_lightmap, 0.0f, 0.5f);
  std::vector<float> lm_ref(base), cl_ref(clutter_base);
  drt_apply_gather(f.drt, ld, x_t, lm_ref);
  drt_clutter_add_gather(f.drt, ld, x_t, cl_ref);
  const auto minus = [](const std::vector<float>& a, const std::vector<float>& b) {
    std::vector<float> d(a.size());
    for (std::size_t i = 0; i < a.size(); ++i) d[i] = a[i] - b[i];
    return d;
  };
  for (Isa isa : supported_isas()) {
    Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(f.level, f.drt, isa);
    ASSERT_TRUE(rt.ok()) << rt.status().to_string();
    std::vector<float> lm(base), cl(clutter_base);
    ASSERT_TRUE(rt->apply_gather(ld, x_t, lm).ok());
    ASSERT_TRUE(rt->clutter_add_gather(ld, x_t, cl).ok());
    const Error es = compare(minus(lm, base), minus(lm_ref, base)),
                ec = compare(minus(cl, clutter_base), minus(cl_ref, clutter_base));
    EXPECT_LE(es.rel_l2, 1e-5) << isa_name(isa);
    EXPECT_LE(ec.rel_l2, 1e-5) << isa_name(isa);
    Worst ws, wc;
    ws.add(es), wc.add(ec);
    ws.print("Ht x_t - Hs x_s", isa), wc.print("Gs x_s + Gt x_t", isa);
    EXPECT_EQ(rt->apply_gather(std::vector<float>(ld.size() - 3), x_t, lm).code(),
              ErrorCode::invalid_argument);
    EXPECT_EQ(rt->clutter_add_gather(ld, std::vector<float>(x_t.size() + 3), cl).code(),
              ErrorCode::invalid_argument);
  }
}

TEST(CpuDrt, MatchesScalarReferenceForEveryIsa) {
  const DrtFixture& f = fixture();
  const DrtBufferSizes sizes = drt_buffer_sizes(f.drt);
  ASSERT_GT(sizes.c, 0u);
  std::mt19937 rng(11);
  const std::vector<float> b =
      random_vector(rng, 3 * std::size_t(f.level.kb) * f.level.blocks.size(), -1.0f, 1.0f);
  const std::vector<float> clutter_ld = random_vector(rng, sizes.clutter_ld, 0.0f, 1.0f);
  const std::vector<float> direct = random_vector(rng, sizes.clutter_lightmap, 0.0f, 0.5f);
  const std::vector<float> base = random_vector(rng, 3 * std::size_t(f.level.sample_count), 0.0f, 1.0f);
  std::vector<float> c_ref(sizes.c), lm_ref(base), cl_ref(sizes.clutter_lightmap);
  ASSERT_TRUE(drt_compute_c(f.drt, clutter_ld, c_ref).ok());
  drt_apply(f.level, f.drt, b, c_ref, lm_ref);
  drt_clutter_lightmap(f.drt, b, direct, cl_ref);
  std::vector<float> delta_ref(lm_ref.size());  // the DRT part alone, for a strict comparison
  for (std::size_t i = 0; i < delta_ref.size(); ++i) delta_ref[i] = lm_ref[i] - base[i];
  for (Isa isa : supported_isas()) {
    Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(f.level, f.drt, isa);
    ASSERT_TRUE(rt.ok()) << rt.status().to_string();
    std::vector<float> c(sizes.c), lm(base), cl(sizes.clutter_lightmap), delta(lm.size());
    ASSERT_TRUE(rt->compute_c(clutter_ld, c).ok());
    ASSERT_TRUE(rt->apply(b, c, lm).ok());
    ASSERT_TRUE(rt->clutter_lightmap(b, direct, cl).ok());
    for (std::size_t i = 0; i < delta.size(); ++i) delta[i] = lm[i] - base[i];
    Worst wc, wd, wl;
    expect_close(c, c_ref, std::string("c ") + isa_name(isa), &wc);
    const Error e = compare(delta, delta_ref);
    EXPECT_LE(e.rel_l2, 1e-5) << isa_name(isa);
    wd.add(e);
    expect_close(cl, cl_ref, std::string("clutter lightmap ") + isa_name(isa), &wl);
    wc.print("c", isa), wd.print("dUb b + dUc c", isa), wl.print("clutter lightmap", isa);
  }
}

// Clutter-to-clutter light (Cc c): the box and the pillar see each other through the opening.
TEST(CpuDrt, ClutterToClutterLightMatchesScalarReferenceForEveryIsa) {
  const DrtFixture& f = fixture();
  const DrtBufferSizes sizes = drt_buffer_sizes(f.drt);
  ASSERT_FALSE(f.drt.objects[0].Cc.empty());
  ASSERT_FALSE(f.drt.objects[1].Cc.empty());
  std::mt19937 rng(12);
  const std::vector<float> c = random_vector(rng, sizes.c, 0.0f, 1.0f);
  const std::vector<float> base = random_vector(rng, sizes.clutter_lightmap, 0.0f, 0.5f);
  std::vector<float> ref(base);
  drt_clutter_add_cc(f.drt, c, ref);
  std::vector<float> ref_delta(ref.size());
  for (std::size_t i = 0; i < ref.size(); ++i) ref_delta[i] = ref[i] - base[i];
  for (Isa isa : supported_isas()) {
    Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(f.level, f.drt, isa);
    ASSERT_TRUE(rt.ok()) << rt.status().to_string();
    std::vector<float> out(base), delta(base.size());
    ASSERT_TRUE(rt->clutter_add_cc(c, out).ok());
    for (std::size_t i = 0; i < out.size(); ++i) delta[i] = out[i] - base[i];
    const Error e = compare(delta, ref_delta);
    EXPECT_LE(e.rel_l2, 1e-5) << isa_name(isa);
    Worst w;
    w.add(e);
    w.print("Cc c", isa);
    EXPECT_EQ(rt->clutter_add_cc(std::vector<float>(sizes.c + 3), out).code(), ErrorCode::invalid_argument);
  }
}

// The vector deltas (dUb_vec b + dUc_vec c) and the clutter-aware probes (Udyn b + Udyn_c c).
TEST(CpuDrt, VectorAndProbeDeltasMatchScalarReferenceForEveryIsa) {
  const DrtFixture& f = fixture();
  const DrtBufferSizes sizes = drt_buffer_sizes(f.drt);
  ASSERT_FALSE(f.drt.objects[1].dUb_vec.empty());
  ASSERT_FALSE(f.drt.objects[1].Udyn.empty());
  std::mt19937 rng(13);
  const std::vector<float> b =
      random_vector(rng, 3 * std::size_t(f.level.kb) * f.level.blocks.size(), -1.0f, 1.0f);
  const std::vector<float> c = random_vector(rng, sizes.c, 0.0f, 1.0f);
  const std::size_t probe_size = 27 * std::size_t(f.drt.probes_per_block) * f.level.blocks.size();
  const std::vector<float> zero_vec(12 * std::size_t(f.level.sample_count), 0.0f),
      zero_probes(probe_size, 0.0f);
  std::vector<float> vec_ref(zero_vec), probes_ref(zero_probes);
  drt_apply_vector(f.level, f.drt, b, c, vec_ref);
  drt_apply_probes(f.drt, b, c, probes_ref);
  for (Isa isa : supported_isas()) {
    Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(f.level, f.drt, isa);
    ASSERT_TRUE(rt.ok()) << rt.status().to_string();
    std::vector<float> vec(zero_vec), probes(zero_probes);
    ASSERT_TRUE(rt->apply_vector(b, c, vec).ok());
    ASSERT_TRUE(rt->apply_probes(b, c, probes).ok());
    const Error ev = compare(vec, vec_ref), ep = compare(probes, probes_ref);
    EXPECT_LE(ev.rel_l2, 1e-5) << isa_name(isa);
    EXPECT_LE(ep.rel_l2, 1e-5) << isa_name(isa);
    Worst wv, wp;
    wv.add(ev);
    wp.add(ep);
    wv.print("dUb_vec b + dUc_vec c", isa), wp.print("Udyn b + Udyn_c c", isa);
    std::vector<float> too_long_vec(zero_vec.size() + 1), too_long_probes(probe_size + 1);
    EXPECT_EQ(rt->apply_vector(b, c, too_long_vec).code(), ErrorCode::invalid_argument);
    EXPECT_EQ(rt->apply_probes(b, c, too_long_probes).code(), ErrorCode::invalid_argument);
  }
}

// The four-pillar corridor of drt_scenes.h (64 rays, vector and probe operators): the pillars
// stand around one light, so their shadows fall on the same samples and probes.
struct PillarFixture {
  Level level;
  DrtOperators drt;
};

const PillarFixture& pillars() {
  static const PillarFixture f = [] {
    PillarFixture s;
    const test::ClutterScene scene = test::maze_block_four_pillars();
    s.level = precompute::build_level(scene.description, dict()).value();
    precompute::DrtBuildSettings settings;
    settings.rays = 64;
    settings.vector = settings.probes = true;
    Result<DrtOperators> drt = precompute::DrtBuilder(s.level, dict(), settings).build(scene.clutter);
    if (!drt.ok()) {
      std::fprintf(stderr, "drt build: %s\n", drt.status().to_string().c_str());
      std::abort();
    }
    s.drt = std::move(drt).value();
    return s;
  }();
  return f;
}

// Rows of different objects for the same (sample or probe, block) are summed into one, and
// each item's face rows concatenated over the pillars' c. A merge that kept one object's row
// of a shared pair, or scattered a merged row to the wrong item, would leave the deltas far
// from core's per-object reference; the row counts show that shared pairs exist.
TEST(CpuDrt, MergedRowsOfOverlappingObjectsMatchScalarReferenceForEveryIsa) {
  const PillarFixture& f = pillars();
  ASSERT_EQ(f.drt.objects.size(), 4u);
  std::size_t dUb = 0, dUb_vec = 0, Udyn = 0, dUc = 0, dUc_cells = 0, dUc_vec = 0, Udyn_c = 0;
  for (const DrtObjectOperators& o : f.drt.objects) {
    dUb += o.dUb.rows, dUb_vec += o.dUb_vec.rows, Udyn += o.Udyn.rows;
    dUc += o.dUc.rows, dUc_cells += o.dUc.data.size(), dUc_vec += o.dUc_vec.rows, Udyn_c += o.Udyn_c.rows;
  }
  Result<CpuDrtRuntime> layout = CpuDrtRuntime::create(f.level, f.drt, Isa::scalar);
  ASSERT_TRUE(layout.ok()) << layout.status().to_string();
  const CpuDrtRuntime::DeltaShape &lm = layout->lightmap_shape(), &vec = layout->vector_shape(),
                                  &pr = layout->probe_shape();
  EXPECT_LT(lm.b_rows, dUb);
  EXPECT_LT(vec.b_rows, dUb_vec);
  EXPECT_LT(pr.b_rows, Udyn);
  EXPECT_LE(lm.b_groups, f.level.blocks.size());  // one GEMV per source block
  EXPECT_LE(vec.b_groups, f.level.blocks.size());
  EXPECT_LE(pr.b_groups, f.level.blocks.size());
  EXPECT_LT(lm.c_rows, dUc);
  EXPECT_LT(vec.c_rows, dUc_vec);
  EXPECT_LT(pr.c_rows, Udyn_c);
  EXPECT_LE(lm.c_cells, 2 * dUc_cells);  // the concatenation's zeros stay bounded
  std::printf(
      "four pillars: dUb %zu -> %zu rows (%zu groups), dUb_vec %zu -> %zu, Udyn %zu -> %zu; "
      "dUc %zu -> %zu rows (%zu -> %zu cells, %zu groups)\n",
      dUb, lm.b_rows, lm.b_groups, dUb_vec, vec.b_rows, Udyn, pr.b_rows, dUc, lm.c_rows, dUc_cells,
      lm.c_cells, lm.c_groups);

  const DrtBufferSizes sizes = drt_buffer_sizes(f.drt);
  std::mt19937 rng(14);
  const std::vector<float> b =
      random_vector(rng, 3 * std::size_t(f.level.kb) * f.level.blocks.size(), -1.0f, 1.0f);
  const std::vector<float> c = random_vector(rng, sizes.c, 0.0f, 1.0f);
  const std::vector<float> zero_lm(3 * std::size_t(f.level.sample_count), 0.0f),
      zero_vec(4 * zero_lm.size(), 0.0f),
      zero_probes(27 * std::size_t(f.drt.probes_per_block) * f.level.blocks.size(), 0.0f);
  std::vector<float> lm_ref(zero_lm), vec_ref(zero_vec), probes_ref(zero_probes);
  drt_apply(f.level, f.drt, b, c, lm_ref);
  drt_apply_vector(f.level, f.drt, b, c, vec_ref);
  drt_apply_probes(f.drt, b, c, probes_ref);
  for (Isa isa : supported_isas()) {
    Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(f.level, f.drt, isa);
    ASSERT_TRUE(rt.ok()) << rt.status().to_string();
    std::vector<float> out_lm(zero_lm), out_vec(zero_vec), out_probes(zero_probes);
    ASSERT_TRUE(rt->apply(b, c, out_lm).ok());
    ASSERT_TRUE(rt->apply_vector(b, c, out_vec).ok());
    ASSERT_TRUE(rt->apply_probes(b, c, out_probes).ok());
    const Error el = compare(out_lm, lm_ref), ev = compare(out_vec, vec_ref),
                ep = compare(out_probes, probes_ref);
    EXPECT_LE(el.rel_l2, 1e-5) << isa_name(isa);
    EXPECT_LE(ev.rel_l2, 1e-5) << isa_name(isa);
    EXPECT_LE(ep.rel_l2, 1e-5) << isa_name(isa);
    Worst wl, wv, wp;
    wl.add(el), wv.add(ev), wp.add(ep);
    // The face rows' values are reused while c keeps its bits: the same c again gives the
    // same bits, and a new c in the same buffer (one face changed) is not served stale values.
    std::vector<float> again(zero_lm), again_vec(zero_vec), again_probes(zero_probes);
    ASSERT_TRUE(rt->apply(b, c, again).ok());
    ASSERT_TRUE(rt->apply_vector(b, c, again_vec).ok());
    ASSERT_TRUE(rt->apply_probes(b, c, again_probes).ok());
    EXPECT_EQ(again, out_lm) << isa_name(isa);
    EXPECT_EQ(again_vec, out_vec) << isa_name(isa);
    EXPECT_EQ(again_probes, out_probes) << isa_name(isa);
    std::vector<float> c2(c);
    c2[3 * 5 + 1] += 0.5f;  // face 5 (the second pillar), green
    std::vector<float> ref2(zero_lm), vec_ref2(zero_vec), probes_ref2(zero_probes);
    drt_apply(f.level, f.drt, b, c2, ref2);
    drt_apply_vector(f.level, f.drt, b, c2, vec_ref2);
    drt_apply_probes(f.drt, b, c2, probes_ref2);
    ASSERT_GT(compare(ref2, lm_ref).rel_l2, 1e-3);  // the change is visible in the reference
    std::fill(again.begin(), again.end(), 0.0f);
    std::fill(again_vec.begin(), again_vec.end(), 0.0f);
    std::fill(again_probes.begin(), again_probes.end(), 0.0f);
    ASSERT_TRUE(rt->apply(b, c2, again).ok());
    ASSERT_TRUE(rt->apply_vector(b, c2, again_vec).ok());
    ASSERT_TRUE(rt->apply_probes(b, c2, again_probes).ok());
    const Error el2 = compare(again, ref2), ev2 = compare(again_vec, vec_ref2),
                ep2 = compare(again_probes, probes_ref2);
    EXPECT_LE(el2.rel_l2, 1e-5) << isa_name(isa);
    EXPECT_LE(ev2.rel_l2, 1e-5) << isa_name(isa);
    EXPECT_LE(ep2.rel_l2, 1e-5) << isa_name(isa);
    wl.add(el2), wv.add(ev2), wp.add(ep2);
    wl.print("merged dUb b + dUc c", isa), wv.print("merged dUb_vec b + dUc_vec c", isa),
        wp.print("merged Udyn b + Udyn_c c", isa);
  }
}

// Operators without U_dyn add nothing to the probes, whatever the dictionary's probe grid (the
// CPU backend passes its probes on every frame).
// The clutter's vector irradiance (Uc_vec Vc_vec b + Cc_vec c, DRT §5) on the four pillars,
// which see each other (Cc_vec), every ISA, and through the CPU backend after an update.
TEST(CpuDrt, ClutterVectorLightmapMatchesScalarReferenceForEveryIsa) {
  const PillarFixture& f = pillars();
  const DrtBufferSizes sizes = drt_buffer_sizes(f.drt);
  for (const DrtObjectOperators& o : f.drt.objects) {
    ASSERT_FALSE(o.Uc_vec.empty());
    ASSERT_FALSE(o.Cc_vec.empty());
  }
  std::mt19937 rng(15);
  const std::vector<float> b =
      random_vector(rng, 3 * std::size_t(f.level.kb) * f.level.blocks.size(), -0.2f, 1.0f);
  const std::vector<float> c = random_vector(rng, sizes.c, 0.0f, 1.0f);
  std::vector<float> ref(sizes.clutter_vector_lightmap, -1.0f);
  drt_clutter_vector_lightmap(f.drt, b, c, ref);
  for (Isa isa : supported_isas()) {
    Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(f.level, f.drt, isa);
    ASSERT_TRUE(rt.ok()) << rt.status().to_string();
    std::vector<float> out(sizes.clutter_vector_lightmap, -1.0f);
    ASSERT_TRUE(rt->clutter_vector_lightmap(b, c, out).ok());
    const Error e = compare(out, ref);
    EXPECT_LE(e.rel_l2, 1e-5) << isa_name(isa);
    Worst w;
    w.add(e);
    w.print("clutter vector lightmap", isa);
    std::vector<float> short_out(sizes.clutter_vector_lightmap - 1);
    EXPECT_EQ(rt->clutter_vector_lightmap(b, c, short_out).code(), ErrorCode::invalid_argument);
  }
  // Through the backend (the b of its update, the c of its clutter light):
  // test_backend_conformance's ClutterVectorLightmapMatchesCore.
}

TEST(CpuDrt, ProbesAreLeftAsTheyAreWithoutUdyn) {
  const DrtFixture& f = fixture();
  DrtOperators no_udyn = f.drt;
  for (DrtObjectOperators& o : no_udyn.objects) {
    o.Udyn_probe.clear(), o.Udyn_block.clear(), o.Udyn_c_probe.clear();
    o.Udyn = {}, o.Udyn_c = {};
  }
  no_udyn.probes_per_block = 0;
  Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(f.level, no_udyn);
  ASSERT_TRUE(rt.ok()) << rt.status().to_string();
  const std::vector<float> b(3 * std::size_t(f.level.kb) * f.level.blocks.size(), 1.0f),
      c(rt->sizes().c, 1.0f);
  std::vector<float> probes(27 * 64 * f.level.blocks.size(), 0.5f);
  const std::vector<float> before = probes;
  ASSERT_TRUE(rt->apply_probes(b, c, probes).ok());
  EXPECT_EQ(probes, before);
  EXPECT_EQ(rt->apply_probes(b, std::vector<float>(c.size() + 1), probes).code(),
            ErrorCode::invalid_argument);
}

TEST(CpuDrt, NoClutterCostsNothingAndBadSizesAreRefused) {
  const DrtFixture& f = fixture();
  const DrtOperators none;
  Result<CpuDrtRuntime> rt = CpuDrtRuntime::create(f.level, none);
  ASSERT_TRUE(rt.ok());
  std::vector<float> b(3 * std::size_t(f.level.kb) * f.level.blocks.size(), 1.0f);
  std::vector<float> lm(3 * std::size_t(f.level.sample_count), 0.25f);
  const std::vector<float> before = lm;
  ASSERT_TRUE(rt->apply(b, {}, lm).ok());
  EXPECT_EQ(lm, before);
  Result<CpuDrtRuntime> full = CpuDrtRuntime::create(f.level, f.drt);
  ASSERT_TRUE(full.ok());
  std::vector<float> c(full->sizes().c + 1);
  EXPECT_EQ(full->apply(b, c, lm).code(), ErrorCode::invalid_argument);
  std::vector<float> clutter_ld(full->sizes().clutter_ld, 1.0f);
  clutter_ld[4] = std::nanf("");
  c.pop_back();
  EXPECT_EQ(full->compute_c(clutter_ld, c).code(), ErrorCode::non_finite);
}

}  // namespace
}  // namespace modrt::cpu
