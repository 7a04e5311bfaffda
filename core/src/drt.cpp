// SPDX-License-Identifier: MIT
#include "modrt/drt.h"
#include "modrt/feedback_policy.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "modrt/clutter_mesh.h"
#include "modrt/level_runtime.h"
#include "modrt/reference_runtime.h"

namespace modrt {

int clutter_face_count(const ClutterObject& object) {
  if (object.kind == ClutterKind::mesh) return object.mesh ? object.mesh->atlas.chart_count : 0;
  return face_count(object.faces);
}

int clutter_texel_count(const ClutterObject& object) {
  if (object.kind == ClutterKind::mesh)
    return object.mesh ? int(object.mesh->atlas.texels.position.size()) : 0;
  return clutter_face_count(object) * object.res * object.res;
}

glm::dvec3 clutter_to_world(const ClutterBox& box, const glm::dvec3& q) {
  return box.center + box.rotation * ((q - glm::dvec3(0.5)) * 2.0 * box.half_extent);
}

glm::dvec3 clutter_face_point(const ClutterBox& box, int face, double u, double v) {
  // The cube's frames have inward normals; swapping u and v turns them outward.
  return clutter_to_world(box, face_point(face, v, u));
}

glm::dvec3 clutter_face_normal(const ClutterBox& box, int face) {
  return glm::normalize(box.rotation * (-face_frame(face).normal));
}

bool clutter_contains(const ClutterBox& box, const glm::dvec3& p, double margin) {
  const glm::dvec3 local = glm::transpose(box.rotation) * (p - box.center);
  for (int a = 0; a < 3; ++a)
    if (std::abs(local[a]) > box.half_extent[a] + margin) return false;
  return true;
}

double clutter_bounding_radius(const ClutterBox& box) { return glm::length(box.half_extent); }

ClutterTexelGeometry clutter_texel_geometry(const ClutterObject& object) {
  if (object.kind == ClutterKind::mesh)
    return object.mesh ? object.mesh->atlas.texels : ClutterTexelGeometry{};
  ClutterTexelGeometry g;
  const std::size_t m = std::size_t(clutter_texel_count(object));
  g.position.reserve(m);
  g.normal.reserve(m);
  g.face.reserve(m);
  const int res = object.res;
  for (int f = 0; f < kFaceCount; ++f) {
    if (!face_present(object.faces, f)) continue;
    const glm::dvec3 n = clutter_face_normal(object.box, f);
    for (int j = 0; j < res; ++j)
      for (int i = 0; i < res; ++i) {
        g.position.push_back(clutter_face_point(object.box, f, (i + 0.5) / res, (j + 0.5) / res));
        g.normal.push_back(n);
        g.tangent.push_back(glm::normalize(clutter_face_point(object.box, f, 1.0, 0.0) -
                                           clutter_face_point(object.box, f, 0.0, 0.0)));
        g.face.push_back(f);
      }
  }
  return g;
}

ClutterTexelCells clutter_texel_cells(const ClutterObject& object) {
  ClutterTexelCells c;
  if (object.kind == ClutterKind::mesh) {
    if (!object.mesh) return c;
    const ClutterMeshAtlas& atlas = object.mesh->atlas;
    c.res = atlas.res;
    c.face = atlas.texels.face;
    c.cell.assign(atlas.texels.face.size(), glm::ivec2(0));
    for (std::size_t i = 0; i < atlas.cell_texel.size(); ++i)
      if (const std::int32_t t = atlas.cell_texel[i]; t >= 0 && std::size_t(t) < c.cell.size())
        c.cell[std::size_t(t)] = glm::ivec2(int(i % std::size_t(atlas.res)), int(i / std::size_t(atlas.res)));
    return c;
  }
  c.res = object.res;
  for (int f = 0; f < kFaceCount; ++f) {  // clutter_texel_geometry's order
    if (!face_present(object.faces, f)) continue;
    for (int j = 0; j < object.res; ++j)
      for (int i = 0; i < object.res; ++i) {
        c.face.push_back(f);
        c.cell.emplace_back(i, j);
      }
  }
  return c;
}

std::vector<double> clutter_texel_area(const ClutterObject& object) {
  if (object.kind == ClutterKind::mesh) return object.mesh ? object.mesh->atlas.area : std::vector<double>{};
  std::vector<double> area;
  const glm::dvec3 e = 2.0 * object.box.half_extent;
  const double per_face[3] = {e.y * e.z, e.x * e.z, e.x * e.y};  // faces 2a, 2a + 1 are normal to axis a
  const double cells = double(object.res) * double(object.res);
  for (int f = 0; f < kFaceCount; ++f)
    if (face_present(object.faces, f)) area.insert(area.end(), std::size_t(cells), per_face[f / 2] / cells);
  return area;
}

namespace {

// texel_cell against texel_count and cell_res (drt.h): 3 per texel or empty, cells inside the
// grid, no two texels of one face in one cell.
Status check_texel_cells(const DrtObjectOperators& o) {
  auto bad = [](const std::string& what) { return Status::error(ErrorCode::invalid_argument, what); };
  if (o.texel_cell.empty())
    return o.cell_res == 0 ? Status::success() : bad("cell_res is set but texel_cell is empty");
  if (o.texel_cell.size() != 3 * std::size_t(o.texel_count)) return bad("texel_cell is not 3 x m");
  if (o.cell_res == 0 || o.cell_res > kMaxClutterCellRes)
    return bad("cell_res " + std::to_string(o.cell_res) + " is not in 1.." +
               std::to_string(kMaxClutterCellRes));
  std::vector<std::uint64_t> keys(o.texel_count);
  for (std::size_t t = 0; t < o.texel_count; ++t) {
    const std::uint32_t face = o.texel_cell[3 * t], u = o.texel_cell[3 * t + 1], v = o.texel_cell[3 * t + 2];
    if (u >= o.cell_res || v >= o.cell_res)
      return bad("texel_cell of texel " + std::to_string(t) + ": cell (" + std::to_string(u) + ", " +
                 std::to_string(v) + ") is outside the " + std::to_string(o.cell_res) + " x " +
                 std::to_string(o.cell_res) + " grid");
    if (face >= kMaxClutterCellFaces)
      return bad("texel_cell of texel " + std::to_string(t) + ": face " + std::to_string(face) +
                 " is not below " + std::to_string(kMaxClutterCellFaces));
    keys[t] = (std::uint64_t(face) * o.cell_res + v) * o.cell_res + u;
  }
  std::sort(keys.begin(), keys.end());
  if (std::adjacent_find(keys.begin(), keys.end()) != keys.end())
    return bad("texel_cell: two texels share a cell");
  return Status::success();
}

// A mesh object's data against itself: what clutter_texel_geometry, the operator build and
// the backends index without further checks.
std::string check_mesh_data(const ClutterObject& o) {
  if (!o.mesh) return "kind mesh without mesh data";
  const ClutterMeshData& d = *o.mesh;
  const ClutterMeshAtlas& a = d.atlas;
  const std::size_t m = a.texels.position.size(), triangles = d.mesh.indices.size() / 3;
  if (a.res != o.res) return "res " + std::to_string(o.res) + " is not the atlas's " + std::to_string(a.res);
  if (m == 0) return "the atlas has no texels";
  if (a.texels.normal.size() != m || a.texels.face.size() != m || a.texels.tangent.size() != m ||
      a.area.size() != m || a.triangle.size() != m ||
      a.cell_texel.size() != std::size_t(a.res) * std::size_t(a.res))
    return "atlas arrays of different lengths";
  if (a.chart_count < 1 || d.chart_of_triangle.size() != triangles || d.mesh.indices.size() % 3 != 0)
    return "charts do not match the triangles";
  for (std::size_t t = 0; t < m; ++t)
    if (a.texels.face[t] < 0 || a.texels.face[t] >= a.chart_count || a.triangle[t] >= triangles ||
        !(a.area[t] > 0.0) || !std::isfinite(a.area[t]))
      return "texel " + std::to_string(t) + " has a bad chart, triangle or area";
  for (int c : d.chart_of_triangle)
    if (c < 0 || c >= a.chart_count) return "a triangle's chart is out of range";
  for (std::uint32_t i : d.mesh.indices)
    if (i >= d.mesh.positions.size()) return "a triangle index is out of range";
  return {};
}

}  // namespace

Status validate_clutter(const Level& level, std::span<const ClutterObject> objects) {
  for (std::size_t k = 0; k < objects.size(); ++k) {
    const ClutterObject& o = objects[k];
    auto fail = [&](const std::string& what) {
      return Status::error(ErrorCode::invalid_argument, "clutter object " + std::to_string(k) + ": " + what);
    };
    if (o.kind != ClutterKind::box && o.kind != ClutterKind::mesh) return fail("unknown kind");
    if (o.kind == ClutterKind::mesh)
      if (std::string why = check_mesh_data(o); !why.empty()) return fail(why);
    if (o.block < 0 || std::size_t(o.block) >= level.blocks.size())
      return fail("block " + std::to_string(o.block) + " is not a level block");
    if (o.res < 1) return fail("res must be >= 1");
    if ((o.faces & ~kAllFaces) != 0 || o.faces == 0) return fail("faces must name 1 to 6 faces");
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(o.box.center[a])) return fail("non-finite centre");
      if (!std::isfinite(o.box.half_extent[a]) || o.box.half_extent[a] <= 0.0)
        return fail("half extents must be finite and positive");
      if (!std::isfinite(o.albedo[a]) || o.albedo[a] < 0.0 || o.albedo[a] > 1.0)
        return fail("albedo outside [0, 1]");
    }
    const glm::dmat3 RtR = glm::transpose(o.box.rotation) * o.box.rotation;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        if (!(std::abs(RtR[c][r] - (r == c ? 1.0 : 0.0)) <= 1e-6)) return fail("rotation is not orthonormal");
  }
  return Status::success();
}

