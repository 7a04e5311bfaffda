// SPDX-License-Identifier: MIT
// The GPU direct-light pass at the proxy samples (gles/include/modrt/gles/gles_direct_light.h)
// on every GL context: without shadows it is modrt::cpu's CpuDirectLight (point, spot and
// directional models, the same light units and falloff floor; relative L2 <= 1e-5, float32 GPU math in
// another order); the level runtime evaluates its texture as it evaluates the same ld from
// memory (relative L2 <= 1e-6); a bad light is refused by name. The shadowed pass against the
// ray-traced direct light: test_demo (DemoRender.LdPassMatchesRayTracedDirectLight).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "compare_support.h"
#include "gl_test_context.h"
#include "level_fixtures.h"
#include "modrt/cpu/direct_light.h"
#include "modrt/gles/gles_direct_light.h"
#include "modrt/gles/gles_level_runtime.h"
#include "modrt/level_geometry.h"

namespace modrt {
namespace {

using platform::ContextRequest;

using test::rel_l2;

class GlesDirectLightTest : public test::GlContextTest {};

std::vector<float> cpu_ld(const Level& level, std::span<const float> albedo, const cpu::CpuLight& light) {
  cpu::CpuDirectLightOptions o;
  o.shadows = false;
  Result<cpu::CpuDirectLight> d = cpu::CpuDirectLight::create(level, albedo, o);
  EXPECT_TRUE(d.ok()) << d.status().to_string();
  std::vector<float> ld(albedo.size());
  EXPECT_TRUE(d->evaluate(std::span(&light, 1), ld).ok());
  return ld;
}

TEST_P(GlesDirectLightTest, WithoutShadowsItIsTheCpuEvaluator) {
  const test::TestLevel& t = test::test_level("maze11");
  Result<std::unique_ptr<gles::GlesDirectLight>> d = gles::GlesDirectLight::create(gl(), t.level, t.albedo);
  ASSERT_TRUE(d.ok()) << d.status().to_string();
  const glm::vec3 at = glm::vec3(t.description.lights.front().position);
  for (const cpu::LightType type :
       {cpu::LightType::point, cpu::LightType::spot, cpu::LightType::directional}) {
    const bool spot = type == cpu::LightType::spot, directional = type == cpu::LightType::directional;
    const char* name = spot ? "spot" : directional ? "directional" : "point";
    cpu::CpuLight c;
    c.type = type;
    c.position = at;
    c.color = glm::vec3(1.0f, 0.8f, 0.6f);
    c.intensity = 2.5f;
    c.radius = 0.05f;
    c.direction = glm::vec3(0.4f, -1.0f, 0.2f);
    c.inner_angle = 0.4f;
    c.outer_angle = 0.9f;
    gles::GpuLight g;
    g.position = c.position;
    g.rgb = c.color * c.intensity;
    g.radius = c.radius;
    if (spot) g.spot_direction = c.direction, g.spot_inner = c.inner_angle, g.spot_outer = c.outer_angle;
    if (directional) g.directional = true, g.spot_direction = c.direction;
    ASSERT_TRUE(d.value()->render(g).ok());
    std::vector<float> ld(t.albedo.size());
    ASSERT_TRUE(d.value()->read_ld(ld).ok());
    const std::vector<float> ref = cpu_ld(t.level, t.albedo, c);
    const double e = rel_l2(ld, ref);
    EXPECT_LT(e, 1e-5) << name;
    EXPECT_GT(*std::max_element(ld.begin(), ld.end()), 0.0f) << name << ": nothing lit";
    std::printf("  %s light: GPU ld vs CpuDirectLight (no shadows) rel L2 %.2e\n", name, e);
  }
}

TEST_P(GlesDirectLightTest, TheLevelRuntimeReadsItsTextureAsTheSameLdFromMemory) {
  const test::TestLevel& t = test::test_level("maze11");
  std::unique_ptr<gles::GlesDirectLight> d = gles::GlesDirectLight::create(gl(), t.level, t.albedo).value();
  gles::GpuLight g;
  g.position = glm::vec3(t.description.lights.front().position);
  g.rgb = glm::vec3(3.0f);
  ASSERT_TRUE(d->render(g).ok());
  std::vector<float> ld(t.albedo.size());
  ASSERT_TRUE(d->read_ld(ld).ok());
  std::unique_ptr<gles::GlesLevelRuntime> a =
      gles::GlesLevelRuntime::create(gl(), gles(), t.level, test::small_test_dictionary()).value();
  std::unique_ptr<gles::GlesLevelRuntime> b =
      gles::GlesLevelRuntime::create(gl(), gles(), t.level, test::small_test_dictionary()).value();
  EXPECT_EQ(d->layout().width, a->ld_texture_size().width);
  EXPECT_EQ(d->layout().height, a->ld_texture_size().height);
  ASSERT_TRUE(a->set_albedo(t.albedo).ok());
  ASSERT_TRUE(b->set_albedo(t.albedo).ok());
  ASSERT_TRUE(a->update_from_texture(d->ld_texture()).ok());
  ASSERT_TRUE(a->multi_bounce_step_from_texture(d->ld_texture()).ok());
  ASSERT_TRUE(b->update(ld).ok());
  ASSERT_TRUE(b->multi_bounce_step(ld).ok());
  std::vector<float> la(a->sizes().lightmap), lb(la.size());
  ASSERT_TRUE(a->read_lightmap(la).ok());
  ASSERT_TRUE(b->read_lightmap(lb).ok());
  EXPECT_LT(rel_l2(la, lb), 1e-6);
  // The converged solve from the texture is the one from the values read back.
  ASSERT_TRUE(a->update_converged_from_texture(d->ld_texture()).ok());
  ASSERT_TRUE(b->update_converged(ld).ok());
  ASSERT_TRUE(a->read_lightmap(la).ok());
  ASSERT_TRUE(b->read_lightmap(lb).ok());
  EXPECT_LT(rel_l2(la, lb), 1e-6);
  EXPECT_EQ(a->update_converged_from_texture(0).code(), ErrorCode::invalid_argument) << "not a texture";
}

TEST_P(GlesDirectLightTest, ABadLightIsRefused) {
  const test::TestLevel& t = test::test_level("single");
  std::unique_ptr<gles::GlesDirectLight> d = gles::GlesDirectLight::create(gl(), t.level, t.albedo).value();
  gles::GpuLight g;
  g.position.y = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(d->render(g).code(), ErrorCode::non_finite);
  g = gles::GpuLight{};
  g.rgb.z = -1.0f;
  EXPECT_EQ(d->render(g).code(), ErrorCode::invalid_argument);
  g = gles::GpuLight{};
  g.directional = true;
  g.spot_direction = glm::vec3(0.0f);
  EXPECT_EQ(d->render(g).code(), ErrorCode::invalid_argument) << "a directional light without a direction";
  std::vector<float> short_ld(5);
  EXPECT_EQ(d->read_ld(short_ld).code(), ErrorCode::invalid_argument);
  std::vector<float> albedo = t.albedo;
  albedo[4] = -0.5f;
  EXPECT_FALSE(gles::GlesDirectLight::create(gl(), t.level, albedo).ok());
  EXPECT_FALSE(gles::GlesDirectLight::create(gl(), t.level, std::span(albedo).first(6)).ok());
}

INSTANTIATE_TEST_SUITE_P(Contexts, GlesDirectLightTest,
                         ::testing::Values(ContextRequest::egl_surfaceless, ContextRequest::osmesa,
                                           ContextRequest::egl_device),
                         test::gl_context_test_name);

}  // namespace
}  // namespace modrt
