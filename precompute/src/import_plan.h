// SPDX-License-Identifier: MIT
// modrt precompute (private) — the plan of a storey for scene_import.cpp: horizontal cuts of
// the triangles rasterised on a grid, the rooms and walls of the plan, the rooms' floor and
// ceiling heights, and the openings through the walls (steps 1-3 of scene_import.h).
#pragma once

#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "modrt/precompute/scene_import.h"

namespace modrt::precompute::import_detail {

// All static triangles of the scene, flattened.
struct TriangleSoup {
  std::vector<glm::dvec3> a, b, c;
  std::vector<std::uint32_t> object;  // input object of each triangle
  std::vector<std::uint32_t> local;   // its index within that object
  glm::dvec3 min{0.0}, max{0.0};
  std::size_t size() const { return a.size(); }
};

struct PlanGrid {
  glm::dvec2 origin{0.0};
  double cell = 1.0;
  int width = 0, height = 0;
  std::size_t index(int i, int k) const { return std::size_t(k) * std::size_t(width) + std::size_t(i); }
  std::size_t count() const { return std::size_t(width) * std::size_t(height); }
  glm::dvec2 centre(int i, int k) const { return origin + cell * glm::dvec2(i + 0.5, k + 0.5); }
  // Cell containing plan point p (clamped to the grid).
  void locate(const glm::dvec2& p, int& i, int& k) const;
};

// Cells crossed by the cut of the triangles at height y (1), exactly (grid traversal of each
// cut segment, so a wall's outline is 4-connected and regions cannot leak through it).
std::vector<std::uint8_t> cut_plan(const TriangleSoup& tris, const PlanGrid& grid, double y);

// The height of the plan cut: where the near-vertical geometry's cross-section is longest in
// the upper half of the scene (above door and window heads, below the ceilings).
double choose_cut_height(const TriangleSoup& tris);

// Rooms, outside and walls of the plan at the cut (ImportPlan::label and ::wall); returns the
// number of rooms.
int classify_plan(const TriangleSoup& tris, const PlanGrid& grid, const ImportSettings& settings,
                  ImportPlan& plan);

// Vertical rays: the triangles bucketed by their plan bounds.
class VerticalRays {
 public:
  VerticalRays(const TriangleSoup& tris, double bucket);
  // Height of the first surface below (down) or above (!down) (x, y, z); false on a miss.
  bool cast(const glm::dvec3& origin, bool down, double& hit_y) const;

 private:
  const TriangleSoup& tris_;
  glm::dvec2 origin_{0.0};
  double bucket_ = 1.0;
  int width_ = 0, height_ = 0;
  std::vector<std::vector<std::uint32_t>> cells_;
};

// Measured floor and ceiling per room (ImportedRoom::measured_*, area and bounds); warnings
// for rooms without a floor or ceiling under or over most of them.
void measure_rooms(const TriangleSoup& tris, const ImportPlan& plan, int room_count,
                   std::vector<ImportedRoom>& rooms, std::vector<std::string>& warnings);

// Openings through the plan's walls between rooms or to the outside, from cuts every
// `step` metres between the lowest floor and the plan cut.
std::vector<ImportedOpening> find_openings(const TriangleSoup& tris, const ImportPlan& plan,
                                           const std::vector<ImportedRoom>& rooms, double step,
                                           std::vector<std::string>& warnings);

}  // namespace modrt::precompute::import_detail
