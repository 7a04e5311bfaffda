// SPDX-License-Identifier: MIT
#include "modrt/precompute/block_scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <embree3/rtcore.h>
#include <glm/geometric.hpp>
#include "embree_rays.h"

namespace modrt::precompute {

struct BlockScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<int> face_of_prim;  // Embree primID -> face index
};

namespace {

void embree_error(void*, RTCError code, const char* message) {
  // Errors are surfaced by the null checks below; keep the message for diagnostics.
  (void)code;
  (void)message;
}

}  // namespace

BlockScene::BlockScene(FaceMask mask, const glm::dvec3& extent)
    : impl_(std::make_unique<Impl>()), mask_(mask), extent_(extent) {
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(extent[a]) || !(extent[a] > 0.0))
      throw std::invalid_argument("BlockScene: extent " + std::to_string(a) + " = " +
                                  std::to_string(extent[a]) + ": must be finite and > 0");
  // No "threads=N": with Embree's TBB tasking it installs a process-wide
  // tbb::global_control(max_allowed_parallelism, N) while the device lives, which would
  // serialize every parallel_for of the bake (see level_scene.cpp).
  impl_->device = rtcNewDevice("set_affinity=0");
  if (!impl_->device)
    throw std::runtime_error("Embree: rtcNewDevice failed (error " +
                             std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
  rtcSetDeviceErrorFunction(impl_->device, embree_error, nullptr);
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  const int quads = face_count(mask);
  if (quads > 0) {
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_QUAD);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), std::size_t(4 * quads)));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4, 4 * sizeof(unsigned), std::size_t(quads)));
    if (!vertices || !indices) throw std::runtime_error("Embree: cannot allocate geometry buffers");
    int q = 0;
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(mask, f)) continue;
      const glm::dvec3 corners[4] = {point(face_point(f, 0, 0)), point(face_point(f, 1, 0)),
                                     point(face_point(f, 1, 1)), point(face_point(f, 0, 1))};
      for (int c = 0; c < 4; ++c)
        for (int a = 0; a < 3; ++a) vertices[(4 * q + c) * 3 + a] = float(corners[c][a]);
      for (int c = 0; c < 4; ++c) indices[4 * q + c] = unsigned(4 * q + c);
      impl_->face_of_prim.push_back(f);
      ++q;
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE)
    throw std::runtime_error("Embree: scene build failed");
}

BlockScene::~BlockScene() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

FaceHit BlockScene::intersect(const glm::dvec3& origin, const glm::dvec3& dir, double t_near,
                              double t_far) const {
  const RTCRayHit rh = embree_intersect(impl_->scene, origin, dir, t_near);
  FaceHit hit;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID || rh.ray.tfar >= t_far) return hit;
  hit.face = impl_->face_of_prim[rh.hit.primID];
  hit.t = rh.ray.tfar;
  // Face coordinates from the hit point in double: exact for planar faces and independent
  // of how Embree splits a quad into triangles.
  // The hit in canonical coordinates: the box is the unit cube scaled by extent_ per axis.
  const FaceFrame& frame = face_frame(hit.face);
  const glm::dvec3 p = (origin + hit.t * dir) / extent_ - frame.origin;
  hit.u = std::clamp(glm::dot(p, frame.u_axis), 0.0, 1.0);
  hit.v = std::clamp(glm::dot(p, frame.v_axis), 0.0, 1.0);
  return hit;
}

double BlockScene::texel_area(int face, int res) const {
  const FaceFrame& frame = face_frame(face);
  const double width = glm::length(frame.u_axis * extent_), height = glm::length(frame.v_axis * extent_);
  return res > 0 ? width * height / (double(res) * res) : 0.0;
}

bool BlockScene::occluded(const glm::dvec3& origin, const glm::dvec3& target, double t_near) const {
  return embree_occluded(impl_->scene, origin, target, t_near);
}

BilinearTaps bilinear_taps(double u, double v, int res) {
  BilinearTaps taps{};
  const double x = u * res - 0.5;
  const double y = v * res - 0.5;
  const double fx0 = std::floor(x);
  const double fy0 = std::floor(y);
  const double ax = x - fx0;
  const double ay = y - fy0;
  const int x0 = int(fx0);
  const int y0 = int(fy0);
  const int xs[2] = {std::clamp(x0, 0, res - 1), std::clamp(x0 + 1, 0, res - 1)};
  const int ys[2] = {std::clamp(y0, 0, res - 1), std::clamp(y0 + 1, 0, res - 1)};
  const double wx[2] = {1.0 - ax, ax};
  const double wy[2] = {1.0 - ay, ay};
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      taps.i[2 * b + a] = xs[a];
      taps.j[2 * b + a] = ys[b];
      taps.w[2 * b + a] = wx[a] * wy[b];
    }
  return taps;
}

}  // namespace modrt::precompute
