// SPDX-License-Identifier: MIT
// Scene import (precompute/scene_import.h): proxy blocks from an interior's own geometry,
// on scenes modelled the way an artist does (walls as boxes, a doorway narrower and lower
// than the wall, slabs spanning every room, furniture), checked against what was modelled.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include "modrt/precompute/level_build.h"
#include "modrt/precompute/scene_import.h"

namespace modrt::precompute {
namespace {

// A closed box [lo, hi] with outward faces (two triangles per side).
void add_box(ImportObject& o, const glm::dvec3& lo, const glm::dvec3& hi) {
  const std::uint32_t base = std::uint32_t(o.positions.size());
  for (int c = 0; c < 8; ++c)
    o.positions.push_back({(c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z});
  // Quads (corner indices, counter-clockwise seen from outside).
  const int quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads)
    for (int t : {0, 1, 2, 0, 2, 3}) o.indices.push_back(base + std::uint32_t(q[t]));
}

ImportObject box_object(const std::string& name, const glm::dvec3& lo, const glm::dvec3& hi,
                        glm::dvec3 albedo) {
  ImportObject o;
  o.name = name;
  add_box(o, lo, hi);
  o.triangle_albedo = {albedo};
  return o;
}

// Two rooms side by side along x: A = [0, 5] x [0, 5], B = [5, 7.5] x [0, 5] (to the wall
// mid-planes), 2.5 m high, walls 0.15 m thick; a 1 x 2.1 m doorway in the wall between them
// at z in [2, 3]; a red wall panel on A's west wall; a 2 x 0.8 x 1 m sofa in A.
struct TwoRooms {
  std::vector<ImportObject> objects;
  int red_wall = -1, sofa = -1, partition = -1;
};

TwoRooms two_rooms() {
  const double t = 0.075, h = 2.5;
  const glm::dvec3 grey(0.6), red(0.7, 0.1, 0.1);
  TwoRooms s;
  s.objects.push_back(box_object("floor", {-t, -0.1, -t}, {7.5 + t, 0.0, 5 + t}, grey));
  s.objects.push_back(box_object("ceiling", {-t, h, -t}, {7.5 + t, h + 0.1, 5 + t}, grey));
  s.objects.push_back(box_object("south wall", {-t, 0, -t}, {7.5 + t, h, t}, grey));
  s.objects.push_back(box_object("north wall", {-t, 0, 5 - t}, {7.5 + t, h, 5 + t}, grey));
  s.red_wall = int(s.objects.size());
  s.objects.push_back(box_object("west wall", {-t, 0, t}, {t, h, 5 - t}, red));
  s.objects.push_back(box_object("east wall", {7.5 - t, 0, t}, {7.5 + t, h, 5 - t}, grey));
  // The partition, as three boxes around the doorway.
  ImportObject partition;
  partition.name = "partition";
  add_box(partition, {5 - t, 0, t}, {5 + t, h, 2.0});
  add_box(partition, {5 - t, 0, 3.0}, {5 + t, h, 5 - t});
  add_box(partition, {5 - t, 2.1, 2.0}, {5 + t, h, 3.0});
  partition.triangle_albedo = {grey};
  s.partition = int(s.objects.size());
  s.objects.push_back(partition);
  s.sofa = int(s.objects.size());
  s.objects.push_back(box_object("sofa", {1.5, 0.0, 3.5}, {3.5, 0.8, 4.5}, glm::dvec3(0.2, 0.3, 0.6)));
  return s;
}

// Level block whose box contains plan point (x, z), or -1.
int block_at(const LevelDescription& level, double x, double z) {
  for (std::size_t b = 0; b < level.blocks.size(); ++b) {
    const auto& c = level.blocks[b].corners;
    if (x > c[0].x && x < c[7].x && z > c[0].z && z < c[7].z) return int(b);
  }
  return -1;
}

TEST(SceneImport, TwoRoomsWithADoorway) {
  const TwoRooms scene = two_rooms();
  Result<SceneImport> r = import_scene(scene.objects, {});
  ASSERT_TRUE(r.ok()) << r.status().message();
  const SceneImport& s = r.value();
  ASSERT_EQ(s.rooms.size(), 2u);
  for (const ImportedRoom& room : s.rooms) {
    EXPECT_NEAR(room.floor, 0.0, 1e-9);
    EXPECT_NEAR(room.ceiling, 2.5, 1e-9);
  }
  // The proxy walls run through the 0.15 m walls' mid-planes: 0.075 m behind the surfaces,
  // plus up to three cells (the raster takes every cell a wall face touches, and one of slack).
  EXPECT_GE(s.plan.proxy_depth, 0.075 - s.plan.cell);
  EXPECT_LE(s.plan.proxy_depth, 0.075 + 3.0 * s.plan.cell + 1e-9);
  // One doorway, between the two rooms, with its jambs, sill and head within two plan cells.
  ASSERT_EQ(s.openings.size(), 1u) << s.openings.size();
  const ImportedOpening& door = s.openings[0];
  const double tol = 2.0 * s.plan.cell + 1e-9;
  EXPECT_EQ(door.kind, OpeningKind::doorway);
  EXPECT_EQ(door.normal_axis, 0);
  EXPECT_NEAR(door.position, 5.0, tol);
  EXPECT_NEAR(door.span_min, 2.0, tol);
  EXPECT_NEAR(door.span_max, 3.0, tol);
  EXPECT_NEAR(door.sill, 0.0, 2.5 / 24.0 + 1e-9);
  EXPECT_NEAR(door.head, 2.1, 2.5 / 24.0 + 1e-9);
  EXPECT_TRUE(door.removes_face);

  const LevelDescription& level = s.level;
  ASSERT_TRUE(build_level_layout(level, 4).ok());
  // Blocks tile the two rooms to the wall mid-planes: total plan area 7.5 x 5.
  double area = 0.0;
  for (const BlockDescription& b : level.blocks) {
    const glm::dvec3 lo = b.corners[0], hi = b.corners[7];
    area += (hi.x - lo.x) * (hi.z - lo.z);
    EXPECT_NEAR(lo.y, 0.0, 1e-9);
    EXPECT_NEAR(hi.y, 2.5, 1e-9);
    // Within the aspect bound.
    const double e[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    EXPECT_LE(*std::max_element(e, e + 3) / *std::min_element(e, e + 3), 3.5 + 1e-9) << b.name;
  }
  EXPECT_NEAR(area, 37.5, 0.05 * 37.5);
  // The doorway is the whole face shared by the two blocks on either side of it; the rest of
  // the partition is wall on both sides.
  const int a_door = block_at(level, 4.9, 2.5), b_door = block_at(level, 5.1, 2.5);
  ASSERT_GE(a_door, 0);
  ASSERT_GE(b_door, 0);
  EXPECT_FALSE(face_present(level.blocks[std::size_t(a_door)].faces, kFacePosX));
  EXPECT_FALSE(face_present(level.blocks[std::size_t(b_door)].faces, kFaceNegX));
  EXPECT_NEAR(level.blocks[std::size_t(a_door)].corners[0].z, 2.0, tol);
  EXPECT_NEAR(level.blocks[std::size_t(a_door)].corners[7].z, 3.0, tol);
  for (double z : {0.5, 4.5}) {
    const int a = block_at(level, 4.9, z), b = block_at(level, 5.1, z);
    ASSERT_GE(a, 0);
    ASSERT_GE(b, 0);
    EXPECT_TRUE(face_present(level.blocks[std::size_t(a)].faces, kFacePosX));
    EXPECT_TRUE(face_present(level.blocks[std::size_t(b)].faces, kFaceNegX));
  }
  // Inside a room, blocks are joined; outer walls, floors and ceilings are present.
  const int a0 = block_at(level, 1.0, 1.0), a1 = block_at(level, 1.0, 4.5);
  ASSERT_GE(a0, 0);
  ASSERT_NE(a0, a1);
  EXPECT_FALSE(face_present(level.blocks[std::size_t(a0)].faces, kFacePosZ));
  EXPECT_TRUE(face_present(level.blocks[std::size_t(a0)].faces, kFaceNegX));
  EXPECT_TRUE(face_present(level.blocks[std::size_t(a0)].faces, kFaceNegZ));

  // The sofa is clutter; walls, floor and ceiling are structure.
  EXPECT_EQ(s.object_role[std::size_t(scene.sofa)], ObjectRole::clutter);
  for (int o = 0; o < int(scene.objects.size()); ++o) {
    if (o != scene.sofa) {
      EXPECT_EQ(s.object_role[std::size_t(o)], ObjectRole::structure) << scene.objects[std::size_t(o)].name;
    }
  }
  // Per-face albedo from the geometry: the west wall is red, the floor grey.
  EXPECT_NEAR(level.blocks[std::size_t(a0)].albedo[kFaceNegX].r, 0.7, 0.02);
  EXPECT_NEAR(level.blocks[std::size_t(a0)].albedo[kFaceNegX].g, 0.1, 0.02);
  EXPECT_NEAR(level.blocks[std::size_t(a0)].albedo[kFaceNegY].g, 0.6, 0.02);
  // Box walls as modelled face out of the wall: the faces toward the rooms face the rooms.
  EXPECT_EQ(s.triangles_flipped, 0u);
}

TEST(SceneImport, InvertedWindingIsFoundAndChangesNothing) {
  const TwoRooms scene = two_rooms();
  std::vector<ImportObject> flipped = scene.objects;
  std::size_t inverted = 0;
  for (int o : {scene.red_wall, scene.partition}) {
    std::vector<std::uint32_t>& idx = flipped[std::size_t(o)].indices;
    for (std::size_t t = 0; t < idx.size(); t += 3) std::swap(idx[t + 1], idx[t + 2]);
  }
  Result<SceneImport> a = import_scene(scene.objects, {}), b = import_scene(flipped, {});
  ASSERT_TRUE(a.ok() && b.ok());
  // The inverted objects are found, whole: the faces that border a room decide, the hidden
  // ones (ends, tops under the ceiling) follow them.
  for (int o : {scene.red_wall, scene.partition})
    for (std::uint8_t f : b->flipped[std::size_t(o)]) inverted += f;
  EXPECT_EQ(inverted, scene.objects[std::size_t(scene.red_wall)].indices.size() / 3 +
                          scene.objects[std::size_t(scene.partition)].indices.size() / 3);
  EXPECT_EQ(b->triangles_flipped, inverted);
  ASSERT_EQ(a->level.blocks.size(), b->level.blocks.size());
  for (std::size_t i = 0; i < a->level.blocks.size(); ++i) {
    EXPECT_EQ(a->level.blocks[i].faces, b->level.blocks[i].faces);
    for (int f = 0; f < kFaceCount; ++f)
      EXPECT_NEAR(
          glm::length(a->level.blocks[i].albedo[std::size_t(f)] - b->level.blocks[i].albedo[std::size_t(f)]),
          0.0, 1e-9);
  }
}

// A wall box between plan points a and b (0.15 m thick, 2.5 m high), any direction.
void add_wall(ImportObject& o, glm::dvec2 a, glm::dvec2 b) {
  const glm::dvec2 d = glm::normalize(b - a), n(-d.y * 0.075, d.x * 0.075);
  const glm::dvec2 p[4] = {a - n, b - n, b + n, a + n};
  const std::uint32_t base = std::uint32_t(o.positions.size());
  for (int c = 0; c < 8; ++c) o.positions.push_back({p[c % 4].x, c < 4 ? 0.0 : 2.5, p[c % 4].y});
  // Bottom, top and four sides; the winding does not matter here (a closed box of either).
  const int quads[6][4] = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1},
                           {1, 5, 6, 2}, {2, 6, 7, 3}, {3, 7, 4, 0}};
  for (const auto& q : quads)
    for (int t : {0, 1, 2, 0, 2, 3}) o.indices.push_back(base + std::uint32_t(q[t]));
}

TEST(SceneImport, SlantedWallIsFollowedByWarpedBlocks) {
  // A 6 x 3 room whose corner at the origin is cut at 45 degrees from (1.5, 0) to (0, 1.5).
  std::vector<ImportObject> objects;
  objects.push_back(box_object("floor", {-0.1, -0.1, -0.1}, {6.1, 0.0, 3.1}, glm::dvec3(0.5)));
  objects.push_back(box_object("ceiling", {-0.1, 2.5, -0.1}, {6.1, 2.6, 3.1}, glm::dvec3(0.8)));
  ImportObject walls;
  walls.name = "walls";
  const glm::dvec2 outline[5] = {{1.5, 0}, {6, 0}, {6, 3}, {0, 3}, {0, 1.5}};
  for (int e = 0; e < 5; ++e) add_wall(walls, outline[e], outline[(e + 1) % 5]);
  walls.triangle_albedo = {glm::dvec3(0.6)};
  objects.push_back(walls);
  Result<SceneImport> r = import_scene(objects, {});
  ASSERT_TRUE(r.ok()) << r.status().message();
  ASSERT_EQ(r->rooms.size(), 1u);
  ASSERT_TRUE(build_level_layout(r->level, 4).ok());
  // The blocks cover the room (to the walls' centre lines: 18 - 1.125 m^2) and none reaches
  // past the slanted wall by more than a plan cell or two.
  double area = 0.0;
  const double tol = 2.0 * r->plan.cell + 1e-9;
  bool on_slant = false;
  for (const BlockDescription& b : r->level.blocks) {
    const auto& c = b.corners;
    const glm::dvec2 q[4] = {{c[0].x, c[0].z}, {c[1].x, c[1].z}, {c[5].x, c[5].z}, {c[4].x, c[4].z}};
    for (int k = 0; k < 4; ++k) {
      area += 0.5 * (q[k].x * q[(k + 1) % 4].y - q[(k + 1) % 4].x * q[k].y);
      EXPECT_GE(q[k].x + q[k].y, 1.5 - tol) << b.name << " corner " << k;
      if (std::abs(q[k].x + q[k].y - 1.5) < tol && q[k].x > 0.3 && q[k].x < 1.2) on_slant = true;
    }
  }
  EXPECT_NEAR(std::abs(area), 18.0 - 1.125, 0.03 * 16.875);
  EXPECT_TRUE(on_slant) << "no block corner was moved onto the slanted wall";
}

TEST(SceneImport, BadInputIsRefusedByName) {
  TwoRooms scene = two_rooms();
  scene.objects[3].positions[2].y = std::nan("");
  Result<SceneImport> r = import_scene(scene.objects, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("'north wall'"), std::string::npos) << r.status().message();
  EXPECT_NE(r.status().message().find("position 2"), std::string::npos) << r.status().message();

  scene = two_rooms();
  scene.objects[0].indices[5] = 99;
  r = import_scene(scene.objects, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("index 5"), std::string::npos) << r.status().message();

  scene = two_rooms();
  scene.objects[1].triangle_albedo = {glm::dvec3(1.5)};
  r = import_scene(scene.objects, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("outside [0, 1]"), std::string::npos);

  // A lone box encloses nothing wider than a room.
  std::vector<ImportObject> lone = {box_object("crate", {0, 0, 0}, {0.5, 0.5, 0.5}, glm::dvec3(0.5))};
  r = import_scene(lone, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("no enclosed room"), std::string::npos) << r.status().message();
}

}  // namespace
}  // namespace modrt::precompute
