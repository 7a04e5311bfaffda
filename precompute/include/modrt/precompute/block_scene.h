// SPDX-License-Identifier: MIT
// modrt precompute — an Embree scene of one block's present faces.
//
// Every precompute ray query (prior visibility, the F gather, SH projections, probes)
// goes through this class so that Embree objects never leak into the rest of the code.
// Faces are planar unit squares given by their FaceFrame; a hit reports the face and the
// face (u, v) of the hit point so callers can sample a face's texel grid.
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
  explicit BlockScene(FaceMask mask);
  ~BlockScene();
  BlockScene(const BlockScene&) = delete;
  BlockScene& operator=(const BlockScene&) = delete;

  FaceMask mask() const { return mask_; }

  // Closest present face along origin + t*dir, t in (t_near, t_far). Thread-safe.
  FaceHit intersect(const glm::dvec3& origin, const glm::dvec3& dir, double t_near = 1e-6,
                    double t_far = 1e30) const;
  // True when any present face blocks the open segment origin -> target. Thread-safe.
  bool occluded(const glm::dvec3& origin, const glm::dvec3& target, double t_near = 1e-6) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  FaceMask mask_;
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
