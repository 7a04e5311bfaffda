// SPDX-License-Identifier: MIT
#include "modrt/cube_rotation.h"

#include <cmath>
#include <string>

#include <glm/geometric.hpp>

namespace modrt {
namespace {

// glm matrices are column-major: imat3x3(c0, c1, c2) has columns c0, c1, c2.
// cube.h's quarter turn about +Y: d -> (d.z, d.y, -d.x).
const CubeMatrix kTurnY{glm::ivec3(0, 0, -1), glm::ivec3(0, 1, 0), glm::ivec3(1, 0, 0)};

// A_k: +Y -> +Y, -Y, +X, -X, +Z, -Z (each a proper rotation).
const CubeMatrix kUp[6] = {
    CubeMatrix(1),
    // half turn about X: (x, y, z) -> (x, -y, -z)
    CubeMatrix(glm::ivec3(1, 0, 0), glm::ivec3(0, -1, 0), glm::ivec3(0, 0, -1)),
    // quarter turn about Z taking +Y to +X: (x, y, z) -> (y, -x, z)
    CubeMatrix(glm::ivec3(0, -1, 0), glm::ivec3(1, 0, 0), glm::ivec3(0, 0, 1)),
    // taking +Y to -X: (x, y, z) -> (-y, x, z)
    CubeMatrix(glm::ivec3(0, 1, 0), glm::ivec3(-1, 0, 0), glm::ivec3(0, 0, 1)),
    // quarter turn about X taking +Y to +Z: (x, y, z) -> (x, -z, y)
    CubeMatrix(glm::ivec3(1, 0, 0), glm::ivec3(0, 0, 1), glm::ivec3(0, -1, 0)),
    // taking +Y to -Z: (x, y, z) -> (x, z, -y)
    CubeMatrix(glm::ivec3(1, 0, 0), glm::ivec3(0, 0, -1), glm::ivec3(0, 1, 0)),
};

// The outward direction of a face from the block's centre, and the face of a direction.
glm::ivec3 face_direction(int face) {
  glm::ivec3 d(0);
  d[face / 2] = (face % 2) ? 1 : -1;
  return d;
}
int face_of_direction(const glm::ivec3& d) {
  for (int a = 0; a < 3; ++a)
    if (d[a] != 0) return 2 * a + (d[a] > 0 ? 1 : 0);
  return -1;
}

struct Table {
  std::array<CubeRotation, kCubeRotationCount> rotations;
  Table() {
    for (int k = 0; k < 6; ++k) {
      CubeMatrix turn(1);
      for (int q = 0; q < 4; ++q) {
        CubeRotation& r = rotations[std::size_t(4 * k + q)];
        r.matrix = kUp[k] * turn;
        for (int f = 0; f < kFaceCount; ++f)
          r.face[std::size_t(f)] = face_of_direction(r.matrix * face_direction(f));
        turn = kTurnY * turn;
      }
    }
    for (CubeRotation& r : rotations)
      for (int j = 0; j < kCubeRotationCount; ++j)
        if (rotations[std::size_t(j)].matrix * r.matrix == CubeMatrix(1)) r.inverse = j;
  }
  int find(const CubeMatrix& m) const {
    for (int j = 0; j < kCubeRotationCount; ++j)
      if (rotations[std::size_t(j)].matrix == m) return j;
    return -1;
  }
};
const Table& table() {
  static const Table t;
  return t;
}

constexpr FaceMask bit(int f) { return FaceMask(1u << f); }
constexpr FaceMask kExtraMasks[kCubeShapeCount - kDictionaryShapeCount] = {
    FaceMask(kAllFaces & ~(bit(kFaceNegZ) | bit(kFacePosX) | bit(kFacePosY))),
    FaceMask(kAllFaces & ~(bit(kFaceNegZ) | bit(kFacePosX) | bit(kFacePosZ) | bit(kFacePosY))),
    bit(kFaceNegY),
    0,
};
constexpr const char* kExtraNames[kCubeShapeCount - kDictionaryShapeCount] = {
    "corner_open_above", "t_junction_open_above", "crossing_open_above", "open"};

}  // namespace

const CubeRotation& cube_rotation(int rotation) { return table().rotations[std::size_t(rotation)]; }

int compose_cube_rotations(int first, int second) {
  return table().find(cube_rotation(second).matrix * cube_rotation(first).matrix);
}

int rotate_face_3d(int face, int rotation) { return cube_rotation(rotation).face[std::size_t(face)]; }

FaceMask rotate_face_mask_3d(FaceMask mask, int rotation) {
  FaceMask out = 0;
  for (int f = 0; f < kFaceCount; ++f)
    if (face_present(mask, f)) out |= bit(rotate_face_3d(f, rotation));
  return out;
}

glm::dvec3 rotate_direction_3d(const glm::dvec3& d, int rotation) {
  return glm::dmat3(cube_rotation(rotation).matrix) * d;
}

glm::dvec3 rotate_point_3d(const glm::dvec3& p, int rotation) {
  return rotate_direction_3d(p - glm::dvec3(0.5), rotation) + glm::dvec3(0.5);
}

glm::dvec2 rotate_face_uv(int face, int rotation, const glm::dvec2& uv) {
  // The rotated point lies on the target face; its (u, v) there are its offsets from the
  // target's origin along the target's unit axes.
  const int target = rotate_face_3d(face, rotation);
  const FaceFrame& t = face_frame(target);
  const glm::dvec3 p = rotate_point_3d(face_point(face, uv.x, uv.y), rotation) - t.origin;
  return {glm::dot(p, t.u_axis), glm::dot(p, t.v_axis)};
}

FaceMask cube_shape_mask(int shape) {
  return shape < kDictionaryShapeCount ? dictionary_shape_mask(shape)
                                       : kExtraMasks[std::size_t(shape - kDictionaryShapeCount)];
}

const char* cube_shape_name(int shape) {
  if (shape >= 0 && shape < kDictionaryShapeCount) return dictionary_shape_name(shape);
  if (shape >= kDictionaryShapeCount && shape < kCubeShapeCount)
    return kExtraNames[std::size_t(shape - kDictionaryShapeCount)];
  return "?";
}

Result<ShapeRotation> canonicalise_face_mask_3d(FaceMask mask) {
  if (mask & ~kAllFaces)
    return Status::error(ErrorCode::invalid_argument,
                         "face mask 0x" + std::to_string(unsigned(mask)) + " has bits above face 5");
  for (int r = 0; r < kCubeRotationCount; ++r)
    for (int s = 0; s < kCubeShapeCount; ++s)
      if (rotate_face_mask_3d(cube_shape_mask(s), r) == mask) return ShapeRotation{s, r};
  return Status::error(ErrorCode::internal_error, "face mask matches no 3D dictionary shape");
}

}  // namespace modrt
