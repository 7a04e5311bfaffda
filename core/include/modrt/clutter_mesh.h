// SPDX-License-Identifier: MIT
// modrt — the data of a triangle-mesh clutter object (DRT §3, architecture.md §6): the mesh in world
// space and its lightmap atlas, the texels the operators gather from. precompute's
// clutter_mesh.h makes them (rasterize_clutter_mesh, make_mesh_clutter); core only reads
// them (texel counts, texel geometry, charts), so the runtime needs no rasterizer.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "modrt/drt.h"

namespace modrt {

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

// What a ClutterObject of kind mesh points to (shared: copies of the object share it).
// chart_of_triangle: each triangle's chart, the index its texels carry in atlas.texels.face.
struct ClutterMeshData {
  ClutterMesh mesh;
  ClutterMeshAtlas atlas;
  std::vector<int> chart_of_triangle;
};

}  // namespace modrt
