// SPDX-License-Identifier: MIT
// Numerical stress of the level build under extreme warps (issue 9): corridors stretched to
// 100:1, squeezed to 1:100 and 1:1000 (nearly flat blocks) and sheared 5:1, through
// validate_level, build_level (small test dictionary), the warped sample geometry, both
// direct-light evaluators (Embree's level_direct_light and the CPU runtime's CpuDirectLight)
// and the SIMD CPU runtime. MRT reuses the canonical operators under any warp (MRT §6.2), so
// what a warp can break is the geometry: normals from central differences of the trilinear
// map, shadow rays grazing walls a hair apart, 1/d^2 next to a light.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "level_fixtures.h"
#include "modrt/cpu/cpu_level_runtime.h"
#include "modrt/cpu/direct_light.h"
#include "modrt/level_description.h"
#include "modrt/level_runtime.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/level_scene.h"
#include "stress/stress_report.h"

namespace modrt::precompute {
namespace {

using stress::fmt;
using stress::row;

struct WarpCase {
  const char* name;
  glm::dvec3 scale;    // of the canonical x, y, z
  double shear = 0.0;  // x += shear * y (the top of every block shifted along the corridor)
  double twist = 0.0;  // z += twist * y at odd x lattice corners: side faces bend (non-planar)
};

// A closed corridor of `blocks` warped blocks along +x; a point light in the middle block.
LevelDescription warped_corridor(const WarpCase& w, int blocks = 3) {
  LevelDescription d;
  d.name = w.name;
  for (int i = 0; i < blocks; ++i) {
    BlockDescription b;
    b.cell = glm::ivec3(i, 0, 0);
    b.faces = kAllFaces;
    if (i > 0) b.faces &= FaceMask(~(1u << kFaceNegX));
    if (i + 1 < blocks) b.faces &= FaceMask(~(1u << kFacePosX));
    b.warped = true;
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 p(double(i + (c & 1)), double((c >> 1) & 1), double((c >> 2) & 1));
      const double bend = w.twist * p.y * double(int(p.x) % 2);
      b.corners[std::size_t(c)] =
          glm::dvec3(p.x * w.scale.x + w.shear * p.y * w.scale.y, p.y * w.scale.y, (p.z + bend) * w.scale.z);
    }
    b.albedo.fill(glm::dvec3(0.6));
    d.blocks.push_back(b);
  }
  LightDescription light;
  // Near the middle block's centre, off its symmetry planes (shadow rays exactly along an edge
  // are decided differently by Embree and the CPU walk: a measure-zero set).
  light.position = trilinear(d.blocks[std::size_t(blocks / 2)].corners, glm::dvec3(0.513, 0.507, 0.489));
  light.radius = 0.0;  // a point light: both evaluators then use the same model exactly
  d.lights.push_back(light);
  return d;
}

double rel_l2(std::span<const float> a, std::span<const float> b) {
  double num = 0, den = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    num += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
    den += double(b[i]) * b[i];
  }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

bool all_finite(std::span<const float> v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

// Per case: builds; every sample's position finite and normal of unit length; CpuDirectLight
// equal to Embree's level_direct_light within 1e-4 relative L2 (the two trace shadows against
// different triangulations of the walls: a ray grazing a wall may be decided differently);
// the runtime's lightmap finite and within 1e-5 of core's scalar reference.
TEST(StressWarp, ExtremeWarpsBuildAndStayFinite) {
  const Dictionary& dict = test::small_test_dictionary();
  const WarpCase cases[] = {
      {"warp 100:1:1 (long blocks)", {100.0, 1.0, 1.0}},
      {"warp 1:1:0.01 (narrow)", {1.0, 1.0, 0.01}},
      {"warp 1:0.01:1 (nearly flat)", {1.0, 0.01, 1.0}},
      {"warp 1:0.001:1 (flat, det 1e-3)", {1.0, 0.001, 1.0}},
      {"warp shear 5:1", {1.0, 1.0, 1.0}, 5.0},
      {"warp twist 0.9 (bent faces)", {1.0, 1.0, 1.0}, 0.0, 0.9},
  };
  for (const WarpCase& w : cases) {
    const LevelDescription d = warped_corridor(w);
    Result<Level> built = build_level(d, dict);
    ASSERT_TRUE(built.ok()) << w.name << ": " << built.status().to_string();
    const Level& level = built.value();

    const LevelSampleGeometry g = level_sample_geometry(level);
    double worst_normal = 0.0;
    bool positions_finite = true;
    for (std::size_t s = 0; s < g.normal.size(); ++s) {
      const glm::dvec3& n = g.normal[s];
      const double len = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
      worst_normal = std::max(worst_normal, std::isfinite(len) ? std::abs(len - 1.0) : 1e300);
      const glm::dvec3& p = g.position[s];
      positions_finite &= std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
    }
    EXPECT_TRUE(row(
        w.name, "sample geometry",
        fmt("max abs(‖n‖ - 1) %.1e, positions %s", worst_normal, positions_finite ? "finite" : "NON-FINITE"),
        "<= 1e-9, finite", worst_normal <= 1e-9 && positions_finite))
        << w.name;

    const std::vector<float> albedo = level_sample_albedo(level);
    const LevelScene scene(level, level.res);
    const std::vector<float> ld_ref = level_direct_light(scene, d.lights, albedo, 1);
    Result<cpu::CpuDirectLight> direct = cpu::CpuDirectLight::create(level, albedo);
    ASSERT_TRUE(direct.ok()) << w.name << ": " << direct.status().to_string();
    cpu::CpuLight light;
    light.position = glm::vec3(d.lights[0].position);
    light.radius = 0.0f;
    std::vector<float> ld(ld_ref.size());
    ASSERT_TRUE(direct->evaluate(std::span(&light, 1), ld).ok()) << w.name;
    const float ld_max = *std::max_element(ld.begin(), ld.end());
    // Floors and ceilings, and every sample. On bent walls a wall sample sits on the exact
    // curved surface, which either evaluator's tessellation of a wall may cover differently
    // (test_cpu_direct_light.cpp ShadowedPointLightsMatchEmbree): there the walls are logged.
    std::vector<float> h_cpu, h_ref;
    for (std::size_t s = 0; s < g.normal.size(); ++s)
      if (std::abs(g.normal[s].y) > 0.9)
        for (int c = 0; c < 3; ++c) {
          h_cpu.push_back(ld[3 * s + std::size_t(c)]);
          h_ref.push_back(ld_ref[3 * s + std::size_t(c)]);
        }
    const bool finite_ld = all_finite(ld) && all_finite(ld_ref);
    const double e_h = rel_l2(h_cpu, h_ref), e_ld = rel_l2(ld, ld_ref);
    EXPECT_TRUE(row(w.name, "CpuDirectLight vs Embree ld, floors+ceilings",
                    fmt("%.2e%s (max ld %.3g)", e_h, finite_ld ? "" : " NON-FINITE", double(ld_max)),
                    "<= 1e-4, finite", e_h <= 1e-4 && finite_ld))
        << w.name;
    if (w.twist == 0.0)
      EXPECT_TRUE(
          row(w.name, "CpuDirectLight vs Embree ld, all samples", fmt("%.2e", e_ld), "<= 1e-4", e_ld <= 1e-4))
          << w.name;
    else
      stress::report(w.name, "CpuDirectLight vs Embree ld, all samples (bent walls)", fmt("%.2e", e_ld));

    Result<cpu::CpuLevelRuntime> rt = cpu::CpuLevelRuntime::create(level, dict);
    ASSERT_TRUE(rt.ok()) << rt.status().to_string();
    std::vector<float> lightmap(rt->sizes().lightmap);
    ASSERT_TRUE(rt->evaluate(ld, lightmap).ok()) << w.name;
    const LevelBufferSizes sz = level_buffer_sizes(level, dict);
    std::vector<float> b(sz.b), r(sz.r), ref(sz.lightmap);
    ASSERT_TRUE(level_evaluate(level, dict, ld, b, r, ref).ok());
    const double e = rel_l2(lightmap, ref);
    EXPECT_TRUE(row(w.name, "CPU lightmap vs core reference",
                    fmt("%.2e%s", e, all_finite(lightmap) ? "" : " NON-FINITE"), "<= 1e-5, finite",
                    e <= 1e-5 && all_finite(lightmap)))
        << w.name;
  }
}

// Flatter than the validator's floor (Jacobian determinant <= 1e-6 cell^3): refused, naming
// the block and the determinant, before anything is built.
TEST(StressWarp, DegenerateWarpIsRefused) {
  const LevelDescription d = warped_corridor({"warp 1:1e-7:1 (degenerate)", {1.0, 1e-7, 1.0}});
  const Result<Level> built = build_level(d, test::small_test_dictionary());
  const bool refused = !built.ok() && built.status().code() == ErrorCode::invalid_argument &&
                       built.status().message().find("degenerate") != std::string::npos;
  EXPECT_TRUE(row("warp 1:1e-7:1 (det 1e-7)", "validate_level",
                  refused ? "refused: degenerate warp" : "accepted", "invalid_argument naming the block",
                  refused))
      << built.status().to_string();
  std::printf("  %s\n", built.status().to_string().c_str());
}

}  // namespace
}  // namespace modrt::precompute
