// SPDX-License-Identifier: MIT
// Core's exact dirty tracking (level_dirty.h) against brute force over the level's records and
// slots: the graph in both directions, and which blocks, slots and tiles a changed ld reaches,
// on random changes of the corridor and the 41-block maze; and the padded atlas per block
// (atlas_block_padding, the camera skip's atlas work) from the tile rectangles directly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

#include "level_fixtures.h"
#include "modrt/level_dirty.h"

namespace modrt::test {
namespace {

std::vector<std::uint32_t> sorted(std::span<const std::uint32_t> v) {
  std::vector<std::uint32_t> out(v.begin(), v.end());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(LevelDirty, DependenciesAreTheLevelsRecordsAndSlots) {
  for (const char* name : {"single", "corridor", "maze41"}) {
    const Level& level = test_level(name).level;
    const LevelDependencies d = level_dependencies(level);
    for (std::size_t s = 0; s < level.slots.size(); ++s) {
      std::vector<std::uint32_t> records;
      for (std::size_t m = 0; m < level.records.size(); ++m)
        if (level.records[m].slot == s) records.push_back(std::uint32_t(m));
      EXPECT_EQ(sorted(d.records_of_slot(s)), records) << name << " slot " << s;
    }
    for (std::size_t i = 0; i < level.blocks.size(); ++i) {
      std::vector<std::uint32_t> entering, fed;
      for (std::size_t s = 0; s < level.slots.size(); ++s)
        if (level.slots[s].block == i) entering.push_back(std::uint32_t(s));
      for (const ResponseRecord& r : level.records)
        if (r.source_block == i) fed.push_back(r.slot);
      std::sort(fed.begin(), fed.end());
      EXPECT_EQ(sorted(d.slots_of_block(i)), entering) << name << " block " << i;
      EXPECT_EQ(sorted(d.slots_fed_by(i)), fed) << name << " block " << i;
    }
  }
}

// Blocks, slots and tiles a set of changed blocks reaches, from the records directly.
struct Reach {
  std::vector<std::uint8_t> blocks, slots, tiles;
};
Reach brute_force(const Level& level, const std::vector<std::uint8_t>& changed) {
  Reach r{changed, std::vector<std::uint8_t>(level.slots.size(), 0), changed};
  for (const ResponseRecord& rec : level.records)
    if (changed[rec.source_block]) r.slots[rec.slot] = 1;
  for (std::size_t s = 0; s < level.slots.size(); ++s)
    if (r.slots[s]) r.tiles[level.slots[s].block] = 1;
  return r;
}

std::vector<std::uint8_t> flags(std::span<const std::uint8_t> v) { return {v.begin(), v.end()}; }

TEST(LevelDirty, MarkReachesWhatTheRecordsCarry) {
  for (const char* name : {"corridor", "maze41"}) {
    const TestLevel& t = test_level(name);
    const Level& level = t.level;
    const std::size_t blocks = level.blocks.size();
    LevelDirtyTracker tracker = LevelDirtyTracker::create(level);
    std::vector<float> ld = t.ld;
    EXPECT_EQ(tracker.mark(ld), blocks) << "the first frame computes everything";
    EXPECT_EQ(tracker.dirty_slots(), level.slots.size());
    EXPECT_EQ(tracker.mark(ld), 0u) << "the same ld reaches nothing";
    EXPECT_EQ(tracker.dirty_slots(), 0u);
    EXPECT_EQ(tracker.dirty_tiles(), 0u);
    std::mt19937 rng(17);
    std::size_t partly_reached = 0;
    for (int trial = 0; trial < 40; ++trial) {
      const std::vector<float> before = ld;
      const std::size_t n = 1 + std::size_t(rng() % (trial % 4 == 0 ? blocks : 3));
      for (std::size_t k = 0; k < n; ++k) {
        const LevelBlock& b = level.blocks[rng() % blocks];
        const std::size_t at = 3 * std::size_t(b.sample_offset) + rng() % (3 * std::size_t(b.sample_count));
        ld[at] =
            ld[at] == 0.0f ? (std::signbit(ld[at]) ? 0.0f : -0.0f) : ld[at] * 1.5f;  // -0 vs +0: a change
      }
      std::vector<std::uint8_t> changed(blocks, 0);  // bit for bit, from the buffers
      for (std::size_t i = 0; i < blocks; ++i) {
        const std::size_t first = 3 * std::size_t(level.blocks[i].sample_offset);
        changed[i] = std::memcmp(ld.data() + first, before.data() + first,
                                 3 * std::size_t(level.blocks[i].sample_count) * sizeof(float)) != 0;
      }
      const Reach want = brute_force(level, changed);
      const std::size_t dirty = tracker.mark(ld);
      EXPECT_EQ(flags(tracker.blocks()), want.blocks) << name << " trial " << trial;
      EXPECT_EQ(flags(tracker.slots()), want.slots) << name << " trial " << trial;
      EXPECT_EQ(flags(tracker.tiles()), want.tiles) << name << " trial " << trial;
      EXPECT_EQ(dirty, std::size_t(std::count(changed.begin(), changed.end(), 1)));
      EXPECT_EQ(tracker.dirty_tiles(), std::size_t(std::count(want.tiles.begin(), want.tiles.end(), 1)));
      partly_reached += tracker.dirty_tiles() > dirty && tracker.dirty_tiles() < blocks;
    }
    // In the maze light crosses interfaces (tiles beyond the changed blocks) but does not
    // reach the whole level (the corridor's few blocks all see each other).
    if (blocks > 20) {
      EXPECT_GT(partly_reached, 10u) << name;
    }
    EXPECT_EQ(tracker.mark(ld, true), blocks) << "everything";
    EXPECT_EQ(tracker.mark(ld), 0u);
    tracker.invalidate();
    EXPECT_EQ(tracker.mark(ld), blocks) << "after invalidate()";
    std::printf("  %s: %llu of 40 random changes reach tiles beyond their blocks but not all\n", name,
                (unsigned long long)partly_reached);
  }
}

// Each padding record belongs to the block whose tile rectangle holds its destination, and its
// source's block (the sample texel it copies) is a padding neighbour of that block unless it
// is the block itself: from the tile origins and the sample ranges, record by record.
TEST(LevelDirty, AtlasPaddingPerBlockIsTheTileRectanglesRecords) {
  for (const char* name : {"single", "corridor", "maze11", "maze41"}) {
    const Level& level = test_level(name).level;
    const LightmapAtlas& atlas = level.atlas;
    const std::size_t blocks = level.blocks.size();
    const AtlasBlockPadding p = atlas_block_padding(level);
    ASSERT_EQ(p.record_begin.size(), blocks + 1) << name;
    ASSERT_EQ(p.source_begin.size(), blocks + 1) << name;
    const auto in_tiles_of = [&](std::size_t i, std::uint32_t texel) {
      const std::int64_t x = texel % std::uint32_t(atlas.width), y = texel / std::uint32_t(atlas.width);
      for (int f = 0; f < kFaceCount; ++f) {
        const std::int64_t ox = atlas.tile_origin_x[i][std::size_t(f)],
                           oy = atlas.tile_origin_y[i][std::size_t(f)];
        if (ox >= 0 && x >= ox && x < ox + atlas.tile && y >= oy && y < oy + atlas.tile) return true;
      }
      return false;
    };
    const auto sample_block = [&](std::uint32_t texel) {
      for (std::size_t i = 0; i < blocks; ++i)
        for (std::uint32_t k = 0; k < level.blocks[i].sample_count; ++k)
          if (atlas.sample_texel[level.blocks[i].sample_offset + k] == texel) return i;
      return blocks;
    };
    std::size_t records = 0, with_neighbours = 0;
    for (std::size_t i = 0; i < blocks; ++i) {
      std::vector<std::uint32_t> want_records, want_sources;
      for (std::size_t m = 0; m < atlas.padding.size(); ++m)
        if (in_tiles_of(i, atlas.padding[m].dst)) {
          want_records.push_back(std::uint32_t(m));
          const std::size_t j = sample_block(atlas.padding[m].src);
          ASSERT_LT(j, blocks) << name << " record " << m << " copies no sample texel";
          if (j != i) want_sources.push_back(std::uint32_t(j));
        }
      std::sort(want_sources.begin(), want_sources.end());
      want_sources.erase(std::unique(want_sources.begin(), want_sources.end()), want_sources.end());
      const std::span<const std::uint32_t> got = p.records_of(i);
      EXPECT_EQ(std::vector<std::uint32_t>(got.begin(), got.end()), want_records) << name << " block " << i;
      EXPECT_EQ(sorted(p.sources_of(i)), want_sources) << name << " block " << i;
      records += got.size(), with_neighbours += !want_sources.empty();
    }
    EXPECT_EQ(records, atlas.padding.size()) << name << ": every record has a block";
    if (blocks > 1) {
      EXPECT_GT(with_neighbours, 0u) << name << ": padding reads across open faces";
    }
    std::printf("  %s: %zu padding records, %zu of %zu blocks read a neighbour's interior\n", name, records,
                with_neighbours, blocks);
  }
}

}  // namespace
}  // namespace modrt::test
