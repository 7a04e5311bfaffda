// SPDX-License-Identifier: MIT
// modrt precompute — an Embree scene of one block's present faces.
//
// Every precompute ray query (prior visibility, the F gather, SH projections, probes)
// goes through this class so that Embree objects never leak into the rest of the code.
// Faces are the planar faces of the box [0, extent] (the unit cube by default; MRT §8's
// shaped blocks stretch it), given by their FaceFrame scaled by the extent; a hit reports
// the face and the face's normalised (u, v) in [0, 1]^2 of the hit point so callers can
// sample a face's texel grid. Ray origins and directions are in the box's own (stretched)
// coordinates: `point` maps a canonical [0,1]^3 position (a SampleLayout position, a prior
// light, a probe) into them.
#pragma once

#include <memory>

#include <glm/vec3.hpp>

#include "modrt/cube.h"

namespace modrt::precompute {

struct FaceHit {
  int face = -1;  // -1: the ray left the block through a missing face (or hit nothing)
  double u = 0.0;
  double v = 0.0;
  double t = 0.0;
};

class BlockScene {
 public:
  // Throws std::runtime_error when Embree cannot create its device or scene.
  // extent: the box's edge lengths (x, y, z), each finite and > 0; invalid_argument otherwise.
  explicit BlockScene(FaceMask mask, const glm::dvec3& extent = glm::dvec3(1.0));
  ~BlockScene();
  BlockScene(const BlockScene&) = delete;
  BlockScene& operator=(const BlockScene&) = delete;

  FaceMask mask() const { return mask_; }
  const glm::dvec3& extent() const { return extent_; }
  // Canonical [0,1]^3 point -> the box's coordinates.
  glm::dvec3 point(const glm::dvec3& canonical) const { return canonical * extent_; }
  // Area of one texel of `face` on a res x res grid.
  double texel_area(int face, int res) const;

  // Closest present face along origin + t*dir, t in (t_near, t_far). Thread-safe.
  FaceHit intersect(const glm::dvec3& origin, const glm::dvec3& dir, double t_near = 1e-6,
                    double t_far = 1e30) const;
  // True when any present face blocks the open segment origin -> target. Thread-safe.
  bool occluded(const glm::dvec3& origin, const glm::dvec3& target, double t_near = 1e-6) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  FaceMask mask_;
  glm::dvec3 extent_;
};

// Bilinear texel weights of face point (u, v) on a res x res grid with texel centres at
// (i + 0.5) / res, clamped to the face's edge texels (no wrap across creases).
struct BilinearTaps {
  int i[4];
  int j[4];
  double w[4];
};
BilinearTaps bilinear_taps(double u, double v, int res);

}  // namespace modrt::precompute
