// SPDX-License-Identifier: MIT
#include "modrt/precompute/scene_import.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <string>

#include <glm/geometric.hpp>

#include "import_plan.h"
#include "modrt/mesh_lightmap_uv.h"
#include "modrt/precompute/level_build.h"

namespace modrt::precompute {
namespace {

using import_detail::PlanGrid;
using import_detail::TriangleSoup;

std::string fmt(double v, int digits = 2) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, v);
  return text;
}

std::string object_label(std::span<const ImportObject> objects, std::size_t o) {
  return "object " + std::to_string(o) +
         (objects[o].name.empty() ? std::string() : " ('" + objects[o].name + "')");
}

Status check_objects(std::span<const ImportObject> objects, const ImportSettings& settings,
                     std::size_t& triangles) {
  triangles = 0;
  for (std::size_t o = 0; o < objects.size(); ++o) {
    const ImportObject& ob = objects[o];
    const std::string what = object_label(objects, o);
    if (ob.indices.size() % 3 != 0)
      return Status::error(ErrorCode::invalid_argument,
                           what + ": " + std::to_string(ob.indices.size()) + " indices, not a multiple of 3");
    for (std::size_t v = 0; v < ob.positions.size(); ++v)
      if (!std::isfinite(ob.positions[v].x) || !std::isfinite(ob.positions[v].y) ||
          !std::isfinite(ob.positions[v].z) || std::abs(ob.positions[v].x) > 1e7 ||
          std::abs(ob.positions[v].y) > 1e7 || std::abs(ob.positions[v].z) > 1e7)
        return Status::error(ErrorCode::non_finite,
                             what + ": position " + std::to_string(v) + " is not finite or beyond 1e7 m");
    for (std::size_t i = 0; i < ob.indices.size(); ++i)
      if (ob.indices[i] >= ob.positions.size())
        return Status::error(ErrorCode::invalid_argument,
                             what + ": index " + std::to_string(i) + " = " + std::to_string(ob.indices[i]) +
                                 ", the object has " + std::to_string(ob.positions.size()) + " positions");
    const std::size_t tris = ob.indices.size() / 3;
    if (ob.triangle_albedo.size() != 1 && ob.triangle_albedo.size() != tris)
      return Status::error(ErrorCode::invalid_argument,
                           what + ": " + std::to_string(ob.triangle_albedo.size()) + " albedo values for " +
                               std::to_string(tris) + " triangles (give one, or one per triangle)");
    for (std::size_t t = 0; t < ob.triangle_albedo.size(); ++t)
      for (int c = 0; c < 3; ++c)
        if (!(ob.triangle_albedo[t][c] >= 0.0 && ob.triangle_albedo[t][c] <= 1.0))
          return Status::error(ErrorCode::invalid_argument,
                               what + ": albedo " + std::to_string(t) + " is outside [0, 1]");
    triangles += tris;
    if (triangles > settings.max_triangles)
      return Status::error(ErrorCode::resource_limit, "the scene has more than " +
                                                          std::to_string(settings.max_triangles) +
                                                          " triangles (ImportSettings::max_triangles)");
  }
  return Status::success();
}

TriangleSoup flatten(std::span<const ImportObject> objects) {
  TriangleSoup soup;
  soup.min = glm::dvec3(std::numeric_limits<double>::max());
  soup.max = glm::dvec3(std::numeric_limits<double>::lowest());
  for (std::size_t o = 0; o < objects.size(); ++o)
    for (std::size_t t = 0; 3 * t < objects[o].indices.size(); ++t) {
      const glm::dvec3& a = objects[o].positions[objects[o].indices[3 * t]];
      const glm::dvec3& b = objects[o].positions[objects[o].indices[3 * t + 1]];
      const glm::dvec3& c = objects[o].positions[objects[o].indices[3 * t + 2]];
      soup.a.push_back(a);
      soup.b.push_back(b);
      soup.c.push_back(c);
      soup.object.push_back(std::uint32_t(o));
      soup.local.push_back(std::uint32_t(t));
      soup.min = glm::min(soup.min, glm::min(a, glm::min(b, c)));
      soup.max = glm::max(soup.max, glm::max(a, glm::max(b, c)));
    }
  return soup;
}

// ---- step 4: the block grid ----

struct Line {
  double at;
  int priority;   // 2: a wall (room boundary), 1: a jamb
  double weight;  // wall length along it (m), for ties
  double e0, e1;  // where it is needed, along the other axis (m)
};

// Room boundaries along one axis: raster cell edges where the label changes for a run of at
// least min_run, strongest first, one per two cells, each needed where its changes are.
std::vector<Line> boundary_lines(const ImportPlan& plan, int axis, double min_run) {
  const int n = axis == 0 ? plan.width : plan.height;
  std::vector<double> run(std::size_t(n + 1), 0.0);
  std::vector<int> lo(std::size_t(n + 1), std::numeric_limits<int>::max()), hi(std::size_t(n + 1), -1);
  for (int k = 0; k < plan.height; ++k)
    for (int i = 0; i < plan.width; ++i) {
      const int l = plan.label[std::size_t(k) * std::size_t(plan.width) + std::size_t(i)];
      const int ni = axis == 0 ? i + 1 : i, nk = axis == 0 ? k : k + 1;
      if (ni >= plan.width || nk >= plan.height) continue;
      const int m = plan.label[std::size_t(nk) * std::size_t(plan.width) + std::size_t(ni)];
      if (l == m || (l < 0 && m < 0)) continue;
      const std::size_t e = std::size_t(axis == 0 ? i + 1 : k + 1);
      const int along = axis == 0 ? k : i;
      run[e] += plan.cell;
      lo[e] = std::min(lo[e], along);
      hi[e] = std::max(hi[e], along);
    }
  std::vector<int> order(std::size_t(n + 1));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return run[std::size_t(a)] > run[std::size_t(b)]; });
  std::vector<int> taken;
  std::vector<Line> lines;
  const double other_origin = axis == 0 ? plan.origin.y : plan.origin.x;
  for (int e : order) {
    if (run[std::size_t(e)] < min_run) break;
    if (std::any_of(taken.begin(), taken.end(), [&](int t) { return std::abs(t - e) <= 2; })) continue;
    taken.push_back(e);
    lines.push_back({(axis == 0 ? plan.origin.x : plan.origin.y) + e * plan.cell, 2, run[std::size_t(e)],
                     other_origin + lo[std::size_t(e)] * plan.cell,
                     other_origin + (hi[std::size_t(e)] + 1) * plan.cell});
  }
  return lines;
}

