// SPDX-License-Identifier: MIT
#include "modrt/precompute/symmetry.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace modrt::precompute {

glm::dvec3 BlockSymmetry::apply(const glm::dvec3& p) const {
  return rotate_point(mirror ? glm::dvec3(1.0 - p.x, p.y, p.z) : p, quarter_turns);
}

int BlockSymmetry::apply_face(int face) const {
  if (mirror && (face == kFaceNegX || face == kFacePosX)) face ^= 1;
  return rotate_face(face, quarter_turns);
}

std::vector<BlockSymmetry> shape_symmetries(FaceMask mask, const glm::dvec3& extent) {
  std::vector<BlockSymmetry> out;
  for (bool mirror : {false, true})
    for (int t = 0; t < 4; ++t) {
      if (t % 2 == 1 && extent.x != extent.z) continue;
      const BlockSymmetry g{mirror, t};
      FaceMask image = 0;
      for (int f = 0; f < kFaceCount; ++f)
        if (face_present(mask, f)) image |= FaceMask(1u << g.apply_face(f));
      if (image == mask) out.push_back(g);
    }
  return out;
}

std::vector<int> sample_permutation(const SampleLayout& layout, const BlockSymmetry& g) {
  std::vector<int> perm(std::size_t(layout.sample_count()));
  for (int s = 0; s < layout.sample_count(); ++s) {
    const int f = g.apply_face(layout.face_of(s));
    const FaceFrame& fr = face_frame(f);
    const glm::dvec3 rel = g.apply(layout.position(s)) - fr.origin;
    const int i = std::clamp(int(std::floor(glm::dot(rel, fr.u_axis) * layout.res)), 0, layout.res - 1);
    const int j = std::clamp(int(std::floor(glm::dot(rel, fr.v_axis) * layout.res)), 0, layout.res - 1);
    perm[std::size_t(s)] = layout.index(f, i, j);
  }
  return perm;
}

}  // namespace modrt::precompute
