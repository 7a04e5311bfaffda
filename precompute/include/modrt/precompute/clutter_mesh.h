// modrt::precompute — the lightmap of a triangle-mesh clutter object (DRT §3, SPEC §6):
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
#include <string>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "modrt/drt.h"
#include "modrt/status.h"

namespace modrt::precompute {

struct ClutterMesh {
  std::vector<glm::dvec3> positions;   // world space
  std::vector<glm::dvec2> uvs;         // lightmap UVs in [0, 1]^2, one per position
  std::vector<std::uint32_t> indices;  // three per triangle, counter-clockwise seen from outside
};

struct ClutterMeshAtlas {
  int res = 0;
  // Per grid cell (row-major, res x res): its texel index, or -1 when no triangle covers it.
  std::vector<std::int32_t> cell_texel;
  // Covered texels in cell order; `face` is the chart index.
  ClutterTexelGeometry texels;
  std::vector<std::uint32_t> triangle;  // the triangle each texel stands for
  std::vector<double> area;             // world area per texel (the triangle's, split by UV area)
  int chart_count = 0;
  // Unused cell -> used cell it copies (dilation by one texel ring).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> padding;
};

// Fails (invalid_argument, naming `what` and the triangle or vertex) on: no triangles, an
// index out of range, NaN/Inf positions or UVs, UVs outside [0, 1], a triangle with zero
// world or UV area, overlapping UV triangles (two triangles claiming the same texel centre),
// or res outside 1..1024.
Result<ClutterMeshAtlas> rasterize_clutter_mesh(const ClutterMesh& mesh, int res, const std::string& what);

}  // namespace modrt::precompute
