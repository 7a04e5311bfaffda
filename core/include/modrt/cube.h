// SPDX-License-Identifier: MIT
// modrt — the canonical block of the 2D cube dictionary (architecture.md §2, MRT §6.1).
//
// The canonical block is the unit cube [0,1]^3 with y up. Faces are numbered
//   0 = -X, 1 = +X, 2 = -Y (floor), 3 = +Y (ceiling), 4 = -Z, 5 = +Z.
// Each face carries a res x res texel grid. A face point is
//   p(u, v) = origin + u * u_axis + v * v_axis,  u, v in [0, 1],
// and (u_axis, v_axis, normal) is a right-handed frame whose normal points into the
// block. Seen from inside the block, u runs to the right and v runs up on the four side
// walls (v = +Y); on the floor u = +X, v = -Z; on the ceiling u = +X, v = +Z.
// Texel (i, j) of a face covers u in [i/res, (i+1)/res], v in [j/res, (j+1)/res]; its
// sample point is the texel centre.
//
// The frames were chosen so that a quarter turn about +Y maps each side wall onto the
// next one texel for texel (see rotate_face); floor and ceiling texels turn in-plane.
#pragma once

#include <array>
#include <cstdint>

#include <glm/vec3.hpp>

#include "modrt/status.h"

namespace modrt {

inline constexpr int kFaceCount = 6;
enum Face : int { kFaceNegX = 0, kFacePosX = 1, kFaceNegY = 2, kFacePosY = 3, kFaceNegZ = 4, kFacePosZ = 5 };

// Bit f set <=> face f is present (a wall); a cleared bit is a missing face, an interface.
using FaceMask = std::uint8_t;
inline constexpr FaceMask kAllFaces = 0x3F;
inline constexpr bool face_present(FaceMask mask, int face) { return (mask >> face) & 1u; }
int face_count(FaceMask mask);

struct FaceFrame {
  glm::dvec3 origin;
  glm::dvec3 u_axis;
  glm::dvec3 v_axis;
  glm::dvec3 normal;  // inward, = cross(u_axis, v_axis)
};
const FaceFrame& face_frame(int face);
glm::dvec3 face_point(int face, double u, double v);
const char* face_name(int face);  // "-X", "+X", ...

// --- the 2D dictionary: floor and ceiling always present, side walls any subset ---
inline constexpr int kDictionaryShapeCount = 6;
// Canonical present-face masks of the six dictionary shapes, in dictionary order:
// closed box, one side missing (-Z), straight corridor (-Z,+Z), corner (-Z,+X),
// T junction (-Z,+X,+Z), crossing (all four sides missing).
FaceMask dictionary_shape_mask(int shape);
const char* dictionary_shape_name(int shape);

// A quarter turn about +Y maps point (x, y, z) to (z, y, 1 - x) and the side faces
// -X -> +Z -> +X -> -Z -> -X. rotate_* apply `quarter_turns` (any integer) such turns.
int rotate_face(int face, int quarter_turns);
FaceMask rotate_face_mask(FaceMask mask, int quarter_turns);
glm::dvec3 rotate_point(const glm::dvec3& p, int quarter_turns);
glm::dvec3 rotate_direction(const glm::dvec3& d, int quarter_turns);

// A level block's face mask expressed as a dictionary shape turned by quarter_turns:
// rotate_face_mask(dictionary_shape_mask(shape), quarter_turns) == mask.
struct ShapeOrientation {
  int shape = 0;
  int quarter_turns = 0;
};
// Fails (invalid_argument) when floor or ceiling is missing or bits above 5 are set.
Result<ShapeOrientation> canonicalise_face_mask(FaceMask mask);

// --- samples: texel centres on the present faces (architecture.md §3.1) ---
// Samples are ordered by face (ascending face index, present faces only), then row j,
// then column i: index = slot * res^2 + j * res + i, slot = rank of the face among the
// present ones. n = face_count(mask) * res^2.
struct SampleLayout {
  FaceMask mask = kAllFaces;
  int res = 0;
  std::array<int, kFaceCount> slot{};  // -1 for a missing face

  static SampleLayout make(FaceMask mask, int res);
  int texels_per_face() const { return res * res; }
  int sample_count() const { return face_count(mask) * res * res; }
  int index(int face, int i, int j) const { return (slot[face] * res + j) * res + i; }
  int face_of(int sample) const;
  // Texel-centre position and inward normal of a sample.
  glm::dvec3 position(int sample) const;
  glm::dvec3 normal(int sample) const;
};

}  // namespace modrt
