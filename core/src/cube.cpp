// SPDX-License-Identifier: MIT
#include "modrt/cube.h"

#include <bit>
#include <string>

namespace modrt {
namespace {

constexpr FaceFrame kFrames[kFaceCount] = {
    // -X wall (x = 0), seen from inside: u toward -Z, v up.
    {{0, 0, 1}, {0, 0, -1}, {0, 1, 0}, {1, 0, 0}},
    // +X wall (x = 1): u toward +Z.
    {{1, 0, 0}, {0, 0, 1}, {0, 1, 0}, {-1, 0, 0}},
    // floor (y = 0): u = +X, v = -Z.
    {{0, 0, 1}, {1, 0, 0}, {0, 0, -1}, {0, 1, 0}},
    // ceiling (y = 1): u = +X, v = +Z.
    {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}, {0, -1, 0}},
    // -Z wall (z = 0): u toward +X.
    {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
    // +Z wall (z = 1): u toward -X.
    {{1, 0, 1}, {-1, 0, 0}, {0, 1, 0}, {0, 0, -1}},
};

// Image of each face under one quarter turn: -X -> +Z -> +X -> -Z -> -X.
constexpr int kRotateOnce[kFaceCount] = {kFacePosZ, kFaceNegZ, kFaceNegY, kFacePosY, kFaceNegX, kFacePosX};

constexpr FaceMask bit(int f) { return FaceMask(1u << f); }
constexpr FaceMask kFloorCeiling = bit(kFaceNegY) | bit(kFacePosY);
constexpr FaceMask kShapeMasks[kDictionaryShapeCount] = {
    kAllFaces,
    FaceMask(kAllFaces & ~bit(kFaceNegZ)),
    FaceMask(kAllFaces & ~(bit(kFaceNegZ) | bit(kFacePosZ))),
    FaceMask(kAllFaces & ~(bit(kFaceNegZ) | bit(kFacePosX))),
    FaceMask(kAllFaces & ~(bit(kFaceNegZ) | bit(kFacePosX) | bit(kFacePosZ))),
    kFloorCeiling,
};
constexpr const char* kShapeNames[kDictionaryShapeCount] = {"closed", "dead_end",   "corridor",
                                                            "corner", "t_junction", "crossing"};

int wrap_turns(int quarter_turns) { return ((quarter_turns % 4) + 4) % 4; }

}  // namespace

int face_count(FaceMask mask) { return std::popcount(unsigned(mask & kAllFaces)); }

const FaceFrame& face_frame(int face) { return kFrames[face]; }

glm::dvec3 face_point(int face, double u, double v) {
  const FaceFrame& f = kFrames[face];
  return f.origin + u * f.u_axis + v * f.v_axis;
}

const char* face_name(int face) {
  static constexpr const char* kNames[kFaceCount] = {"-X", "+X", "-Y", "+Y", "-Z", "+Z"};
  return (face >= 0 && face < kFaceCount) ? kNames[face] : "?";
}

FaceMask dictionary_shape_mask(int shape) { return kShapeMasks[shape]; }
const char* dictionary_shape_name(int shape) {
  return (shape >= 0 && shape < kDictionaryShapeCount) ? kShapeNames[shape] : "?";
}

int rotate_face(int face, int quarter_turns) {
  for (int t = wrap_turns(quarter_turns); t > 0; --t) face = kRotateOnce[face];
  return face;
}

FaceMask rotate_face_mask(FaceMask mask, int quarter_turns) {
  FaceMask out = 0;
  for (int f = 0; f < kFaceCount; ++f)
    if (face_present(mask, f)) out |= bit(rotate_face(f, quarter_turns));
  return out;
}

glm::dvec3 rotate_point(const glm::dvec3& p, int quarter_turns) {
  glm::dvec3 q = p;
  for (int t = wrap_turns(quarter_turns); t > 0; --t) q = {q.z, q.y, 1.0 - q.x};
  return q;
}

glm::dvec3 rotate_direction(const glm::dvec3& d, int quarter_turns) {
  glm::dvec3 q = d;
  for (int t = wrap_turns(quarter_turns); t > 0; --t) q = {q.z, q.y, -q.x};
  return q;
}

Result<ShapeOrientation> canonicalise_face_mask(FaceMask mask) {
  if (mask & ~kAllFaces)
    return Status::error(ErrorCode::invalid_argument,
                         "face mask 0x" + std::to_string(unsigned(mask)) + " has bits above face 5");
  if ((mask & kFloorCeiling) != kFloorCeiling)
    return Status::error(ErrorCode::invalid_argument,
                         "face mask " + std::to_string(unsigned(mask)) +
                             ": the 2D cube dictionary needs floor (-Y) and ceiling (+Y) present");
  for (int s = 0; s < kDictionaryShapeCount; ++s)
    for (int t = 0; t < 4; ++t)
      if (rotate_face_mask(kShapeMasks[s], t) == mask) return ShapeOrientation{s, t};
  return Status::error(ErrorCode::internal_error, "face mask matches no dictionary shape");
}

SampleLayout SampleLayout::make(FaceMask mask, int res) {
  SampleLayout l;
  l.mask = mask;
  l.res = res;
  int next = 0;
  for (int f = 0; f < kFaceCount; ++f) l.slot[f] = face_present(mask, f) ? next++ : -1;
  return l;
}

int SampleLayout::face_of(int sample) const {
  const int s = sample / texels_per_face();
  for (int f = 0; f < kFaceCount; ++f)
    if (slot[f] == s) return f;
  return -1;
}

glm::dvec3 SampleLayout::position(int sample) const {
  const int face = face_of(sample);
  const int t = sample % texels_per_face();
  return face_point(face, (t % res + 0.5) / res, (t / res + 0.5) / res);
}

glm::dvec3 SampleLayout::normal(int sample) const { return kFrames[face_of(sample)].normal; }

}  // namespace modrt
