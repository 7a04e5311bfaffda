// SPDX-License-Identifier: MIT
// modrt demo — lightmap coordinates for real geometry (MRT §7.2): every static mesh of the
// scene goes through core's proxy mapping (modrt/mesh_lightmap_uv.h, the same function the C
// API exposes as modrt_level_map_mesh): each triangle is cut at block boundaries, and each
// piece is assigned to one proxy face of its block and projected onto it in the block's
// canonical frame, so that its three lightmap coordinates lie in one tile of the padded
// atlas. Vertices are therefore emitted per triangle (no index buffer). This file adds the
// demo's own parts: the vertex format (UVs and tangents interpolated onto the pieces) and the
// vertex-buffer limit.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "demo_scene.h"
#include "modrt/level.h"
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
  int triangles_outside = 0;           // with a part in no block: mapped to the nearest block
  int triangles_split = 0;             // cut at block boundaries into pieces in several blocks
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
// Triangle corners (vertex buffer entries) the renderer draws for `scene` before the static
// meshes are cut at block boundaries: a lower bound of the mapped count, known before mapping.
std::size_t drawn_corner_count(const DemoScene& scene);
// The corners drawn once the static meshes are `mapped` (map_to_proxies): exact.
std::size_t drawn_corner_count(const DemoScene& scene, std::span<const MappedMesh> mapped);
// Fails with resource_limit, giving the corner count, the buffer's bytes and `limit`, when the
// vertex buffer for `scene` would exceed `limit` bytes (the unmapped count above).
Status check_vertex_buffer_size(const DemoScene& scene, std::size_t limit = kMaxVertexBufferBytes);

// Maps every static mesh of `scene` onto `level` (built from scene.level). Fails when the
// level has no atlas, a mesh's arrays disagree in size or its data is bad (naming the mesh,
// the array and the index), or the scene's vertex buffer would exceed kMaxVertexBufferBytes:
// checked before anything is expanded, first on the unmapped count, then on the exact count
// of the cut meshes (mesh_lightmap_corner_count).
Result<std::vector<MappedMesh>> map_to_proxies(const DemoScene& scene, const Level& level);

}  // namespace modrt::demo
