// SPDX-License-Identifier: MIT
// The frame pipeline (core/include/modrt/frame_pipeline.h) over the CPU backend: a frame is the
// update and its feedback steps, bit for bit; a repeated frame is skipped exactly and anything
// that changes the result (ld, albedo, clutter, bounce count) runs it again; light that the
// bounces could carry past kMaxLightValue is refused before anything runs; the statistics
// count every evaluation (computed + kept = evaluations x blocks); bad calls are named.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "level_fixtures.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/frame_pipeline.h"
#include "modrt/reference_runtime.h"

namespace modrt {
namespace {

using test::small_test_dictionary;
using test::test_level;

std::unique_ptr<Backend> cpu_backend(const Level& level, bool skip = true) {
  cpu::CpuRuntimeOptions o;
  o.skip.enabled = skip;  // exact
  Result<std::unique_ptr<Backend>> b = cpu::create_cpu_backend(level, small_test_dictionary(), o);
  EXPECT_TRUE(b.ok()) << b.status().to_string();
  return std::move(b).value();
}

std::vector<float> lightmap_of(Backend& b) {
  std::vector<float> out(b.sizes().lightmap);
  EXPECT_TRUE(b.read_lightmap(out).ok());
  return out;
}

FramePipeline pipeline_on(Backend& b, std::uint32_t bounces) {
  FrameOptions o;
  o.bounces = bounces;
  Result<FramePipeline> p = FramePipeline::create(b, o);
  EXPECT_TRUE(p.ok()) << p.status().to_string();
  return std::move(p).value();
}

// A frame with N bounces is update + N multi_bounce_step on the same backend, bit for bit, and
// within 1e-5 of core's level_multi_bounce after N iterations.
TEST(FramePipeline, AFrameIsTheUpdateAndItsFeedbackSteps) {
  const test::TestLevel& t = test_level("maze11");
  std::unique_ptr<Backend> a = cpu_backend(t.level), b = cpu_backend(t.level);
  FramePipeline p = pipeline_on(*a, 3);
  ASSERT_TRUE(p.set_albedo(t.albedo).ok());
  ASSERT_TRUE(p.run(t.ld).ok());
  ASSERT_TRUE(b->set_albedo(t.albedo).ok());
  ASSERT_TRUE(b->update(t.ld).ok());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(b->multi_bounce_step(t.ld).ok());
  EXPECT_EQ(lightmap_of(*a), lightmap_of(*b));

  const LevelBufferSizes s = level_buffer_sizes(t.level, small_test_dictionary());
  std::vector<float> rb(s.b), rr(s.r), ref(s.lightmap);
  MultiBounceSettings mb;
  mb.max_iterations = 3;
  mb.tolerance = 0.0f;
  ASSERT_TRUE(level_multi_bounce(t.level, small_test_dictionary(), t.ld, t.albedo, mb, rb, rr, ref).ok());
  const std::vector<float> got = lightmap_of(*a);
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    num += (double(got[i]) - ref[i]) * (double(got[i]) - ref[i]);
    den += double(ref[i]) * ref[i];
  }
  EXPECT_LT(std::sqrt(num / den), 1e-5);
  // One update and three steps, each over every block (feedback changes every block's ld).
  const FrameStats st = p.stats();
  EXPECT_EQ(st.frames, 1u);
  EXPECT_EQ(st.evaluations.evaluations, 4u);
  EXPECT_EQ(st.evaluations.blocks_computed + st.evaluations.blocks_kept, 4 * t.level.blocks.size());
}

// With bounces, the same frame again runs nothing and keeps the results; a changed ld, albedo
// or bounce count, and any clutter call, run it again.
TEST(FramePipeline, ARepeatedFrameIsSkippedExactly) {
  const test::TestLevel& t = test_level("maze11");
  std::unique_ptr<Backend> a = cpu_backend(t.level);
  FramePipeline p = pipeline_on(*a, 2);
  ASSERT_TRUE(p.set_albedo(t.albedo).ok());
  ASSERT_TRUE(p.run(t.ld).ok());
  EXPECT_FALSE(p.last_frame_skipped());
  const std::vector<float> first = lightmap_of(*a);
  const BackendEvaluationStats before = p.stats().evaluations;

  // The skipped frame runs nothing and counts as one evaluation that kept everything, so
  // computed + kept stays evaluations x blocks (modrt_skip_stats).
  ASSERT_TRUE(p.run(t.ld).ok());
  EXPECT_TRUE(p.last_frame_skipped());
  const BackendEvaluationStats after = p.stats().evaluations;
  EXPECT_EQ(after.evaluations, before.evaluations + 1);
  EXPECT_EQ(after.evaluations_skipped, before.evaluations_skipped + 1);
  EXPECT_EQ(after.blocks_computed, before.blocks_computed);
  EXPECT_EQ(after.blocks_kept, before.blocks_kept + t.level.blocks.size());
  EXPECT_EQ(after.slots_kept, before.slots_kept + t.level.slots.size());
  EXPECT_EQ(after.tiles_written, before.tiles_written);
  EXPECT_EQ(after.tiles_kept, before.tiles_kept + t.level.blocks.size());
  EXPECT_EQ(after.blocks_computed + after.blocks_kept, after.evaluations * t.level.blocks.size());
  EXPECT_EQ(p.stats().frames, 2u);
  EXPECT_EQ(p.stats().frames_skipped, 1u);
  EXPECT_EQ(lightmap_of(*a), first);

  std::vector<float> ld = t.ld;
  ld[0] += 0.25f;
  ASSERT_TRUE(p.run(ld).ok());
  EXPECT_FALSE(p.last_frame_skipped());
  EXPECT_NE(lightmap_of(*a), first);
  ASSERT_TRUE(p.run(ld).ok());
  EXPECT_TRUE(p.last_frame_skipped());

  std::vector<float> darker = t.albedo;
  for (float& v : darker) v *= 0.5f;
  ASSERT_TRUE(p.set_albedo(darker).ok());
  ASSERT_TRUE(p.run(ld).ok());
  EXPECT_FALSE(p.last_frame_skipped());
  ASSERT_TRUE(p.run(ld, 3).ok());  // another bounce count: another result
  EXPECT_FALSE(p.last_frame_skipped());
  ASSERT_TRUE(p.set_clutter(nullptr).ok());
  ASSERT_TRUE(p.run(ld, 3).ok());
  EXPECT_FALSE(p.last_frame_skipped());

  // Skipping off: every frame runs.
  FrameOptions o;
  o.bounces = 2;
  o.skip_unchanged = false;
  std::unique_ptr<Backend> c = cpu_backend(t.level);
  FramePipeline q = FramePipeline::create(*c, o).value();
  ASSERT_TRUE(q.set_albedo(t.albedo).ok());
  ASSERT_TRUE(q.run(t.ld).ok());
  ASSERT_TRUE(q.run(t.ld).ok());
  EXPECT_FALSE(q.last_frame_skipped());
  EXPECT_EQ(q.stats().evaluations.evaluations, 6u);
}

// Light that the bounces could carry past 1e30 is refused before the update runs: the
// backend's results and counters do not change.
TEST(FramePipeline, LightTheBouncesCouldCarryPastTheLimitIsRefusedFirst) {
  const test::TestLevel& t = test_level("maze11");
  std::unique_ptr<Backend> a = cpu_backend(t.level);
  FramePipeline p = pipeline_on(*a, 1);
  std::vector<float> white(t.albedo.size(), 0.9f);
  ASSERT_TRUE(p.set_albedo(white).ok());
  ASSERT_TRUE(p.run(t.ld).ok());
  const std::vector<float> before = lightmap_of(*a);
  const std::uint64_t evaluations = p.stats().evaluations.evaluations;
  std::vector<float> hot = t.ld;
  hot[5] = 1e29f;  // 1e29 (1 + 0.9 / 0.1) = 1e30 x 1.0000...: past the limit
  const Status s = p.run(hot);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("above the largest light value 1e30"), std::string::npos) << s.message();
  EXPECT_EQ(p.stats().evaluations.evaluations, evaluations);
  EXPECT_EQ(lightmap_of(*a), before);
  // Without bounces the same ld is fine (it is below kMaxLightValue).
  ASSERT_TRUE(p.run(hot, 0).ok());
}

