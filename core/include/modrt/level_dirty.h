// SPDX-License-Identifier: MIT
// modrt — what a change of ld reaches in a level (architecture.md §5, "Skipping"): the
// transport graph ld_i -> b_i (Td_b) -> r_s for every slot s a record of block i feeds (Tb->r)
// -> the tile of slot s's block (Ur r_s), and the exact dirty propagation over it, stated once
// for every backend:
//   - a block is dirty when its ld changed (bit for bit) since the last marked ld;
//   - a slot is dirty when a block feeding it (the source of one of its records) is dirty;
//   - a tile (a block's lightmap texels, its atlas rectangles and its probes) is dirty when its
//     block or a slot entering it is dirty.
// Everything not dirty would be recomputed from bit-identical inputs, so keeping it is exact.
// How a backend turns the sets into work (partial passes, per-block tasks) stays its own.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "modrt/level.h"

namespace modrt {

// The graph in compressed rows (each list in increasing order).
struct LevelDependencies {
  // The records of slot s: slot_records[slot_record_begin[s] .. slot_record_begin[s + 1]).
  std::vector<std::uint32_t> slot_record_begin, slot_records;
  // The slots entering block i (ResponseSlot::block == i).
  std::vector<std::uint32_t> block_slot_begin, block_slots;
  // The slots block i feeds (the slot of each record whose source is i; one entry per record).
  std::vector<std::uint32_t> fed_slot_begin, fed_slots;

  std::span<const std::uint32_t> records_of_slot(std::size_t s) const {
    return {slot_records.data() + slot_record_begin[s], slot_record_begin[s + 1] - slot_record_begin[s]};
  }
  std::span<const std::uint32_t> slots_of_block(std::size_t i) const {
    return {block_slots.data() + block_slot_begin[i], block_slot_begin[i + 1] - block_slot_begin[i]};
  }
  std::span<const std::uint32_t> slots_fed_by(std::size_t i) const {
    return {fed_slots.data() + fed_slot_begin[i], fed_slot_begin[i + 1] - fed_slot_begin[i]};
  }
};

// The graph of a checked level (records and slots index valid blocks and slots).
LevelDependencies level_dependencies(const Level& level);

// The padded atlas per block (MRT §6.2): the padding records whose destination lies in one of
// the block's tiles, and the other blocks whose tile interiors those records copy (its
// open-face neighbours). A block's atlas rectangles are current when its own tile and these
// blocks' tiles are (the camera skip, StagedBackend::set_visible_blocks). Padding sources are
// tile interiors (check_level_runtime refuses a level whose padding copies padding).
struct AtlasBlockPadding {
  std::vector<std::uint32_t> record_begin, records;  // indices into level.atlas.padding, in order
  std::vector<std::uint32_t> source_begin, sources;  // other blocks, increasing

  std::span<const std::uint32_t> records_of(std::size_t i) const {
    return {records.data() + record_begin[i], record_begin[i + 1] - record_begin[i]};
  }
  std::span<const std::uint32_t> sources_of(std::size_t i) const {
    return {sources.data() + source_begin[i], source_begin[i + 1] - source_begin[i]};
  }
};

// The padding of a checked level (its records and sample texels within the atlas).
AtlasBlockPadding atlas_block_padding(const Level& level);

// The blocks whose ld changed bit for bit since the last marked ld: LevelDirtyTracker's first
// step, and alone the converged solve's b0 = Td_b ld (staged_backend.h), which depends on its
// block's ld only. create() allocates (the last ld and the flags); mark() does not.
class LevelBlockChanges {
 public:
  static LevelBlockChanges create(const Level& level);
  // Flags the blocks whose ld differs from the last marked one (every block on the first call,
  // after invalidate(), or with `everything`) and keeps their ld. Returns how many are flagged.
  // ld must have 3 x samples floats.
  std::size_t mark(std::span<const float> ld, bool everything = false);
  void invalidate() { valid_ = false; }
  std::span<const std::uint8_t> blocks() const { return changed_; }  // 1: changed
  std::size_t count() const { return count_; }

 private:
  const Level* level_ = nullptr;
  std::vector<float> ld_last_;
  std::vector<std::uint8_t> changed_;
  std::size_t count_ = 0;
  bool valid_ = false;
};

// Exact dirty tracking over one level's frames. create() allocates (the last ld and the
// flags); mark() does not.
class LevelDirtyTracker {
 public:
  static LevelDirtyTracker create(const Level& level);

  // Marks the blocks whose ld (3 floats per sample) differs bit for bit from the last marked
  // ld — every block on the first call, after invalidate(), or with `everything` — keeps
  // their ld for the next call and propagates to slots and tiles. Returns the number of dirty
  // blocks (0: the frame's results are the last frame's). ld must have 3 x samples floats.
  std::size_t mark(std::span<const float> ld, bool everything = false);
  // The next mark() marks everything (the results on hand are not of the last marked ld: a
  // feedback step ran, a frame failed half way, the clutter changed).
  void invalidate() { blocks_.invalidate(); }

  std::span<const std::uint8_t> blocks() const { return blocks_.blocks(); }  // 1: dirty
  std::span<const std::uint8_t> slots() const { return slot_dirty_; }
  std::span<const std::uint8_t> tiles() const { return tile_dirty_; }
  std::size_t dirty_blocks() const { return blocks_.count(); }
  std::size_t dirty_slots() const { return dirty_slots_; }
  std::size_t dirty_tiles() const { return dirty_tiles_; }
  const LevelDependencies& dependencies() const { return deps_; }

 private:
  const Level* level_ = nullptr;
  LevelDependencies deps_;
  LevelBlockChanges blocks_;
  std::vector<std::uint8_t> slot_dirty_, tile_dirty_;
  std::size_t dirty_slots_ = 0, dirty_tiles_ = 0;
};

}  // namespace modrt
