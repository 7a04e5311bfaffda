// SPDX-License-Identifier: MIT
// modrt::precompute — an artist's furniture as DRT mesh clutter (docs/drt.md "Mesh clutter",
// docs/import.md): any triangle soup of one object (several intersecting closed boxes joined
// into one mesh, vertices split per face, no lightmap UVs) becomes one closed, manifold,
// outward-wound mesh with lightmap UV charts packed into [0, 1]^2, ready for
// make_mesh_clutter (clutter_mesh.h).
//
// The steps (clutter_import.cpp):
//  1. Weld. Vertices closer than `weld_distance` become one; triangles joined through an edge
//     that exactly two triangles use form a component (boxes that merely share an edge stay
//     apart). A component is closed when each edge borders an even number of its triangles:
//     its inside is then defined by crossing parity, whatever its winding.
//  2. Frame. The object is voxelized in its own frame: the orthonormal axes along which most
//     of its area faces (a table turned 15 degrees about +Y keeps exact, axis-aligned faces);
//     the world axes when no frame beats them.
//  3. Grid. A rectilinear grid in that frame whose lines are the planes of the object's
//     axis-aligned faces (planes closer than `plane_merge` share a line) plus even subdivisions
//     of at most `voxel_size` between them, at most `max_cells` per axis (the subdivision grows
//     for large objects). A union of boxes in one frame is therefore reproduced exactly (and
//     needs no subdivision); other surfaces (bevels, spheres) within a cell.
//  4. Inside. A cell is inside when its centre lies inside any closed component (crossing
//     parity along grid lines through the cell centres, exact and watertight, one component
//     at a time: the union of intersecting parts), or when a component's span along a
//     cell-centre line is too thin to hold a centre (a thin slab keeps a cell). Open
//     components (sheets, a box without its bottom face) are thickened: every cell their
//     surface passes through is inside (OpenSurfaces::thicken), or the object is refused
//     (OpenSurfaces::refuse). Enclosed cavities are filled, and wherever two inside cells
//     touch only along an edge or at a corner the cells between are filled, so that the
//     surface is a 2-manifold.
//  5. Surface. The faces between inside and outside cells. Faces of one direction form charts
//     seen along that direction: in each cell column the outermost face is layer 0, the next
//     layer 1, ...; faces of one layer in neighbouring columns join when their planes are at
//     most `chart_step` apart (the stairs of a sphere's side make one chart, as a cube map;
//     box furniture keeps a chart per face). The UV map is the projection along the normal:
//     isometric on every face, never overlapping (one face per column and layer). A chart
//     filling less than half its bounding rectangle gives a chart per rectangle (packing).
//     Faces are merged per plane and chart into maximal rectangles (greedy meshing),
//     triangulated through every rectangle corner on their edges (no T-junctions); edges
//     that meet in UV across a step are split at the same points, so that each chart is one
//     UV island (one DRT chart for clutter_mesh_charts).
//  6. Atlas. Charts packed into shelves of a res x res grid with `gutter` empty texels around
//     each (two between neighbours: make_mesh_clutter's padding ring for each side), at one
//     texel density for all charts (the largest that fits, or `texels_per_metre`). When the
//     charts fill less than a quarter of the atlas (many small charts with their gutters: a
//     curved or clustered object), steps 5 and 6 are redone joining charts across steps of
//     4 chart_step + 0.1 m, then across any step, and the best filling result is kept.
//
// Deterministic (no hashing order, no threads), allocation-bounded by max_cells^3.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "modrt/clutter_mesh.h"
#include "modrt/level_description.h"
#include "modrt/precompute/clutter_mesh.h"
#include "modrt/status.h"