// A grid line: fixed at its anchors (walls and jambs, each where it is needed) and straight in
// between, so that features of different walls that are too close for two lines (a doorway's
// jamb and a window's across the room) share one line that bends between them; or a split
// line at fraction t between two others.
struct GridLine {
  std::vector<Line> anchors;
  int lower = -1, upper = -1;  // a split line: between these lines, at fraction t
  double t = 0.0;
  double nominal = 0.0;
};

double anchored_position(const GridLine& g, double s, double tolerance) {
  const Line* left = nullptr;
  const Line* right = nullptr;
  for (const Line& a : g.anchors) {
    if (s >= a.e0 - tolerance && s <= a.e1 + tolerance) return a.at;
    if (a.e1 < s && (!left || a.e1 > left->e1)) left = &a;
    if (a.e0 > s && (!right || a.e0 < right->e0)) right = &a;
  }
  if (left && right) {
    const double w = (s - left->e1) / (right->e0 - left->e1);
    return left->at + w * (right->at - left->at);
  }
  return left ? left->at : right->at;
}

double line_position(const std::vector<GridLine>& lines, std::size_t i, double s, double tolerance) {
  const GridLine& g = lines[i];
  if (g.lower < 0) return anchored_position(g, s, tolerance);
  const double a = anchored_position(lines[std::size_t(g.lower)], s, tolerance);
  const double b = anchored_position(lines[std::size_t(g.upper)], s, tolerance);
  return a + g.t * (b - a);
}

// Candidates strongest first: each joins the line within min_gap of it when their needs do
// not overlap (the line bends), is dropped when they do (a jamb too close to a wall: the
// opening widens to the wall), or starts a line. Then intervals are split into pieces near
// `target`, never shorter than min_gap.
std::vector<GridLine> grid_lines(std::vector<Line> candidates, double min_gap, double target,
                                 double tolerance, bool bend) {
  std::stable_sort(candidates.begin(), candidates.end(), [](const Line& a, const Line& b) {
    return a.priority != b.priority ? a.priority > b.priority : a.weight > b.weight;
  });
  std::vector<GridLine> lines;
  for (const Line& c : candidates) {
    const double mid = 0.5 * (c.e0 + c.e1);
    std::vector<std::size_t> near;
    for (std::size_t i = 0; i < lines.size(); ++i)
      if (std::abs(anchored_position(lines[i], mid, tolerance) - c.at) < min_gap ||
          std::abs(lines[i].nominal - c.at) < min_gap)
        near.push_back(i);
    if (near.empty()) {
      lines.push_back({{c}, -1, -1, 0.0, c.at});
      continue;
    }
    if (!bend) continue;
    // The nearest line whose anchors are needed elsewhere takes it (the bend is checked below).
    std::size_t pick = lines.size();
    double pick_distance = std::numeric_limits<double>::max();
    for (std::size_t i : near) {
      const bool overlaps = std::any_of(lines[i].anchors.begin(), lines[i].anchors.end(), [&](const Line& a) {
        return c.e0 <= a.e1 + 2.0 * tolerance && a.e0 <= c.e1 + 2.0 * tolerance;
      });
      const double d = std::abs(anchored_position(lines[i], mid, tolerance) - c.at);
      if (!overlaps && d < pick_distance) {
        pick = i;
        pick_distance = d;
      }
    }
    if (pick == lines.size()) continue;
    near = {pick};
    GridLine& g = lines[pick];
    GridLine bent = g;
    bent.anchors.push_back(c);
    double sum = 0.0;
    for (const Line& a : bent.anchors) sum += a.at;
    bent.nominal = sum / double(bent.anchors.size());
    // The bend keeps the line at least min_gap / 2 from every other line, on the same side,
    // wherever either of them is anchored.
    bool fits = true;
    for (std::size_t h = 0; h < lines.size() && fits; ++h) {
      if (h == near[0]) continue;
      const double side = lines[h].nominal - bent.nominal;
      std::vector<double> at;
      for (const GridLine* l : {&bent, &lines[h]})
        for (const Line& a : l->anchors) {
          at.push_back(a.e0);
          at.push_back(a.e1);
          at.push_back(0.5 * (a.e0 + a.e1));
        }
      for (double s : at) {
        const double d = anchored_position(lines[h], s, tolerance) - anchored_position(bent, s, tolerance);
        if (std::abs(d) < 0.5 * min_gap || (d > 0.0) != (side > 0.0)) {
          fits = false;
          break;
        }
      }
    }
    if (fits) g = std::move(bent);
  }
  std::sort(lines.begin(), lines.end(),
            [](const GridLine& a, const GridLine& b) { return a.nominal < b.nominal; });
  std::vector<GridLine> out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    out.push_back(lines[i]);
    if (i + 1 == lines.size()) break;
    const double len = lines[i + 1].nominal - lines[i].nominal;
    const int pieces =
        std::max(1, std::min(int(std::lround(len / target)), int(std::floor(len / min_gap + 1e-9))));
    const int lower = int(out.size()) - 1;
    for (int p = 1; p < pieces; ++p) {
      GridLine split;
      split.t = double(p) / pieces;
      split.nominal = lines[i].nominal + len * split.t;
      split.lower = lower;  // fixed up below, once the upper line's index is known
      split.upper = -(int(i) + 2);
      out.push_back(split);
    }
  }
  // Split lines refer to the anchored lines around them by their index in `out`.
  std::vector<int> anchored_index;
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i].lower < 0) anchored_index.push_back(int(i));
  for (GridLine& g : out)
    if (g.lower >= 0) g.upper = anchored_index[std::size_t(-g.upper - 2 + 1)];
  return out;
}