namespace {

std::size_t matrix_bytes(const Matrix& m) { return m.data.size() * sizeof(float); }

std::size_t sparse_bytes(const DrtSparseRows& g) {
  return (g.start.size() + g.index.size()) * sizeof(std::uint32_t) + g.weight.size() * sizeof(float);
}

// A CSR of `rows` rows (or none) whose indices are below `columns` and whose weights are
// finite and non-negative; "" or what is wrong.
std::string check_sparse(const DrtSparseRows& g, std::size_t rows, std::size_t columns) {
  if (g.empty()) return g.index.empty() && g.weight.empty() ? "" : "has entries but no rows";
  if (g.rows() != rows) return "has " + std::to_string(g.rows()) + " rows, not " + std::to_string(rows);
  if (g.index.size() != g.weight.size()) return "has a different number of indices and weights";
  if (g.start.front() != 0 || g.start.back() != g.index.size()) return "row starts do not span its entries";
  for (std::size_t r = 0; r < rows; ++r)
    if (g.start[r + 1] < g.start[r]) return "row starts decrease";
  for (std::size_t e = 0; e < g.index.size(); ++e) {
    if (g.index[e] >= columns) return "index out of range";
    if (!(g.weight[e] >= 0.0f) || !std::isfinite(g.weight[e])) return "weight negative, NaN or Inf";
  }
  return "";
}

bool all_finite(const Matrix& m) {
  return std::all_of(m.data.begin(), m.data.end(), [](float x) { return std::isfinite(x); });
}

}  // namespace

