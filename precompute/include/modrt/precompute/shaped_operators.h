// SPDX-License-Identifier: MIT
// modrt precompute — operators for blocks whose proportions are not a cube's (MRT §8,
// Figure 12; architecture.md §4). A cube's operators spread light across a stretched block
// as if it were a cube (a 3 x 1 x 1 room's far end came out 2.8x too bright), so the level
// build re-bakes Ub, Td_b, Limp, the vector and probe operators for the block's box: the
// prior lattice stretched with the box and F re-traced in it (bake_box_shape). Proportions
// are quantised on a logarithmic lattice so that blocks of nearly equal proportions share
// one bake, and a ShapedOperatorCache keeps bakes across level builds.
#pragma once

#include <array>
#include <mutex>
#include <string>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/level.h"
#include "modrt/precompute/shaped_interfaces.h"
#include "modrt/status.h"

namespace modrt::precompute {

// Edge lengths of a block's canonical box: the mean length of its four edges along each
// canonical axis (a warp's bend and shear stay with the warp; only the stretch is baked).
glm::dvec3 block_box_extent(const LevelBlock& block);

// Proportions quantised to 1 / steps_per_octave of an octave: round(steps log2(e_i / g)),
// g = the geometric mean of the extent. All zero: a cube (within half a step). Beyond
// kMaxShapedAspect between two edges the box is baked at that aspect (the 100:1:1 stress
// block gets 16:1:1 operators): thinner boxes' operators leave the measured limits of
// operator_limits.h, and light barely crosses them anyway.
inline constexpr double kMaxShapedAspect = 16.0;
using ProportionSteps = std::array<int, 3>;
ProportionSteps quantise_proportions(const glm::dvec3& extent, int steps_per_octave);
// The box of quantised proportions, scaled to geometric mean 1.
glm::dvec3 proportions_extent(const ProportionSteps& steps, int steps_per_octave);

// How many cubes' modes a box's operators keep (MRT §8's "U-vector scaled" bake, with the
// modes to match): one block has kb modes for its whole surface, so a 3 x 1 x 1 room as one
// block with the cube's 32 modes stays 1.7x the error of three cubes (docs/proportions.md,
// the rank study). The factor is the box's volume in cubes of its shortest edge (a slab's
// shortest edge counted as at least half its middle one, so a thin slab is not a stack of
// cubes), rounded down after a 10 % allowance for the proportion lattice's rounding, in
// [1, kMaxShapedModeFactor]: a block of factor m costs m cube blocks at run time, never more
// than the cubes it stands for would.
inline constexpr int kMaxShapedModeFactor = 4;
int shaped_mode_factor(const glm::dvec3& extent);
// The dictionary's settings with kb times m = shaped_mode_factor(extent) and, for m > 1, kd
// times 3m - 1 (both at most the box's sample count): what bake_shaped_operators bakes with.
DictionarySettings shaped_bake_settings(const DictionarySettings& dict, FaceMask mask,
                                        const glm::dvec3& extent);

// bake_box_shape of dictionary shape `shape` for `extent` at shaped_bake_settings,
// converted to the run-time operators. Rb_rlf stays empty: a connected block's comes from
// its traced interfaces (ShapedOperatorCache::interfaces, the level build fills it in).
// Errors name the shape and the extent.
Result<ShapedOperators> bake_shaped_operators(const Dictionary& dict, int shape, const glm::dvec3& extent);

// Shaped operators by (dictionary settings, shape, proportion steps); thread-safe. Keep one
// alive across level builds (an editor moving a wall, the importer re-running) and a rebuild
// with the same proportions traces no ray. With a directory, every bake is also saved there
// (atomically, one file per entry: a .modrtlevel image holding no block and one shaped
// set, so the level file's checks guard it) and later processes load it instead of baking;
// an entry that fails to load is baked again and overwritten.
class ShapedOperatorCache {
 public:
  ShapedOperatorCache() = default;
  explicit ShapedOperatorCache(std::string directory) : directory_(std::move(directory)) {}
  // The entry's file name in the directory: the dictionary's cache name (its settings), the
  // shape and the proportion steps.
  static std::string file_name(const DictionarySettings& settings, int shape, const ProportionSteps& steps,
                               int steps_per_octave);

  Result<ShapedOperators> get(const Dictionary& dict, int shape, const ProportionSteps& steps,
                              int steps_per_octave);
  // The interface operators of get()'s set `ops` (bake_shaped_interfaces with the
  // dictionary's basis Hrlf), cached the same way (a matrix file "<file_name stem>.lfops").
  Result<ShapedInterfaces> interfaces(const Dictionary& dict, const Matrix& Hrlf, const ShapedOperators& ops,
                                      const ProportionSteps& steps, int steps_per_octave);
  std::size_t bakes() const;       // operator sets baked (cache misses) so far
  std::size_t hits() const;        // served from memory
  std::size_t disk_loads() const;  // served from the directory

 private:
  struct Key {
    DictionarySettings settings;
    int shape, steps_per_octave;
    ProportionSteps steps;
    bool operator==(const Key&) const = default;
  };
  struct Entry {
    Key key;
    ShapedOperators operators;
  };
  Result<ShapedOperators> load_or_bake(const Dictionary& dict, int shape, const ProportionSteps& steps,
                                       int steps_per_octave);
  Result<ShapedInterfaces> load_or_bake_interfaces(const Dictionary& dict, const Matrix& Hrlf,
                                                   const ShapedOperators& ops, const ProportionSteps& steps,
                                                   int steps_per_octave);
  struct InterfaceEntry {
    Key key;
    ShapedInterfaces interfaces;
  };
  std::vector<InterfaceEntry> interface_entries_;
  std::string directory_;
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;
  std::size_t bakes_ = 0, hits_ = 0, disk_loads_ = 0;
};

}  // namespace modrt::precompute
