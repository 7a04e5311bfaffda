// modrt precompute (private) — the two Embree queries every scene class makes.
#pragma once

#include <embree3/rtcore.h>
#include <glm/vec3.hpp>

namespace modrt::precompute {

// Closest hit along origin + t dir, t in (t_near, inf); geomID is RTC_INVALID_GEOMETRY_ID
// on a miss.
inline RTCRayHit embree_intersect(RTCScene scene, const glm::dvec3& origin, const glm::dvec3& dir, double t_near) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh{};
  rh.ray.org_x = float(origin.x);
  rh.ray.org_y = float(origin.y);
  rh.ray.org_z = float(origin.z);
  rh.ray.dir_x = float(dir.x);
  rh.ray.dir_y = float(dir.y);
  rh.ray.dir_z = float(dir.z);
  rh.ray.tnear = float(t_near);
  rh.ray.tfar = 1e30f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene, &context, &rh);
  return rh;
}

// True when anything blocks the open segment origin -> target.
inline bool embree_occluded(RTCScene scene, const glm::dvec3& origin, const glm::dvec3& target, double t_near) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  const glm::dvec3 d = target - origin;
  RTCRay ray{};
  ray.org_x = float(origin.x);
  ray.org_y = float(origin.y);
  ray.org_z = float(origin.z);
  ray.dir_x = float(d.x);
  ray.dir_y = float(d.y);
  ray.dir_z = float(d.z);
  ray.tnear = float(t_near);
  ray.tfar = float(1.0 - 1e-6);  // stop just short of the target point itself
  ray.mask = 0xFFFFFFFFu;
  rtcOccluded1(scene, &context, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

}  // namespace modrt::precompute
