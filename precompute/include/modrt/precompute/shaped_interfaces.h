// SPDX-License-Identifier: MIT
// modrt precompute — interface operators of a shaped block (MRT §5, §8): the reduced
// lightfield leaving it, crossing it and lighting it, traced in the block's own box.
//
// Blocks connected to others need these once their operators follow their proportions: a
// lightfield that crosses a 1 x 1 x 3 corridor must travel three times as far as through a
// cube, and light entering a long room lights its far end less. Everything stays in the
// dictionary's reduced lightfield basis Hrlf (load_or_bake_interface_basis), so a shaped
// block and a cube block exchange lightfields through their common face unchanged, and the
// run time is untouched: R and the response fit only enter the level's Tb->r records; the
// response is drawn with the dictionary's shared Ur.
#pragma once

#include <array>

#include <glm/vec3.hpp>

#include "modrt/dictionary.h"

namespace modrt::precompute {

struct ShapedInterfaces {
  // Rb_rlf[f]: krlf x kb, the shaped b -> the lightfield leaving through missing side face f.
  std::array<Matrix, kFaceCount> Rb_rlf;
  // R[entry][exit]: krlf x krlf, the lightfield entering through missing side face `entry`
  // -> leaving through missing side face `exit` (canonical faces; free space in the box).
  std::array<std::array<Matrix, kFaceCount>, kFaceCount> R;
  // Trlf_r[entry]: kr x krlf, the lightfield entering through `entry` -> the response r that
  // the dictionary's Ur draws: Ur^T G_box, the least-squares fit of the box's dead-end
  // response G_box (Ur's columns are orthonormal; for the unit box it is the dictionary's
  // Trlf_r).
  std::array<Matrix, kFaceCount> Trlf_r;

  bool empty() const {
    for (const Matrix& m : Trlf_r)
      if (!m.empty()) return false;
    return true;
  }
};

// Traces them for dictionary shape `shape` in the box `extent` with the shaped implicit
// lights Limp (n x kb, bake_shaped_operators). Hrlf: the dictionary's basis (S^2 D^2 x
// krlf). Throws std::invalid_argument on sizes that do not match the dictionary.
ShapedInterfaces bake_shaped_interfaces(const Dictionary& dict, const Matrix& Hrlf, int shape,
                                        const glm::dvec3& extent, const Matrix& Limp);

// The extent of the box as seen from the dead end that light entering through side face
// `entry` lights (interfaces.h: the canonical dead end is entered through -Z).
glm::dvec3 dead_end_extent(const glm::dvec3& extent, int entry);

}  // namespace modrt::precompute
