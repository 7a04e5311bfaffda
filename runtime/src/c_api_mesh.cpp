// SPDX-License-Identifier: MIT
// Lightmap coordinates for the app's own static meshes: modrt_level_map_mesh over core's
// proxy mapping (modrt/mesh_lightmap_uv.h).
#include <array>
#include <span>
#include <string>

#include "c_api_internal.h"
#include "modrt/mesh_lightmap_uv.h"

namespace modrt::capi {
namespace {

// The C description as core's, after the checks that need the C view (struct_size, null
// index pointer); the rest (strides, values, indices) core checks and names.
modrt_status mesh_view(const char* fn, const modrt_level* level, const modrt_mesh_input* mesh,
                       MeshLightmapInput& out) {
  if (!level) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": level is null");
  if (!mesh) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": mesh is null");
  if (modrt_status s = check_struct_size(fn, "mesh", *mesh, "modrt_mesh_input", "modrt_mesh_input_init");
      s != MODRT_OK)
    return s;
  if (!mesh->indices && mesh->index_count > 0)
    return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": mesh->indices is null (index_count " +
                                                  std::to_string(mesh->index_count) + ")");
  constexpr std::size_t tight = 3 * sizeof(float);
  out.positions = {mesh->positions, mesh->position_stride == 0 ? tight : mesh->position_stride};
  out.normals = {mesh->normals, mesh->normal_stride == 0 ? tight : mesh->normal_stride};
  out.vertex_count = mesh->vertex_count;
  out.indices = mesh->index_count > 0 ? std::span<const std::uint32_t>(mesh->indices, mesh->index_count)
                                      : std::span<const std::uint32_t>();
  return MODRT_OK;
}

modrt_status fail_in(const char* fn, const Status& s) {
  return fail(from_error_code(s.code()), std::string(fn) + ": " + s.message());
}

void copy3(float dst[3], const glm::vec3& v) { dst[0] = v.x, dst[1] = v.y, dst[2] = v.z; }

}  // namespace
}  // namespace modrt::capi

using namespace modrt::capi;

extern "C" {

void modrt_mesh_input_init(modrt_mesh_input* mesh) {
  if (!mesh) return;
  *mesh = modrt_mesh_input{};
  mesh->struct_size = sizeof(modrt_mesh_input);
  mesh->position_stride = mesh->normal_stride = 3 * sizeof(float);
}

modrt_status modrt_level_map_mesh_bound(const modrt_level* level, const modrt_mesh_input* mesh,
                                        size_t* corners) {
  static constexpr char fn[] = "modrt_level_map_mesh_bound";
  return guarded(fn, [&] {
    if (!corners) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": corners is null");
    modrt::MeshLightmapInput in;
    if (modrt_status s = mesh_view(fn, level, mesh, in); s != MODRT_OK) return s;
    const modrt::Result<modrt::MeshLightmapStats> count = modrt::mesh_lightmap_corner_count(level->level, in);
    if (!count.ok()) return fail_in(fn, count.status());
    *corners = count->corners;
    return MODRT_OK;
  });
}

modrt_status modrt_level_map_mesh(const modrt_level* level, const modrt_mesh_input* mesh,
                                  modrt_mapped_corner* out, size_t capacity, size_t* written,
                                  modrt_mesh_map_stats* stats) {
  static constexpr char fn[] = "modrt_level_map_mesh";
  return guarded(fn, [&] {
    if (!written) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": written is null");
    if (stats)
      if (modrt_status s = check_struct_size(fn, "stats", *stats, "modrt_mesh_map_stats"); s != MODRT_OK)
        return s;
    modrt::MeshLightmapInput in;
    if (modrt_status s = mesh_view(fn, level, mesh, in); s != MODRT_OK) return s;
    // Counted first, so that a failure (bad input, too little room) writes nothing.
    const modrt::Result<modrt::MeshLightmapStats> count = modrt::mesh_lightmap_corner_count(level->level, in);
    if (!count.ok()) return fail_in(fn, count.status());
    if (count->corners > 0 && !out)
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out is null");
    if (capacity < count->corners)
      return fail(MODRT_ERROR_INVALID_ARGUMENT,
                  std::string(fn) + ": capacity " + std::to_string(capacity) + " is less than the " +
                      std::to_string(count->corners) +
                      " corners of the mapped mesh (modrt_level_map_mesh_bound)");
    std::size_t n = 0;
    const modrt::MappedTriangleFn write = [&](const std::array<modrt::MappedCorner, 3>& triangle) {
      for (const modrt::MappedCorner& c : triangle) {
        if (n >= capacity) return;  // never: the two runs are the same
        modrt_mapped_corner& o = out[n++];
        copy3(o.position, c.position);
        copy3(o.normal, c.normal);
        o.lightmap[0] = c.lightmap.x, o.lightmap[1] = c.lightmap.y;
        copy3(o.face_u, c.face_u);
        copy3(o.face_v, c.face_v);
        copy3(o.barycentric, c.barycentric);
        o.triangle = c.triangle;
        o.block = c.block;
        o.face = std::uint32_t(c.face);
        o.outside = c.outside ? 1u : 0u;
      }
    };
    const modrt::Result<modrt::MeshLightmapStats> mapped = modrt::map_mesh_lightmap(level->level, in, write);
    if (!mapped.ok()) return fail_in(fn, mapped.status());  // not reached: the count run passed
    *written = n;
    if (stats) {
      stats->triangles = mapped->triangles;
      stats->split_triangles = mapped->split_triangles;
      stats->triangles_outside = mapped->triangles_outside;
      stats->corners = mapped->corners;
    }
    return MODRT_OK;
  });
}

}  // extern "C"
