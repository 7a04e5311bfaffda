// SPDX-License-Identifier: MIT
#include "modrt/level_dirty.h"

#include <algorithm>
#include <cstring>

namespace modrt {
namespace {

// Rows of `count` groups: begin has count + 1 entries, items each group's members in
// increasing order; group_of(m) names the group of member m < members.
template <class GroupOf, class ItemOf>
void build_rows(std::size_t count, std::size_t members, GroupOf group_of, ItemOf item_of,
                std::vector<std::uint32_t>& begin, std::vector<std::uint32_t>& items) {
  begin.assign(count + 1, 0);
  for (std::size_t m = 0; m < members; ++m) ++begin[group_of(m) + 1];
  for (std::size_t g = 0; g < count; ++g) begin[g + 1] += begin[g];
  items.assign(members, 0);
  std::vector<std::uint32_t> fill(begin.begin(), begin.end() - 1);
  for (std::size_t m = 0; m < members; ++m) items[fill[group_of(m)]++] = std::uint32_t(item_of(m));
}

}  // namespace

LevelDependencies level_dependencies(const Level& level) {
  LevelDependencies d;
  const auto self = [](std::size_t m) { return m; };
  build_rows(
      level.slots.size(), level.records.size(),
      [&](std::size_t m) { return std::size_t(level.records[m].slot); }, self, d.slot_record_begin,
      d.slot_records);
  build_rows(
      level.blocks.size(), level.slots.size(),
      [&](std::size_t m) { return std::size_t(level.slots[m].block); }, self, d.block_slot_begin,
      d.block_slots);
  build_rows(
      level.blocks.size(), level.records.size(),
      [&](std::size_t m) { return std::size_t(level.records[m].source_block); },
      [&](std::size_t m) { return std::size_t(level.records[m].slot); }, d.fed_slot_begin, d.fed_slots);
  return d;
}

AtlasBlockPadding atlas_block_padding(const Level& level) {
  const LightmapAtlas& atlas = level.atlas;
  const std::size_t blocks = level.blocks.size();
  const std::size_t width = std::size_t(std::max(atlas.width, 0)),
                    height = std::size_t(std::max(atlas.height, 0));
  // The block owning each atlas texel: tile rectangles (padding included) and sample texels.
  std::vector<std::int32_t> owner(width * height, -1);
  for (std::size_t i = 0; i < blocks && i < atlas.tile_origin_x.size() && i < atlas.tile_origin_y.size(); ++i)
    for (std::size_t f = 0; f < std::size_t(kFaceCount); ++f) {
      const std::int32_t ox = atlas.tile_origin_x[i][f], oy = atlas.tile_origin_y[i][f];
      if (ox < 0 || oy < 0) continue;
      for (std::size_t y = std::size_t(oy); y < std::min(height, std::size_t(oy) + std::size_t(atlas.tile));
           ++y)
        for (std::size_t x = std::size_t(ox); x < std::min(width, std::size_t(ox) + std::size_t(atlas.tile));
             ++x)
          owner[y * width + x] = std::int32_t(i);
    }
  if (atlas.sample_texel.size() == level.sample_count)
    for (std::size_t i = 0; i < blocks; ++i) {
      const LevelBlock& b = level.blocks[i];
      for (std::uint32_t k = 0; k < b.sample_count; ++k)
        if (const std::size_t t = std::size_t(b.sample_offset) + k;
            t < atlas.sample_texel.size() && atlas.sample_texel[t] < owner.size())
          owner[atlas.sample_texel[t]] = std::int32_t(i);
    }
  const auto owner_of = [&](std::uint32_t texel) {
    return texel < owner.size() && owner[texel] >= 0 ? std::size_t(owner[texel]) : blocks;
  };
  AtlasBlockPadding p;
  // Records of a texel no block owns (a hand-made atlas) go to no block.
  std::vector<std::uint32_t> kept;
  for (std::size_t m = 0; m < atlas.padding.size(); ++m)
    if (owner_of(atlas.padding[m].dst) < blocks) kept.push_back(std::uint32_t(m));
  build_rows(
      blocks, kept.size(), [&](std::size_t m) { return owner_of(atlas.padding[kept[m]].dst); },
      [&](std::size_t m) { return kept[m]; }, p.record_begin, p.records);
  std::vector<std::vector<std::uint32_t>> sources(blocks);
  for (std::size_t i = 0; i < blocks; ++i) {
    for (std::uint32_t m : p.records_of(i)) {
      const std::size_t j = owner_of(atlas.padding[m].src);
      if (j < blocks && j != i) sources[i].push_back(std::uint32_t(j));
    }
    std::sort(sources[i].begin(), sources[i].end());
    sources[i].erase(std::unique(sources[i].begin(), sources[i].end()), sources[i].end());
  }
  p.source_begin.assign(blocks + 1, 0);
  for (std::size_t i = 0; i < blocks; ++i)
    p.source_begin[i + 1] = p.source_begin[i] + std::uint32_t(sources[i].size());
  for (const std::vector<std::uint32_t>& s : sources) p.sources.insert(p.sources.end(), s.begin(), s.end());
  return p;
}

LevelBlockChanges LevelBlockChanges::create(const Level& level) {
  LevelBlockChanges c;
  c.level_ = &level;
  c.ld_last_.assign(3 * std::size_t(level.sample_count), 0.0f);
  c.changed_.assign(level.blocks.size(), 1);
  c.count_ = level.blocks.size();
  return c;
}

std::size_t LevelBlockChanges::mark(std::span<const float> ld, bool everything) {
  const Level& level = *level_;
  const bool all = everything || !valid_ || ld.size() != ld_last_.size();
  count_ = 0;
  for (std::size_t i = 0; i < level.blocks.size(); ++i) {
    const std::size_t first = 3 * std::size_t(level.blocks[i].sample_offset);
    const std::size_t count = 3 * std::size_t(level.blocks[i].sample_count);
    const bool changed =
        all || std::memcmp(ld.data() + first, ld_last_.data() + first, count * sizeof(float)) != 0;
    changed_[i] = changed;
    if (changed) {
      if (first + count <= ld.size())
        std::memcpy(ld_last_.data() + first, ld.data() + first, count * sizeof(float));
      ++count_;
    }
  }
  valid_ = ld.size() == ld_last_.size();
  return count_;
}

LevelDirtyTracker LevelDirtyTracker::create(const Level& level) {
  LevelDirtyTracker t;
  t.level_ = &level;
  t.deps_ = level_dependencies(level);
  t.blocks_ = LevelBlockChanges::create(level);
  t.slot_dirty_.assign(level.slots.size(), 1);
  t.tile_dirty_.assign(level.blocks.size(), 1);
  t.dirty_tiles_ = level.blocks.size();
  t.dirty_slots_ = level.slots.size();
  return t;
}

std::size_t LevelDirtyTracker::mark(std::span<const float> ld, bool everything) {
  const Level& level = *level_;
  const std::size_t dirty_blocks = blocks_.mark(ld, everything);
  const std::span<const std::uint8_t> block_dirty = blocks_.blocks();
  std::fill(slot_dirty_.begin(), slot_dirty_.end(), std::uint8_t(0));
  for (std::size_t i = 0; i < level.blocks.size(); ++i)
    if (block_dirty[i])
      for (std::uint32_t s : deps_.slots_fed_by(i)) slot_dirty_[s] = 1;
  dirty_slots_ = std::size_t(std::count(slot_dirty_.begin(), slot_dirty_.end(), std::uint8_t(1)));
  std::copy(block_dirty.begin(), block_dirty.end(), tile_dirty_.begin());
  for (std::size_t s = 0; s < level.slots.size(); ++s)
    if (slot_dirty_[s]) tile_dirty_[level.slots[s].block] = 1;
  dirty_tiles_ = std::size_t(std::count(tile_dirty_.begin(), tile_dirty_.end(), std::uint8_t(1)));
  return dirty_blocks;
}

}  // namespace modrt