// Fraction of the face between plan points along `axis` ... the opening covers.
double opening_coverage(const ImportedOpening& o, int face_axis, double plane, double s0, double s1,
                        double y0, double y1, double tolerance) {
  if (o.normal_axis != face_axis || std::abs(o.position - plane) > tolerance) return 0.0;
  const double w = std::max(0.0, std::min(s1, o.span_max) - std::max(s0, o.span_min));
  const double h = std::max(0.0, std::min(y1, o.head) - std::max(y0, o.sill));
  return (w * h) / ((s1 - s0) * (y1 - y0));
}

// Whether the object is closed (vertices welded by position, every edge used as often in one
// direction as in the other), and then its signed volume: positive when its triangles face
// out of it.
bool closed_volume(const ImportObject& ob, double& volume) {
  std::map<std::array<double, 3>, std::uint32_t> weld;
  std::vector<std::uint32_t> id(ob.positions.size());
  for (std::size_t v = 0; v < ob.positions.size(); ++v)
    id[v] = weld.try_emplace({ob.positions[v].x, ob.positions[v].y, ob.positions[v].z},
                             std::uint32_t(weld.size()))
                .first->second;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;  // directed edge -> count
  volume = 0.0;
  for (std::size_t t = 0; 3 * t < ob.indices.size(); ++t) {
    const std::uint32_t v[3] = {id[ob.indices[3 * t]], id[ob.indices[3 * t + 1]], id[ob.indices[3 * t + 2]]};
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) continue;
    for (int e = 0; e < 3; ++e) ++edges[{v[e], v[(e + 1) % 3]}];
    const glm::dvec3& a = ob.positions[ob.indices[3 * t]];
    volume +=
        glm::dot(a, glm::cross(ob.positions[ob.indices[3 * t + 1]], ob.positions[ob.indices[3 * t + 2]])) /
        6.0;
  }
  if (edges.empty()) return false;
  // Every edge crossed as often in each direction: a closed surface, or several (furniture
  // made of intersecting closed boxes, whose edges may coincide), so the volume is defined.
  for (const auto& [e, n] : edges) {
    const auto back = edges.find({e.second, e.first});
    if (back == edges.end() || back->second != n) return false;
  }
  return true;
}

// A convex, counter-clockwise or clockwise, quad with no edge shorter than min_edge.
bool good_quad(const std::array<glm::dvec2, 4>& q, double min_edge) {
  double first = 0.0;
  for (int e = 0; e < 4; ++e) {
    const glm::dvec2 a = q[std::size_t(e)], b = q[std::size_t((e + 1) % 4)], c = q[std::size_t((e + 2) % 4)];
    const double turn = (b.x - a.x) * (c.y - b.y) - (b.y - a.y) * (c.x - b.x);
    if (!(std::abs(turn) > 1e-12) || glm::length(b - a) < min_edge) return false;
    if (e == 0)
      first = turn;
    else if ((turn > 0.0) != (first > 0.0))
      return false;
  }
  return true;
}

// A straight wall of a room that follows neither axis (plan points; `inside` a point in the room).
struct SlantedWall {
  glm::dvec2 a{0.0}, b{0.0}, inside{0.0};
  int room = -1;
};

// Douglas-Peucker on lattice points [first, last] of a closed loop.
void simplify(const std::vector<glm::ivec2>& loop, std::size_t first, std::size_t last, double tolerance,
              std::vector<std::size_t>& keep) {
  if (last <= first + 1) return;
  const glm::dvec2 a(loop[first]), b(loop[last % loop.size()]);
  const glm::dvec2 d = b - a;
  const double len = glm::length(d);
  double worst = -1.0;
  std::size_t at = first;
  for (std::size_t i = first + 1; i < last; ++i) {
    const glm::dvec2 p(loop[i]);
    const double dist =
        len > 0.0 ? std::abs(d.x * (p.y - a.y) - d.y * (p.x - a.x)) / len : glm::length(p - a);
    if (dist > worst) {
      worst = dist;
      at = i;
    }
  }
  if (worst <= tolerance) return;
  simplify(loop, first, at, tolerance, keep);
  keep.push_back(at);
  simplify(loop, at, last, tolerance, keep);
}

// The rooms' slanted walls: each room's outline (its plan cells, to the wall mid-planes)
// traced and simplified (Douglas-Peucker, 1.5 cells), keeping segments at least min_length
// long and at least 10 degrees off both axes.
std::vector<SlantedWall> slanted_walls(const ImportPlan& plan, int room_count, double min_length) {
  std::vector<SlantedWall> out;
  auto in = [&](int r, int i, int k) {
    return i >= 0 && k >= 0 && i < plan.width && k < plan.height &&
           plan.label[std::size_t(k) * std::size_t(plan.width) + std::size_t(i)] == r;
  };
  for (int r = 0; r < room_count; ++r) {
    // Directed boundary edges with the room on the left, keyed by their start.
    std::multimap<std::pair<int, int>, std::pair<int, int>> edges;
    for (int k = 0; k < plan.height; ++k)
      for (int i = 0; i < plan.width; ++i) {
        if (!in(r, i, k)) continue;
        if (!in(r, i, k - 1)) edges.insert({{i, k}, {i + 1, k}});
        if (!in(r, i + 1, k)) edges.insert({{i + 1, k}, {i + 1, k + 1}});
        if (!in(r, i, k + 1)) edges.insert({{i + 1, k + 1}, {i, k + 1}});
        if (!in(r, i - 1, k)) edges.insert({{i, k + 1}, {i, k}});
      }
    while (!edges.empty()) {
      std::vector<glm::ivec2> loop;
      auto it = edges.begin();
      const std::pair<int, int> start = it->first;
      std::pair<int, int> at = start;
      while (it != edges.end()) {
        loop.push_back({at.first, at.second});
        at = it->second;
        edges.erase(it);
        if (at == start) break;
        it = edges.find(at);
      }
      if (loop.size() < 8) continue;
      std::vector<std::size_t> keep = {0};
      simplify(loop, 0, loop.size(), 1.5, keep);
      std::sort(keep.begin(), keep.end());
      for (std::size_t s = 0; s < keep.size(); ++s) {
        const glm::dvec2 a = plan.origin + plan.cell * glm::dvec2(loop[keep[s]]);
        const glm::dvec2 b = plan.origin + plan.cell * glm::dvec2(loop[keep[(s + 1) % keep.size()]]);
        const glm::dvec2 d = b - a;
        const double len = glm::length(d);
        if (len < min_length || std::min(std::abs(d.x), std::abs(d.y)) < std::sin(0.1745) * len) continue;
        // The room lies on the left of the traced direction.
        const glm::dvec2 inside = 0.5 * (a + b) + glm::dvec2(-d.y, d.x) / len * (2.0 * plan.cell);
        out.push_back({a, b, inside, r});
      }
    }
  }
  return out;
}