std::size_t DrtOperators::storage_bytes() const {
  std::size_t bytes = 0;
  for (const DrtObjectOperators& o : objects) {
    bytes += matrix_bytes(o.dUb) + matrix_bytes(o.Td_c) + matrix_bytes(o.dUc) + matrix_bytes(o.Uc) +
             matrix_bytes(o.Vc);
    bytes += matrix_bytes(o.Uc_vec) + matrix_bytes(o.Vc_vec) + matrix_bytes(o.Cc_vec) +
             (o.Cb_vec_blocks.size() + o.Cc_vec_objects.size()) * sizeof(std::uint32_t);
    bytes += matrix_bytes(o.Cc) + matrix_bytes(o.dUb_vec) + matrix_bytes(o.dUc_vec) + matrix_bytes(o.Udyn) +
             matrix_bytes(o.Udyn_c);
    bytes += (o.Udyn_probe.size() + o.Udyn_block.size() + o.Udyn_c_probe.size()) * sizeof(std::uint32_t);
    bytes +=
        (o.dUb_sample.size() + o.dUb_block.size() + o.dUc_sample.size() + o.Cb_blocks.size() +
         o.Cc_objects.size() + o.dUb_vec_sample.size() + o.dUb_vec_block.size() + o.dUc_vec_sample.size()) *
        sizeof(std::uint32_t);
    bytes += sparse_bytes(o.Gs) + sparse_bytes(o.Gt) + sparse_bytes(o.Hs) + sparse_bytes(o.Ht) +
             o.H_sample.size() * sizeof(std::uint32_t);
  }
  return bytes;
}

bool DrtOperators::has_gather() const {
  return std::any_of(objects.begin(), objects.end(),
                     [](const DrtObjectOperators& o) { return o.has_gather(); });
}

DrtBufferSizes drt_buffer_sizes(const DrtOperators& drt) {
  DrtBufferSizes s;
  std::size_t faces = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    s.clutter_texels += o.texel_count;
    faces += o.face_count;
  }
  s.clutter_ld = s.clutter_lightmap = 3 * s.clutter_texels;
  s.clutter_vector_lightmap = 12 * s.clutter_texels;
  s.c = 3 * faces;
  return s;
}

