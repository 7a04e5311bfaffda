// SPDX-License-Identifier: MIT
#include "modrt/precompute/shaped_interfaces.h"

#include <stdexcept>
#include <string>

#include "modrt/precompute/bake.h"
#include "modrt/precompute/interfaces.h"
#include "modrt/precompute/linalg.h"

namespace modrt::precompute {
namespace {

constexpr int kSideFaces[4] = {kFaceNegX, kFacePosX, kFaceNegZ, kFacePosZ};

}  // namespace

glm::dvec3 dead_end_extent(const glm::dvec3& extent, int entry) {
  // A quarter turn about y swaps the x and z edges.
  return turns_to_face(entry) % 2 ? glm::dvec3(extent.z, extent.y, extent.x) : extent;
}

ShapedInterfaces bake_shaped_interfaces(const Dictionary& dict, const Matrix& Hrlf_f, int shape,
                                        const glm::dvec3& extent, const Matrix& Limp_f) {
  const InterfaceSettings s = interface_settings(dict.settings);
  const int res = int(dict.settings.res);
  const FaceMask mask = dictionary_shape_mask(shape);
  const std::uint64_t lf = std::uint64_t(s.spatial) * s.spatial * s.directional * s.directional;
  if (dict.interfaces.empty() || Hrlf_f.rows != lf || Hrlf_f.cols != dict.settings.krlf)
    throw std::invalid_argument("shaped interfaces: the interface basis is " + std::to_string(Hrlf_f.rows) +
                                " x " + std::to_string(Hrlf_f.cols) + ", the dictionary's is " +
                                std::to_string(lf) + " x " + std::to_string(dict.settings.krlf));
  if (Limp_f.rows != std::uint32_t(face_count(mask) * res * res) || Limp_f.cols == 0)
    throw std::invalid_argument("shaped interfaces: Limp does not match shape " + std::to_string(shape));
  const MatrixXd Hrlf = to_eigen(Hrlf_f);
  const MatrixXd Limp = to_eigen(Limp_f);
  const MatrixXd UrT = to_eigen(dict.interfaces.Ur).transpose();
  ShapedInterfaces out;
  // Entries e and e ^ 1 see the same dead-end box; trace each box once.
  MatrixXd response_by_axis[2];
  for (int e : kSideFaces) {
    if (face_present(mask, e)) continue;
    out.Rb_rlf[std::size_t(e)] =
        to_float(project_onto_lightfield_basis(Hrlf, exit_lightfield(mask, e, Limp, res, s, extent)));
    // Traced turned so that light enters through -Z, as the dictionary's R were: the level
    // build turns lightfields the same way for cubes, and the walk's rounding at the face
    // edges then matches the dictionary's (a unit box reproduces its R to float precision).
    const int turns = turns_to_face(e);
    const glm::dvec3 turned = dead_end_extent(extent, e);
    for (int x : kSideFaces)
      if (x != e && !face_present(mask, x)) {
        const SparseRowMatrix P =
            box_propagation_operator(turned, kCanonicalEntryFace, rotate_face(x, -turns), s);
        out.R[std::size_t(e)][std::size_t(x)] = to_float(reduced_propagation(Hrlf, P));
      }
    MatrixXd& G = response_by_axis[turns % 2];
    if (G.size() == 0) G = symmetric_response_to_lightfield(Hrlf, res, s, turned);
    out.Trlf_r[std::size_t(e)] = to_float(MatrixXd(UrT * G));
  }
  return out;
}

}  // namespace modrt::precompute