// Exact skipping inside the update: one changed block recomputes fewer blocks than a full
// frame, and computed + kept adds up over every evaluation.
TEST(FramePipeline, StatisticsCountEveryEvaluation) {
  const test::TestLevel& t = test_level("maze41");
  std::unique_ptr<Backend> a = cpu_backend(t.level);
  FramePipeline p = pipeline_on(*a, 0);
  ASSERT_TRUE(p.run(t.ld).ok());
  std::vector<float> ld = t.ld;
  const LevelBlock& blk = t.level.blocks[7];
  ld[3 * blk.sample_offset] += 1.0f;
  ASSERT_TRUE(p.run(ld).ok());
  const FrameStats s = p.stats();
  const std::uint64_t blocks = t.level.blocks.size(), slots = t.level.slots.size();
  EXPECT_EQ(s.frames, 2u);
  EXPECT_EQ(s.evaluations.evaluations, 2u);
  EXPECT_EQ(s.evaluations.blocks_computed + s.evaluations.blocks_kept, 2 * blocks);
  EXPECT_EQ(s.evaluations.slots_computed + s.evaluations.slots_kept, 2 * slots);
  EXPECT_EQ(s.evaluations.tiles_written + s.evaluations.tiles_kept, 2 * blocks);
  // The first frame's blocks and block 7: exactly what changed (level_dirty.h), dark blocks
  // included in neither count of their own.
  EXPECT_EQ(s.evaluations.blocks_computed, blocks + 1);
  EXPECT_GT(s.evaluations.slots_kept, 0u);
  EXPECT_LT(s.evaluations.tiles_written, 2 * blocks);
}

TEST(FramePipeline, BadCallsAreNamed) {
  const test::TestLevel& t = test_level("single");
  std::unique_ptr<Backend> a = cpu_backend(t.level);
  FrameOptions o;
  o.bounces = kMaxFrameBounces + 1;
  const Result<FramePipeline> too_many = FramePipeline::create(*a, o);
  ASSERT_FALSE(too_many.ok());
  EXPECT_NE(too_many.status().message().find("bounces 65 is not in 0..64"), std::string::npos);

  FramePipeline p = pipeline_on(*a, 0);
  const Status short_ld = p.run(std::span<const float>(t.ld).first(3));
  ASSERT_FALSE(short_ld.ok());
  EXPECT_NE(short_ld.message().find("ld has 3 floats, expected"), std::string::npos) << short_ld.message();
  const Status texture = p.run_from_texture(1);  // the CPU backend reads ld from memory
  ASSERT_FALSE(texture.ok());
  EXPECT_NE(texture.message().find("cpu: ld comes from CPU memory"), std::string::npos) << texture.message();
  // Feedback steps without an albedo: the backend's own message.
  EXPECT_FALSE(p.run(t.ld, 1).ok());
  const Status bounces = p.run_from_texture(1, kMaxFrameBounces + 1);
  ASSERT_FALSE(bounces.ok());
  EXPECT_NE(bounces.message().find("bounces 65 is not in 0..64"), std::string::npos) << bounces.message();
}

}  // namespace
}  // namespace modrt
