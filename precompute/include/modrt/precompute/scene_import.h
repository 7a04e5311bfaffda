// SPDX-License-Identifier: MIT
// modrt precompute — scene import: proxy blocks generated from an interior's own geometry
// (MRT §6.2 / §7.2 without a level editor; docs/import.md).
//
// Input: the static triangle meshes of one storey (world space, metres, +Y up), each with a
// diffuse albedo per triangle. Output: a LevelDescription of connected, warped blocks that
// conform to the rooms, plus what the importer decided (rooms, openings, clutter, facing) for
// a report and for writing the meshes back.
//
// The algorithm, in order (each step a function of scene_import.cpp / import_plan.cpp):
//  1. Plan. The storey is cut by a horizontal plane just below the ceilings (the height where
//     the walls' cross-section is longest, above door and window heads), rasterised at
//     `plan_cell`. Empty regions not reached from the raster's border whose inscribed radius
//     is at least min_room_width / 2 are rooms; thinner ones (the inside of a box wall) and
//     what a room encloses (a column, a lamp) are solid or belong to that room. Every solid
//     cell within max_wall_thickness of a room goes to the nearest region (room or outside),
//     so two rooms meet at their wall's mid-plane.
//  2. Heights. Floor and ceiling of each room: the lowest (highest) surface that vertical
//     rays from the plan height hit over at least a fifth of the room (furniture tops and
//     pendant lamps do not count). Rooms joined by openings share one floor and ceiling
//     (their shared faces must match).
//  3. Openings. Lower cuts (every opening_slice_step of the storey height) find passages
//     through the wall cells joining two regions: doorways (room-room), exterior doors and
//     windows (room-outside), with their jambs, sill and head.
//  4. Blocks. A rectilinear, non-uniform grid: lines along walls (room boundaries) and door
//     jambs, lines closer than storey height / max_block_aspect merged (walls win over
//     jambs), long intervals split into blocks near the storey height (cube-like blocks are
//     the most accurate, docs/proportions.md). A grid cell is a block of the room covering
//     most of it. Side faces between cells of one room are missing (connected); between
//     rooms or toward solid they are walls, except where an opening covers at least
//     min_opening_fraction of the face (then missing on both sides, or open to the outside).
//  5. Facing. Every triangle whose front faces solid and whose back faces a room is marked
//     flipped (artists' inverted walls); the proxy mapping then sees it facing into the room.
//  6. Mapping. Each triangle goes through the runtime's proxy mapping (mesh_lightmap_uv.h) on
//     the built layout; an object most of whose area lies farther than clutter_distance from
//     the face it maps to is clutter (furniture); the per-face albedo is the area-weighted
//     mean albedo of the other (structural) geometry mapped onto that face.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "modrt/level_description.h"
#include "modrt/status.h"

namespace modrt::precompute {

// One static object (a glTF node's mesh, all its primitives): world-space triangles.
struct ImportObject {
  std::string name;
  std::vector<glm::dvec3> positions;
  std::vector<std::uint32_t> indices;       // three per triangle
  std::vector<glm::dvec3> triangle_albedo;  // linear RGB in [0, 1] per triangle, or one for all
};

struct ImportSettings {
  double plan_cell = 0.0;       // plan raster cell (m); 0: largest horizontal extent / 400, in [0.02, 0.25]
  double min_room_width = 0.7;  // narrower empty regions are not rooms (m)
  double max_wall_thickness = 0.6;  // solid farther than this from every room is no room's (m)
  // Longest over shortest edge of a block: grid lines closer than storey height / this are
  // merged. 3.5 keeps a 1 m doorway 0.75 m from a corner of a 2.5 m storey a block of its own.
  double max_block_aspect = 3.5;
  double min_opening_fraction = 0.5;  // an opening covering this much of a face removes the face
  double clutter_distance = 0.3;      // m: geometry farther from its face than this is furniture
  double clutter_fraction = 0.5;      // an object with more of its area that far is clutter
  double default_albedo = 0.7;        // faces no geometry maps onto
  int layout_res = 8;                 // texels per face side for the mapping layout
  std::size_t max_triangles = 20'000'000;
  int max_plan_side = 4096;  // plan raster cells per side
};

enum class OpeningKind { doorway, exterior };

struct ImportedOpening {
  OpeningKind kind = OpeningKind::doorway;
  int room_a = -1, room_b = -1;           // room_b = -1: to the outside
  int normal_axis = 0;                    // 0: the wall is a plane x = position; 2: z = position
  double position = 0.0;                  // the wall plane (m)
  double span_min = 0.0, span_max = 0.0;  // jambs along the wall (m)
  double sill = 0.0, head = 0.0;          // m
  bool removes_face = false;              // covers enough of its block faces to make them missing
  double coverage = 0.0;                  // the largest fraction of one block face it covers
};

struct ImportedRoom {
  double floor = 0.0, ceiling = 0.0;  // m, as built (shared across joined rooms)
  double measured_floor = 0.0, measured_ceiling = 0.0;
  double area = 0.0;              // plan area (m^2), to the wall mid-planes
  glm::dvec2 min{0.0}, max{0.0};  // plan bounds (x, z)
  int blocks = 0;
};

enum class ObjectRole : std::uint8_t { structure, clutter, outside };

// The plan raster: label per cell, row-major (z rows, x columns).
struct ImportPlan {
  glm::dvec2 origin{0.0};  // (x, z) of cell (0, 0)'s corner
  double cell = 0.0;
  int width = 0, height = 0;  // cells along x, along z
  // >= 0: room (after step 1, to the wall mid-planes); kPlanOutside; kPlanSolid.
  std::vector<int> label;
  // Cells that are wall (solid in the plan cut), whatever region they were handed to.
  std::vector<std::uint8_t> wall;
  double cut_height = 0.0;
  // How far a proxy wall lies behind the surface it stands for (m): rooms meet at their wall's
  // mid-plane, so up to half the thickest wall between two regions, plus one cell. A renderer's
  // shadow test moves the proxy samples this far along their normals (DemoScene::proxy_depth).
  double proxy_depth = 0.0;
};
inline constexpr int kPlanOutside = -1;
inline constexpr int kPlanSolid = -2;

struct SceneImport {
  LevelDescription level;
  std::vector<ImportedRoom> rooms;
  std::vector<ImportedOpening> openings;
  std::vector<double> x_lines, z_lines;  // the block grid
  std::vector<int> block_room;           // room of each level block
  ImportPlan plan;
  std::vector<ObjectRole> object_role;             // per input object
  std::vector<std::vector<std::uint8_t>> flipped;  // per object, per triangle: faces solid
  std::vector<double> object_far_fraction;         // area fraction beyond clutter_distance
  std::size_t triangles = 0, triangles_flipped = 0, triangles_outside = 0;
  std::vector<std::string> warnings;
};

// Generates the proxy level for `objects` and `lights` (copied into the level). Fails with a
// message naming the object and index for bad input (non-finite position, index out of
// range, albedo outside [0, 1] or of the wrong count), invalid_argument when the scene has
// no room (nothing enclosed), resource_limit past max_triangles or max_plan_side. Never throws.
Result<SceneImport> import_scene(std::span<const ImportObject> objects,
                                 std::span<const LightDescription> lights,
                                 const ImportSettings& settings = {});

}  // namespace modrt::precompute
