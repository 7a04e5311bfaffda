// SPDX-License-Identifier: MIT
#include "proxy_mapping.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "modrt/cube.h"
#include "modrt/level_geometry.h"

namespace modrt::demo {

namespace {

// How far p lies outside [0,1]^3 (0 inside).
double outside(const glm::dvec3& p) {
  double d = 0.0;
  for (int a = 0; a < 3; ++a) d = std::max({d, -p[a], p[a] - 1.0});
  return d;
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

Status check_vertex_buffer_size(const DemoScene& scene, std::size_t limit) {
  const std::string problem = vertex_buffer_problem(drawn_corner_count(scene), limit);
  return problem.empty() ? Status::success() : Status::error(ErrorCode::resource_limit, problem);
}

Result<std::vector<MappedMesh>> map_to_proxies(const DemoScene& scene, const Level& level) {
  if (Status s = check_vertex_buffer_size(scene); !s.ok())
    return Status::error(s.code(), "proxy mapping: " + s.message());
  if (level.atlas.tile_origin_x.size() != level.blocks.size() || level.res <= 0)
    return Status::error(ErrorCode::invalid_argument, "proxy mapping: the level has no lightmap atlas");
  const double res = level.res;
  const double block_size =
      level.blocks.empty()
          ? 1.0
          : glm::length(level.blocks[0].corners[7] - level.blocks[0].corners[0]) / std::sqrt(3.0);
  std::vector<MappedMesh> out;
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& mesh = scene.meshes[mi];
    if (mesh.dynamic || mesh.clutter >= 0) continue;  // probes / the clutter lightmap light them
    const std::size_t n = mesh.position.size();
    if (mesh.normal.size() != n || (!mesh.uv.empty() && mesh.uv.size() != n) ||
        (!mesh.tangent.empty() && mesh.tangent.size() != n) || mesh.indices.size() % 3 != 0)
      return Status::error(ErrorCode::invalid_argument,
                           "proxy mapping: mesh '" + mesh.name +
                               "': normals, uvs, tangents and positions differ in count, or the index "
                               "count is not a multiple of 3");
    MappedMesh mapped;
    mapped.mesh = int(mi);
    mapped.vertices.reserve(mesh.indices.size());
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      std::uint32_t idx[3] = {mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]};
      if (idx[0] >= n || idx[1] >= n || idx[2] >= n)
        return Status::error(ErrorCode::invalid_argument, "proxy mapping: mesh '" + mesh.name + "': index " +
                                                              std::to_string(t) + " out of range");
      const glm::dvec3 a(mesh.position[idx[0]]), b(mesh.position[idx[1]]), c(mesh.position[idx[2]]);
      const glm::dvec3 centroid = (a + b + c) / 3.0;
      glm::dvec3 normal =
          glm::dvec3(mesh.normal[idx[0]]) + glm::dvec3(mesh.normal[idx[1]]) + glm::dvec3(mesh.normal[idx[2]]);
      if (glm::dot(normal, normal) < 1e-20) normal = glm::cross(b - a, c - a);
      normal = glm::dot(normal, normal) > 0 ? glm::normalize(normal) : glm::dvec3(0, 1, 0);
      // The block containing the centroid (or the nearest one), looked up a little in front of
      // the surface: a wall on the boundary of two blocks is lit from the block it faces. 2 %
      // of a block: more than a warped wall's flat triangles stray from its bilinear surface.
      const glm::dvec3 probe = centroid + 0.02 * block_size * normal;
      std::size_t best_block = 0;
      double best_out = std::numeric_limits<double>::infinity();
      glm::dvec3 best_p(0.5);
      for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
        const LevelBlock& blk = level.blocks[bi];
        const glm::dvec3 lo = glm::min(blk.corners[0], blk.corners[7]) - 0.5,
                         hi = glm::max(blk.corners[0], blk.corners[7]) + 0.5;
        if (glm::any(glm::lessThan(probe, lo)) || glm::any(glm::greaterThan(probe, hi))) continue;
        const glm::dvec3 p = world_to_block(blk, probe);
        const double o = outside(p);
        if (o < best_out) best_out = o, best_block = bi, best_p = p;
        if (o == 0.0) break;
      }
      if (best_out > 1e-6) ++mapped.triangles_outside;
      const LevelBlock& blk = level.blocks[best_block];
      // Face choice: the present face whose inward normal the surface faces alike (a floor
      // rug maps to the floor, a shelf's front to the wall behind it), the nearer on ties.
      const glm::dvec3 n_canonical = rotate_direction(normal, -blk.quarter_turns);
      const FaceMask mask = dictionary_shape_mask(blk.shape);
      int face = -1;
      double best_score = -std::numeric_limits<double>::infinity();
      for (int f = 0; f < kFaceCount; ++f) {
        if (!face_present(mask, f)) continue;
        const FaceFrame& fr = face_frame(f);
        const double distance = std::abs(glm::dot(best_p - fr.origin, fr.normal));
        const double score = glm::dot(n_canonical, fr.normal) - 0.25 * distance;
        if (score > best_score) best_score = score, face = f;
      }
      const FaceFrame& fr = face_frame(face);
      const std::size_t bi = best_block;
      const double ox = level.atlas.tile_origin_x[bi][std::size_t(face)] + 1;
      const double oy = level.atlas.tile_origin_y[bi][std::size_t(face)] + 1;
      const glm::vec3 face_u(glm::normalize(rotate_direction(fr.u_axis, blk.quarter_turns)));
      const glm::vec3 face_v(glm::normalize(rotate_direction(fr.v_axis, blk.quarter_turns)));
      for (std::uint32_t i : idx) {
        const glm::dvec3 p = world_to_block(blk, glm::dvec3(mesh.position[i]));
        // Orthographic projection onto the face, kept on the tile's interior so that
        // bilinear taps stay within the tile and its padding.
        const double u = std::clamp(glm::dot(p - fr.origin, fr.u_axis), 0.0, 1.0);
        const double v = std::clamp(glm::dot(p - fr.origin, fr.v_axis), 0.0, 1.0);
        MappedVertex mv;
        mv.position = mesh.position[i];
        mv.normal = mesh.normal[i];
        if (!mesh.tangent.empty()) mv.tangent = mesh.tangent[i];
        if (!mesh.uv.empty()) mv.uv = mesh.uv[i];
        mv.lightmap = glm::vec2(float(ox + u * res), float(oy + v * res));
        mv.face_u = face_u;
        mv.face_v = face_v;
        mapped.vertices.push_back(mv);
      }
    }
    out.push_back(std::move(mapped));
  }
  return out;
}

}  // namespace modrt::demo