Status check_drt_operators(const Level& level, const DrtOperators& drt) {
  if (drt.empty()) return Status::success();
  if (drt.kb != level.kb)
    return Status::error(ErrorCode::invalid_argument, "DRT operators: kb " + std::to_string(drt.kb) +
                                                          " does not match the level's kb " +
                                                          std::to_string(level.kb));
  if ((drt.level_blocks != 0 && drt.level_blocks != level.blocks.size()) ||
      (drt.level_samples != 0 && drt.level_samples != level.sample_count))
    return Status::error(ErrorCode::invalid_argument,
                         "DRT operators: built for a level of " + std::to_string(drt.level_blocks) +
                             " blocks and " + std::to_string(drt.level_samples) +
                             " samples, this level has " + std::to_string(level.blocks.size()) + " and " +
                             std::to_string(level.sample_count));
  for (std::size_t k = 0; k < drt.objects.size(); ++k) {
    const DrtObjectOperators& o = drt.objects[k];
    auto fail = [&](const std::string& what) {
      return Status::error(ErrorCode::invalid_argument, "DRT object " + std::to_string(k) + ": " + what);
    };
    const std::size_t rows = o.dUb_sample.size();
    if (o.dUb_block.size() != rows || o.dUb.rows != rows || (rows > 0 && o.dUb.cols != drt.kb))
      return fail("dUb is not rows x kb with one sample and block per row");
    for (std::size_t r = 0; r < rows; ++r) {
      if (o.dUb_sample[r] >= level.sample_count) return fail("dUb sample index out of range");
      if (o.dUb_block[r] >= level.blocks.size()) return fail("dUb block index out of range");
      if (r > 0 && (o.dUb_sample[r] < o.dUb_sample[r - 1] ||
                    (o.dUb_sample[r] == o.dUb_sample[r - 1] && o.dUb_block[r] <= o.dUb_block[r - 1])))
        return fail("dUb rows not sorted by (sample, block)");
    }
    if (o.Td_c.rows != o.face_count || o.Td_c.cols != o.texel_count) return fail("Td_c is not f x m");
    if (o.texel_position.size() != o.texel_normal.size() ||
        (!o.texel_position.empty() && o.texel_position.size() != 3 * std::size_t(o.texel_count)))
      return fail("texel_position and texel_normal are not both empty or both 3 x m");
    if (Status s = check_texel_cells(o); !s.ok()) return fail(s.message());
    if (o.dUc.rows != o.dUc_sample.size() || (o.dUc.rows > 0 && o.dUc.cols != o.face_count))
      return fail("dUc is not |dUc_sample| x f");
    for (std::size_t r = 0; r < o.dUc_sample.size(); ++r) {
      if (o.dUc_sample[r] >= level.sample_count) return fail("dUc sample index out of range");
      if (r > 0 && o.dUc_sample[r] <= o.dUc_sample[r - 1]) return fail("dUc samples not sorted and unique");
    }
    for (std::uint32_t blk : o.Cb_blocks)
      if (blk >= level.blocks.size()) return fail("Cb block index out of range");
    if (!o.Uc.empty() || !o.Vc.empty()) {
      if (o.Uc.rows != o.texel_count || o.Vc.rows != o.Uc.cols ||
          o.Vc.cols != std::size_t(drt.kb) * o.Cb_blocks.size())
        return fail("Uc / Vc are not m x modes and modes x (kb * |Cb_blocks|)");
    }
    std::size_t cc_cols = 0;
    for (std::size_t j = 0; j < o.Cc_objects.size(); ++j) {
      const std::uint32_t src = o.Cc_objects[j];
      if (src >= drt.objects.size() || src == k) return fail("Cc source object out of range or itself");
      if (j > 0 && src <= o.Cc_objects[j - 1]) return fail("Cc source objects not sorted and unique");
      cc_cols += drt.objects[src].face_count;
    }
    if ((!o.Cc_objects.empty() || !o.Cc.empty()) && (o.Cc.rows != o.texel_count || o.Cc.cols != cc_cols))
      return fail("Cc is not m x (faces of its source objects)");
    const std::size_t clutter_texels = drt_buffer_sizes(drt).clutter_texels;
    if (const std::string e = check_sparse(o.Gs, o.texel_count, level.sample_count); !e.empty())
      return fail("Gs " + e);
    if (const std::string e = check_sparse(o.Gt, o.texel_count, clutter_texels); !e.empty())
      return fail("Gt " + e);
    for (std::size_t r = 0; r < o.H_sample.size(); ++r)
      if (o.H_sample[r] >= level.sample_count || (r > 0 && o.H_sample[r] <= o.H_sample[r - 1]))
        return fail("H_sample out of range, not sorted or not unique");
    if (o.H_sample.empty() && (!o.Hs.empty() || !o.Ht.empty()))
      return fail("Hs / Ht have rows but no H_sample");
    if (!o.H_sample.empty()) {
      if (const std::string e = check_sparse(o.Hs, o.H_sample.size(), level.sample_count); !e.empty())
        return fail("Hs " + e);
      if (const std::string e = check_sparse(o.Ht, o.H_sample.size(), clutter_texels); !e.empty())
        return fail("Ht " + e);
      if (o.Hs.empty() || o.Ht.empty()) return fail("H_sample without both Hs and Ht rows");
    }
    const std::size_t vrows = o.dUb_vec_sample.size();
    if (o.dUb_vec_block.size() != vrows || o.dUb_vec.rows != 4 * vrows ||
        (vrows > 0 && o.dUb_vec.cols != drt.kb))
      return fail("dUb_vec is not 4 entries x kb with one sample and block per entry");
    for (std::size_t r = 0; r < vrows; ++r) {
      if (o.dUb_vec_sample[r] >= level.sample_count || o.dUb_vec_block[r] >= level.blocks.size())
        return fail("dUb_vec sample or block index out of range");
      if (r > 0 &&
          (o.dUb_vec_sample[r] < o.dUb_vec_sample[r - 1] ||
           (o.dUb_vec_sample[r] == o.dUb_vec_sample[r - 1] && o.dUb_vec_block[r] <= o.dUb_vec_block[r - 1])))
        return fail("dUb_vec entries not sorted by (sample, block)");
    }
    if (o.dUc_vec.rows != 4 * o.dUc_vec_sample.size() ||
        (o.dUc_vec.rows > 0 && o.dUc_vec.cols != o.face_count))
      return fail("dUc_vec is not 4 |dUc_vec_sample| x f");
    for (std::size_t r = 0; r < o.dUc_vec_sample.size(); ++r)
      if (o.dUc_vec_sample[r] >= level.sample_count ||
          (r > 0 && o.dUc_vec_sample[r] <= o.dUc_vec_sample[r - 1]))
        return fail("dUc_vec samples out of range, not sorted or not unique");
    const std::size_t probes = std::size_t(drt.probes_per_block) * level.blocks.size(),
                      prows = o.Udyn_probe.size();
    if (o.Udyn_block.size() != prows || o.Udyn.rows != 9 * prows || (prows > 0 && o.Udyn.cols != drt.kb))
      return fail("Udyn is not 9 entries x kb with one probe and block per entry");
    for (std::size_t r = 0; r < prows; ++r) {
      if (o.Udyn_probe[r] >= probes || o.Udyn_block[r] >= level.blocks.size())
        return fail("Udyn probe or block index out of range");
      if (r > 0 && (o.Udyn_probe[r] < o.Udyn_probe[r - 1] ||
                    (o.Udyn_probe[r] == o.Udyn_probe[r - 1] && o.Udyn_block[r] <= o.Udyn_block[r - 1])))
        return fail("Udyn entries not sorted by (probe, block)");
    }
    if (o.Udyn_c.rows != 9 * o.Udyn_c_probe.size() || (o.Udyn_c.rows > 0 && o.Udyn_c.cols != o.face_count))
      return fail("Udyn_c is not 9 |Udyn_c_probe| x f");
    for (std::size_t r = 0; r < o.Udyn_c_probe.size(); ++r)
      if (o.Udyn_c_probe[r] >= probes || (r > 0 && o.Udyn_c_probe[r] <= o.Udyn_c_probe[r - 1]))
        return fail("Udyn_c probes out of range, not sorted or not unique");
    if (!all_finite(o.Udyn) || !all_finite(o.Udyn_c)) return fail("non-finite operator value");
    for (std::uint32_t blk : o.Cb_vec_blocks)
      if (blk >= level.blocks.size()) return fail("Cb_vec block index out of range");
    if (!o.Uc_vec.empty() || !o.Vc_vec.empty()) {
      if (o.Uc_vec.rows != 4 * o.texel_count || o.Vc_vec.rows != o.Uc_vec.cols ||
          o.Vc_vec.cols != std::size_t(drt.kb) * o.Cb_vec_blocks.size())
        return fail("Uc_vec / Vc_vec are not 4m x modes and modes x (kb * |Cb_vec_blocks|)");
    }
    std::size_t cc_vec_cols = 0;
    for (std::size_t j = 0; j < o.Cc_vec_objects.size(); ++j) {
      const std::uint32_t src = o.Cc_vec_objects[j];
      if (src >= drt.objects.size() || src == k) return fail("Cc_vec source object out of range or itself");
      if (j > 0 && src <= o.Cc_vec_objects[j - 1]) return fail("Cc_vec source objects not sorted and unique");
      cc_vec_cols += drt.objects[src].face_count;
    }
    if ((!o.Cc_vec_objects.empty() || !o.Cc_vec.empty()) &&
        (o.Cc_vec.rows != 4 * o.texel_count || o.Cc_vec.cols != cc_vec_cols))
      return fail("Cc_vec is not 4m x (faces of its source objects)");
    if (!all_finite(o.Uc_vec) || !all_finite(o.Vc_vec) || !all_finite(o.Cc_vec))
      return fail("non-finite operator value");
    if (!all_finite(o.dUb) || !all_finite(o.Td_c) || !all_finite(o.dUc) || !all_finite(o.Uc) ||
        !all_finite(o.Vc) || !all_finite(o.Cc) || !all_finite(o.dUb_vec) || !all_finite(o.dUc_vec))
      return fail("non-finite operator value");
  }
  return Status::success();
}