struct BlockGrid {
  int nx = 0, nz = 0;              // cells along x and z
  std::vector<glm::dvec2> vertex;  // (nx + 1) x (nz + 1) plan corners, row j = z index
  std::vector<double> x_nominal, z_nominal;
  std::vector<int> cell_room;  // room covering most of each cell, or -1
};

bool inside_triangle(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
  auto cross = [](const glm::dvec2& u, const glm::dvec2& v) { return u.x * v.y - u.y * v.x; };
  const double d0 = cross(b - a, p - a), d1 = cross(c - b, p - b), d2 = cross(a - c, p - c);
  return (d0 >= 0 && d1 >= 0 && d2 >= 0) || (d0 <= 0 && d1 <= 0 && d2 <= 0);
}

Result<BlockGrid> make_block_grid(const ImportPlan& plan, const std::vector<ImportedOpening>& openings,
                                  const std::vector<SlantedWall>& slanted, int room_count, double storey,
                                  const ImportSettings& settings, bool bend) {
  const double min_gap = storey / settings.max_block_aspect;
  const double tolerance = settings.max_wall_thickness;
  std::array<std::vector<Line>, 2> candidates = {boundary_lines(plan, 0, min_gap),
                                                 boundary_lines(plan, 2, min_gap)};
  for (const ImportedOpening& o : openings) {
    std::vector<Line>& along = candidates[o.normal_axis == 0 ? 1 : 0];
    along.push_back({o.span_min, 1, o.span_max - o.span_min, o.position, o.position});
    along.push_back({o.span_max, 1, o.span_max - o.span_min, o.position, o.position});
  }
  // A slanted wall's ends are grid lines, so that the blocks along it can be warped onto it.
  for (const SlantedWall& w : slanted)
    for (const glm::dvec2& e : {w.a, w.b}) {
      candidates[0].push_back({e.x, 2, glm::length(w.b - w.a), e.y, e.y});
      candidates[1].push_back({e.y, 2, glm::length(w.b - w.a), e.x, e.x});
    }
  const std::vector<GridLine> xl = grid_lines(candidates[0], min_gap, storey, tolerance, bend);
  const std::vector<GridLine> zl = grid_lines(candidates[1], min_gap, storey, tolerance, bend);
  if (xl.size() < 2 || zl.size() < 2)
    return Status::error(ErrorCode::invalid_argument, "import_scene: the rooms' walls give no block grid");
  BlockGrid g;
  g.nx = int(xl.size()) - 1;
  g.nz = int(zl.size()) - 1;
  for (const GridLine& l : xl) g.x_nominal.push_back(l.nominal);
  for (const GridLine& l : zl) g.z_nominal.push_back(l.nominal);
  for (int j = 0; j <= g.nz; ++j)
    for (int i = 0; i <= g.nx; ++i)
      g.vertex.push_back({line_position(xl, std::size_t(i), g.z_nominal[std::size_t(j)], tolerance),
                          line_position(zl, std::size_t(j), g.x_nominal[std::size_t(i)], tolerance)});
  auto v = [&](int i, int j) { return g.vertex[std::size_t(j) * std::size_t(g.nx + 1) + std::size_t(i)]; };
  // Every cell a convex quad no thinner than a quarter of min_gap (a bend must not fold it).
  for (int j = 0; j < g.nz; ++j)
    for (int i = 0; i < g.nx; ++i)
      if (!good_quad({v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)}, 0.25 * min_gap))
        return Status::error(ErrorCode::invalid_argument, "a bent line folds a cell");
  // Room of each cell: the region covering most of its plan cells.
  const PlanGrid grid{plan.origin, plan.cell, plan.width, plan.height};
  g.cell_room.assign(std::size_t(g.nx) * std::size_t(g.nz), -1);
  for (int j = 0; j < g.nz; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const glm::dvec2 q[4] = {v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)};
      glm::dvec2 lo = q[0], hi = q[0];
      for (const glm::dvec2& p : q) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
      }
      int i0, i1, k0, k1;
      grid.locate(lo, i0, k0);
      grid.locate(hi, i1, k1);
      std::vector<int> count(std::size_t(room_count), 0);
      int total = 0;
      for (int k = k0; k <= k1; ++k)
        for (int ii = i0; ii <= i1; ++ii) {
          const glm::dvec2 c = grid.centre(ii, k);
          if (!inside_triangle(c, q[0], q[1], q[2]) && !inside_triangle(c, q[0], q[2], q[3])) continue;
          ++total;
          const int l = plan.label[grid.index(ii, k)];
          if (l >= 0) ++count[std::size_t(l)];
        }
      const auto best = std::max_element(count.begin(), count.end());
      if (total > 0 && 2 * *best > total)
        g.cell_room[std::size_t(j) * std::size_t(g.nx) + std::size_t(i)] = int(best - count.begin());
    }
  // Along a slanted wall: a cell it cuts stays a block only when most (3/5) of it lies on the
  // room's side; then each grid vertex between the room's blocks and the cells beyond moves
  // onto the wall when it lies within 3/4 of a cell of it (a move that would fold a cell is
  // undone). The blocks' faces then run along the wall (MRT's warped blocks).
  auto room_at = [&](int i, int j) {
    return i < 0 || j < 0 || i >= g.nx || j >= g.nz
               ? -1
               : g.cell_room[std::size_t(j) * std::size_t(g.nx) + std::size_t(i)];
  };
  for (const SlantedWall& w : slanted) {
    const glm::dvec2 d = w.b - w.a, n = glm::dvec2(-d.y, d.x) / glm::length(d);
    const double side = glm::dot(w.inside - w.a, n) > 0.0 ? 1.0 : -1.0;
    for (int j = 0; j < g.nz; ++j)
      for (int i = 0; i < g.nx; ++i) {
        if (room_at(i, j) != w.room) continue;
        const glm::dvec2 q[4] = {v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)};
        // The cell's area on the room's side of the wall's line, from a 6 x 6 sample grid.
        int in = 0, on_line = 0;
        for (int sy = 0; sy < 6; ++sy)
          for (int sx = 0; sx < 6; ++sx) {
            const double u = (sx + 0.5) / 6.0, t = (sy + 0.5) / 6.0;
            const glm::dvec2 p =
                (1 - u) * (1 - t) * q[0] + u * (1 - t) * q[1] + u * t * q[2] + (1 - u) * t * q[3];
            const double along = glm::dot(p - w.a, d) / glm::dot(d, d);
            if (along < 0.0 || along > 1.0) continue;
            ++on_line;
            if (side * glm::dot(p - w.a, n) > 0.0) ++in;
          }
        if (on_line == 36 && 5 * in < 3 * 36)
          g.cell_room[std::size_t(j) * std::size_t(g.nx) + std::size_t(i)] = -1;
      }
    for (int j = 0; j <= g.nz; ++j)
      for (int i = 0; i <= g.nx; ++i) {
        int blocks = 0, others = 0;
        double size = std::numeric_limits<double>::max();
        for (int dj = -1; dj <= 0; ++dj)
          for (int di = -1; di <= 0; ++di) {
            const int r = room_at(i + di, j + dj);
            if (r == w.room) {
              ++blocks;
              const glm::dvec2 a = v(std::max(i + di, 0), std::max(j + dj, 0));
              const glm::dvec2 b = v(std::min(i + di + 1, g.nx), std::min(j + dj + 1, g.nz));
              size = std::min({size, std::abs(b.x - a.x), std::abs(b.y - a.y)});
            } else if (r < 0) {
              ++others;
            }
          }
        if (blocks == 0 || others == 0 || blocks + others != 4) continue;
        glm::dvec2& p = g.vertex[std::size_t(j) * std::size_t(g.nx + 1) + std::size_t(i)];
        const double along = std::clamp(glm::dot(p - w.a, d) / glm::dot(d, d), 0.0, 1.0);
        const glm::dvec2 onto = w.a + along * d;
        if (glm::length(onto - p) > 0.75 * size || glm::length(onto - p) < 1e-9) continue;
        const glm::dvec2 before = p;
        p = onto;
        bool fine = true;
        for (int dj = -1; dj <= 0 && fine; ++dj)
          for (int di = -1; di <= 0 && fine; ++di) {
            const int ci = i + di, cj = j + dj;
            if (room_at(ci, cj) < 0) continue;  // not a block: its shape does not matter
            fine = good_quad({v(ci, cj), v(ci + 1, cj), v(ci + 1, cj + 1), v(ci, cj + 1)}, 0.25 * min_gap);
          }
        if (!fine) p = before;
      }
  }
  return g;
}

