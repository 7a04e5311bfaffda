// SPDX-License-Identifier: MIT
// modrt::precompute — the lightmap of a triangle-mesh clutter object (DRT §3, architecture.md §6):
// rasterizes the mesh's lightmap UVs into a res x res texel grid and gives every covered
// texel the world position and normal it stands for, the same texel geometry a box clutter
// object has (drt.h ClutterTexelGeometry), so the DRT operator build can gather from mesh
// texels exactly as from box-face texels.
//
// Rasterization is the usual lightmapper's: a texel belongs to the triangle that contains
// its centre in UV space; texels a triangle touches but whose centres lie outside every
// triangle (thin triangles, chart borders) are added conservatively and take the closest
// point of the triangle that overlaps them most, so every cell the mesh touches is a texel
// and the texels' world areas add up to the mesh's area.
// Unused texels next to used ones copy their nearest used neighbour (`padding`), as the level
// atlas's padding does, so bilinear lookups at chart borders never read black.
//
// Charts (groups of triangles connected through shared UV edges) stand in for a box's
// faces: the per-face constant basis of Td_c (DRT §4.2) becomes one constant per chart.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "modrt/clutter_mesh.h"
#include "modrt/drt.h"
#include "modrt/status.h"

namespace modrt::precompute {

// Fails (invalid_argument, naming `what` and the triangle or vertex) on: no triangles, an
// index out of range, NaN/Inf positions or UVs, UVs outside [0, 1], a triangle with zero
// world or UV area, overlapping UV triangles (two triangles claiming the same texel centre),
// or res outside 1..1024.
Result<ClutterMeshAtlas> rasterize_clutter_mesh(const ClutterMesh& mesh, int res, const std::string& what);

// A clutter object of kind mesh owned by level block `block`: the atlas rasterized at res
// (kClutterMeshDefaultRes: about as many texels as a box of 16 x 16 per face), its charts,
// and the mesh's axis-aligned bounds as `box` (for culling). Fails as rasterize_clutter_mesh.
inline constexpr int kClutterMeshDefaultRes = 48;
Result<ClutterObject> make_mesh_clutter(ClutterMesh mesh, int block, const glm::dvec3& albedo, int res,
                                        const std::string& what);

// The ray queries the DRT build asks of a clutter object, for a closed triangle mesh (the
// box's analytic slab test in drt_build.cpp answers the same for boxes): where a ray from
// outside enters the object and through which chart, and whether a point lies inside. One
// Embree scene of the mesh; thread-safe for queries after create().
class ClutterMeshShape {
 public:
  // Fails like rasterize_clutter_mesh on bad geometry (UVs are not needed here), and with
  // internal_error when Embree cannot build the scene.
  static Result<ClutterMeshShape> create(const ClutterMesh& mesh, std::vector<int> chart_of_triangle,
                                         const std::string& what);
  ~ClutterMeshShape();
  ClutterMeshShape(ClutterMeshShape&&) noexcept;
  ClutterMeshShape& operator=(ClutterMeshShape&&) noexcept;

  struct Entry {
    bool hit = false;
    double t = 0.0;
    int chart = -1;
    // The entered triangle and the barycentric weights of its second and third vertex there.
    std::uint32_t triangle = 0;
    double u = 0.0, v = 0.0;
  };
  // The first surface the ray crosses in front of its origin, when that crossing enters the
  // mesh (against the outward normal). A ray that starts inside (first crossing leaves) or
  // misses enters nothing.
  Entry enter(const glm::dvec3& origin, const glm::dvec3& dir) const;
  // Inside by crossing parity along three fixed directions (majority), so a ray grazing an
  // edge cannot flip the answer alone.
  bool contains(const glm::dvec3& p) const;
  glm::dvec3 bounding_center() const { return center_; }
  double bounding_radius() const { return radius_; }

 private:
  ClutterMeshShape() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  glm::dvec3 center_{0.0};
  double radius_ = 0.0;
};

// Charts of a mesh (triangles joined through edges with equal lightmap UVs), as
// ClutterMeshAtlas::texels.face numbers them; one entry per triangle.
std::vector<int> clutter_mesh_charts(const ClutterMesh& mesh);

}  // namespace modrt::precompute
