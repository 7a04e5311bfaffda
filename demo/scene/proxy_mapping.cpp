// SPDX-License-Identifier: MIT
#include "proxy_mapping.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <string>

#include <glm/geometric.hpp>

#include "modrt/checked_arithmetic.h"
#include "modrt/mesh_lightmap_uv.h"

namespace modrt::demo {

namespace {

MeshLightmapInput lightmap_input(const Mesh& mesh) {
  MeshLightmapInput in;
  in.positions = StridedVec3::tight(mesh.position);
  in.normals = StridedVec3::tight(mesh.normal);
  in.vertex_count = mesh.position.size();
  in.indices = mesh.indices;
  return in;
}

// The demo's vertex of a mapped corner: UV and tangent interpolated onto the piece (an input
// vertex keeps its own bit for bit).
MappedVertex demo_vertex(const Mesh& mesh, const MappedCorner& c) {
  MappedVertex v;
  v.position = c.position;
  v.normal = c.normal;
  v.lightmap = c.lightmap;
  v.face_u = c.face_u;
  v.face_v = c.face_v;
  const std::size_t t = 3 * std::size_t(c.triangle);
  const std::array<std::uint32_t, 3> idx = {mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]};
  const int k = input_vertex(c);
  if (k >= 0) {
    if (!mesh.uv.empty()) v.uv = mesh.uv[idx[std::size_t(k)]];
    if (!mesh.tangent.empty()) v.tangent = mesh.tangent[idx[std::size_t(k)]];
    return v;
  }
  if (!mesh.uv.empty())
    v.uv = c.barycentric[0] * mesh.uv[idx[0]] + c.barycentric[1] * mesh.uv[idx[1]] +
           c.barycentric[2] * mesh.uv[idx[2]];
  if (!mesh.tangent.empty()) {
    // xyz blended and renormalised; the handedness of the corner with the largest weight.
    const int major = c.barycentric[0] >= c.barycentric[1] && c.barycentric[0] >= c.barycentric[2] ? 0
                      : c.barycentric[1] >= c.barycentric[2]                                       ? 1
                                                                                                   : 2;
    const glm::vec4& tm = mesh.tangent[idx[std::size_t(major)]];
    glm::vec3 xyz(0.0f);
    for (std::size_t j = 0; j < 3; ++j) xyz += c.barycentric[int(j)] * glm::vec3(mesh.tangent[idx[j]]);
    const float length = glm::length(xyz);
    v.tangent = glm::vec4(length > 1e-6f ? xyz / length : glm::vec3(tm), tm.w);
  }
  return v;
}

}  // namespace

std::size_t drawn_corner_count(const DemoScene& scene) {
  std::size_t corners = kLightMarkerCorners;
  for (const Mesh& mesh : scene.meshes) corners += mesh.indices.size();
  return corners;
}

std::string vertex_buffer_problem(std::size_t corners, std::size_t limit) {
  if (corners <= limit / sizeof(MappedVertex)) return {};  // division: no overflow
  char text[256];
  std::snprintf(text, sizeof text,
                "%zu triangle corners need a vertex buffer of %zu x %zu bytes = %.4g GB, more than the limit "
                "of %zu bytes (%.4g GB)",
                corners, corners, sizeof(MappedVertex), double(corners) * double(sizeof(MappedVertex)) * 1e-9,
                limit, double(limit) * 1e-9);
  return text;
}

std::size_t drawn_corner_count(const DemoScene& scene, std::span<const MappedMesh> mapped) {
  std::size_t corners = kLightMarkerCorners;
  for (const Mesh& mesh : scene.meshes)
    if (mesh.dynamic || mesh.clutter >= 0) corners = saturating_add(corners, mesh.indices.size());
  for (const MappedMesh& m : mapped) corners = saturating_add(corners, m.vertices.size());
  return corners;
}

Status check_vertex_buffer_size(const DemoScene& scene, std::size_t limit) {
  const std::string problem = vertex_buffer_problem(drawn_corner_count(scene), limit);
  return problem.empty() ? Status::success() : Status::error(ErrorCode::resource_limit, problem);
}

Result<std::vector<MappedMesh>> map_to_proxies(const DemoScene& scene, const Level& level) {
  // Refused on the unmapped count first (a lower bound: cutting only adds corners).
  if (Status s = check_vertex_buffer_size(scene); !s.ok())
    return Status::error(s.code(), "proxy mapping: " + s.message());
  if (Status s = check_level_for_mesh_lightmap(level); !s.ok())
    return Status::error(s.code(), "proxy mapping: " + s.message());
  // Then on the exact count of the cut meshes, before any of them is expanded.
  std::vector<std::size_t> mapped_corners(scene.meshes.size(), 0);
  std::size_t corners = kLightMarkerCorners;
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& mesh = scene.meshes[mi];
    if (mesh.dynamic || mesh.clutter >= 0) {  // probes / the clutter lightmap light them
      corners = saturating_add(corners, mesh.indices.size());
      continue;
    }
    const std::size_t n = mesh.position.size();
    if (mesh.normal.size() != n || (!mesh.uv.empty() && mesh.uv.size() != n) ||
        (!mesh.tangent.empty() && mesh.tangent.size() != n))
      return Status::error(
          ErrorCode::invalid_argument,
          "proxy mapping: mesh '" + mesh.name + "': normals, uvs, tangents and positions differ in count");
    const Result<MeshLightmapStats> count = mesh_lightmap_corner_count(level, lightmap_input(mesh));
    if (!count.ok())
      return Status::error(count.status().code(),
                           "proxy mapping: mesh '" + mesh.name + "': " + count.status().message());
    mapped_corners[mi] = count->corners;
    corners = saturating_add(corners, count->corners);
  }
  if (const std::string problem = vertex_buffer_problem(corners); !problem.empty())
    return Status::error(ErrorCode::resource_limit,
                         "proxy mapping: the static meshes cut at block boundaries: " + problem);
  std::vector<MappedMesh> out;
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& mesh = scene.meshes[mi];
    if (mesh.dynamic || mesh.clutter >= 0) continue;
    MappedMesh mapped;
    mapped.mesh = int(mi);
    mapped.vertices.reserve(mapped_corners[mi]);
    const Result<MeshLightmapStats> stats =
        map_mesh_lightmap(level, lightmap_input(mesh), [&](const std::array<MappedCorner, 3>& triangle) {
          for (const MappedCorner& c : triangle) mapped.vertices.push_back(demo_vertex(mesh, c));
        });
    if (!stats.ok())
      return Status::error(stats.status().code(),
                           "proxy mapping: mesh '" + mesh.name + "': " + stats.status().message());
    mapped.triangles_outside = int(stats->triangles_outside);
    mapped.triangles_split = int(stats->split_triangles);
    out.push_back(std::move(mapped));
  }
  return out;
}

}  // namespace modrt::demo
