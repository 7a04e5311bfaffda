// SPDX-License-Identifier: MIT
// modrt — lightmap coordinates for an app's own static meshes (MRT §7.2, the proxy mapping).
//
// Every static triangle is lit from the proxy: it is assigned to one present face of the
// level block containing it and projected orthographically onto that face in the block's
// canonical frame (through the inverse of the block's trilinear warp, world_to_block), which
// gives atlas texel coordinates inside that face's lightmap tile. The renderer then samples
// the padded atlas at those coordinates.
//
// Splitting. A triangle that crosses the shared face of two blocks is cut along it, so that
// every output triangle lies in one block and its three lightmap coordinates lie in one tile
// (a triangle whose corners sampled two tiles would interpolate across unrelated atlas
// texels, and a whole triangle mapped by its centroid samples the wrong block's tile for the
// part beyond the face). The blocks take their pieces in index order, each cutting off what
// lies inside it of what earlier blocks left, so the pieces always partition the triangle
// (no area lost or covered twice). A block cuts exactly along its flat faces that it shares
// with a grid neighbour: every shared face of an unwarped block (a grid cell), and of a warp
// that keeps a face planar (a shear, a taper). It does not cut along its other faces (it
// reaches a quarter block past them, so that it never takes a piece of a block further
// away):
//   - a face with no block behind it (outer walls, floors, ceilings): there is no other
//     tile there, so a wall mesh standing a little proud of its proxy stays whole;
//   - a twisted (non-planar) face of a warped block: a planar cut would hand the strip
//     between the plane and the bilinear face to the wrong side (a wall's piece to the block
//     behind it, whose tile faces the other way). A triangle crossing a twisted face stays
//     whole (up to a quarter block past it), as it always was, and goes to the block
//     containing its centroid (exactly, through the trilinear warp); tessellate such walls
//     per block to have them cut exactly.
// What lies in no block (geometry outside the level, a box's bottom resting on the floor)
// is mapped to the nearest block and reported (`outside`).
//
// Which block "contains" a surface is decided a little in front of it: the triangle is
// classified as if moved 2 % of a block along its normal, so that a wall lying on the shared
// face of two blocks is lit from the block it faces (its pieces are output at their true
// position). Across an oblique surface this moves the cut by up to that 2 %.
//
// Output is a non-indexed triangle list, three MappedCorner per output triangle, in input
// triangle order. Each corner carries the source triangle and its barycentric coordinates
// there, so an app can interpolate any attribute of its own (UVs, tangents, colours) onto
// the pieces; a corner that is an input vertex has exactly one weight 1 and carries that
// vertex's position and normal unchanged. A triangle inside one block is output unchanged.
//
// Sizes. How many pieces a triangle makes depends on how many blocks it spans (a floor quad
// over a 10 x 10 room makes about 200 triangles), so the corner count is a function of the
// level and the mesh: mesh_lightmap_corner_count runs the same clipping without writing and
// returns the exact count, so that a caller allocates once. Double precision throughout;
// the output is float.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "modrt/level.h"
#include "modrt/status.h"

namespace modrt {

// A read-only array of 3 floats per element, `stride` bytes apart (an app's interleaved
// vertex buffer, or a tight glm::vec3 array). Elements are read with memcpy, so neither
// `data` nor `stride` needs any alignment.
struct StridedVec3 {
  const void* data = nullptr;
  std::size_t stride = 3 * sizeof(float);  // bytes from one element to the next; >= 12

  glm::vec3 operator[](std::size_t i) const;
  static StridedVec3 tight(std::span<const glm::vec3> v) { return {v.data(), sizeof(glm::vec3)}; }
};

// A triangle mesh in world space. Requirements (each refused with a message naming the
// argument and index): positions and normals non-null when vertex_count > 0, strides >= 12
// bytes and each array an object (vertex_count x stride within PTRDIFF_MAX); every position
// finite; every normal finite and not zero (length above 1e-6; it need not be unit);
// index_count a multiple of 3 and at most 3 x (2^32 - 1); every index < vertex_count.
// Zero-area triangles are allowed: they are not split (they cover nothing) and are output
// in the block that contains their centroid.
struct MeshLightmapInput {
  StridedVec3 positions;
  StridedVec3 normals;
  std::size_t vertex_count = 0;
  std::span<const std::uint32_t> indices;  // three per triangle
};

// One corner of an output triangle.
struct MappedCorner {
  glm::vec3 position{0.0f};  // world
  glm::vec3 normal{0.0f};    // the input normal, interpolated (and normalised) on cut edges
  // Atlas texel coordinates (continuous; x + 0.5 is a texel centre) inside the unpadded
  // interior of tile (block, face): sample the padded atlas here, bilinearly.
  glm::vec2 lightmap{0.0f};
  // The face's OHLSH frame in world space (sh.h: vector-irradiance coefficients are in the
  // face frame): its canonical u and v axes turned with the block (not warped).
  glm::vec3 face_u{1, 0, 0}, face_v{0, 1, 0};
  glm::vec3 barycentric{1, 0, 0};  // weights of the source triangle's corners 0, 1, 2
  std::uint32_t triangle = 0;      // source triangle: indices[3 * triangle + k]
  std::uint32_t block = 0;         // level block whose tile is sampled
  std::int32_t face = 0;           // canonical face of that block (cube.h numbering)
  bool outside = false;            // the piece lies in no block: mapped to the nearest one
};

// Which corner of the source triangle `c` is (0, 1, 2), or -1 for a point on a cut.
inline int input_vertex(const MappedCorner& c) {
  for (int k = 0; k < 3; ++k)
    if (c.barycentric[k] == 1.0f && c.barycentric[(k + 1) % 3] == 0.0f && c.barycentric[(k + 2) % 3] == 0.0f)
      return k;
  return -1;
}

struct MeshLightmapStats {
  std::size_t triangles = 0;          // input triangles
  std::size_t split_triangles = 0;    // cut into more than one piece (at a block boundary, or
                                      // where it reaches a quarter block past the level)
  std::size_t triangles_outside = 0;  // with a part in no block (mapped to the nearest block)
  std::size_t corners = 0;            // output corners, 3 per output triangle
};

// Checks that `level` has blocks and a lightmap atlas the mapping can use (every block with
// a valid shape and a tile per present face); the mapping functions check this too.
Status check_level_for_mesh_lightmap(const Level& level);

// The exact number of corners map_mesh_lightmap outputs for `mesh` (stats.corners; the
// other statistics too), without writing any. Fails as map_mesh_lightmap does.
Result<MeshLightmapStats> mesh_lightmap_corner_count(const Level& level, const MeshLightmapInput& mesh);

// Maps `mesh` onto `level`: calls `triangle` once per output triangle, in order. The whole
// input is validated before the first call, so a failure calls nothing.
using MappedTriangleFn = std::function<void(const std::array<MappedCorner, 3>&)>;
Result<MeshLightmapStats> map_mesh_lightmap(const Level& level, const MeshLightmapInput& mesh,
                                            const MappedTriangleFn& triangle);

// The same into `out` (at least mesh_lightmap_corner_count corners; the first
// stats.corners are written). Fails with invalid_argument, writing nothing, when `out` is
// too small.
Result<MeshLightmapStats> map_mesh_lightmap(const Level& level, const MeshLightmapInput& mesh,
                                            std::span<MappedCorner> out);

}  // namespace modrt
