// SPDX-License-Identifier: MIT
// modrt precompute (private) — the two Embree queries every scene class makes, and the one guard
// every ray passes before it reaches Embree.
#pragma once

#include <cmath>

#include <embree3/rtcore.h>
#include <glm/vec3.hpp>

#include "modrt/light_policy.h"

namespace modrt::precompute {

// The rule for rays (light_policy.h): Embree asserts (RayK::valid()) on a ray whose origin or
// direction has a coordinate beyond FLT_LARGE or whose t range is NaN. A ray is traced only when
// its origin and direction are finite with every coordinate within kMaxTraceCoordinate (1e15,
// a factor ~900 under FLT_LARGE, so the float conversion cannot overflow it) and
// 0 <= t_near <= t_far with both finite. A ray that cannot be traced carries no light: intersect
// reports a miss, occluded reports the segment blocked. Lights out of reach never get this far
// (light_in_reach); this guard is what keeps any other bad point (a NaN from upstream, a hostile
// mesh) from aborting the process.
inline bool traceable_ray(const glm::dvec3& origin, const glm::dvec3& dir, double t_near, double t_far) {
  return traceable(origin) && traceable(dir) && t_near >= 0.0 && t_near <= t_far && std::isfinite(t_far);
}

// Closest hit along origin + t dir, t in (t_near, inf); geomID is RTC_INVALID_GEOMETRY_ID
// on a miss (and for a ray that cannot be traced). `context`, when given, is the initialised
// context the filter functions receive (a caller's extension of RTCIntersectContext).
inline RTCRayHit embree_intersect(RTCScene scene, const glm::dvec3& origin, const glm::dvec3& dir,
                                  double t_near, RTCIntersectContext* context = nullptr) {
  RTCRayHit rh{};
  rh.ray.tfar = 1e30f;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  if (!traceable_ray(origin, dir, t_near, 1e30)) return rh;
  RTCIntersectContext local;
  if (!context) {
    rtcInitIntersectContext(&local);
    context = &local;
  }
  rh.ray.org_x = float(origin.x);
  rh.ray.org_y = float(origin.y);
  rh.ray.org_z = float(origin.z);
  rh.ray.dir_x = float(dir.x);
  rh.ray.dir_y = float(dir.y);
  rh.ray.dir_z = float(dir.z);
  rh.ray.tnear = float(t_near);
  rh.ray.mask = 0xFFFFFFFFu;
  rtcIntersect1(scene, context, &rh);
  return rh;
}

// True when anything blocks the open segment origin -> target (and for a segment that cannot be
// traced); t_near is a fraction of the segment. `context` as for embree_intersect.
inline bool embree_occluded(RTCScene scene, const glm::dvec3& origin, const glm::dvec3& target, double t_near,
                            RTCIntersectContext* context = nullptr) {
  const glm::dvec3 d = target - origin;
  constexpr double kTFar = 1.0 - 1e-6;  // stop just short of the target point itself
  if (!traceable(target) || !traceable_ray(origin, d, t_near, kTFar)) return true;
  RTCIntersectContext local;
  if (!context) {
    rtcInitIntersectContext(&local);
    context = &local;
  }
  RTCRay ray{};
  ray.org_x = float(origin.x);
  ray.org_y = float(origin.y);
  ray.org_z = float(origin.z);
  ray.dir_x = float(d.x);
  ray.dir_y = float(d.y);
  ray.dir_z = float(d.z);
  ray.tnear = float(t_near);
  ray.tfar = float(kTFar);
  ray.mask = 0xFFFFFFFFu;
  rtcOccluded1(scene, context, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

}  // namespace modrt::precompute
