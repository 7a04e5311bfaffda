// SPDX-License-Identifier: MIT
// modrt precompute — the symmetries of a dictionary shape (the elements of the square's
// dihedral group about +Y that map its face mask onto itself), used to make baked
// operators exactly equivariant: Monte Carlo noise and truncation inside degenerate
// singular-value clusters would otherwise make a level's lighting depend on which of two
// equivalent orientations a symmetric block was canonicalised to.
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "modrt/cube.h"

namespace modrt::precompute {

// p -> rotate_point(mirror ? (1 - x, y, z) : p, quarter_turns).
struct BlockSymmetry {
  bool mirror = false;
  int quarter_turns = 0;

  glm::dvec3 apply(const glm::dvec3& p) const;
  int apply_face(int face) const;
};

// Every element g of the dihedral group with g(mask) = mask (the identity first) that also
// maps the box [0, extent] onto itself: an odd number of quarter turns swaps x and z, so it
// is a symmetry only when extent.x == extent.z (MRT §8's shaped blocks).
std::vector<BlockSymmetry> shape_symmetries(FaceMask mask, const glm::dvec3& extent = glm::dvec3(1.0));

// perm[s] = sample that sample s maps to under g (texel centres map onto texel centres).
std::vector<int> sample_permutation(const SampleLayout& layout, const BlockSymmetry& g);

}  // namespace modrt::precompute