Status drt_compute_c(const DrtOperators& drt, std::span<const float> clutter_ld, std::span<float> c) {
  const DrtBufferSizes sizes = drt_buffer_sizes(drt);
  if (clutter_ld.size() != sizes.clutter_ld)
    return Status::error(ErrorCode::invalid_argument, "clutter_ld: wrong size");
  if (c.size() != sizes.c) return Status::error(ErrorCode::invalid_argument, "c: wrong size");
  if (Status s = validate_light_signal(clutter_ld, sizes.clutter_texels, "clutter_ld"); !s.ok()) return s;
  std::size_t texel0 = 0, face0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    for (std::uint32_t f = 0; f < o.face_count; ++f) {
      double acc[3] = {0, 0, 0};
      const std::span<const float> row = o.Td_c.row(f);
      for (std::uint32_t t = 0; t < o.texel_count; ++t) {
        if (row[t] == 0.0f) continue;
        for (int ch = 0; ch < 3; ++ch)
          acc[ch] += double(row[t]) * clutter_ld[3 * (texel0 + t) + std::size_t(ch)];
      }
      for (int ch = 0; ch < 3; ++ch) c[3 * (face0 + f) + std::size_t(ch)] = float(acc[ch]);
    }
    texel0 += o.texel_count;
    face0 += o.face_count;
  }
  return Status::success();
}

void drt_apply(const Level& level, const DrtOperators& drt, std::span<const float> b,
               std::span<const float> c, std::span<float> lightmap) {
  const std::size_t kb = level.kb;
  std::size_t face0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    for (std::size_t r = 0; r < o.dUb_sample.size(); ++r) {
      const std::span<const float> row = o.dUb.row(std::uint32_t(r));
      const float* bb = b.data() + 3 * kb * o.dUb_block[r];
      double acc[3] = {0, 0, 0};
      for (std::size_t k = 0; k < kb; ++k)
        for (int ch = 0; ch < 3; ++ch) acc[ch] += double(row[k]) * bb[3 * k + std::size_t(ch)];
      for (int ch = 0; ch < 3; ++ch)
        lightmap[3 * std::size_t(o.dUb_sample[r]) + std::size_t(ch)] += float(acc[ch]);
    }
    for (std::size_t r = 0; r < o.dUc_sample.size(); ++r) {
      const std::span<const float> row = o.dUc.row(std::uint32_t(r));
      double acc[3] = {0, 0, 0};
      for (std::uint32_t f = 0; f < o.face_count; ++f)
        for (int ch = 0; ch < 3; ++ch) acc[ch] += double(row[f]) * c[3 * (face0 + f) + std::size_t(ch)];
      for (int ch = 0; ch < 3; ++ch)
        lightmap[3 * std::size_t(o.dUc_sample[r]) + std::size_t(ch)] += float(acc[ch]);
    }
    face0 += o.face_count;
  }
}

