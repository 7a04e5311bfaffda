// SPDX-License-Identifier: MIT
// The ground-truth path tracer on triangle meshes (mesh_path_tracer.h): against the level path
// tracer on the same walls, energy conservation in a closed box, winding independence, the
// runtime's light model (CPU evaluator, spot cones) and its refusals of bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include <tbb/global_control.h>

#include "modrt/cpu/direct_light.h"
#include "modrt/level_geometry.h"
#include "modrt/precompute/level_build.h"
#include "modrt/precompute/mesh_path_tracer.h"
#include "modrt/precompute/path_tracer.h"
#include "modrt/precompute/sampling.h"
#include "test_support.h"

namespace modrt::precompute {
namespace {

struct TestMesh {
  std::vector<glm::dvec3> positions;
  std::vector<std::uint32_t> indices;
  std::vector<glm::dvec3> albedo;

  Result<MeshScene> scene() const { return MeshScene::create(positions, indices, albedo); }
  // Corner 0 stays, corners 1 and 2 swap: the mirror winding.
  void flip(std::size_t triangle) { std::swap(indices[3 * triangle + 1], indices[3 * triangle + 2]); }
  std::size_t triangles() const { return indices.size() / 3; }
};

// The face f of the box [lo, lo + extent] as an m x m grid of quads, two triangles each.
void add_box_face(TestMesh& mesh, const glm::dvec3& lo, const glm::dvec3& extent, int f, int m,
                  const glm::dvec3& albedo) {
  const auto base = std::uint32_t(mesh.positions.size());
  for (int j = 0; j <= m; ++j)
    for (int i = 0; i <= m; ++i)
      mesh.positions.push_back(lo + extent * face_point(f, double(i) / m, double(j) / m));
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) {
      const std::uint32_t v00 = base + std::uint32_t(j * (m + 1) + i), v10 = v00 + 1,
                          v01 = v00 + std::uint32_t(m + 1), v11 = v01 + 1;
      mesh.indices.insert(mesh.indices.end(), {v00, v10, v11, v00, v11, v01});
      mesh.albedo.insert(mesh.albedo.end(), {albedo, albedo});
    }
}

// Every present world face of every block of an unwarped level of unit cells, one quad each,
// with the block's albedo for that face: the level's walls as an artist's triangles.
TestMesh level_mesh(const LevelDescription& d) {
  TestMesh mesh;
  for (const BlockDescription& b : d.blocks)
    for (int f = 0; f < kFaceCount; ++f)
      if (face_present(b.faces, f))
        add_box_face(mesh, glm::dvec3(b.cell), glm::dvec3(1.0), f, 1, b.albedo[std::size_t(f)]);
  return mesh;
}

// Three unit blocks in an L, each face its own colour, the light in the first block; the third
// block sees the light only by reflections.
LevelDescription l_shaped_level() {
  LevelDescription d;
  const glm::ivec3 cells[] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}};
  const std::initializer_list<int> open[] = {{kFacePosX}, {kFaceNegX, kFacePosZ}, {kFaceNegZ}};
  for (int k = 0; k < 3; ++k) {
    BlockDescription b;
    b.cell = cells[k];
    unsigned mask = kAllFaces;
    for (int f : open[k]) mask &= ~(1u << f);
    b.faces = FaceMask(mask);
    for (int f = 0; f < kFaceCount; ++f)
      b.albedo[std::size_t(f)] = glm::dvec3(0.35 + 0.1 * f, 0.8 - 0.07 * f, 0.3 + 0.05 * ((f + k) % 3));
    d.blocks.push_back(b);
  }
  LightDescription light;
  light.position = {0.4, 0.6, 0.45};
  light.radius = 0.05;
  light.color = {1.0, 0.9, 0.7};
  light.intensity = 1.5;
  d.lights = {light};
  return d;
}

std::vector<MeshLight> mesh_lights(const LevelDescription& d) {
  std::vector<MeshLight> out;
  for (const LightDescription& l : d.lights) out.push_back({l, std::nullopt});
  return out;
}

