// SPDX-License-Identifier: MIT
// modrt — level description helpers and validation (architecture.md §4, MRT §6.2).
#include "modrt/level_description.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <unordered_map>

#include <glm/geometric.hpp>

#include "modrt/light_policy.h"

namespace modrt {
namespace {

// Cells must lie within +-kMaxCell on every axis so that neighbour look-ups cannot
// overflow and a cell packs into a 64-bit hash key (21 bits per axis).
constexpr int kMaxCell = (1 << 20) - 1;

// Direction of each face's outward normal in the grid (cube.h numbering).
constexpr int kFaceStep[kFaceCount][3] = {{-1, 0, 0}, {1, 0, 0},  {0, -1, 0},
                                          {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};

int opposite_face(int face) { return face ^ 1; }

// Canonical corner indices (x + 2y + 4z) lying on face f, listed so that entry k of a face
// and entry k of its opposite face differ only in the face's axis: the corners a pair of
// neighbours share.
constexpr int kFaceCorners[kFaceCount][4] = {
    {0, 2, 4, 6},  // -X: x = 0
    {1, 3, 5, 7},  // +X: x = 1
    {0, 1, 4, 5},  // -Y: y = 0
    {2, 3, 6, 7},  // +Y: y = 1
    {0, 1, 2, 3},  // -Z: z = 0
    {4, 5, 6, 7},  // +Z: z = 1
};

std::uint64_t cell_key(const glm::ivec3& c) {
  const auto pack = [](int v) { return std::uint64_t(std::int64_t(v) + (std::int64_t(1) << 20)); };
  return pack(c.x) | (pack(c.y) << 21) | (pack(c.z) << 42);
}

std::string fmt_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string fmt_vec(const glm::dvec3& v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "(%.9g, %.9g, %.9g)", v.x, v.y, v.z);
  return buf;
}

std::string fmt_cell(const glm::ivec3& c) {
  return std::to_string(c.x) + "," + std::to_string(c.y) + "," + std::to_string(c.z);
}

// `block 3 "hall" (cell 2,0,1)` or `block 4 (cell 3,0,1)`.
std::string block_label(const LevelDescription& level, std::size_t index) {
  const BlockDescription& b = level.blocks[index];
  std::string s = "block " + std::to_string(index);
  if (!b.name.empty()) s += " \"" + b.name + "\"";
  s += " (cell " + fmt_cell(b.cell) + ")";
  return s;
}

std::string corner_label(int corner) {
  return "corner " + std::to_string(corner) + " (" + std::to_string(corner & 1) + "," +
         std::to_string((corner >> 1) & 1) + "," + std::to_string((corner >> 2) & 1) + ")";
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

Status fail(std::string message) { return Status::error(ErrorCode::invalid_argument, std::move(message)); }

// Determinant of the Jacobian of the trilinear map at p.
double trilinear_jacobian_det(const std::array<glm::dvec3, 8>& c, const glm::dvec3& p) {
  const double x = p.x, y = p.y, z = p.z;
  const glm::dvec3 dx = (1 - y) * (1 - z) * (c[1] - c[0]) + y * (1 - z) * (c[3] - c[2]) +
                        (1 - y) * z * (c[5] - c[4]) + y * z * (c[7] - c[6]);
  const glm::dvec3 dy = (1 - x) * (1 - z) * (c[2] - c[0]) + x * (1 - z) * (c[3] - c[1]) +
                        (1 - x) * z * (c[6] - c[4]) + x * z * (c[7] - c[5]);
  const glm::dvec3 dz = (1 - x) * (1 - y) * (c[4] - c[0]) + x * (1 - y) * (c[5] - c[1]) +
                        (1 - x) * y * (c[6] - c[2]) + x * y * (c[7] - c[3]);
  return glm::dot(dx, glm::cross(dy, dz));
}

Status check_block(const LevelDescription& level, std::size_t index) {
  const BlockDescription& b = level.blocks[index];
  const auto label = [&] { return block_label(level, index); };

  for (int a = 0; a < 3; ++a) {
    if (b.cell[a] < -kMaxCell || b.cell[a] > kMaxCell)
      return fail(label() + ": cell coordinate " + std::to_string(b.cell[a]) + " is outside [" +
                  std::to_string(-kMaxCell) + ", " + std::to_string(kMaxCell) + "]");
  }
  if (b.faces & ~kAllFaces) {
    char mask[8];
    std::snprintf(mask, sizeof mask, "0x%02x", unsigned(b.faces));
    return fail(label() + ": face mask " + mask + " has bits above face 5 set");
  }
  for (int f : {int(kFaceNegY), int(kFacePosY)}) {
    if (!face_present(b.faces, f))
      return fail(label() + ": the " + (f == kFaceNegY ? "floor" : "ceiling") + " (face " + face_name(f) +
                  ") is missing; the 2D dictionary has no such shape (floor and ceiling must be present)");
  }
  static constexpr const char* kChannel[3] = {"red", "green", "blue"};
  for (int f = 0; f < kFaceCount; ++f) {
    for (int ch = 0; ch < 3; ++ch) {
      const double v = b.albedo[f][ch];
      if (!std::isfinite(v))
        return fail(label() + ": albedo of face " + face_name(f) + " channel " + std::to_string(ch) + " (" +
                    kChannel[ch] + ") is not finite (" + fmt_double(v) + ")");
      if (v < 0.0 || v > 1.0)
        return fail(label() + ": albedo of face " + face_name(f) + " channel " + std::to_string(ch) + " (" +
                    kChannel[ch] + ") is " + fmt_double(v) + ", outside [0, 1]");
    }
  }
  if (b.warped) {
    for (int k = 0; k < 8; ++k) {
      if (!finite(b.corners[k]))
        return fail(label() + ": warp " + corner_label(k) + " is not finite " + fmt_vec(b.corners[k]));
    }
    const std::array<glm::dvec3, 8> grid = grid_cell_corners(b.cell, level.cell_size);
    for (int k = 0; k < 8; ++k) {
      const double offset = glm::length(b.corners[k] - grid[k]);
      if (!(offset <= kMaxWarpOffsetCells * level.cell_size))
        return fail(label() + ": warp " + corner_label(k) + " at " + fmt_vec(b.corners[k]) + " is " +
                    fmt_double(offset) + " from its grid corner " + fmt_vec(grid[k]) + "; at most " +
                    fmt_double(kMaxWarpOffsetCells) +
                    " x cell_size = " + fmt_double(kMaxWarpOffsetCells * level.cell_size) + " is allowed");
    }
    const double s = level.cell_size;
    const double threshold = 1e-6 * s * s * s;
    double worst = 0.0;
    glm::dvec3 worst_at{0.0};
    bool first = true;
    for (int i = 0; i < 27; ++i) {
      const glm::dvec3 p{0.5 * (i % 3), 0.5 * ((i / 3) % 3), 0.5 * (i / 9)};
      const double det = trilinear_jacobian_det(b.corners, p);
      if (first || det < worst) {
        worst = det;
        worst_at = p;
        first = false;
      }
    }
    if (!(worst > threshold)) {
      const bool inverted = worst < -threshold;
      return fail(label() + ": warp is " + (inverted ? "inverted" : "degenerate") +
                  ": the trilinear Jacobian determinant is " + fmt_double(worst) + " at canonical point " +
                  fmt_vec(worst_at) +
                  (inverted ? " (negative: corners swapped or folded over)"
                            : " (~0: corners collapsed onto a plane, line or point)") +
                  "; it must exceed 1e-6 * cell_size^3 = " + fmt_double(threshold) +
                  " on the 3x3x3 lattice (corner index = x + 2y + 4z)");
    }
  }
  return Status::success();
}

}  // namespace

std::array<glm::dvec3, 8> grid_cell_corners(const glm::ivec3& cell, double cell_size) {
  std::array<glm::dvec3, 8> c{};
  for (int k = 0; k < 8; ++k) {
    const glm::dvec3 offset{double(k & 1), double((k >> 1) & 1), double((k >> 2) & 1)};
    c[k] = (glm::dvec3(cell) + offset) * cell_size;
  }
  return c;
}

std::array<glm::dvec3, 8> block_corners(const LevelDescription& level, const BlockDescription& block) {
  return block.warped ? block.corners : grid_cell_corners(block.cell, level.cell_size);
}

glm::dvec3 trilinear(const std::array<glm::dvec3, 8>& c, const glm::dvec3& p) {
  const glm::dvec3 x00 = glm::mix(c[0], c[1], p.x);
  const glm::dvec3 x10 = glm::mix(c[2], c[3], p.x);
  const glm::dvec3 x01 = glm::mix(c[4], c[5], p.x);
  const glm::dvec3 x11 = glm::mix(c[6], c[7], p.x);
  const glm::dvec3 y0 = glm::mix(x00, x10, p.y);
  const glm::dvec3 y1 = glm::mix(x01, x11, p.y);
  return glm::mix(y0, y1, p.z);
}

Result<LevelConnectivity> validate_level(const LevelDescription& level) {
  if (level.version != kLevelFormatVersion)
    return fail("level version " + std::to_string(level.version) +
                " is not supported; this build reads version " + std::to_string(kLevelFormatVersion));
  if (!(level.cell_size >= kMinCellSize && level.cell_size <= kMaxCellSize))
    return fail("cell_size is " + fmt_double(level.cell_size) + "; it must be in [" +
                fmt_double(kMinCellSize) + ", " + fmt_double(kMaxCellSize) + "] (world units per grid cell)");

  for (std::size_t i = 0; i < level.lights.size(); ++i) {
    const LightDescription& l = level.lights[i];
    const std::string label = "light " + std::to_string(i);
    if (!finite(l.position)) return fail(label + ": position " + fmt_vec(l.position) + " is not finite");
    if (!std::isfinite(l.radius) || l.radius < 0.0)
      return fail(label + ": radius " + fmt_double(l.radius) + " must be finite and >= 0");
    if (!finite(l.color) || l.color.x < 0.0 || l.color.y < 0.0 || l.color.z < 0.0)
      return fail(label + ": color " + fmt_vec(l.color) + " must be finite and >= 0");
    if (!std::isfinite(l.intensity) || l.intensity < 0.0)
      return fail(label + ": intensity " + fmt_double(l.intensity) + " must be finite and >= 0");
    // Levels built in code meet the parsers' bounds too (fuzz_settings: colour 6.8e180 gave Inf ld).
    if (!light_brightness_allowed(l.intensity, l.color))
      return fail(label + ": intensity x max(1, color) = " +
                  fmt_double(l.intensity * std::max({1.0, l.color.x, l.color.y, l.color.z})) + " exceeds " +
                  fmt_double(kMaxLightIntensity) + " (kMaxLightIntensity, light_policy.h)");
    if (!light_in_reach(l.position, l.radius))
      return fail(label + ": position " + fmt_vec(l.position) + " with radius " + fmt_double(l.radius) +
                  " is beyond the traceable range (light_policy.h)");
  }

  const std::size_t n = level.blocks.size();
  if (n > std::size_t(1) << 30) return fail("too many blocks (" + std::to_string(n) + ")");
  std::unordered_map<std::uint64_t, int> by_cell;
  by_cell.reserve(n * 2);
  for (std::size_t i = 0; i < n; ++i) {
    if (Status s = check_block(level, i); !s.ok()) return s;
    const auto [it, inserted] = by_cell.emplace(cell_key(level.blocks[i].cell), int(i));
    if (!inserted)
      return fail(block_label(level, i) + " overlaps " + block_label(level, std::size_t(it->second)) +
                  ": two blocks in the same grid cell");
  }

  LevelConnectivity conn;
  conn.neighbour.assign(n, {-1, -1, -1, -1, -1, -1});
  conn.connected.assign(n, {false, false, false, false, false, false});
  const double tolerance = 1e-9 * level.cell_size;
  for (std::size_t i = 0; i < n; ++i) {
    const BlockDescription& a = level.blocks[i];
    for (int f = 0; f < kFaceCount; ++f) {
      const glm::ivec3 nc = a.cell + glm::ivec3(kFaceStep[f][0], kFaceStep[f][1], kFaceStep[f][2]);
      const auto it = by_cell.find(cell_key(nc));
      if (it == by_cell.end()) continue;  // a missing face here opens onto empty space
      const std::size_t j = std::size_t(it->second);
      const BlockDescription& b = level.blocks[j];
      const int g = opposite_face(f);
      conn.neighbour[i][f] = int(j);
      const bool a_missing = !face_present(a.faces, f);
      const bool b_missing = !face_present(b.faces, g);
      if (a_missing != b_missing) {
        const std::size_t m = a_missing ? i : j, p = a_missing ? j : i;
        const int mf = a_missing ? f : g, pf = a_missing ? g : f;
        return fail(block_label(level, m) + ": face " + face_name(mf) + " is missing but " +
                    block_label(level, p) + " has its " + face_name(pf) +
                    " face present (a shared face must be missing on both sides or "
                    "present on both)");
      }
      conn.connected[i][f] = a_missing && b_missing;
      // Shared corners: checked once per pair (from the lower index) when either is warped.
      if (j < i || !(a.warped || b.warped)) continue;
      const auto ca = block_corners(level, a);
      const auto cb = block_corners(level, b);
      std::string bad;
      for (int k = 0; k < 4; ++k) {
        const int ka = kFaceCorners[f][k], kb = kFaceCorners[g][k];
        const glm::dvec3 d = glm::abs(ca[ka] - cb[kb]);
        if (!(d.x <= tolerance && d.y <= tolerance && d.z <= tolerance)) {
          if (!bad.empty()) bad += "; ";
          bad += corner_label(ka) + " of block " + std::to_string(i) + " is " + fmt_vec(ca[ka]) + " but " +
                 corner_label(kb) + " of block " + std::to_string(j) + " is " + fmt_vec(cb[kb]);
        }
      }
      if (!bad.empty())
        return fail(block_label(level, i) + " and " + block_label(level, j) +
                    ": warped corners of the shared face (" + face_name(f) + " of block " +
                    std::to_string(i) + " / " + face_name(g) + " of block " + std::to_string(j) +
                    ") disagree (tolerance " + fmt_double(tolerance) + "): " + bad);
    }
  }
  return conn;
}

}  // namespace modrt
