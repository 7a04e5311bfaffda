// SPDX-License-Identifier: MIT
// modrt demo — DRT clutter objects made in code (the built-in scene, tests): a closed prism
// over a polygon, with lightmap UVs laid out one chart per side and per cap (each in its own
// tile of a square grid, inset so that charts never share an atlas cell), added both as a
// ClutterObject (precompute::make_mesh_clutter) and as the Mesh that draws it. The same
// layout as scripts/make_clutter_gltf.py writes into data/scenes/clutter_room.gltf.
#pragma once

#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "demo_scene.h"
#include "modrt/status.h"

namespace modrt::demo {

struct ClutterPrism {
  std::string name;
  // Footprint (x, z), counter-clockwise seen with x right and z up (positive signed area), and
  // the triangles covering it (indices into polygon) without T-junctions.
  std::vector<glm::dvec2> polygon;
  std::vector<int> cap_triangles;
  double y0 = 0.0, y1 = 1.0;
  int block = 0;
  int material = 0;  // index into DemoScene::materials; its base colour is the albedo
  int res = 48;      // atlas edge in texels
};

// Appends the object to scene.clutter and its mesh (Mesh::clutter set, flat normals) to
// scene.meshes. Fails as make_mesh_clutter does (naming the prism), or on a bad polygon.
Status add_clutter_prism(DemoScene& scene, const ClutterPrism& prism);

}  // namespace modrt::demo