bool all_finite(const std::vector<float>& v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

bool bit_identical(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// (1) The L-shaped level's walls traced as the level (LevelScene, one-sided proxy walls) and as
// a triangle mesh with the same albedo: the indirect estimates at every level texel agree within
// their standard errors, and their per-face means within a few percent.
TEST(MeshPathTracer, AgreesWithTheLevelPathTracerOnTheSameWalls) {
  const LevelDescription d = l_shaped_level();
  const Level level = build_level(d, test::small_test_dictionary()).value();
  const LevelScene level_scene(level, level.res);
  const LevelSampleGeometry& g = level_scene.samples();
  const TestMesh mesh = level_mesh(d);
  const MeshScene scene = mesh.scene().value();
  PathTracerSettings settings;
  settings.paths = 64;
  settings.bounces = 3;
  settings.light_samples = 4;
  settings.seed = 11;
  const IndirectEstimate reference =
      trace_indirect(level_scene, g.position, g.normal, level_direct_radiance(level_scene, d, 4),
                     level_surface_albedo(level_scene, d), settings);
  // The mesh's estimate, by cosine paths and with light-vertex connections (MIS), each against
  // the level's.
  for (const bool mis : {false, true}) {
    settings.seed = mis ? 13 : 12;
    settings.paths = mis ? 32 : 64;
    if (mis) settings.light_vertex_sources = level_light_centres(d);
    const Result<IndirectEstimate> est =
        trace_mesh_indirect(scene, mesh_lights(d), g.position, g.normal, settings);
    ASSERT_TRUE(est.ok()) << est.status().to_string();
    ASSERT_EQ(est->value.size(), reference.value.size());
    ASSERT_TRUE(all_finite(est->value) && all_finite(est->standard_error));
    double z2 = 0.0, worst = 0.0;
    for (std::size_t i = 0; i < est->value.size(); ++i) {
      const double se = std::hypot(double(est->standard_error[i]), double(reference.standard_error[i]));
      const double diff = double(est->value[i]) - double(reference.value[i]);
      z2 += diff * diff / std::max(se * se, 1e-30) / double(est->value.size());
      worst = std::max(worst, std::abs(diff) / std::max(se, 1e-30));
      ASSERT_LE(std::abs(diff), 4.0 * se + 1e-7) << "sample " << i / 3 << " channel " << i % 3;
    }
    // Per (block, face) means of res^2 texels: their relative L2 difference.
    const std::size_t per_face = std::size_t(level.res) * std::size_t(level.res);
    double d2 = 0.0, r2 = 0.0;
    for (std::size_t start = 0; start < g.position.size(); start += per_face)
      for (int c = 0; c < 3; ++c) {
        double a = 0.0, b = 0.0;
        for (std::size_t s = start; s < start + per_face; ++s) {
          ASSERT_TRUE(g.block[s] == g.block[start] && g.face[s] == g.face[start]) << "sample " << s;
          a += est->value[3 * s + std::size_t(c)];
          b += reference.value[3 * s + std::size_t(c)];
        }
        d2 += (a - b) * (a - b);
        r2 += b * b;
      }
    const double face_rel_l2 = std::sqrt(d2 / r2);
    std::printf(
        "%s, %zu texels: mean z^2 %.3f, worst |z| %.2f; noise floors mesh %.4f, level %.4f; face means "
        "rel L2 %.4f\n",
        mis ? "MIS" : "cosine", g.position.size(), z2, worst, relative_noise_floor(est.value()),
        relative_noise_floor(reference), face_rel_l2);
    // Mean squared z-score ~1 for unbiased estimates with honest standard errors (< 1: they
    // are conservative); a bias shows as >> 1.
    EXPECT_LT(z2, 1.6);
    EXPECT_GT(z2, 0.05);
    EXPECT_LT(face_rel_l2, 0.03);
  }
}

// (2) Energy conservation in a closed box of uniform albedo a around a point light of
// intensity I: the walls receive its whole power 4 pi I directly and a^k of it after k
// reflections, so over the box's surface the integral of E_direct / pi is 4 I and that of
// E_ind / pi after n bounces is 4 I (a + ... + a^n). The integrals are estimated from one
// jittered point per stratum (m x m strata per face), their standard error from pairs of
// neighbouring strata (collapsed strata: conservative, and covering the paths' noise too).
TEST(MeshPathTracer, ClosedBoxConservesEnergyAlongTheGeometricSeries) {
  const glm::dvec3 lo(-0.2, 0.1, 0.3), extent(1.0, 0.7, 1.3);
  std::vector<MeshLight> lights(1);
  lights[0].light.position = lo + glm::dvec3(0.3, 0.4, 0.8);
  lights[0].light.radius = 0.0;
  lights[0].light.color = glm::dvec3(1.0);
  const double I = 0.8;
  lights[0].light.intensity = I;
  const int strata = 12;
  std::vector<glm::dvec3> points, normals;
  std::vector<double> area;  // of each point's stratum
  Rng rng(5, 0);
  for (int f = 0; f < kFaceCount; ++f) {
    const FaceFrame& frame = face_frame(f);
    const double face_area = glm::length(glm::cross(extent * frame.u_axis, extent * frame.v_axis));
    for (int j = 0; j < strata; ++j)
      for (int i = 0; i < strata; ++i) {
        const glm::dvec2 s = rng.next_dvec2();
        points.push_back(lo + extent * face_point(f, (i + s.x) / strata, (j + s.y) / strata));
        normals.push_back(frame.normal);
        area.push_back(face_area / (strata * strata));
      }
  }
  // Integral and its collapsed-strata standard error of per-point values (channel 0).
  auto integral = [&](const std::vector<float>& v, double& se) {
    double sum = 0.0, var = 0.0;
    for (std::size_t p = 0; p + 1 < points.size(); p += 2) {
      const double ya = area[p] * v[3 * p], yb = area[p + 1] * v[3 * (p + 1)];
      sum += ya + yb;
      var += (ya - yb) * (ya - yb);
    }
    se = std::sqrt(var);
    return sum;
  };
  for (const double a : {0.6, 1.0}) {
    TestMesh mesh;
    for (int f = 0; f < kFaceCount; ++f) add_box_face(mesh, lo, extent, f, 4, glm::dvec3(a));
    for (std::size_t t = 0; t < mesh.triangles(); t += 3) mesh.flip(t);  // mixed winding
    const MeshScene scene = mesh.scene().value();
    double se = 0.0;
    const Result<std::vector<float>> direct = trace_mesh_direct(scene, lights, {points, normals, {}}, 1);
    ASSERT_TRUE(direct.ok()) << direct.status().to_string();
    const double direct_total = integral(direct.value(), se);
    std::printf("a = %.1f: integral of E_direct / pi %.5f +- %.5f, exact %.5f\n", a, direct_total, se, 4 * I);
    EXPECT_LE(std::abs(direct_total - 4 * I), 4.0 * se);
    for (const int bounces : {1, 4}) {
      if (a == 1.0 && bounces == 1) continue;
      PathTracerSettings settings;
      settings.paths = 64;
      settings.bounces = bounces;
      settings.light_samples = 1;
      const Result<IndirectEstimate> est = trace_mesh_indirect(scene, lights, points, normals, settings);
      ASSERT_TRUE(est.ok()) << est.status().to_string();
      ASSERT_TRUE(all_finite(est->value));
      const double total = integral(est->value, se);
      const double exact = 4 * I * (a == 1.0 ? bounces : a * (1.0 - std::pow(a, bounces)) / (1.0 - a));
      std::printf("a = %.1f, %d bounce(s): integral of E_ind / pi %.5f +- %.5f, exact %.5f (rel %.4f)\n", a,
                  bounces, total, se, exact, total / exact - 1.0);
      EXPECT_LE(std::abs(total - exact), 4.0 * se);
      EXPECT_LT(std::abs(total / exact - 1.0), 0.02);
    }
  }
}

// (3) Flipping every triangle's winding (or only some) changes nothing, bit for bit: the direct
// light, the indirect estimate with light-vertex connections, and the camera's primary hits.
// Float positions equal to the double ones give the same bits too, and so do 1 or 2 threads.
TEST(MeshPathTracer, WindingFloatPositionsAndThreadsChangeNothing) {
  const LevelDescription d = l_shaped_level();
  const TestMesh mesh = level_mesh(d);
  TestMesh flipped = mesh, mixed = mesh;
  for (std::size_t t = 0; t < mesh.triangles(); ++t) {
    flipped.flip(t);
    if (t % 3 == 1) mixed.flip(t);
  }
  std::vector<glm::vec3> float_positions(mesh.positions.begin(), mesh.positions.end());
  const std::vector<MeshLight> lights = mesh_lights(d);
  PathTracerSettings settings;
  settings.paths = 16;
  settings.bounces = 3;
  settings.light_samples = 4;
  settings.light_vertex_sources = mesh_light_centres(lights);

  struct Run {
    std::vector<float> direct, value, error;
    MeshCameraHits cam;
  };
  auto run = [&](const MeshScene& scene) {
    Run r;
    Result<MeshCameraHits> cam =
        mesh_camera_hits(scene, {0.2, 0.5, 0.1}, {1.6, 0.4, 1.7}, {0, 1, 0}, 75, 48, 32);
    EXPECT_TRUE(cam.ok()) << cam.status().to_string();
    r.cam = std::move(cam).value();
    const MeshCameraHits::Points p = r.cam.points();
    EXPECT_GT(p.positions.size(), std::size_t(48 * 32 * 9 / 10));
    r.direct = trace_mesh_direct(scene, lights, p.view(), 4).value();
    const IndirectEstimate est = trace_mesh_indirect(scene, lights, p.view(), settings).value();
    r.value = est.value;
    r.error = est.standard_error;
    return r;
  };
  const MeshScene base_scene = mesh.scene().value();
  const Run base = run(base_scene);
  ASSERT_TRUE(all_finite(base.direct) && all_finite(base.value));
  double sum = 0.0;
  for (float v : base.value) sum += v;
  ASSERT_GT(sum, 0.0);
  for (const char* what : {"flipped", "mixed", "float", "one thread"}) {
    const std::string name = what;
    const MeshScene scene = name == "flipped" ? flipped.scene().value()
                            : name == "mixed" ? mixed.scene().value()
                            : name == "float"
                                ? MeshScene::create(float_positions, mesh.indices, mesh.albedo).value()
                                : mesh.scene().value();
    std::unique_ptr<tbb::global_control> one_thread;
    if (name == "one thread")
      one_thread = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, 1);
    const Run r = run(scene);
    EXPECT_TRUE(bit_identical(r.direct, base.direct)) << what;
    EXPECT_TRUE(bit_identical(r.value, base.value)) << what;
    EXPECT_TRUE(bit_identical(r.error, base.error)) << what;
    EXPECT_EQ(r.cam.triangle, base.cam.triangle) << what;
    EXPECT_TRUE(r.cam.position == base.cam.position) << what;
    EXPECT_TRUE(r.cam.normal == base.cam.normal) << what;
  }
  // Every camera normal faces the camera, whatever the winding.
  const glm::dvec3 eye(0.2, 0.5, 0.1);
  for (std::size_t k : base.cam.hit_pixels())
    EXPECT_LT(glm::dot(base.cam.normal[k], base.cam.position[k] - eye), 0.0) << "pixel " << k;
}

// The light model is the runtime's: at the level's texels of a closed block, E_direct / pi of a
// point light and of a spot light times the albedo equals the CPU evaluator's ld (cpu_neon,
// float) to float precision. The spot's falloff is light_policy.h's smoothstep.
TEST(MeshPathTracer, DirectLightIsTheRuntimesPointAndSpotModel) {
  LevelDescription d;
  BlockDescription b;
  b.faces = kAllFaces;
  for (int f = 0; f < kFaceCount; ++f) b.albedo[std::size_t(f)] = glm::dvec3(0.4 + 0.1 * f, 0.7, 0.5);
  d.blocks = {b};
  const Level level = build_level(d, test::small_test_dictionary()).value();
  const LevelSampleGeometry g = level_sample_geometry(level);
  const std::vector<float> albedo = level_sample_albedo(level);
  const TestMesh mesh = level_mesh(d);
  const MeshScene scene = mesh.scene().value();

  cpu::CpuLight point;
  point.type = cpu::LightType::point;
  point.position = {0.35f, 0.7f, 0.6f};
  point.radius = 0.05f;
  point.color = {1.0f, 0.8f, 0.6f};
  point.intensity = 1.25f;
  cpu::CpuLight spot = point;
  spot.type = cpu::LightType::spot;
  spot.position = {0.5f, 0.75f, 0.45f};
  spot.direction = {0.3f, -1.0f, 0.2f};
  spot.inner_angle = 0.3f;
  spot.outer_angle = 0.6f;
  for (const cpu::CpuLight& light : {point, spot}) {
    Result<cpu::CpuDirectLight> cpu_light = cpu::CpuDirectLight::create(level, albedo);
    ASSERT_TRUE(cpu_light.ok()) << cpu_light.status().to_string();
    std::vector<float> ld(albedo.size());
    ASSERT_TRUE(cpu_light->evaluate(std::span(&light, 1), ld).ok());
    MeshLight m;
    m.light.position = glm::dvec3(light.position);
    m.light.radius = light.radius;
    m.light.color = glm::dvec3(light.color);
    m.light.intensity = light.intensity;
    if (light.type == cpu::LightType::spot)
      m.spot = SpotCone{glm::dvec3(light.direction), light.inner_angle, light.outer_angle};
    const std::vector<float> e =
        trace_mesh_direct(scene, std::span(&m, 1), {g.position, g.normal, {}}, 1).value();
    double max_rel = 0.0, peak = 0.0;
    int dark = 0;
    for (std::size_t i = 0; i < ld.size(); ++i) {
      const double mine = double(albedo[i]) * e[i];
      peak = std::max(peak, mine);
      dark += mine == 0.0;
      max_rel = std::max(max_rel, std::abs(mine - ld[i]) / std::max(double(ld[i]), 1e-3));
    }
    std::printf("%s: max relative difference to the CPU evaluator %.2e (peak ld %.3f, %d of %zu zero)\n",
                light.type == cpu::LightType::spot ? "spot" : "point", max_rel, peak, dark, ld.size());
    EXPECT_LT(max_rel, 1e-4);
    EXPECT_GT(peak, 0.0);
    if (light.type == cpu::LightType::spot) {
      EXPECT_GT(dark, int(ld.size() / 2));  // outside the cone
    }
  }
}

// A spot's falloff at points below it on a floor: full inside the inner cone, the smoothstep
// between, 0 outside; and the mesh's shadows: a small occluder between the light and a point
// darkens it.
TEST(MeshPathTracer, SpotConeAndShadows) {
  TestMesh mesh;
  add_box_face(mesh, {-2, 0, -2}, {4, 1, 4}, kFaceNegY, 1, glm::dvec3(0.5));  // floor y = 0
  const std::size_t floor_triangles = mesh.triangles();
  // A 0.2 x 0.2 square at y = 0.4 around (0.5, 0.4, 0).
  add_box_face(mesh, {0.4, 0.4, -0.1}, {0.2, 1, 0.2}, kFaceNegY, 1, glm::dvec3(0.5));
  const MeshScene scene = mesh.scene().value();
  MeshLight light;
  light.light.position = {0, 1, 0};
  light.light.radius = 0.0;
  light.light.intensity = 2.0;
  light.spot = SpotCone{{0, -1, 0}, 0.4, 0.8};
  std::vector<glm::dvec3> positions, normals;
  for (double angle : {0.0, 0.3, 0.5, 0.6, 0.7, 0.9}) {
    positions.push_back({0, 0, -std::tan(angle)});
    normals.push_back({0, 1, 0});
  }
  positions.push_back({std::tan(0.7), 0, 0});  // behind it: the ray to the light passes x = 0.51 at y = 0.4
  normals.push_back({0, 1, 0});
  const std::vector<float> e =
      trace_mesh_direct(scene, std::span(&light, 1), {positions, normals, {}}, 1).value();
  const SpotFalloff cone = spot_falloff(0.4, 0.8);
  for (std::size_t i = 0; i + 1 < positions.size(); ++i) {
    const double d2 = 1.0 + positions[i].z * positions[i].z, cos_a = 1.0 / std::sqrt(d2);
    const double expected = 2.0 * spot_factor(cone, cos_a) * cos_a / d2 / std::numbers::pi;
    EXPECT_NEAR(e[3 * i], expected, 1e-9 + 1e-6 * expected) << "point " << i;
  }
  EXPECT_GT(e[3 * 2], 0.0);
  EXPECT_LT(e[3 * 2], e[0]);                       // in the falloff
  EXPECT_EQ(e[3 * 5], 0.0f);                       // outside the cone
  EXPECT_EQ(e[3 * (positions.size() - 1)], 0.0f);  // in the occluder's shadow (inside the cone at 0.7)
  EXPECT_EQ(floor_triangles, 2u);
}

void expect_error(const Status& s, ErrorCode code, const std::string& needle, const char* what) {
  EXPECT_FALSE(s.ok()) << what;
  EXPECT_EQ(s.code(), code) << what << ": " << s.to_string();
  EXPECT_NE(s.message().find(needle), std::string::npos)
      << what << ": '" << s.message() << "' lacks '" << needle << "'";
}

// (4) Bad input is refused with a message naming the index; hostile but valid input gives
// finite numbers.
TEST(MeshPathTracer, BadInputIsRefusedNamingTheIndexAndNothingIsNaN) {
  TestMesh box;
  for (int f = 0; f < kFaceCount; ++f)
    add_box_face(box, glm::dvec3(0.0), glm::dvec3(1.0), f, 1, glm::dvec3(0.5));
  {
    TestMesh m = box;
    m.indices.pop_back();
    expect_error(m.scene().status(), ErrorCode::invalid_argument, "multiple of 3", "index count");
    m = box;
    m.albedo.pop_back();
    expect_error(m.scene().status(), ErrorCode::invalid_argument, "11 albedo values for 12 triangles",
                 "albedo count");
    m = box;
    m.positions[5].y = std::nan("");
    expect_error(m.scene().status(), ErrorCode::non_finite, "vertex 5", "NaN vertex");
    m = box;
    m.positions[2].x = 1e16;
    expect_error(m.scene().status(), ErrorCode::invalid_argument, "vertex 2", "untraceable vertex");
    m = box;
    m.indices[3 * 7 + 2] = 99;
    expect_error(m.scene().status(), ErrorCode::invalid_argument, "triangle 7: index 2 is 99", "index range");
    m = box;
    m.albedo[4] = {0.5, 1.5, 0.5};
    expect_error(m.scene().status(), ErrorCode::invalid_argument, "triangle 4: albedo", "albedo > 1");
    m.albedo[4] = {0.5, -0.1, 0.5};
    expect_error(m.scene().status(), ErrorCode::invalid_argument, "triangle 4: albedo", "albedo < 0");
    m.albedo[4] = {0.5, std::nan(""), 0.5};
    expect_error(m.scene().status(), ErrorCode::non_finite, "triangle 4: albedo", "NaN albedo");
  }
  const MeshScene scene = box.scene().value();
  const std::vector<glm::dvec3> positions = {{0.5, 0.0, 0.5}, {0.2, 0.3, 0.4}},
                                normals = {{0, 1, 0}, {0, 0, 2}};
  const MeshPoints points{positions, normals, {}};
  std::vector<MeshLight> good(2);
  good[0].light.position = {0.5, 0.5, 0.5};
  good[1].light.position = {0.3, 0.8, 0.2};
  good[1].spot = SpotCone{};
  PathTracerSettings settings;
  settings.paths = 4;
  settings.bounces = 2;
  ASSERT_TRUE(trace_mesh_indirect(scene, good, points, settings).ok());
  {
    const auto lights_error = [&](auto edit, ErrorCode code, const std::string& needle, const char* what) {
      std::vector<MeshLight> lights = good;
      edit(lights[1]);
      expect_error(validate_mesh_lights(lights), code, needle, what);
      expect_error(trace_mesh_direct(scene, lights, points, 1).status(), code, needle, what);
      expect_error(trace_mesh_indirect(scene, lights, points, settings).status(), code, needle, what);
    };
    lights_error([](MeshLight& l) { l.light.position.z = INFINITY; }, ErrorCode::non_finite,
                 "light 1: position", "light position");
    lights_error([](MeshLight& l) { l.light.radius = -1; }, ErrorCode::invalid_argument, "light 1: radius",
                 "light radius");
    lights_error([](MeshLight& l) { l.light.color.y = -1; }, ErrorCode::invalid_argument, "light 1: color",
                 "light color");
    lights_error([](MeshLight& l) { l.light.intensity = std::nan(""); }, ErrorCode::invalid_argument,
                 "light 1: intensity", "light intensity");
    lights_error([](MeshLight& l) { l.light.intensity = 1e19; }, ErrorCode::invalid_argument,
                 "kMaxLightIntensity", "light brightness");
    lights_error([](MeshLight& l) { l.light.position.x = 2e15; }, ErrorCode::invalid_argument,
                 "traceable range", "light reach");
    lights_error([](MeshLight& l) { l.spot->direction = glm::dvec3(0.0); }, ErrorCode::invalid_argument,
                 "light 1: spot direction", "spot direction");
    lights_error([](MeshLight& l) { l.spot->outer_angle = 0.0; }, ErrorCode::invalid_argument,
                 "light 1: spot outer_angle", "spot outer 0");
    lights_error([](MeshLight& l) { l.spot->outer_angle = 4.0; }, ErrorCode::invalid_argument,
                 "light 1: spot outer_angle", "spot outer > pi");
    lights_error([](MeshLight& l) { l.spot->inner_angle = 0.9; }, ErrorCode::invalid_argument,
                 "light 1: spot inner_angle", "spot inner > outer");
  }
  {
    PathTracerSettings s = settings;
    s.paths = 0;
    expect_error(trace_mesh_indirect(scene, good, points, s).status(), ErrorCode::invalid_argument,
                 "paths = 0", "paths");
    s = settings;
    s.bounces = -1;
    expect_error(trace_mesh_indirect(scene, good, points, s).status(), ErrorCode::invalid_argument,
                 "bounces = -1", "bounces");
    s = settings;
    s.light_samples = 0;
    expect_error(trace_mesh_indirect(scene, good, points, s).status(), ErrorCode::invalid_argument,
                 "light_samples = 0", "light samples");
    expect_error(trace_mesh_direct(scene, good, points, 5000).status(), ErrorCode::invalid_argument,
                 "light_samples = 5000", "direct light samples");
    s = settings;
    s.light_vertex_sources = {glm::dvec3(0.5), glm::dvec3(std::nan(""))};
    expect_error(trace_mesh_indirect(scene, good, points, s).status(), ErrorCode::invalid_argument,
                 "light_vertex_sources[1]", "light-vertex source");
  }
  {
    const std::vector<glm::dvec3> nan_position = {{0.5, 0.0, 0.5}, {0.2, std::nan(""), 0.4}},
                                  zero_normal = {{0, 1, 0}, {0, 0, 0}}, one = {{0, 1, 0}};
    const std::vector<int> bad_triangle = {0, 12}, short_triangles = {0};
    const struct {
      MeshPoints p;
      ErrorCode code;
      const char* needle;
    } cases[] = {
        {{positions, one, {}}, ErrorCode::invalid_argument, "2 positions but 1 normals"},
        {{nan_position, normals, {}}, ErrorCode::non_finite, "point 1: position"},
        {{positions, zero_normal, {}}, ErrorCode::invalid_argument, "point 1: normal"},
        {{positions, normals, bad_triangle}, ErrorCode::invalid_argument, "point 1: triangle 12"},
        {{positions, normals, short_triangles}, ErrorCode::invalid_argument, "1 triangles"},
    };
    for (const auto& c : cases) {
      expect_error(trace_mesh_direct(scene, good, c.p, 1).status(), c.code, c.needle, c.needle);
      expect_error(trace_mesh_indirect(scene, good, c.p, settings).status(), c.code, c.needle, c.needle);
    }
  }
  {
    const glm::dvec3 eye(0.5), target(0.5, 0.5, 1.0), up(0, 1, 0);
    expect_error(mesh_camera_hits(scene, eye, target, up, 60, 0, 10).status(), ErrorCode::invalid_argument,
                 "each side", "width");
    expect_error(mesh_camera_hits(scene, eye, target, up, 180, 10, 10).status(), ErrorCode::invalid_argument,
                 "vertical_fov_degrees", "fov");
    expect_error(mesh_camera_hits(scene, glm::dvec3(NAN), target, up, 60, 10, 10).status(),
                 ErrorCode::invalid_argument, "eye", "eye");
    expect_error(mesh_camera_hits(scene, eye, eye, up, 60, 10, 10).status(), ErrorCode::invalid_argument,
                 "is the eye", "target");
    expect_error(mesh_camera_hits(scene, eye, glm::dvec3(0.5, 0.9, 0.5), up, 60, 10, 10).status(),
                 ErrorCode::invalid_argument, "parallel", "up");
  }
  // Hostile but valid: a light on a wall and at a vertex, points at a light's centre and on an
  // edge, unnormalised normals, degenerate triangles (a repeated index, collinear corners), an
  // empty scene. Every number finite.
  TestMesh hostile = box;
  for (const double c : {0.5, 0.6, 0.7}) hostile.positions.push_back(glm::dvec3(c));
  const auto k = std::uint32_t(hostile.positions.size());
  hostile.indices.insert(hostile.indices.end(), {0, 0, 1, k - 2, k - 1, k - 2, k - 3, k - 2, k - 1});
  hostile.albedo.insert(hostile.albedo.end(), 3, glm::dvec3(1.0));
  const MeshScene hostile_scene = hostile.scene().value();
  EXPECT_EQ(hostile_scene.degenerate_triangle_count(), 3u);
  std::vector<MeshLight> lights(3);
  lights[0].light.position = {0.5, 0.0, 0.5};  // on the floor
  lights[0].light.radius = 0.0;
  lights[1].light.position = {0.0, 0.0, 0.0};  // at a corner
  lights[2].light.position = {0.3, 0.3, 0.3};
  lights[2].light.radius = 0.2;
  lights[2].spot = SpotCone{{1, 1, 1}, 0.0, 0.0001};
  const std::vector<glm::dvec3> hp = {{0.5, 0.0, 0.5}, {0.3, 0.3, 0.3}, {1.0, 0.5, 0.0}, {0.5, 1.0, 0.5}},
                                hn = {{0, 1e-300, 0}, {1e300, 1e300, 0}, {-1, 0, 1}, {0, -3, 0}};
  settings.light_vertex_sources = {{0.5, 0.0, 0.5}, {0.3, 0.3, 0.3}};
  for (const MeshScene* s : {&hostile_scene, &scene}) {
    const Result<std::vector<float>> e = trace_mesh_direct(*s, lights, {hp, hn, {}}, 8);
    ASSERT_TRUE(e.ok()) << e.status().to_string();
    EXPECT_TRUE(all_finite(e.value()));
    const Result<IndirectEstimate> est = trace_mesh_indirect(*s, lights, hp, hn, settings);
    ASSERT_TRUE(est.ok()) << est.status().to_string();
    EXPECT_TRUE(all_finite(est->value) && all_finite(est->standard_error));
  }
  const MeshScene empty = MeshScene::create(std::span<const glm::dvec3>{}, {}, {}).value();
  const Result<IndirectEstimate> nothing = trace_mesh_indirect(empty, lights, hp, hn, settings);
  ASSERT_TRUE(nothing.ok());
  EXPECT_TRUE(std::all_of(nothing->value.begin(), nothing->value.end(), [](float v) { return v == 0.0f; }));
}

}  // namespace
}  // namespace modrt::precompute
