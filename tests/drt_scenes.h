// SPDX-License-Identifier: MIT
// Clutter set-ups shared by test_drt and bench_drt (DRT, [Loos et al. 2012]): the paper's
// Figure 1 box room with two boxes, a corridor whose middle block holds four pillars, and an
// L of three blocks with one box.
#pragma once

#include <initializer_list>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "modrt/drt.h"
#include "modrt/level_description.h"

namespace modrt::test {

inline glm::dmat3 rotation_y(double degrees) {
  return glm::dmat3(glm::rotate(glm::dmat4(1.0), glm::radians(degrees), glm::dvec3(0, 1, 0)));
}

inline FaceMask without(FaceMask mask, std::initializer_list<int> faces) {
  for (int f : faces) mask = FaceMask(mask & ~(1u << f));
  return mask;
}

struct ClutterScene {
  LevelDescription description;
  std::vector<ClutterObject> clutter;
};

// The paper's Figure 1: a closed room, a light under the ceiling, two boxes on the floor.
inline ClutterScene box_room_two_boxes() {
  ClutterScene s;
  BlockDescription b;
  b.faces = kAllFaces;
  b.albedo = {glm::dvec3(0.7, 0.3, 0.3), glm::dvec3(0.3, 0.6, 0.3), glm::dvec3(0.6),
              glm::dvec3(0.6),           glm::dvec3(0.6),           glm::dvec3(0.6)};
  s.description.blocks = {b};
  LightDescription light;
  light.position = glm::dvec3(0.5, 0.85, 0.5);
  light.radius = 0.05;
  s.description.lights = {light};
  ClutterObject a;
  a.box.center = glm::dvec3(0.3, 0.17, 0.32);
  a.box.half_extent = glm::dvec3(0.13, 0.17, 0.13);
  a.faces = without(kAllFaces, {kFaceNegY});  // resting on the floor
  a.albedo = glm::dvec3(0.8, 0.8, 0.3);
  ClutterObject c;
  c.box.center = glm::dvec3(0.68, 0.25, 0.64);
  c.box.half_extent = glm::dvec3(0.11, 0.25, 0.15);
  c.box.rotation = rotation_y(30.0);
  c.faces = without(kAllFaces, {kFaceNegY});
  c.albedo = glm::dvec3(0.3, 0.5, 0.8);
  s.clutter = {a, c};
  return s;
}

// A corridor of three blocks; the middle one holds four floor-to-ceiling pillars around
// its light, so their shadows fall in it and, through the openings, on its neighbours.
inline ClutterScene maze_block_four_pillars() {
  ClutterScene s;
  for (int x = 0; x < 3; ++x) {
    BlockDescription b;
    b.cell = glm::ivec3(x, 0, 0);
    b.faces = kAllFaces;
    if (x > 0) b.faces = without(b.faces, {kFaceNegX});
    if (x < 2) b.faces = without(b.faces, {kFacePosX});
    for (auto& a : b.albedo) a = glm::dvec3(0.6);
    b.albedo[kFaceNegZ] = glm::dvec3(0.7, 0.4, 0.3);
    s.description.blocks.push_back(b);
  }
  LightDescription light;
  light.position = glm::dvec3(1.5, 0.7, 0.5);
  light.radius = 0.05;
  s.description.lights = {light};
  for (const glm::dvec2 p :
       {glm::dvec2(1.3, 0.3), glm::dvec2(1.7, 0.3), glm::dvec2(1.3, 0.7), glm::dvec2(1.7, 0.7)}) {
    ClutterObject pillar;
    pillar.block = 1;
    pillar.box.center = glm::dvec3(p.x, 0.5, p.y);
    pillar.box.half_extent = glm::dvec3(0.06, 0.5, 0.06);
    pillar.faces = without(kAllFaces, {kFaceNegY, kFacePosY});
    pillar.albedo = glm::dvec3(0.75);
    s.clutter.push_back(pillar);
  }
  return s;
}

// An L of three blocks (the corner turns from +X to +Z) with a box in the first block:
// walls round the corner face away from it.
inline ClutterScene l_shaped_level_with_a_box() {
  ClutterScene s;
  const glm::ivec3 cells[3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}};
  const std::initializer_list<int> open[3] = {{kFacePosX}, {kFaceNegX, kFacePosZ}, {kFaceNegZ}};
  for (int k = 0; k < 3; ++k) {
    BlockDescription b;
    b.cell = cells[k];
    b.faces = without(kAllFaces, open[k]);
    for (auto& a : b.albedo) a = glm::dvec3(0.6);
    s.description.blocks.push_back(b);
  }
  ClutterObject box;
  box.box.center = glm::dvec3(0.5, 0.15, 0.5);
  box.box.half_extent = glm::dvec3(0.1, 0.15, 0.1);
  box.faces = without(kAllFaces, {kFaceNegY});
  s.clutter = {box};
  return s;
}

}  // namespace modrt::test
