// SPDX-License-Identifier: MIT
// modrt demo — lightmap coordinates for real geometry (MRT §7.2): every static triangle is
// assigned to one proxy face of the block that contains it and projected orthographically
// onto that face, in the block's canonical frame (through the inverse of its trilinear
// warp), so it samples the face's lightmap tile in the padded atlas.
//
// The paper chooses the face per vertex. Here the choice is per triangle (by its normal and
// centroid), so a triangle's three lightmap coordinates always lie in one tile: a triangle
// whose vertices chose different faces would interpolate across unrelated atlas tiles.
// Vertices are therefore emitted per triangle (no index buffer).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "demo_scene.h"
#include "modrt/level.h"
#include "modrt/level_geometry.h"  // world_to_block
#include "modrt/status.h"

namespace modrt::demo {

// One vertex of the mapped triangle list.
struct MappedVertex {
  glm::vec3 position, normal;
  glm::vec4 tangent{1, 0, 0, 1};
  glm::vec2 uv{0.0f};
  // Atlas texel coordinates (continuous; x + 0.5 is a texel centre) of the face's tile.
  glm::vec2 lightmap{0.0f};
  // The proxy face's OHLSH frame in world space (sh.h: coefficients are in the face frame):
  // its u and v axes turned with the block, for normal-mapped vector irradiance.
  glm::vec3 face_u{1, 0, 0}, face_v{0, 1, 0};
};

struct MappedMesh {
  int mesh = 0;                        // index into DemoScene::meshes
  std::vector<MappedVertex> vertices;  // three per triangle
  int triangles_outside = 0;           // centroids in no block: mapped to the nearest block
};

// The renderer draws every mesh from one non-indexed vertex buffer, a MappedVertex per
// triangle corner: static meshes mapped here, dynamic and clutter meshes expanded as they are,
// plus the light marker (SceneRenderer). 1 GiB of vertices (13.4 M corners, 4.5 M triangles):
// the proxy mapping's vertices and the renderer's upload array each hold about as much on the
// host, and llvmpipe keeps its own copy of the buffer, so a scene at the limit peaks near
// 3 GiB. A scene above it is refused before any of it is expanded (a glTF file with 10^6
// instances of a cube asked for 2.9 GB and crashed llvmpipe, issue 18).
inline constexpr std::size_t kMaxVertexBufferBytes = std::size_t(1) << 30;
// The light marker's corners in the vertex buffer (a sphere of 8 rings x 16 segments).
inline constexpr std::size_t kLightMarkerCorners = 8 * 16 * 6;

// "" when `corners` triangle corners fit in a vertex buffer of `limit` bytes; else the
// problem, with the numbers (the one statement of the bound, for the glTF loader's estimate too).
std::string vertex_buffer_problem(std::size_t corners, std::size_t limit = kMaxVertexBufferBytes);
// Triangle corners (vertex buffer entries) the renderer draws for `scene`.
std::size_t drawn_corner_count(const DemoScene& scene);
// Fails with resource_limit, giving the corner count, the buffer's bytes and `limit`, when the
// vertex buffer for `scene` would exceed `limit` bytes.
Status check_vertex_buffer_size(const DemoScene& scene, std::size_t limit = kMaxVertexBufferBytes);

// Maps every static mesh of `scene` onto `level` (built from scene.level). Fails when the
// level has no atlas, a mesh's arrays disagree in size (naming the mesh) or the scene's vertex
// buffer would exceed kMaxVertexBufferBytes (check_vertex_buffer_size, before expanding).
Result<std::vector<MappedMesh>> map_to_proxies(const DemoScene& scene, const Level& level);

}  // namespace modrt::demo