void drt_apply_vector(const Level& level, const DrtOperators& drt, std::span<const float> b,
                      std::span<const float> c, std::span<float> vector_lightmap) {
  const std::size_t kb = level.kb;
  std::size_t face0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    for (std::size_t r = 0; r < o.dUb_vec_sample.size(); ++r) {
      const float* bb = b.data() + 3 * kb * o.dUb_vec_block[r];
      for (std::size_t i = 0; i < 4; ++i) {
        const std::span<const float> row = o.dUb_vec.row(std::uint32_t(4 * r + i));
        double acc[3] = {0, 0, 0};
        for (std::size_t k = 0; k < kb; ++k)
          for (int ch = 0; ch < 3; ++ch) acc[ch] += double(row[k]) * bb[3 * k + std::size_t(ch)];
        for (int ch = 0; ch < 3; ++ch)
          vector_lightmap[3 * (4 * std::size_t(o.dUb_vec_sample[r]) + i) + std::size_t(ch)] += float(acc[ch]);
      }
    }
    for (std::size_t r = 0; r < o.dUc_vec_sample.size(); ++r)
      for (std::size_t i = 0; i < 4; ++i) {
        const std::span<const float> row = o.dUc_vec.row(std::uint32_t(4 * r + i));
        double acc[3] = {0, 0, 0};
        for (std::uint32_t f = 0; f < o.face_count; ++f)
          for (int ch = 0; ch < 3; ++ch) acc[ch] += double(row[f]) * c[3 * (face0 + f) + std::size_t(ch)];
        for (int ch = 0; ch < 3; ++ch)
          vector_lightmap[3 * (4 * std::size_t(o.dUc_vec_sample[r]) + i) + std::size_t(ch)] += float(acc[ch]);
      }
    face0 += o.face_count;
  }
}

void drt_apply_probes(const DrtOperators& drt, std::span<const float> b, std::span<const float> c,
                      std::span<float> probes) {
  const std::size_t kb = drt.kb;
  std::size_t face0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    for (std::size_t r = 0; r < o.Udyn_probe.size(); ++r) {
      const float* bb = b.data() + 3 * kb * o.Udyn_block[r];
      for (std::size_t j = 0; j < 9; ++j) {
        const std::span<const float> row = o.Udyn.row(std::uint32_t(9 * r + j));
        double acc[3] = {0, 0, 0};
        for (std::size_t k = 0; k < kb; ++k)
          for (int ch = 0; ch < 3; ++ch) acc[ch] += double(row[k]) * bb[3 * k + std::size_t(ch)];
        for (int ch = 0; ch < 3; ++ch)
          probes[3 * (9 * std::size_t(o.Udyn_probe[r]) + j) + std::size_t(ch)] += float(acc[ch]);
      }
    }
    for (std::size_t r = 0; r < o.Udyn_c_probe.size(); ++r)
      for (std::size_t j = 0; j < 9; ++j) {
        const std::span<const float> row = o.Udyn_c.row(std::uint32_t(9 * r + j));
        double acc[3] = {0, 0, 0};
        for (std::uint32_t f = 0; f < o.face_count; ++f)
          for (int ch = 0; ch < 3; ++ch) acc[ch] += double(row[f]) * c[3 * (face0 + f) + std::size_t(ch)];
        for (int ch = 0; ch < 3; ++ch)
          probes[3 * (9 * std::size_t(o.Udyn_c_probe[r]) + j) + std::size_t(ch)] += float(acc[ch]);
      }
    face0 += o.face_count;
  }
}

void drt_clutter_add_cc(const DrtOperators& drt, std::span<const float> c, std::span<float> out) {
  std::vector<std::size_t> face0(drt.objects.size() + 1, 0);
  for (std::size_t k = 0; k < drt.objects.size(); ++k) face0[k + 1] = face0[k] + drt.objects[k].face_count;
  std::size_t texel0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    if (!o.Cc.empty()) {
      for (std::uint32_t t = 0; t < o.texel_count; ++t) {
        const std::span<const float> row = o.Cc.row(t);
        double acc[3] = {0, 0, 0};
        std::size_t col = 0;
        for (std::uint32_t src : o.Cc_objects)
          for (std::uint32_t f = 0; f < drt.objects[src].face_count; ++f, ++col)
            for (int ch = 0; ch < 3; ++ch)
              acc[ch] += double(row[col]) * c[3 * (face0[src] + f) + std::size_t(ch)];
        for (int ch = 0; ch < 3; ++ch) out[3 * (texel0 + t) + std::size_t(ch)] += float(acc[ch]);
      }
    }
    texel0 += o.texel_count;
  }
}

namespace {

// out[3 row + ch] += sign * sum of weight * x[3 index + ch] over row `row` of g.
void add_sparse_row(const DrtSparseRows& g, std::size_t row, std::span<const float> x, double sign,
                    float* out) {
  double acc[3] = {0, 0, 0};
  for (std::uint32_t e = g.start[row]; e < g.start[row + 1]; ++e) {
    const float* v = x.data() + 3 * std::size_t(g.index[e]);
    for (int ch = 0; ch < 3; ++ch) acc[ch] += double(g.weight[e]) * double(v[ch]);
  }
  for (int ch = 0; ch < 3; ++ch) out[ch] += float(sign * acc[ch]);
}

}  // namespace

void drt_apply_gather(const DrtOperators& drt, std::span<const float> ld,
                      std::span<const float> clutter_radiance, std::span<float> lightmap) {
  for (const DrtObjectOperators& o : drt.objects)
    for (std::size_t r = 0; r < o.H_sample.size(); ++r) {
      float* out = lightmap.data() + 3 * std::size_t(o.H_sample[r]);
      add_sparse_row(o.Hs, r, ld, -1.0, out);
      add_sparse_row(o.Ht, r, clutter_radiance, 1.0, out);
    }
}

