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

// Maps every static mesh of `scene` onto `level` (built from scene.level). Fails when the
// level has no atlas or a mesh's arrays disagree in size (naming the mesh).
Result<std::vector<MappedMesh>> map_to_proxies(const DemoScene& scene, const Level& level);

}  // namespace modrt::demo