namespace modrt::precompute {

struct ClutterImportSettings {
  // Atlas edge in texels that the charts are packed for: the res to give make_mesh_clutter.
  int res = kClutterMeshDefaultRes;
  // > 0: pack at this many texels per metre instead, in the smallest res (up to max_res) that
  // holds the charts (uniform density across objects); ClutterImport::res says which.
  double texels_per_metre = 0.0;
  int max_res = 1024;
  // Empty texels around every chart (1: make_mesh_clutter's one padding ring per chart, so
  // bilinear lookups never read a neighbour chart). 0..8.
  int gutter = 1;
  // Largest cell between the object's own planes (m), and the cap on cells per axis (the
  // cell grows for objects larger than voxel_size * max_cells).
  double voxel_size = 0.03;
  int max_cells = 128;
  // m: axis-aligned face planes closer than this (at most a hundredth of the object's size)
  // share a grid line.
  double plane_merge = 0.002;
  double weld_distance = 1e-5;  // m: input vertices closer than this are one
  // m: faces facing the same way in neighbouring cell columns join one chart across a step of
  // at most this (a sphere's stairs: a chart per side; a seat and the top of its back rest,
  // 0.43 m apart, stay two charts, so bilinear lookups never blend them).
  double chart_step = 0.1;
  // Whether to look for the object's own frame (step 2) or voxelize along the world axes.
  bool align_to_object = true;
  enum class OpenSurfaces { thicken, refuse };
  OpenSurfaces open_surfaces = OpenSurfaces::thicken;
  std::size_t max_triangles = 1'000'000;
};

struct ClutterImport {
  // Closed, manifold (every edge, vertices welded by position, borders two triangles in
  // opposite directions), counter-clockwise seen from outside, UVs in [0, 1]^2; vertices are
  // split between charts (a UV each), bitwise-equal positions where charts meet.
  ClutterMesh mesh;
  std::vector<glm::dvec3> normals;  // per vertex: its chart's outward unit normal (flat)
  // Per output triangle: the input triangle (index into `indices` / 3) nearest to its
  // centroid among those facing the same axis (either side), for its material and texture
  // coordinates (the input's attributes extrapolated over that triangle's plane).
  std::vector<std::uint32_t> source_triangle;
  int res = 0;                    // the atlas edge the charts were packed for
  double texels_per_metre = 0.0;  // of every chart
  int chart_count = 0;
  glm::dmat3 frame{1.0};  // the grid's axes in world space (columns)
  glm::ivec3 cells{0};    // grid cells per axis
  // The largest cell edge used (m): surfaces off the grid's planes lie within a cell of it.
  double cell_size = 0.0;
  double volume = 0.0;                // enclosed by `mesh` (m^3)
  glm::dvec3 centroid{0.0};           // of that volume, world space (for the owning block)
  int components = 0;                 // after welding
  int open_components = 0;            // thickened (OpenSurfaces::thicken)
  std::size_t skipped_triangles = 0;  // degenerate input triangles (zero area after welding)
};

// Fails, naming `what`, with invalid_argument for: no triangles, an index count that is not a
// multiple of 3 or an index out of range, a NaN/Inf position (or beyond 1e30), only degenerate
// triangles, settings out of range, an open component with OpenSurfaces::refuse (naming an
// open edge), nothing solid left (a point cloud); resource_limit for more than max_triangles
// or charts that cannot fit max_res (or res); internal_error if the result fails its own
// closedness check. Never throws.
Result<ClutterImport> make_clutter_mesh_from_object(std::span<const glm::dvec3> positions,
                                                    std::span<const std::uint32_t> indices,
                                                    const ClutterImportSettings& settings = {},
                                                    const std::string& what = "clutter object");

// The block of `level` that owns a clutter object at world point p (its centroid): the block
// whose trilinear warp maps p into [0, 1]^3 (Newton on the corners of block_corners), or, when
// none does (a centroid inside a wall or just outside the blocks), the block it lies closest
// to in canonical units; ties to the lower index. -1 for a level without blocks.
int clutter_owner_block(const LevelDescription& level, const glm::dvec3& p);

}  // namespace modrt::precompute