// Distance from p to the plane of face `face` of a block with these corners (its four corners'
// best plane: the cross product of its diagonals).
double face_distance(const std::array<glm::dvec3, 8>& corners, int face, const glm::dvec3& p) {
  const int axis = face / 2, bit = axis == 0 ? 1 : axis == 1 ? 2 : 4, side = face & 1;
  int k[4], n = 0;
  for (int c = 0; c < 8; ++c)
    if (((c & bit) != 0) == (side != 0)) k[n++] = c;
  const glm::dvec3 normal = glm::cross(corners[std::size_t(k[3])] - corners[std::size_t(k[0])],
                                       corners[std::size_t(k[2])] - corners[std::size_t(k[1])]);
  const double len = glm::length(normal);
  const glm::dvec3 centre = 0.25 * (corners[std::size_t(k[0])] + corners[std::size_t(k[1])] +
                                    corners[std::size_t(k[2])] + corners[std::size_t(k[3])]);
  return len > 0.0 ? std::abs(glm::dot(p - centre, normal / len)) : glm::length(p - centre);
}

int find_root(std::vector<int>& parent, int i) {
  while (parent[std::size_t(i)] != i)
    i = parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
  return i;
}

}  // namespace

Result<SceneImport> import_scene(std::span<const ImportObject> objects,
                                 std::span<const LightDescription> lights,
                                 const ImportSettings& settings) try {
  SceneImport out;
  std::size_t triangle_count = 0;
  if (Status s = check_objects(objects, settings, triangle_count); !s.ok()) return s;
  out.triangles = triangle_count;
  if (triangle_count == 0)
    return Status::error(ErrorCode::invalid_argument, "import_scene: the scene has no triangles");
  const TriangleSoup soup = flatten(objects);

  // Step 1: the plan.
  const double extent = std::max(soup.max.x - soup.min.x, soup.max.z - soup.min.z);
  const double cell = settings.plan_cell > 0.0 ? settings.plan_cell : std::clamp(extent / 400.0, 0.02, 0.25);
  PlanGrid grid;
  grid.cell = cell;
  grid.origin = glm::dvec2(soup.min.x, soup.min.z) - 3.0 * cell;
  grid.width = int(std::ceil((soup.max.x - soup.min.x) / cell)) + 6;
  grid.height = int(std::ceil((soup.max.z - soup.min.z) / cell)) + 6;
  if (grid.width > settings.max_plan_side || grid.height > settings.max_plan_side)
    return Status::error(ErrorCode::resource_limit,
                         "import_scene: the plan raster would be " + std::to_string(grid.width) + " x " +
                             std::to_string(grid.height) + " cells of " + fmt(cell, 3) + " m (limit " +
                             std::to_string(settings.max_plan_side) + " per side): raise plan_cell");
  ImportPlan& plan = out.plan;
  plan.origin = grid.origin;
  plan.cell = cell;
  plan.width = grid.width;
  plan.height = grid.height;
  plan.cut_height = import_detail::choose_cut_height(soup);
  const int room_count = import_detail::classify_plan(soup, grid, settings, plan);
  if (room_count == 0)
    return Status::error(
        ErrorCode::invalid_argument,
        "import_scene: no enclosed room found in the plan cut at y = " + fmt(plan.cut_height) +
            " m (the walls must close each room at that height; rooms narrower than " +
            fmt(settings.min_room_width) + " m are not rooms)");

  // Steps 2 and 3: heights and openings.
  import_detail::measure_rooms(soup, plan, room_count, out.rooms, out.warnings);
  std::vector<double> heights;
  for (const ImportedRoom& r : out.rooms) heights.push_back(r.measured_ceiling - r.measured_floor);
  std::sort(heights.begin(), heights.end());
  const double storey = heights[heights.size() / 2];
  if (!(storey > 0.05))
    return Status::error(ErrorCode::invalid_argument,
                         "import_scene: the rooms' floor-to-ceiling height is " + fmt(storey) + " m");
  out.openings = import_detail::find_openings(soup, plan, out.rooms, storey / 24.0, out.warnings);

  // Step 4: the block grid, its lines bending between features of different walls; straight
  // lines (the weaker feature dropped) where a bend would make a cell too thin or not convex.
  const std::vector<SlantedWall> slanted =
      slanted_walls(plan, room_count, storey / settings.max_block_aspect);
  Result<BlockGrid> made = make_block_grid(plan, out.openings, slanted, room_count, storey, settings, true);
  if (!made.ok()) {
    out.warnings.push_back("the block grid's lines could not bend between openings (" +
                           made.status().message() +
                           "); straight lines, where the weaker of two close features is dropped");
    made = make_block_grid(plan, out.openings, slanted, room_count, storey, settings, false);
  }
  if (!made.ok()) return made.status();
  const BlockGrid& bg = made.value();
  out.x_lines = bg.x_nominal;
  out.z_lines = bg.z_nominal;
  const int nx = bg.nx, nz = bg.nz;
  const std::vector<int>& cell_room = bg.cell_room;
  auto vtx = [&](int i, int j) { return bg.vertex[std::size_t(j) * std::size_t(nx + 1) + std::size_t(i)]; };
  auto room_at = [&](int i, int j) {
    return i < 0 || j < 0 || i >= nx || j >= nz
               ? -1
               : cell_room[std::size_t(j) * std::size_t(nx) + std::size_t(i)];
  };

  // Side faces: missing within a room and where an opening covers enough of the face.
  // open[(j * nx + i) * 2 + d]: the face on the +X (d = 0) / +Z (d = 1) side of cell (i, j).
  std::vector<std::uint8_t> open_face(std::size_t(nx) * std::size_t(nz) * 2, 0);
  std::vector<std::uint8_t> open_low(std::size_t(nx) * std::size_t(nz) * 2,
                                     0);  // the -X / -Z side, at the border
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = room_at(i, j);
      if (a < 0) continue;
      for (int d = 0; d < 2; ++d)
        for (int side : {1, -1}) {
          const int ni = d == 0 ? i + side : i, nj = d == 0 ? j : j + side;
          const int b = room_at(ni, nj);
          if (side < 0 && b >= 0) continue;  // decided from the other cell
          const std::size_t slot = (std::size_t(j) * std::size_t(nx) + std::size_t(i)) * 2 + std::size_t(d);
          std::uint8_t& flag = side > 0 ? open_face[slot] : open_low[slot];
          if (b == a) {
            flag = 1;
            continue;
          }
          // The face's two plan corners (a vertical quad).
          const int fi = d == 0 ? (side > 0 ? i + 1 : i) : i, fj = d == 0 ? j : (side > 0 ? j + 1 : j);
          const glm::dvec2 c0 = vtx(fi, fj), c1 = d == 0 ? vtx(fi, fj + 1) : vtx(fi + 1, fj);
          const double plane = d == 0 ? 0.5 * (c0.x + c1.x) : 0.5 * (c0.y + c1.y);
          const double s0 = d == 0 ? c0.y : c0.x;
          const double s1 = d == 0 ? c1.y : c1.x;
          const ImportedRoom& ra = out.rooms[std::size_t(a)];
          double coverage = 0.0;
          for (const ImportedOpening& o : out.openings) {
            const bool joins = (o.room_a == a && o.room_b == b) || (o.room_a == b && o.room_b == a);
            if (!joins) continue;
            coverage += opening_coverage(o, d == 0 ? 0 : 2, plane, s0, s1, ra.measured_floor,
                                         ra.measured_ceiling, settings.max_wall_thickness);
          }
          for (ImportedOpening& o : out.openings) {
            const bool joins = (o.room_a == a && o.room_b == b) || (o.room_a == b && o.room_b == a);
            if (!joins) continue;
            const double c = opening_coverage(o, d == 0 ? 0 : 2, plane, s0, s1, ra.measured_floor,
                                              ra.measured_ceiling, settings.max_wall_thickness);
            if (c > 0.0) {
              o.coverage = std::max(o.coverage, coverage);
              if (coverage >= settings.min_opening_fraction) o.removes_face = true;
            }
          }
          if (coverage >= settings.min_opening_fraction) flag = 1;
        }
    }
  for (const ImportedOpening& o : out.openings)
    if (!o.removes_face)
      out.warnings.push_back(
          std::string(o.kind == OpeningKind::doorway ? "doorway" : "exterior opening") + " of room " +
          std::to_string(o.room_a) +
          (o.room_b >= 0 ? " to room " + std::to_string(o.room_b) : std::string(" to the outside")) + " (" +
          fmt(o.span_max - o.span_min) + " x " + fmt(o.head - o.sill) + " m) covers only " +
          fmt(100.0 * o.coverage, 0) + " % of its block face: the face stays a wall");

  // Rooms joined through missing faces share one floor and ceiling (their faces must match).
  std::vector<int> parent(static_cast<std::size_t>(room_count));
  std::iota(parent.begin(), parent.end(), 0);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i)
      for (int d = 0; d < 2; ++d) {
        const int a = room_at(i, j), b = d == 0 ? room_at(i + 1, j) : room_at(i, j + 1);
        if (a >= 0 && b >= 0 && a != b &&
            open_face[(std::size_t(j) * std::size_t(nx) + std::size_t(i)) * 2 + std::size_t(d)])
          parent[std::size_t(find_root(parent, a))] = find_root(parent, b);
      }
  std::vector<double> group_floor(std::size_t(room_count), std::numeric_limits<double>::max()),
      group_ceiling(std::size_t(room_count), std::numeric_limits<double>::lowest());
  for (int r = 0; r < room_count; ++r) {
    const int g = find_root(parent, r);
    group_floor[std::size_t(g)] =
        std::min(group_floor[std::size_t(g)], out.rooms[std::size_t(r)].measured_floor);
    group_ceiling[std::size_t(g)] =
        std::max(group_ceiling[std::size_t(g)], out.rooms[std::size_t(r)].measured_ceiling);
  }
  for (int r = 0; r < room_count; ++r) {
    ImportedRoom& room = out.rooms[std::size_t(r)];
    const int g = find_root(parent, r);
    room.floor = group_floor[std::size_t(g)];
    room.ceiling = group_ceiling[std::size_t(g)];
    if (room.floor < room.measured_floor - 0.02 * storey ||
        room.ceiling > room.measured_ceiling + 0.02 * storey)
      out.warnings.push_back("room " + std::to_string(r) + " (floor " + fmt(room.measured_floor) +
                             ", ceiling " + fmt(room.measured_ceiling) + " m) shares the floor and ceiling " +
                             fmt(room.floor) + " / " + fmt(room.ceiling) + " m of the rooms it opens into");
  }

  // The level: one warped box block per room cell.
  LevelDescription& level = out.level;
  level.name = "imported";
  level.cell_size = storey;
  const int ci0 = int(std::lround(vtx(0, 0).x / storey)), cj0 = int(std::lround(vtx(0, 0).y / storey));
  std::vector<int> block_of(cell_room.size(), -1);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const int r = room_at(i, j);
      if (r < 0) continue;
      const ImportedRoom& room = out.rooms[std::size_t(r)];
      BlockDescription b;
      b.cell = glm::ivec3(ci0 + i, int(std::lround(room.floor / storey)), cj0 + j);
      b.warped = true;
      for (int c = 0; c < 8; ++c) {
        const glm::dvec2 v = vtx(i + (c & 1), j + ((c >> 2) & 1));
        b.corners[std::size_t(c)] = glm::dvec3(v.x, (c & 2) ? room.ceiling : room.floor, v.y);
      }
      b.faces = kAllFaces;
      const std::size_t here = (std::size_t(j) * std::size_t(nx) + std::size_t(i)) * 2;
      if (open_face[here]) b.faces &= FaceMask(~(1u << kFacePosX));
      if (open_face[here + 1]) b.faces &= FaceMask(~(1u << kFacePosZ));
      const int west = room_at(i - 1, j), south = room_at(i, j - 1);
      const bool open_west =
          west >= 0 ? bool(open_face[(std::size_t(j) * std::size_t(nx) + std::size_t(i - 1)) * 2])
                    : bool(open_low[here]);
      const bool open_south =
          south >= 0 ? bool(open_face[(std::size_t(j - 1) * std::size_t(nx) + std::size_t(i)) * 2 + 1])
                     : bool(open_low[here + 1]);
      if (open_west) b.faces &= FaceMask(~(1u << kFaceNegX));
      if (open_south) b.faces &= FaceMask(~(1u << kFaceNegZ));
      for (glm::dvec3& a : b.albedo) a = glm::dvec3(settings.default_albedo);
      b.name = "room " + std::to_string(r) + " cell " + std::to_string(i) + "," + std::to_string(j);
      block_of[std::size_t(j) * std::size_t(nx) + std::size_t(i)] = int(level.blocks.size());
      out.block_room.push_back(r);
      ++out.rooms[std::size_t(r)].blocks;
      level.blocks.push_back(std::move(b));
    }
  for (int r = 0; r < room_count; ++r)
    if (out.rooms[std::size_t(r)].blocks == 0)
      out.warnings.push_back(
          "room " + std::to_string(r) + " (" + fmt(out.rooms[std::size_t(r)].area) +
          " m^2) is too small for a block of its own; its light comes from its neighbours");
  level.lights.assign(lights.begin(), lights.end());

  // Step 5: facing. Air is a room's own plan cell between its floor and ceiling, or an
  // opening's passage between its sill and head.
  auto air = [&](const glm::dvec3& p) {
    int i, k;
    grid.locate({p.x, p.z}, i, k);
    const std::size_t s = grid.index(i, k);
    const int l = plan.label[s];
    if (l < 0) return false;
    const ImportedRoom& room = out.rooms[std::size_t(l)];
    if (p.y <= room.measured_floor || p.y >= room.measured_ceiling) return false;
    if (!plan.wall[s]) return true;
    for (const ImportedOpening& o : out.openings) {
      const double along = o.normal_axis == 0 ? p.z : p.x, across = o.normal_axis == 0 ? p.x : p.z;
      if (along > o.span_min && along < o.span_max &&
          std::abs(across - o.position) < settings.max_wall_thickness && p.y > o.sill && p.y < o.head)
        return true;
    }
    return false;
  };
  // Artists invert whole objects (Blender's recalculated normals, a mirrored export), and the
  // faces that border no room (a wall's top under the ceiling slab, a sofa's underside on
  // the floor) cannot be decided on their own, nor correctly for furniture, whose inside the
  // plan sees as air. So a closed object (a box wall, a piece of furniture) faces out of its
  // own volume (the sign of its volume decides), and any other object (a room shell, a
  // single-sided floor) follows the side that at least 3/4 of its decided area faces; without
  // such a majority each decided triangle keeps its own answer.
  const double eps = std::max(2.0 * cell, 0.02);
  out.flipped.resize(objects.size());
  for (std::size_t o = 0; o < objects.size(); ++o) out.flipped[o].assign(objects[o].indices.size() / 3, 0);
  std::vector<double> flip_area(objects.size(), 0.0), keep_area(objects.size(), 0.0);
  std::vector<std::int8_t> decided(soup.size(), 0);  // +1 keep, -1 flip, 0 undecided
  for (std::size_t t = 0; t < soup.size(); ++t) {
    const glm::dvec3 n = glm::cross(soup.b[t] - soup.a[t], soup.c[t] - soup.a[t]);
    const double len = glm::length(n);
    if (!(len > 0.0)) continue;
    const glm::dvec3 p = (soup.a[t] + soup.b[t] + soup.c[t]) / 3.0, u = n / len;
    const bool front = air(p + eps * u), back = air(p - eps * u);
    if (front == back) continue;
    decided[t] = front ? 1 : -1;
    (front ? keep_area : flip_area)[soup.object[t]] += 0.5 * len;
  }
  std::vector<std::int8_t> closed_sign(objects.size(), 0);  // +1 / -1: closed, facing out / in
  for (std::size_t o = 0; o < objects.size(); ++o) {
    double volume = 0.0;
    if (closed_volume(objects[o], volume) && volume != 0.0) closed_sign[o] = volume > 0.0 ? 1 : -1;
  }
  for (std::size_t t = 0; t < soup.size(); ++t) {
    const std::uint32_t o = soup.object[t];
    if (closed_sign[o] != 0) {
      if (closed_sign[o] < 0) {
        out.flipped[o][soup.local[t]] = 1;
        ++out.triangles_flipped;
      }
      continue;
    }
    const double total = flip_area[o] + keep_area[o];
    bool flip = decided[t] < 0;
    if (total > 0.0 && flip_area[o] >= 0.75 * total) flip = true;
    if (total > 0.0 && keep_area[o] >= 0.75 * total) flip = false;
    if (flip) {
      out.flipped[o][soup.local[t]] = 1;
      ++out.triangles_flipped;
    }
  }

  // Step 6: map every triangle onto the layout; roles and per-face albedo.
  Result<Level> layout = build_level_layout(level, settings.layout_res);
  if (!layout.ok())
    return Status::error(
        layout.status().code(),
        "import_scene: the generated level does not validate (a bug): " + layout.status().message());
  std::vector<glm::dvec3> albedo_sum(level.blocks.size() * kFaceCount, glm::dvec3(0.0));
  std::vector<double> area_sum(level.blocks.size() * kFaceCount, 0.0);
  out.object_role.assign(objects.size(), ObjectRole::structure);
  out.object_far_fraction.assign(objects.size(), 0.0);
  struct Piece {
    std::uint32_t block;
    int world_face;
    double area;
    bool far;
    std::uint32_t triangle;
  };
  for (std::size_t o = 0; o < objects.size(); ++o) {
    const ImportObject& ob = objects[o];
    const std::size_t tris = ob.indices.size() / 3;
    std::vector<glm::vec3> pos, nrm;
    std::vector<std::uint32_t> idx;
    for (std::size_t t = 0; t < tris; ++t) {
      glm::dvec3 v[3] = {ob.positions[ob.indices[3 * t]], ob.positions[ob.indices[3 * t + 1]],
                         ob.positions[ob.indices[3 * t + 2]]};
      if (out.flipped[o][t]) std::swap(v[1], v[2]);
      glm::dvec3 n = glm::cross(v[1] - v[0], v[2] - v[0]);
      const double len = glm::length(n);
      n = len > 0.0 ? n / len : glm::dvec3(0.0, 1.0, 0.0);
      for (const glm::dvec3& p : v) {
        idx.push_back(std::uint32_t(pos.size()));
        pos.push_back(glm::vec3(p));
        nrm.push_back(glm::vec3(n));
      }
    }
    if (pos.empty()) continue;
    MeshLightmapInput input{StridedVec3::tight(pos), StridedVec3::tight(nrm), pos.size(), idx};
    std::vector<Piece> pieces;
    double total = 0.0, outside = 0.0, far = 0.0;
    Result<MeshLightmapStats> stats =
        map_mesh_lightmap(layout.value(), input, [&](const std::array<MappedCorner, 3>& c) {
          const glm::dvec3 a(c[0].position), b(c[1].position), d(c[2].position);
          const double area = 0.5 * glm::length(glm::cross(b - a, d - a));
          total += area;
          if (c[0].outside) {
            outside += area;
            return;
          }
          const LevelBlock& blk = layout->blocks[c[0].block];
          const int wf = rotate_face(c[0].face, blk.quarter_turns);
          const glm::dvec3 centre = (a + b + d) / 3.0;
          const bool is_far = face_distance(blk.corners, wf, centre) > settings.clutter_distance;
          if (is_far) far += area;
          pieces.push_back({c[0].block, wf, area, is_far, c[0].triangle});
        });
    if (!stats.ok())
      return Status::error(stats.status().code(), object_label(objects, o) + ": " + stats.status().message());
    out.triangles_outside += stats->triangles_outside;
    const double inside = total - outside;
    out.object_far_fraction[o] = inside > 0.0 ? far / inside : 0.0;
    if (total > 0.0 && outside >= 0.9 * total)
      out.object_role[o] = ObjectRole::outside;
    else if (out.object_far_fraction[o] >= settings.clutter_fraction)
      out.object_role[o] = ObjectRole::clutter;
    if (out.object_role[o] != ObjectRole::structure) continue;
    for (const Piece& p : pieces) {
      if (p.far) continue;
      const glm::dvec3 al =
          ob.triangle_albedo.size() == 1 ? ob.triangle_albedo[0] : ob.triangle_albedo[p.triangle];
      const std::size_t slot = std::size_t(p.block) * kFaceCount + std::size_t(p.world_face);
      albedo_sum[slot] += p.area * al;
      area_sum[slot] += p.area;
    }
  }
  for (std::size_t b = 0; b < level.blocks.size(); ++b)
    for (int f = 0; f < kFaceCount; ++f) {
      const std::size_t slot = b * kFaceCount + std::size_t(f);
      if (area_sum[slot] > 0.0)
        level.blocks[b].albedo[std::size_t(f)] = glm::clamp(albedo_sum[slot] / area_sum[slot], 0.0, 1.0);
    }
  return out;
} catch (const std::bad_alloc&) {
  return Status::error(ErrorCode::resource_limit, "import_scene: out of memory");
} catch (const std::exception& e) {
  return Status::error(ErrorCode::internal_error, std::string("import_scene: ") + e.what());
}

}  // namespace modrt::precompute