void drt_clutter_add_gather(const DrtOperators& drt, std::span<const float> ld,
                            std::span<const float> clutter_radiance, std::span<float> out) {
  std::size_t texel0 = 0;
  for (const DrtObjectOperators& o : drt.objects) {
    for (std::uint32_t t = 0; t < o.texel_count; ++t) {
      float* row = out.data() + 3 * (texel0 + t);
      if (!o.Gs.empty()) add_sparse_row(o.Gs, t, ld, 1.0, row);
      if (!o.Gt.empty()) add_sparse_row(o.Gt, t, clutter_radiance, 1.0, row);
    }
    texel0 += o.texel_count;
  }
}

void drt_clutter_indirect(const DrtOperators& drt, std::span<const float> b, std::span<const float> c,
                          std::span<const float> ld, std::span<const float> clutter_radiance,
                          std::span<float> out) {
  drt_clutter_lightmap(drt, b, {}, out);
  drt_clutter_add_cc(drt, c, out);
  drt_clutter_add_gather(drt, ld, clutter_radiance, out);
}

void drt_evaluate_clutter_lightmap(const DrtOperators& drt, std::span<const float> b,
                                   std::span<const float> c, std::span<const float> ld,
                                   std::span<const float> clutter_radiance,
                                   std::span<const float> clutter_direct, std::span<float> out,
                                   std::span<float> indirect) {
  drt_clutter_indirect(drt, b, c, ld, clutter_radiance, out);
  if (!indirect.empty()) std::copy(out.begin(), out.end(), indirect.begin());
  if (!clutter_direct.empty())
    for (std::size_t i = 0; i < out.size(); ++i) out[i] += clutter_direct[i];
  clamp_lightmap(out);
}

void drt_clutter_vector_lightmap(const DrtOperators& drt, std::span<const float> b, std::span<const float> c,
                                 std::span<float> out) {
  const std::size_t kb = drt.kb;
  std::size_t texel0 = 0, face0 = 0;
  std::vector<std::size_t> first_face;
  for (const DrtObjectOperators& o : drt.objects) {
    first_face.push_back(face0);
    face0 += o.face_count;
  }
  std::vector<double> y;
  for (const DrtObjectOperators& o : drt.objects) {
    const std::uint32_t modes = o.Uc_vec.cols;
    y.assign(3 * std::size_t(modes), 0.0);
    for (std::uint32_t q = 0; q < modes; ++q) {
      const std::span<const float> row = o.Vc_vec.row(q);
      for (std::size_t blk = 0; blk < o.Cb_vec_blocks.size(); ++blk) {
        const float* bb = b.data() + 3 * kb * o.Cb_vec_blocks[blk];
        for (std::size_t k = 0; k < kb; ++k)
          for (int ch = 0; ch < 3; ++ch)
            y[3 * q + std::size_t(ch)] += double(row[blk * kb + k]) * bb[3 * k + std::size_t(ch)];
      }
    }
    for (std::uint32_t r = 0; r < 4 * o.texel_count; ++r) {
      double acc[3] = {0, 0, 0};
      for (std::uint32_t q = 0; q < modes; ++q)
        for (int ch = 0; ch < 3; ++ch) acc[ch] += double(o.Uc_vec(r, q)) * y[3 * q + std::size_t(ch)];
      if (!o.Cc_vec.empty()) {
        const std::span<const float> row = o.Cc_vec.row(r);
        std::size_t col = 0;
        for (std::uint32_t src : o.Cc_vec_objects)
          for (std::uint32_t f = 0; f < drt.objects[src].face_count; ++f, ++col)
            for (int ch = 0; ch < 3; ++ch)
              acc[ch] += double(row[col]) * c[3 * (first_face[src] + f) + std::size_t(ch)];
      }
      for (int ch = 0; ch < 3; ++ch) out[3 * (4 * texel0 + r) + std::size_t(ch)] = float(acc[ch]);
    }
    texel0 += o.texel_count;
  }
}

void drt_clutter_lightmap(const DrtOperators& drt, std::span<const float> b,
                          std::span<const float> clutter_direct, std::span<float> out) {
  const std::size_t kb = drt.kb;
  std::size_t texel0 = 0;
  std::vector<double> y;  // Vc b: one value per mode and channel
  for (const DrtObjectOperators& o : drt.objects) {
    const std::uint32_t modes = o.Uc.cols;
    y.assign(3 * std::size_t(modes), 0.0);
    for (std::uint32_t q = 0; q < modes; ++q) {
      const std::span<const float> row = o.Vc.row(q);
      for (std::size_t blk = 0; blk < o.Cb_blocks.size(); ++blk) {
        const float* bb = b.data() + 3 * kb * o.Cb_blocks[blk];
        for (std::size_t k = 0; k < kb; ++k)
          for (int ch = 0; ch < 3; ++ch)
            y[3 * q + std::size_t(ch)] += double(row[blk * kb + k]) * bb[3 * k + std::size_t(ch)];
      }
    }
    for (std::uint32_t t = 0; t < o.texel_count; ++t) {
      double acc[3] = {0, 0, 0};
      for (std::uint32_t q = 0; q < modes; ++q)
        for (int ch = 0; ch < 3; ++ch) acc[ch] += double(o.Uc(t, q)) * y[3 * q + std::size_t(ch)];
      for (int ch = 0; ch < 3; ++ch) {
        const std::size_t i = 3 * (texel0 + t) + std::size_t(ch);
        out[i] = float(acc[ch]) + (clutter_direct.empty() ? 0.0f : clutter_direct[i]);
      }
    }
    texel0 += o.texel_count;
  }
}

