// SPDX-License-Identifier: MIT
// modrt — the 24 rotations of the canonical block and the shapes of the 3D dictionary
// (MRT §6.1: "3D mazes do not have this constraint [a top and a bottom face] and result in a
// 9 element dictionary"; the multi-storey issue).
//
// A rotation is one of the 24 proper rotations of the unit cube about its centre (0.5, 0.5,
// 0.5): a signed permutation matrix M with det M = +1, acting on directions as d -> M d and on
// points as p -> M (p - 0.5) + 0.5. Rotation 4 k + q is A_k * Y^q, where Y is cube.h's quarter
// turn about +Y ((x, y, z) -> (z, y, 1 - x)) and A_k takes +Y to the face k of
// {+Y, -Y, +X, -X, +Z, -Z}: rotations 0..3 are the 2D dictionary's quarter turns.
//
// Face masks (present faces, cube.h) fall into ten classes under these rotations; the first
// six are the 2D dictionary's shapes with the same canonical masks and names, so a level that
// needs no vertical opening uses the same (shape, rotation) pairs as with the 2D dictionary.
// MRT §6.1 counts nine; the 64 masks up to rotation make ten classes (counted in
// tests/test_cube_rotation.cpp), and modrt names all ten.
#pragma once

#include <array>

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "modrt/cube.h"
#include "modrt/status.h"

namespace modrt {

inline constexpr int kCubeRotationCount = 24;
using CubeMatrix = glm::mat<3, 3, int, glm::defaultp>;  // integer entries: exact compositions

// Rotation `rotation` in [0, 24): its matrix (columns are the images of +X, +Y, +Z), the
// image of each face and its inverse's index.
struct CubeRotation {
  CubeMatrix matrix = CubeMatrix(1);
  std::array<int, kFaceCount> face{};
  int inverse = 0;
};
const CubeRotation& cube_rotation(int rotation);
// The rotation equal to applying `first`, then `second`.
int compose_cube_rotations(int first, int second);

int rotate_face_3d(int face, int rotation);
FaceMask rotate_face_mask_3d(FaceMask mask, int rotation);
glm::dvec3 rotate_point_3d(const glm::dvec3& p, int rotation);
glm::dvec3 rotate_direction_3d(const glm::dvec3& d, int rotation);
// Where the texel coordinates (u, v) of `face` land on face rotate_face_3d(face, rotation):
// rotate_point_3d(face_point(face, u, v), rotation) == face_point(that face, result). One of
// the square's eight symmetries (u and v swapped and/or mirrored).
glm::dvec2 rotate_face_uv(int face, int rotation, const glm::dvec2& uv);

// --- the 3D dictionary's shapes: any face mask up to rotation ---
inline constexpr int kCubeShapeCount = 10;
// Canonical present-face masks, in order: the 2D dictionary's six (closed, dead end, corridor,
// corner, T junction, crossing; dictionary_shape_mask), then the corner open above (-Z, +X
// and +Y missing: three mutually adjacent faces), the T junction open above (-Z, +X, +Z and +Y
// missing: two adjacent faces present), the crossing open above (only the floor present) and
// the open block (no face present).
FaceMask cube_shape_mask(int shape);
const char* cube_shape_name(int shape);
// A face mask as a 3D dictionary shape turned by a rotation:
// rotate_face_mask_3d(cube_shape_mask(shape), rotation) == mask, the smallest such rotation,
// so that a mask with floor and ceiling present gets canonicalise_face_mask's (shape,
// quarter_turns). Fails (invalid_argument) when bits above face 5 are set.
struct ShapeRotation {
  int shape = 0;
  int rotation = 0;
};
Result<ShapeRotation> canonicalise_face_mask_3d(FaceMask mask);

}  // namespace modrt
