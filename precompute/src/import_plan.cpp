// SPDX-License-Identifier: MIT
#include "import_plan.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <set>
#include <string>

#include <glm/geometric.hpp>

namespace modrt::precompute::import_detail {

void PlanGrid::locate(const glm::dvec2& p, int& i, int& k) const {
  const glm::dvec2 t = (p - origin) / cell;
  i = std::clamp(int(std::floor(t.x)), 0, width - 1);
  k = std::clamp(int(std::floor(t.y)), 0, height - 1);
}

namespace {

// The segment where triangle (a, b, c) crosses the plane y = h, as plan points; false when it
// does not cross (a triangle lying in the plane is not cut: h never equals a vertex height
// in practice, the callers nudge it).
bool cut_segment(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, double h, glm::dvec2& p,
                 glm::dvec2& q) {
  const std::array<glm::dvec3, 3> v = {a, b, c};
  glm::dvec2 pts[3];
  int n = 0;
  for (int e = 0; e < 3; ++e) {
    const glm::dvec3& s = v[std::size_t(e)];
    const glm::dvec3& t = v[std::size_t((e + 1) % 3)];
    if ((s.y < h) == (t.y < h)) continue;
    const double w = (h - s.y) / (t.y - s.y);
    pts[n++] = glm::dvec2(s.x + w * (t.x - s.x), s.z + w * (t.z - s.z));
  }
  if (n != 2) return false;
  p = pts[0];
  q = pts[1];
  return true;
}

// Marks every cell the segment p-q passes through (Amanatides & Woo traversal).
void mark_segment(const PlanGrid& grid, const glm::dvec2& p, const glm::dvec2& q,
                  std::vector<std::uint8_t>& out) {
  const glm::dvec2 a = (p - grid.origin) / grid.cell, b = (q - grid.origin) / grid.cell;
  int i = int(std::floor(a.x)), k = int(std::floor(a.y));
  const int i_end = int(std::floor(b.x)), k_end = int(std::floor(b.y));
  const glm::dvec2 d = b - a;
  const int si = d.x > 0 ? 1 : -1, sk = d.y > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double dx = d.x != 0.0 ? std::abs(1.0 / d.x) : inf, dk = d.y != 0.0 ? std::abs(1.0 / d.y) : inf;
  double tx = d.x != 0.0 ? ((si > 0 ? std::floor(a.x) + 1.0 - a.x : a.x - std::floor(a.x)) * dx) : inf;
  double tk = d.y != 0.0 ? ((sk > 0 ? std::floor(a.y) + 1.0 - a.y : a.y - std::floor(a.y)) * dk) : inf;
  const int steps = std::abs(i_end - i) + std::abs(k_end - k);
  for (int s = 0; s <= steps; ++s) {
    if (i >= 0 && k >= 0 && i < grid.width && k < grid.height) out[grid.index(i, k)] = 1;
    if (tx < tk) {
      tx += dx;
      i += si;
    } else {
      tk += dk;
      k += sk;
    }
  }
}

// 4-connected components of the cells where `in` is true; returns the count, labels -1 elsewhere.
int components(const PlanGrid& grid, const std::vector<std::uint8_t>& in, std::vector<int>& label) {
  label.assign(grid.count(), -1);
  int count = 0;
  std::vector<std::size_t> stack;
  for (std::size_t s = 0; s < grid.count(); ++s) {
    if (!in[s] || label[s] >= 0) continue;
    label[s] = count;
    stack.push_back(s);
    while (!stack.empty()) {
      const std::size_t c = stack.back();
      stack.pop_back();
      const int i = int(c % std::size_t(grid.width)), k = int(c / std::size_t(grid.width));
      const int ni[4] = {i - 1, i + 1, i, i}, nk[4] = {k, k, k - 1, k + 1};
      for (int e = 0; e < 4; ++e) {
        if (ni[e] < 0 || nk[e] < 0 || ni[e] >= grid.width || nk[e] >= grid.height) continue;
        const std::size_t n = grid.index(ni[e], nk[e]);
        if (in[n] && label[n] < 0) {
          label[n] = count;
          stack.push_back(n);
        }
      }
    }
    ++count;
  }
  return count;
}

// Chessboard distance (cells) from every cell to the nearest cell where `source` is set.
std::vector<int> distance_to(const PlanGrid& grid, const std::vector<std::uint8_t>& source) {
  std::vector<int> dist(grid.count(), std::numeric_limits<int>::max());
  std::deque<std::size_t> queue;
  for (std::size_t s = 0; s < grid.count(); ++s)
    if (source[s]) {
      dist[s] = 0;
      queue.push_back(s);
    }
  while (!queue.empty()) {
    const std::size_t c = queue.front();
    queue.pop_front();
    const int i = int(c % std::size_t(grid.width)), k = int(c / std::size_t(grid.width));
    for (int dk = -1; dk <= 1; ++dk)
      for (int di = -1; di <= 1; ++di) {
        const int ni = i + di, nk = k + dk;
        if (ni < 0 || nk < 0 || ni >= grid.width || nk >= grid.height) continue;
        const std::size_t n = grid.index(ni, nk);
        if (dist[n] > dist[c] + 1) {
          dist[n] = dist[c] + 1;
          queue.push_back(n);
        }
      }
  }
  return dist;
}

glm::dvec3 unit_normal(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double l = glm::length(n);
  return l > 0.0 ? n / l : glm::dvec3(0.0);
}

}  // namespace

std::vector<std::uint8_t> cut_plan(const TriangleSoup& tris, const PlanGrid& grid, double y) {
  std::vector<std::uint8_t> out(grid.count(), 0);
  glm::dvec2 p, q;
  for (std::size_t t = 0; t < tris.size(); ++t)
    if (cut_segment(tris.a[t], tris.b[t], tris.c[t], y, p, q)) mark_segment(grid, p, q, out);
  return out;
}

double choose_cut_height(const TriangleSoup& tris) {
  const double lo = tris.min.y + 0.5 * (tris.max.y - tris.min.y), hi = tris.max.y;
  constexpr int kCandidates = 48;
  std::vector<double> length(kCandidates, 0.0), height(kCandidates);
  // Nudged off round heights, so that the cut does not run exactly through modelled edges.
  for (int c = 0; c < kCandidates; ++c) height[std::size_t(c)] = lo + (hi - lo) * (c + 0.5137) / kCandidates;
  glm::dvec2 p, q;
  for (std::size_t t = 0; t < tris.size(); ++t) {
    if (std::abs(unit_normal(tris.a[t], tris.b[t], tris.c[t]).y) > 0.3) continue;
    for (int c = 0; c < kCandidates; ++c)
      if (cut_segment(tris.a[t], tris.b[t], tris.c[t], height[std::size_t(c)], p, q))
        length[std::size_t(c)] += glm::length(q - p);
  }
  const double best = *std::max_element(length.begin(), length.end());
  // The middle of the candidates within 2 % of the longest cut: a plateau between the openings'
  // heads and the ceiling.
  std::vector<double> plateau;
  for (int c = 0; c < kCandidates; ++c)
    if (length[std::size_t(c)] >= 0.98 * best) plateau.push_back(height[std::size_t(c)]);
  return plateau[plateau.size() / 2];
}

int classify_plan(const TriangleSoup& tris, const PlanGrid& grid, const ImportSettings& settings,
                  ImportPlan& plan) {
  const std::vector<std::uint8_t> solid = cut_plan(tris, grid, plan.cut_height);
  std::vector<std::uint8_t> empty(grid.count());
  for (std::size_t s = 0; s < grid.count(); ++s) empty[s] = !solid[s];
  std::vector<int> comp;
  const int n = components(grid, empty, comp);
  // Outside: the components touching the raster's border (the raster has a margin of empty cells).
  std::vector<std::uint8_t> outside(std::size_t(n), 0);
  for (int i = 0; i < grid.width; ++i)
    for (int k : {0, grid.height - 1})
      if (comp[grid.index(i, k)] >= 0) outside[std::size_t(comp[grid.index(i, k)])] = 1;
  for (int k = 0; k < grid.height; ++k)
    for (int i : {0, grid.width - 1})
      if (comp[grid.index(i, k)] >= 0) outside[std::size_t(comp[grid.index(i, k)])] = 1;
  // Rooms: the enclosed components wide enough (inscribed radius) to stand in.
  const std::vector<int> dist = distance_to(grid, solid);
  std::vector<int> radius(std::size_t(n), 0);
  for (std::size_t s = 0; s < grid.count(); ++s)
    if (comp[s] >= 0) radius[std::size_t(comp[s])] = std::max(radius[std::size_t(comp[s])], dist[s]);
  const int min_radius = std::max(1, int(std::ceil(0.5 * settings.min_room_width / grid.cell)));
  std::vector<int> room_of(std::size_t(n), kPlanSolid);
  int rooms = 0;
  // Rooms numbered in raster order of their first cell, so the numbering is deterministic.
  for (std::size_t s = 0; s < grid.count(); ++s) {
    const int c = comp[s];
    if (c < 0 || room_of[std::size_t(c)] != kPlanSolid) continue;
    if (outside[std::size_t(c)])
      room_of[std::size_t(c)] = kPlanOutside;
    else if (radius[std::size_t(c)] >= min_radius)
      room_of[std::size_t(c)] = rooms++;
    else
      room_of[std::size_t(c)] = kPlanSolid - 1;  // thin pocket: solid, marked visited
  }
  plan.label.assign(grid.count(), kPlanSolid);
  for (std::size_t s = 0; s < grid.count(); ++s)
    if (comp[s] >= 0 && room_of[std::size_t(comp[s])] >= kPlanOutside)
      plan.label[s] = room_of[std::size_t(comp[s])];
  // What a single room encloses (a column, a lamp, furniture cut by the plane) is that room's.
  std::vector<std::uint8_t> rest(grid.count());
  for (std::size_t s = 0; s < grid.count(); ++s) rest[s] = plan.label[s] == kPlanSolid;
  std::vector<int> rest_comp;
  const int rn = components(grid, rest, rest_comp);
  std::vector<std::set<int>> touches(static_cast<std::size_t>(rn));
  for (std::size_t s = 0; s < grid.count(); ++s) {
    if (rest_comp[s] < 0) continue;
    const int i = int(s % std::size_t(grid.width)), k = int(s / std::size_t(grid.width));
    const int ni[4] = {i - 1, i + 1, i, i}, nk[4] = {k, k, k - 1, k + 1};
    for (int e = 0; e < 4; ++e) {
      if (ni[e] < 0 || nk[e] < 0 || ni[e] >= grid.width || nk[e] >= grid.height) continue;
      const int l = plan.label[grid.index(ni[e], nk[e])];
      if (l != kPlanSolid) touches[std::size_t(rest_comp[s])].insert(l);
    }
  }
  plan.wall.assign(grid.count(), 0);
  for (std::size_t s = 0; s < grid.count(); ++s) {
    if (rest_comp[s] < 0) continue;
    const std::set<int>& t = touches[std::size_t(rest_comp[s])];
    if (t.size() == 1 && *t.begin() >= 0)
      plan.label[s] = *t.begin();
    else
      plan.wall[s] = 1;
  }
  // Walls go to the nearest region (breadth first from rooms and outside at once), so two
  // rooms meet at their wall's mid-plane; solid beyond max_wall_thickness stays solid.
  const int max_steps = std::max(1, int(std::ceil(settings.max_wall_thickness / grid.cell)));
  std::vector<int> steps(grid.count(), -1);
  std::deque<std::size_t> queue;
  for (std::size_t s = 0; s < grid.count(); ++s)
    if (plan.label[s] != kPlanSolid) {
      steps[s] = 0;
      queue.push_back(s);
    }
  while (!queue.empty()) {
    const std::size_t c = queue.front();
    queue.pop_front();
    if (steps[c] >= max_steps) continue;
    const int i = int(c % std::size_t(grid.width)), k = int(c / std::size_t(grid.width));
    const int ni[4] = {i - 1, i + 1, i, i}, nk[4] = {k, k, k - 1, k + 1};
    for (int e = 0; e < 4; ++e) {
      if (ni[e] < 0 || nk[e] < 0 || ni[e] >= grid.width || nk[e] >= grid.height) continue;
      const std::size_t nb = grid.index(ni[e], nk[e]);
      if (steps[nb] >= 0 || !plan.wall[nb]) continue;
      steps[nb] = steps[c] + 1;
      plan.label[nb] = plan.label[c];
      queue.push_back(nb);
    }
  }
  // How deep the proxy walls lie: the wall cells on a boundary between two rooms (between a
  // room and the outside when no two rooms meet), their 90th percentile of steps from free
  // space. Not the maximum: at a corner the steps count two walls' half thicknesses (4-connected).
  std::vector<int> between_rooms, toward_outside;
  for (int k = 0; k < grid.height; ++k)
    for (int i = 0; i < grid.width; ++i) {
      const std::size_t c = grid.index(i, k);
      if (steps[c] <= 0 || plan.label[c] == kPlanSolid) continue;
      const int ni[4] = {i - 1, i + 1, i, i}, nk[4] = {k, k, k - 1, k + 1};
      bool room_room = false, room_outside = false;
      for (int e = 0; e < 4; ++e) {
        if (ni[e] < 0 || nk[e] < 0 || ni[e] >= grid.width || nk[e] >= grid.height) continue;
        const int other = plan.label[grid.index(ni[e], nk[e])];
        if (other == plan.label[c] || other == kPlanSolid) continue;
        (other >= 0 && plan.label[c] >= 0 ? room_room : room_outside) = true;
      }
      if (room_room)
        between_rooms.push_back(steps[c]);
      else if (room_outside)
        toward_outside.push_back(steps[c]);
    }
  std::vector<int>& boundary = between_rooms.empty() ? toward_outside : between_rooms;
  int deepest = 0;
  if (!boundary.empty()) {
    const std::size_t p90 = (boundary.size() - 1) * 9 / 10;
    std::nth_element(boundary.begin(), boundary.begin() + std::ptrdiff_t(p90), boundary.end());
    deepest = boundary[p90];
  }
  plan.proxy_depth = double(deepest + 1) * grid.cell;
  return rooms;
}

VerticalRays::VerticalRays(const TriangleSoup& tris, double bucket) : tris_(tris), bucket_(bucket) {
  origin_ = glm::dvec2(tris.min.x, tris.min.z);
  width_ = std::max(1, int(std::ceil((tris.max.x - tris.min.x) / bucket)) + 1);
  height_ = std::max(1, int(std::ceil((tris.max.z - tris.min.z) / bucket)) + 1);
  cells_.resize(std::size_t(width_) * std::size_t(height_));
  for (std::size_t t = 0; t < tris.size(); ++t) {
    if (std::abs(unit_normal(tris.a[t], tris.b[t], tris.c[t]).y) < 1e-3) continue;  // seen edge-on
    const double x0 = std::min({tris.a[t].x, tris.b[t].x, tris.c[t].x}),
                 x1 = std::max({tris.a[t].x, tris.b[t].x, tris.c[t].x});
    const double z0 = std::min({tris.a[t].z, tris.b[t].z, tris.c[t].z}),
                 z1 = std::max({tris.a[t].z, tris.b[t].z, tris.c[t].z});
    const int i0 = std::clamp(int((x0 - origin_.x) / bucket), 0, width_ - 1),
              i1 = std::clamp(int((x1 - origin_.x) / bucket), 0, width_ - 1);
    const int k0 = std::clamp(int((z0 - origin_.y) / bucket), 0, height_ - 1),
              k1 = std::clamp(int((z1 - origin_.y) / bucket), 0, height_ - 1);
    for (int k = k0; k <= k1; ++k)
      for (int i = i0; i <= i1; ++i)
        cells_[std::size_t(k) * std::size_t(width_) + std::size_t(i)].push_back(std::uint32_t(t));
  }
}

bool VerticalRays::cast(const glm::dvec3& o, bool down, double& hit_y) const {
  const int i = int(std::floor((o.x - origin_.x) / bucket_)),
            k = int(std::floor((o.z - origin_.y) / bucket_));
  if (i < 0 || k < 0 || i >= width_ || k >= height_) return false;
  bool hit = false;
  for (std::uint32_t t : cells_[std::size_t(k) * std::size_t(width_) + std::size_t(i)]) {
    const glm::dvec3 &a = tris_.a[t], &b = tris_.b[t], &c = tris_.c[t];
    // Barycentrics of (o.x, o.z) in the triangle's plan projection.
    const double d = (b.x - a.x) * (c.z - a.z) - (c.x - a.x) * (b.z - a.z);
    if (d == 0.0) continue;
    const double u = ((o.x - a.x) * (c.z - a.z) - (c.x - a.x) * (o.z - a.z)) / d;
    const double v = ((b.x - a.x) * (o.z - a.z) - (o.x - a.x) * (b.z - a.z)) / d;
    if (u < 0.0 || v < 0.0 || u + v > 1.0) continue;
    const double y = a.y + u * (b.y - a.y) + v * (c.y - a.y);
    if (down ? (y < o.y && (!hit || y > hit_y)) : (y > o.y && (!hit || y < hit_y))) {
      hit_y = y;
      hit = true;
    }
  }
  return hit;
}

namespace {

// The lowest (down) or highest (up) cluster of hit heights holding at least a fifth of the
// rays: the floor under the furniture, the ceiling above the lamps.
bool dominant_level(std::vector<double> hits, std::size_t rays, bool lowest, double& level) {
  if (hits.empty()) return false;
  std::sort(hits.begin(), hits.end());
  if (!lowest) std::reverse(hits.begin(), hits.end());
  constexpr double kTolerance = 0.02;  // m: one surface, tessellated or slightly uneven
  const std::size_t need = std::max<std::size_t>(1, rays / 5);
  std::size_t start = 0;
  for (std::size_t i = 1; i <= hits.size(); ++i) {
    if (i < hits.size() && std::abs(hits[i] - hits[i - 1]) <= kTolerance) continue;
    if (i - start >= need) {
      level = hits[start];
      return true;
    }
    start = i;
  }
  return false;
}

}  // namespace

void measure_rooms(const TriangleSoup& tris, const ImportPlan& plan, int room_count,
                   std::vector<ImportedRoom>& rooms, std::vector<std::string>& warnings) {
  PlanGrid grid{plan.origin, plan.cell, plan.width, plan.height};
  rooms.assign(std::size_t(room_count), ImportedRoom{});
  std::vector<std::vector<std::size_t>> cells(static_cast<std::size_t>(room_count));
  for (std::size_t s = 0; s < grid.count(); ++s)
    if (plan.label[s] >= 0) cells[std::size_t(plan.label[s])].push_back(s);
  const VerticalRays rays(tris, std::max(4.0 * plan.cell, 0.25));
  for (int r = 0; r < room_count; ++r) {
    ImportedRoom& room = rooms[std::size_t(r)];
    const std::vector<std::size_t>& rc = cells[std::size_t(r)];
    room.area = double(rc.size()) * plan.cell * plan.cell;
    room.min = glm::dvec2(std::numeric_limits<double>::max());
    room.max = glm::dvec2(std::numeric_limits<double>::lowest());
    for (std::size_t s : rc) {
      const glm::dvec2 c = grid.centre(int(s % std::size_t(grid.width)), int(s / std::size_t(grid.width)));
      room.min = glm::min(room.min, c - 0.5 * plan.cell);
      room.max = glm::max(room.max, c + 0.5 * plan.cell);
    }
    // Rays from the room's own (not wall) cells, at most about 2000 per room.
    std::vector<std::size_t> inner;
    for (std::size_t s : rc)
      if (!plan.wall[s]) inner.push_back(s);
    const std::size_t stride = std::max<std::size_t>(1, inner.size() / 2000);
    std::vector<double> down, up;
    std::size_t cast = 0;
    for (std::size_t n = 0; n < inner.size(); n += stride, ++cast) {
      const glm::dvec2 c =
          grid.centre(int(inner[n] % std::size_t(grid.width)), int(inner[n] / std::size_t(grid.width)));
      double y;
      if (rays.cast({c.x, plan.cut_height, c.y}, true, y)) down.push_back(y);
      if (rays.cast({c.x, plan.cut_height, c.y}, false, y)) up.push_back(y);
    }
    if (!dominant_level(down, cast, true, room.measured_floor)) {
      room.measured_floor = tris.min.y;
      warnings.push_back("room " + std::to_string(r) +
                         ": no floor under most of it; the scene's lowest point is used");
    }
    if (!dominant_level(up, cast, false, room.measured_ceiling)) {
      room.measured_ceiling = tris.max.y;
      warnings.push_back(
          "room " + std::to_string(r) +
          ": no ceiling over most of it (open to the sky?); the scene's highest point is used");
    }
    room.floor = room.measured_floor;
    room.ceiling = room.measured_ceiling;
  }
}

namespace {

// The raster finds an opening's jambs to a plan cell and its sill and head to a cut step;
// the geometry has them exactly: each moves to the plane of the nearest triangle facing
// along it (a reveal for a jamb, the lintel's underside for the head, the sill's top) within
// `reach` (jambs) or `step` (sill, head) of the estimate, among the triangles at the opening.
void snap_to_geometry(const TriangleSoup& tris, ImportedOpening& o, double reach, double step) {
  const int along = o.normal_axis == 0 ? 2 : 0, across = o.normal_axis;
  double best[4] = {reach, reach, step, step};  // span_min, span_max, sill, head
  double snapped[4] = {o.span_min, o.span_max, o.sill, o.head};
  for (std::size_t t = 0; t < tris.size(); ++t) {
    const glm::dvec3 &a = tris.a[t], &b = tris.b[t], &c = tris.c[t];
    const glm::dvec3 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
    // Near the opening: within half a metre across its wall and overlapping it.
    if (hi[across] < o.position - 0.5 || lo[across] > o.position + 0.5) continue;
    if (hi[along] < o.span_min - reach || lo[along] > o.span_max + reach) continue;
    if (hi.y < o.sill - step || lo.y > o.head + step) continue;
    const glm::dvec3 n = unit_normal(a, b, c);
    if (std::abs(n[along]) > 0.99 && hi[along] - lo[along] < 1e-6 && lo.y < o.head && hi.y > o.sill)
      for (int e = 0; e < 2; ++e) {
        const double d = std::abs(lo[along] - (e == 0 ? o.span_min : o.span_max));
        if (d < best[e]) best[e] = d, snapped[e] = lo[along];
      }
    if (std::abs(n.y) > 0.99 && hi.y - lo.y < 1e-6 && hi[along] > o.span_min && lo[along] < o.span_max)
      for (int e = 2; e < 4; ++e) {
        const double d = std::abs(lo.y - (e == 2 ? o.sill : o.head));
        if (d < best[e]) best[e] = d, snapped[e] = lo.y;
      }
  }
  if (snapped[1] - snapped[0] > 0.1) o.span_min = snapped[0], o.span_max = snapped[1];
  if (snapped[3] - snapped[2] > 0.1) o.sill = snapped[2], o.head = snapped[3];
}

}  // namespace

std::vector<ImportedOpening> find_openings(const TriangleSoup& tris, const ImportPlan& plan,
                                           const std::vector<ImportedRoom>& rooms, double step,
                                           std::vector<std::string>& warnings) {
  const PlanGrid grid{plan.origin, plan.cell, plan.width, plan.height};
  double lowest = std::numeric_limits<double>::max();
  for (const ImportedRoom& r : rooms) lowest = std::min(lowest, r.measured_floor);
  struct Found {
    int a, b;
    int i0, i1, k0, k1;  // cell bounds
    double y0, y1;       // lowest and highest cut it was open at
    glm::dvec2 side_a{0.0}, side_b{0.0};
    int side_count_a = 0, side_count_b = 0;
  };
  std::vector<Found> found;
  std::vector<int> comp;
  for (double y = lowest + 0.5 * step + 1.37e-4; y < plan.cut_height; y += step) {
    const std::vector<std::uint8_t> solid = cut_plan(tris, grid, y);
    std::vector<std::uint8_t> open(grid.count());
    for (std::size_t s = 0; s < grid.count(); ++s) open[s] = plan.wall[s] && !solid[s];
    const int n = components(grid, open, comp);
    // Per component: its bounds, and the regions (rooms, outside) it joins at this height.
    std::vector<Found> slice(std::size_t(n), Found{0, 0, grid.width, -1, grid.height, -1, y, y});
    std::vector<std::map<int, std::pair<glm::dvec2, int>>> regions(static_cast<std::size_t>(n));
    for (std::size_t s = 0; s < grid.count(); ++s) {
      if (comp[s] < 0) continue;
      Found& f = slice[std::size_t(comp[s])];
      const int i = int(s % std::size_t(grid.width)), k = int(s / std::size_t(grid.width));
      f.i0 = std::min(f.i0, i);
      f.i1 = std::max(f.i1, i);
      f.k0 = std::min(f.k0, k);
      f.k1 = std::max(f.k1, k);
      const int ni[4] = {i - 1, i + 1, i, i}, nk[4] = {k, k, k - 1, k + 1};
      for (int e = 0; e < 4; ++e) {
        if (ni[e] < 0 || nk[e] < 0 || ni[e] >= grid.width || nk[e] >= grid.height) continue;
        const std::size_t nb = grid.index(ni[e], nk[e]);
        if (plan.wall[nb] || solid[nb] || plan.label[nb] == kPlanSolid) continue;
        auto& entry = regions[std::size_t(comp[s])][plan.label[nb]];
        entry.first += grid.centre(ni[e], nk[e]);
        entry.second += 1;
      }
    }
    for (int c = 0; c < n; ++c) {
      const auto& reg = regions[std::size_t(c)];
      if (reg.size() < 2) continue;
      // Every pair of regions it joins (a corridor end may join three).
      for (auto ia = reg.begin(); ia != reg.end(); ++ia)
        for (auto ib = std::next(ia); ib != reg.end(); ++ib) {
          if (ib->first < 0 && ia->first < 0) continue;
          Found f = slice[std::size_t(c)];
          // Room first; the outside (-1) second.
          const bool swap = ia->first < 0;
          const auto& ra = swap ? *ib : *ia;
          const auto& rb = swap ? *ia : *ib;
          f.a = ra.first;
          f.b = rb.first;
          f.side_a = ra.second.first;
          f.side_count_a = ra.second.second;
          f.side_b = rb.second.first;
          f.side_count_b = rb.second.second;
          bool merged = false;
          for (Found& g : found) {
            if (g.a != f.a || g.b != f.b || f.i0 > g.i1 + 1 || g.i0 > f.i1 + 1 || f.k0 > g.k1 + 1 ||
                g.k0 > f.k1 + 1)
              continue;
            g.i0 = std::min(g.i0, f.i0);
            g.i1 = std::max(g.i1, f.i1);
            g.k0 = std::min(g.k0, f.k0);
            g.k1 = std::max(g.k1, f.k1);
            g.y0 = std::min(g.y0, f.y0);
            g.y1 = std::max(g.y1, f.y1);
            g.side_a += f.side_a;
            g.side_count_a += f.side_count_a;
            g.side_b += f.side_b;
            g.side_count_b += f.side_count_b;
            merged = true;
            break;
          }
          if (!merged) found.push_back(f);
        }
    }
  }
  std::vector<ImportedOpening> out;
  for (const Found& f : found) {
    ImportedOpening o;
    o.kind = f.b < 0 ? OpeningKind::exterior : OpeningKind::doorway;
    o.room_a = f.a;
    o.room_b = f.b;
    const glm::dvec2 d = f.side_b / double(f.side_count_b) - f.side_a / double(f.side_count_a);
    o.normal_axis = std::abs(d.x) >= std::abs(d.y) ? 0 : 2;
    const glm::dvec2 lo = grid.origin + plan.cell * glm::dvec2(f.i0, f.k0);
    const glm::dvec2 hi = grid.origin + plan.cell * glm::dvec2(f.i1 + 1, f.k1 + 1);
    o.position = o.normal_axis == 0 ? 0.5 * (lo.x + hi.x) : 0.5 * (lo.y + hi.y);
    o.span_min = o.normal_axis == 0 ? lo.y : lo.x;
    o.span_max = o.normal_axis == 0 ? hi.y : hi.x;
    const ImportedRoom& ra = rooms[std::size_t(f.a)];
    o.sill = std::max(ra.measured_floor, f.y0 - 0.5 * step);
    o.head = std::min(ra.measured_ceiling, f.y1 + 0.5 * step);
    snap_to_geometry(tris, o, 2.0 * plan.cell, step);
    if (o.span_max - o.span_min < 0.2 || o.head - o.sill < 0.2) {
      warnings.push_back("an opening of " + std::to_string(o.span_max - o.span_min).substr(0, 4) + " x " +
                         std::to_string(o.head - o.sill).substr(0, 4) + " m at (" +
                         std::to_string(0.5 * (lo.x + hi.x)).substr(0, 6) + ", " +
                         std::to_string(0.5 * (lo.y + hi.y)).substr(0, 6) +
                         ") is too small to be a block face; it is ignored");
      continue;
    }
    out.push_back(o);
  }
  return out;
}

}  // namespace modrt::precompute::import_detail