void drt_clutter_feedback(std::span<const float> clutter_ld, std::span<const float> rho_c,
                          std::span<const float> indirect, float bound, std::span<float> out) {
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = clutter_ld[i] + rho_c[i] * std::min(std::max(indirect[i], 0.0f), bound);
}

float drt_feedback_bound(float ld_max, float rho_max, float clutter_ld_max, float rho_c_max) {
  return feedback_energy_bound(std::max(ld_max, clutter_ld_max), std::max(rho_max, rho_c_max));
}

Result<MultiBounceReport> drt_multi_bounce(const Level& level, const Dictionary& dict,
                                           const DrtOperators& drt, std::span<const float> ld_direct,
                                           std::span<const float> albedo, std::span<const float> clutter_ld,
                                           std::span<const float> clutter_albedo,
                                           const MultiBounceSettings& settings, std::span<float> b,
                                           std::span<float> r, std::span<float> lightmap, std::span<float> c,
                                           std::span<float> last_ld, std::span<float> last_clutter_radiance,
                                           bool from_evaluation) {
  const DrtBufferSizes sizes = drt_buffer_sizes(drt);
  if (c.size() != sizes.c) return Status::error(ErrorCode::invalid_argument, "c: wrong size");
  if (!clutter_albedo.empty())
    if (Status s = validate_light_signal(clutter_albedo, sizes.clutter_texels, "clutter_albedo"); !s.ok())
      return s;
  std::vector<float> c_given;
  if (from_evaluation) c_given.assign(c.begin(), c.end());
  if (Status s = drt_compute_c(drt, clutter_ld, c); !s.ok()) return s;  // validates clutter_ld
  if (from_evaluation) std::copy(c_given.begin(), c_given.end(), c.begin());
  if (!last_ld.empty() && last_ld.size() != ld_direct.size())
    return Status::error(ErrorCode::invalid_argument, "last_ld: wrong size");
  if (!last_clutter_radiance.empty() && last_clutter_radiance.size() != sizes.clutter_ld)
    return Status::error(ErrorCode::invalid_argument, "last_clutter_radiance: wrong size");
  Result<FeedbackClamp> clamp = prepare_feedback(ld_direct, albedo, level.sample_count, settings);
  if (!clamp.ok()) return clamp.status();
  MultiBounceReport report;
  report.albedo_clamped = clamp->albedo_clamped;
  report.energy_bound = clamp->energy_bound;
  // The clutter's feedback (docs/drt.md "Multi-bounce"): its albedo clamped as the level's.
  std::vector<float> rho_c(clutter_albedo.begin(), clutter_albedo.end()), indirect, fed;
  float rho_max = 0.0f, rho_c_max = 0.0f, bound_c = 0.0f;
  if (!rho_c.empty()) {
    rho_max = largest_light(clamp->rho);
    const ClampedAlbedo clamped_c = clamp_albedo(rho_c, settings.max_albedo, rho_c);
    report.albedo_clamped |= clamped_c.clamped;
    rho_c_max = clamped_c.rho_max;
    bound_c = drt_feedback_bound(largest_light(ld_direct), rho_max, largest_light(clutter_ld), rho_c_max);
    indirect.resize(sizes.clutter_lightmap);
    fed.resize(sizes.clutter_ld);
  }
  std::vector<float> ld(ld_direct.begin(), ld_direct.end()), b_prev(b.size());
  // x_t of the gather: the clutter's direct light, then the light fed back.
  std::span<const float> clutter_radiance = clutter_ld;
  auto evaluate = [&]() -> Status {
    if (Status s = level_evaluate(level, dict, ld, b, r, lightmap); !s.ok()) return s;
    drt_apply(level, drt, b, c, lightmap);
    drt_apply_gather(drt, ld, clutter_radiance, lightmap);
    clamp_lightmap(lightmap);  // the corrected lightmap is a lightmap too (reference_runtime.h)
    return Status::success();
  };
  if (!from_evaluation)
    if (Status s = evaluate(); !s.ok()) return s;
  for (int it = 1; it <= settings.max_iterations; ++it) {
    if (!rho_c.empty()) {
      drt_clutter_indirect(drt, b, c, ld, clutter_radiance, indirect);
      drt_clutter_feedback(clutter_ld, rho_c, indirect, bound_c, fed);
      if (Status s = drt_compute_c(drt, fed, c); !s.ok()) return s;
      clutter_radiance = fed;
    }
    report.value_clamped |= apply_feedback(clamp.value(), ld_direct, lightmap, ld);
    std::copy(b.begin(), b.end(), b_prev.begin());
    if (Status s = evaluate(); !s.ok()) return s;
    report.iterations = it;
    if (feedback_converged(b, b_prev, settings.tolerance)) {
      report.converged = true;
      break;
    }
  }
  if (!last_ld.empty()) std::copy(ld.begin(), ld.end(), last_ld.begin());
  if (!last_clutter_radiance.empty())
    std::copy(clutter_radiance.begin(), clutter_radiance.end(), last_clutter_radiance.begin());
  return report;
}

}  // namespace modrt
