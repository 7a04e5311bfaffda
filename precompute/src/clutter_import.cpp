// SPDX-License-Identifier: MIT
#include "modrt/precompute/clutter_import.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <unordered_map>
#include <utility>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <glm/vec2.hpp>

namespace modrt::precompute {
namespace {

using Settings = ClutterImportSettings;
using GridPoint = std::array<int, 3>;

Status bad(const std::string& what, const std::string& problem) {
  return Status::error(ErrorCode::invalid_argument, what + ": " + problem);
}

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}
std::string fmt(const glm::dvec3& v) { return "(" + fmt(v.x) + ", " + fmt(v.y) + ", " + fmt(v.z) + ")"; }

int find_root(std::vector<int>& parent, int i) {
  while (parent[std::size_t(i)] != i)
    i = parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
  return i;
}

struct Tri {
  std::array<std::uint32_t, 3> v{};  // welded vertices
  std::uint32_t source = 0;          // input triangle
  double area = 0.0;
  glm::dvec3 normal{0.0};  // world, unit
};

struct Key3Hash {
  std::size_t operator()(const std::array<std::int64_t, 3>& k) const {
    std::uint64_t h = std::uint64_t(k[0]) * 0x9E3779B97F4A7C15ull;
    h = (h ^ (h >> 29) ^ std::uint64_t(k[1])) * 0xBF58476D1CE4E5B9ull;
    h = (h ^ (h >> 32) ^ std::uint64_t(k[2])) * 0x94D049BB133111EBull;
    return std::size_t(h ^ (h >> 31));
  }
};

// Vertices within eps of an earlier representative join it (the first found, in a fixed
// neighbour order: deterministic). Buckets of 2 eps: a point's partners lie in its own bucket
// or the neighbour towards it on each axis (8 buckets). Unreferenced vertices stay unwelded
// (UINT32_MAX).
std::vector<std::uint32_t> weld(std::span<const glm::dvec3> p, const std::vector<char>& used,
                                const glm::dvec3& lo, double eps, std::vector<glm::dvec3>& rep) {
  std::unordered_map<std::array<std::int64_t, 3>, std::vector<std::uint32_t>, Key3Hash> buckets;
  buckets.reserve(p.size());
  std::vector<std::uint32_t> id(p.size(), UINT32_MAX);
  for (std::size_t v = 0; v < p.size(); ++v) {
    if (!used[v]) continue;
    const glm::dvec3 q = (p[v] - lo) / (2.0 * eps), cell = glm::floor(q);
    const std::array<std::int64_t, 3> key{std::int64_t(cell.x), std::int64_t(cell.y), std::int64_t(cell.z)};
    const std::array<std::int64_t, 3> side{q.x - cell.x < 0.5 ? -1 : 1, q.y - cell.y < 0.5 ? -1 : 1,
                                           q.z - cell.z < 0.5 ? -1 : 1};
    std::uint32_t found = UINT32_MAX;
    for (int d = 0; d < 8 && found == UINT32_MAX; ++d) {
      const auto it = buckets.find(
          {key[0] + (d & 1 ? side[0] : 0), key[1] + (d & 2 ? side[1] : 0), key[2] + (d & 4 ? side[2] : 0)});
      if (it == buckets.end()) continue;
      for (std::uint32_t r : it->second)
        if (glm::length(rep[r] - p[v]) <= eps) {
          found = r;
          break;
        }
    }
    if (found == UINT32_MAX) {
      found = std::uint32_t(rep.size());
      rep.push_back(p[v]);
      buckets[key].push_back(found);
    }
    id[v] = found;
  }
  return id;
}

// The orthonormal frame along which most of the area faces (columns, permuted and signed to
// lie nearest the world axes, right-handed), or identity when it does not beat the world axes.
glm::dmat3 object_frame(const std::vector<Tri>& tris) {
  const double tol = std::cos(2.0 * 3.14159265358979323846 / 180.0);
  double total = 0.0;
  for (const Tri& t : tris) total += t.area;
  auto aligned = [&](std::span<const glm::dvec3> axes) {
    double a = 0.0;
    for (const Tri& t : tris)
      for (const glm::dvec3& x : axes)
        if (std::abs(glm::dot(t.normal, x)) > tol) {
          a += t.area;
          break;
        }
    return a;
  };
  std::vector<std::size_t> order(tris.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return tris[a].area > tris[b].area; });
  // The best axis among the distinct directions of the largest triangles satisfying `keep`.
  auto best_axis = [&](auto keep, auto direction) {
    std::vector<glm::dvec3> tried;
    glm::dvec3 best(0.0);
    double best_score = -1.0;
    for (std::size_t i : order) {
      if (tried.size() >= 24) break;
      if (!keep(tris[i].normal)) continue;
      const glm::dvec3 d = direction(tris[i].normal);
      if (!(glm::length(d) > 0.5)) continue;
      if (std::any_of(tried.begin(), tried.end(),
                      [&](const glm::dvec3& x) { return std::abs(glm::dot(x, d)) > tol; }))
        continue;
      tried.push_back(d);
      const double s = aligned(std::span<const glm::dvec3>(&d, 1));
      if (s > best_score) best_score = s, best = d;
    }
    return best;
  };
  const glm::dvec3 a1 =
      best_axis([](const glm::dvec3&) { return true; }, [](const glm::dvec3& n) { return n; });
  const double perpendicular = std::sin(2.0 * 3.14159265358979323846 / 180.0);
  glm::dvec3 a2 = best_axis([&](const glm::dvec3& n) { return std::abs(glm::dot(n, a1)) < perpendicular; },
                            [&](const glm::dvec3& n) {
                              const glm::dvec3 d = n - glm::dot(n, a1) * a1;
                              const double l = glm::length(d);
                              return l > 0.0 ? d / l : glm::dvec3(0.0);
                            });
  if (glm::length(a2) < 0.5) {
    int least = 0;
    for (int k = 1; k < 3; ++k)
      if (std::abs(a1[k]) < std::abs(a1[least])) least = k;
    glm::dvec3 e(0.0);
    e[least] = 1.0;
    a2 = glm::normalize(glm::cross(a1, e));
  }
  const std::array<glm::dvec3, 3> frame{a1, a2, glm::cross(a1, a2)};
  const std::array<glm::dvec3, 3> world{glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)};
  const double frame_score = aligned(frame), world_score = aligned(world);
  if (!(frame_score > world_score + 0.02 * total) || frame_score < 0.25 * total) return glm::dmat3(1.0);
  // The permutation of the frame's axes nearest the world axes.
  std::array<int, 3> perm{0, 1, 2}, best_perm = perm;
  double best = -1.0;
  do {
    double s = 0.0;
    for (int k = 0; k < 3; ++k) s += std::abs(frame[std::size_t(perm[std::size_t(k)])][k]);
    if (s > best) best = s, best_perm = perm;
  } while (std::next_permutation(perm.begin(), perm.end()));
  glm::dmat3 r;
  for (int k = 0; k < 3; ++k) {
    glm::dvec3 axis = frame[std::size_t(best_perm[std::size_t(k)])];
    if (axis[k] < 0.0) axis = -axis;
    r[k] = axis;
  }
  if (glm::determinant(r) < 0.0) {
    int weakest = 0;
    for (int k = 1; k < 3; ++k)
      if (std::abs(r[k][k]) < std::abs(r[weakest][weakest])) weakest = k;
    r[weakest] = -r[weakest];
  }
  return r;
}

// Cell boundaries along one axis: lo, hi, the object's axis-aligned planes (clustered within
// `merge`, each cluster at its largest face) and even subdivisions of at most h between them;
// h grows until at most max_cells cells remain (uniform cells if the planes alone are too many).
std::vector<double> axis_lines(std::vector<std::pair<double, double>> planes, double lo, double hi, double h,
                               int max_cells, double merge) {
  std::sort(planes.begin(), planes.end());
  std::vector<double> fixed{lo};
  for (std::size_t i = 0; i < planes.size();) {
    std::size_t j = i, best = i;
    while (j < planes.size() && planes[j].first - planes[i].first <= merge) {
      if (planes[j].second > planes[best].second) best = j;
      ++j;
    }
    const double x = planes[best].first;
    if (x > lo + merge && x < hi - merge && x > fixed.back() + merge) fixed.push_back(x);
    i = j;
  }
  fixed.push_back(hi);
  auto parts = [&](double gap, double step) {
    return std::max(1, int(std::min(std::ceil(gap / step - 1e-9), 1e9)));
  };
  auto count = [&](double step) {
    long long n = 0;
    for (std::size_t i = 0; i + 1 < fixed.size(); ++i) n += parts(fixed[i + 1] - fixed[i], step);
    return n;
  };
  std::vector<double> lines;
  if (static_cast<long long>(fixed.size()) - 1 > max_cells) {
    const int n =
        std::max(1, int(std::min(double(max_cells), std::ceil((hi - lo) / std::min(h, hi - lo) - 1e-9))));
    for (int i = 0; i <= n; ++i) lines.push_back(i == n ? hi : lo + (hi - lo) * i / n);
    return lines;
  }
  double step = std::max(h, (hi - lo) / max_cells);
  while (count(step) > max_cells) step *= 1.1;
  for (std::size_t i = 0; i + 1 < fixed.size(); ++i) {
    const int n = parts(fixed[i + 1] - fixed[i], step);
    for (int k = 0; k < n; ++k) lines.push_back(fixed[i] + (fixed[i + 1] - fixed[i]) * k / n);
  }
  lines.push_back(hi);
  return lines;
}

// The voxel grid in the object's frame: cells with one cell of outside padding all round.
struct Grid {
  std::array<std::vector<double>, 3> lines;
  std::array<std::vector<double>, 3> centre;
  std::array<int, 3> n{};    // cells per axis
  std::array<int, 3> dim{};  // padded
  std::vector<std::uint8_t> inside;
  std::size_t at(int i, int j, int k) const {  // real cell indices, -1..n
    return (std::size_t(k + 1) * std::size_t(dim[1]) + std::size_t(j + 1)) * std::size_t(dim[0]) +
           std::size_t(i + 1);
  }
  bool in(const GridPoint& c) const { return inside[at(c[0], c[1], c[2])] != 0; }
  void set(const GridPoint& c) { inside[at(c[0], c[1], c[2])] = 1; }
  int cell_of(int axis, double x) const {  // the cell containing coordinate x (clamped)
    const std::vector<double>& l = lines[std::size_t(axis)];
    const int i = int(std::upper_bound(l.begin(), l.end(), x) - l.begin()) - 1;
    return std::clamp(i, 0, n[std::size_t(axis)] - 1);
  }
};

struct Interval {
  std::uint32_t column;
  double lo, hi;
};

// Crossings of the closed component's triangles with the lines along `axis` through the cell
// centres, paired by parity into the component's inside intervals. The point-in-triangle test
// is exact and watertight: edge functions are computed from the edge's welded endpoints in
// one canonical order, and points on an edge go to the side the top-left rule picks, so a
// line through a shared edge or vertex crosses the surface once (twice on a fold).
void component_intervals(int axis, const Grid& g, const std::vector<Tri>& tris,
                         const std::vector<glm::dvec3>& local, const std::vector<std::uint32_t>& component,
                         std::vector<Interval>& out) {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const std::vector<double>&cb = g.centre[std::size_t(b)], &cc = g.centre[std::size_t(c)];
  const int nc = g.n[std::size_t(c)];
  std::vector<std::pair<std::uint32_t, double>> crossings;
  for (std::uint32_t ti : component) {
    const Tri& t = tris[ti];
    std::array<glm::dvec2, 3> p;
    std::array<double, 3> h;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3& q = local[t.v[std::size_t(k)]];
      p[std::size_t(k)] = {q[b], q[c]};
      h[std::size_t(k)] = q[axis];
    }
    // Edge k runs from vertex k to k + 1; canonical endpoints (a, e) ordered by welded id.
    std::array<glm::dvec2, 3> ea, ed;
    std::array<double, 3> sign;
    for (int k = 0; k < 3; ++k) {
      const std::size_t k0 = std::size_t(k), k1 = std::size_t((k + 1) % 3);
      const bool forward = t.v[k0] < t.v[k1];
      ea[k0] = forward ? p[k0] : p[k1];
      ed[k0] = (forward ? p[k1] : p[k0]) - ea[k0];
      sign[k0] = forward ? 1.0 : -1.0;
    }
    auto edge = [&](int k, const glm::dvec2& q) {
      const std::size_t kk = std::size_t(k);
      const glm::dvec2 r = q - ea[kk];
      return sign[kk] * (ed[kk].x * r.y - ed[kk].y * r.x);
    };
    const double orient = edge(0, p[2]);
    if (orient == 0.0) continue;  // seen edge-on
    const double s = orient > 0.0 ? 1.0 : -1.0;
    std::array<bool, 3> top_left;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec2 d = s * (p[std::size_t((k + 1) % 3)] - p[std::size_t(k)]);
      top_left[std::size_t(k)] = d.y < 0.0 || (d.y == 0.0 && d.x < 0.0);
    }
    const double blo = std::min({p[0].x, p[1].x, p[2].x}), bhi = std::max({p[0].x, p[1].x, p[2].x});
    const double clo = std::min({p[0].y, p[1].y, p[2].y}), chi = std::max({p[0].y, p[1].y, p[2].y});
    const int i0 = int(std::lower_bound(cb.begin(), cb.end(), blo) - cb.begin());
    const int i1 = int(std::upper_bound(cb.begin(), cb.end(), bhi) - cb.begin());
    const int j0 = int(std::lower_bound(cc.begin(), cc.end(), clo) - cc.begin());
    const int j1 = int(std::upper_bound(cc.begin(), cc.end(), chi) - cc.begin());
    for (int i = i0; i < i1; ++i)
      for (int j = j0; j < j1; ++j) {
        const glm::dvec2 q{cb[std::size_t(i)], cc[std::size_t(j)]};
        std::array<double, 3> e;
        bool hit = true;
        for (int k = 0; k < 3 && hit; ++k) {
          e[std::size_t(k)] = s * edge(k, q);
          hit = e[std::size_t(k)] > 0.0 || (e[std::size_t(k)] == 0.0 && top_left[std::size_t(k)]);
        }
        if (!hit) continue;
        const double sum = e[0] + e[1] + e[2];
        // Edge k's function is the barycentric weight of the vertex opposite it.
        const double at = sum > 0.0 ? (e[0] * h[2] + e[1] * h[0] + e[2] * h[1]) / sum : h[0];
        crossings.emplace_back(std::uint32_t(i * nc + j), at);
      }
  }
  std::sort(crossings.begin(), crossings.end());
  for (std::size_t i = 0; i < crossings.size();) {
    std::size_t j = i;
    while (j < crossings.size() && crossings[j].first == crossings[i].first) ++j;
    for (std::size_t k = i; k + 1 < j; k += 2)
      out.push_back({crossings[i].first, crossings[k].second, crossings[k + 1].second});
    i = j;
  }
}

// 2x2x2 cell configurations (bit x + 2y + 4z set: inside) whose surface is a disk at the
// shared corner: inside and outside cells each face-connected within the 8.
std::array<bool, 256> manifold_configurations() {
  auto connected = [](int set) {
    if (set == 0) return true;
    int seen = set & -set, grow = seen;
    while (grow) {
      int next = 0;
      for (int c = 0; c < 8; ++c)
        if (grow & (1 << c))
          for (int d : {1, 2, 4}) next |= (1 << (c ^ d));
      next &= set & ~seen;
      seen |= next;
      grow = next;
    }
    return seen == set;
  };
  std::array<bool, 256> ok{};
  for (int m = 0; m < 256; ++m) ok[std::size_t(m)] = connected(m) && connected(~m & 255);
  return ok;
}

// Fills enclosed cavities and then the cells around every corner where the surface would not
// be a 2-manifold (only real cells: padding stays outside), until nothing changes. Returns
// the cells filled for the manifold.
std::size_t close_and_make_manifold(Grid& g) {
  static const std::array<bool, 256> ok = manifold_configurations();
  const int dx = g.dim[0], dy = g.dim[1], dz = g.dim[2];
  const std::size_t total = g.inside.size();
  std::vector<std::uint8_t> reached(total);
  std::vector<std::size_t> stack;
  std::size_t filled = 0;
  for (bool changed = true; changed;) {
    changed = false;
    std::fill(reached.begin(), reached.end(), 0);
    stack.assign(1, 0);  // a padding cell; the padding is one connected shell
    reached[0] = 1;
    while (!stack.empty()) {
      const std::size_t c = stack.back();
      stack.pop_back();
      const int i = int(c % std::size_t(dx)), j = int(c / std::size_t(dx) % std::size_t(dy)),
                k = int(c / (std::size_t(dx) * std::size_t(dy)));
      const std::array<std::pair<bool, std::size_t>, 6> next{
          {{i > 0, c - 1},
           {i + 1 < dx, c + 1},
           {j > 0, c - std::size_t(dx)},
           {j + 1 < dy, c + std::size_t(dx)},
           {k > 0, c - std::size_t(dx) * std::size_t(dy)},
           {k + 1 < dz, c + std::size_t(dx) * std::size_t(dy)}}};
      for (const auto& [valid, n] : next)
        if (valid && !reached[n] && !g.inside[n]) reached[n] = 1, stack.push_back(n);
    }
    for (std::size_t c = 0; c < total; ++c)
      if (!reached[c] && !g.inside[c]) g.inside[c] = 1;
    for (int k = 1; k < dz; ++k)
      for (int j = 1; j < dy; ++j)
        for (int i = 1; i < dx; ++i) {
          int mask = 0;
          std::array<std::size_t, 8> cell;
          for (int b = 0; b < 8; ++b) {
            cell[std::size_t(b)] =
                (std::size_t(k - 1 + (b >> 2)) * std::size_t(dy) + std::size_t(j - 1 + (b >> 1 & 1))) *
                    std::size_t(dx) +
                std::size_t(i - 1 + (b & 1));
            if (g.inside[cell[std::size_t(b)]]) mask |= 1 << b;
          }
          if (ok[std::size_t(mask)]) continue;
          for (int b = 0; b < 8; ++b) {
            const int ci = i - 1 + (b & 1), cj = j - 1 + (b >> 1 & 1), ck = k - 1 + (b >> 2);
            const bool padding =
                ci == 0 || cj == 0 || ck == 0 || ci == dx - 1 || cj == dy - 1 || ck == dz - 1;
            if (!padding && !g.inside[cell[std::size_t(b)]])
              g.inside[cell[std::size_t(b)]] = 1, changed = true, ++filled;
          }
        }
  }
  return filled;
}

struct Rect {
  int axis = 0, dir = 1, plane = 0;    // face normal dir * e_axis at grid line `plane`
  int u0 = 0, u1 = 0, v0 = 0, v1 = 0;  // grid lines along (axis + 1) % 3 and (axis + 2) % 3
  int chart = 0;
};

struct Chart {
  double u_lo = 0, v_lo = 0, w = 0, h = 0;  // metres in its plane
  int x = 0, y = 0;                         // packed cell origin (inside the gutter)
  bool rotated = false;
};

// The faces of one direction (normal dir * e_axis) as charts and rectangles. Seen along the
// normal, each cell column holds its faces in layers (the outermost first); faces of one layer
// in neighbouring columns join one chart when their planes are at most `step` apart (the
// treads of a staircase, a seat beside its arm rest only when close in height). A chart's UV
// map is the projection along its normal: isometric on each face, and one face per column, so
// a chart never overlaps itself. A chart filling less than `min_fill` of its bounding
// rectangle gives a chart per rectangle instead (packing bounds). Rectangles: greedy per plane
// and chart.
void direction_charts(const Grid& g, int axis, int dir, double step, double min_fill,
                      std::vector<Rect>& rects, std::vector<Chart>& charts) {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const int nu = g.n[std::size_t(b)], nv = g.n[std::size_t(c)], na = g.n[std::size_t(axis)];
  const std::vector<double>&la = g.lines[std::size_t(axis)], &lu = g.lines[std::size_t(b)],
        &lv = g.lines[std::size_t(c)];
  auto cell = [&](int layer, int u, int v) {
    GridPoint p{};
    p[std::size_t(axis)] = layer;
    p[std::size_t(b)] = u;
    p[std::size_t(c)] = v;
    return g.in(p);
  };
  // Faces column by column (v-major), outermost first: plane, and where each column starts.
  const std::size_t columns = std::size_t(nu) * std::size_t(nv);
  std::vector<int> plane_of;
  std::vector<std::size_t> column_start(columns + 1, 0);
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) {
      column_start[std::size_t(v) * std::size_t(nu) + std::size_t(u)] = plane_of.size();
      for (int k = 0; k <= na; ++k) {
        const int s = dir > 0 ? na - k : k;
        const bool face = dir > 0 ? cell(s - 1, u, v) && !cell(s, u, v) : cell(s, u, v) && !cell(s - 1, u, v);
        if (face) plane_of.push_back(s);
      }
    }
  column_start[columns] = plane_of.size();
  if (plane_of.empty()) return;
  auto face_at = [&](std::size_t column, std::size_t layer) {
    return column_start[column] + layer < column_start[column + 1] ? int(column_start[column] + layer) : -1;
  };
  std::vector<int> parent(plane_of.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<int> u_of(plane_of.size()), v_of(plane_of.size());
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) {
      const std::size_t col = std::size_t(v) * std::size_t(nu) + std::size_t(u);
      for (std::size_t f = column_start[col]; f < column_start[col + 1]; ++f) {
        u_of[f] = u, v_of[f] = v;
        const std::size_t layer = f - column_start[col];
        const std::array<std::pair<bool, std::size_t>, 2> next{
            {{u + 1 < nu, col + 1}, {v + 1 < nv, col + std::size_t(nu)}}};
        for (const auto& [valid, other] : next) {
          if (!valid) continue;
          const int o = face_at(other, layer);
          if (o >= 0 &&
              std::abs(la[std::size_t(plane_of[std::size_t(o)])] - la[std::size_t(plane_of[f])]) <= step)
            parent[std::size_t(find_root(parent, o))] = find_root(parent, int(f));
        }
      }
    }
  // Provisional charts in order of their first face; greedy rectangles per plane and chart.
  std::vector<int> group(plane_of.size());
  std::map<int, int> group_of_root;
  for (std::size_t f = 0; f < plane_of.size(); ++f)
    group[f] = group_of_root.try_emplace(find_root(parent, int(f)), int(group_of_root.size())).first->second;
  std::vector<std::vector<std::size_t>> by_plane(std::size_t(na) + 1);
  for (std::size_t f = 0; f < plane_of.size(); ++f) by_plane[std::size_t(plane_of[f])].push_back(f);
  std::vector<std::vector<Rect>> group_rects(group_of_root.size());
  std::vector<int> label(columns, -1);
  std::vector<std::uint8_t> used(columns, 0);
  for (int s = 0; s <= na; ++s) {
    if (by_plane[std::size_t(s)].empty()) continue;
    for (std::size_t f : by_plane[std::size_t(s)]) {
      const std::size_t col = std::size_t(v_of[f]) * std::size_t(nu) + std::size_t(u_of[f]);
      label[col] = group[f], used[col] = 0;
    }
    for (std::size_t f : by_plane[std::size_t(s)]) {  // faces in column order
      const int u0 = u_of[f], v0 = v_of[f], lab = group[f];
      if (used[std::size_t(v0) * std::size_t(nu) + std::size_t(u0)]) continue;
      auto free_cell = [&](int u, int v) {
        const std::size_t i = std::size_t(v) * std::size_t(nu) + std::size_t(u);
        return label[i] == lab && !used[i];
      };
      int u1 = u0 + 1;
      while (u1 < nu && free_cell(u1, v0)) ++u1;
      int v1 = v0 + 1;
      while (v1 < nv) {
        bool row = true;
        for (int u = u0; u < u1 && row; ++u) row = free_cell(u, v1);
        if (!row) break;
        ++v1;
      }
      for (int v = v0; v < v1; ++v)
        for (int u = u0; u < u1; ++u) used[std::size_t(v) * std::size_t(nu) + std::size_t(u)] = 1;
      group_rects[std::size_t(lab)].push_back({axis, dir, s, u0, u1, v0, v1, 0});
    }
    for (std::size_t f : by_plane[std::size_t(s)])
      label[std::size_t(v_of[f]) * std::size_t(nu) + std::size_t(u_of[f])] = -1;
  }
  for (std::vector<Rect>& list : group_rects) {
    double area = 0.0, u_lo = INFINITY, u_hi = -INFINITY, v_lo = INFINITY, v_hi = -INFINITY;
    for (const Rect& r : list) {
      area +=
          (lu[std::size_t(r.u1)] - lu[std::size_t(r.u0)]) * (lv[std::size_t(r.v1)] - lv[std::size_t(r.v0)]);
      u_lo = std::min(u_lo, lu[std::size_t(r.u0)]), u_hi = std::max(u_hi, lu[std::size_t(r.u1)]);
      v_lo = std::min(v_lo, lv[std::size_t(r.v0)]), v_hi = std::max(v_hi, lv[std::size_t(r.v1)]);
    }
    const bool one_chart = list.size() == 1 || area >= min_fill * (u_hi - u_lo) * (v_hi - v_lo);
    for (std::size_t i = 0; i < list.size(); ++i) {
      Rect rect = list[i];
      if (!one_chart || i == 0) {
        Chart ch;
        if (one_chart) {
          ch.u_lo = u_lo, ch.v_lo = v_lo, ch.w = u_hi - u_lo, ch.h = v_hi - v_lo;
        } else {
          ch.u_lo = lu[std::size_t(rect.u0)], ch.v_lo = lv[std::size_t(rect.v0)];
          ch.w = lu[std::size_t(rect.u1)] - ch.u_lo, ch.h = lv[std::size_t(rect.v1)] - ch.v_lo;
        }
        charts.push_back(ch);
      }
      rect.chart = int(charts.size()) - 1;
      rects.push_back(rect);
    }
  }
}

// Shelf packing at `scale` texels per metre into a res x res grid; every chart's cells with
// `gutter` empty cells around them. Fills x, y, rotated when everything fits.
bool shelf_pack(std::vector<Chart>& charts, double scale, int res, int gutter) {
  struct Item {
    int w, h;
    std::size_t chart;
    bool rotated;
  };
  std::vector<Item> items;
  items.reserve(charts.size());
  for (std::size_t i = 0; i < charts.size(); ++i) {
    const double fw = std::ceil(charts[i].w * scale - 1e-9), fh = std::ceil(charts[i].h * scale - 1e-9);
    if (!(fw <= res && fh <= res)) return false;
    int w = std::max(1, int(fw)) + 2 * gutter, h = std::max(1, int(fh)) + 2 * gutter;
    const bool rotated = h > w;
    if (rotated) std::swap(w, h);
    if (w > res || h > res) return false;
    items.push_back({w, h, i, rotated});
  }
  std::sort(items.begin(), items.end(), [](const Item& a, const Item& b) {
    return a.h != b.h ? a.h > b.h : a.w != b.w ? a.w > b.w : a.chart < b.chart;
  });
  int x = 0, y = 0, shelf = 0;
  for (const Item& it : items) {
    if (x + it.w > res) y += shelf, x = 0, shelf = 0;
    if (y + it.h > res) return false;
    Chart& c = charts[it.chart];
    c.x = x + gutter, c.y = y + gutter, c.rotated = it.rotated;
    x += it.w;
    shelf = std::max(shelf, it.h);
  }
  return true;
}

// Closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
glm::dvec3 closest_on_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                               const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// Nearest input triangle to each query point (a triangle not facing the query's axis costs
// `penalty` extra), through a uniform bin grid searched in growing rings.
class TriangleBins {
 public:
  TriangleBins(const std::vector<Tri>& tris, const std::vector<glm::dvec3>& world)
      : tris_(tris), world_(world) {
    lo_ = glm::dvec3(INFINITY), hi_ = glm::dvec3(-INFINITY);
    for (const Tri& t : tris)
      for (std::uint32_t v : t.v) lo_ = glm::min(lo_, world[v]), hi_ = glm::max(hi_, world[v]);
    const int n = std::clamp(int(std::cbrt(double(tris.size()))), 1, 32);
    const glm::dvec3 ext = glm::max(hi_ - lo_, glm::dvec3(1e-9));
    const double side = std::max({ext.x, ext.y, ext.z}) / n;
    for (int k = 0; k < 3; ++k) n_[std::size_t(k)] = std::clamp(int(std::ceil(ext[k] / side)), 1, 32);
    size_ = ext / glm::dvec3(n_[0], n_[1], n_[2]);
    bins_.assign(std::size_t(n_[0] * n_[1] * n_[2]), {});
    for (std::size_t t = 0; t < tris.size(); ++t) {
      glm::dvec3 a(INFINITY), b(-INFINITY);
      for (std::uint32_t v : tris[t].v) a = glm::min(a, world[v]), b = glm::max(b, world[v]);
      const glm::ivec3 i0 = bin(a), i1 = bin(b);
      for (int z = i0.z; z <= i1.z; ++z)
        for (int y = i0.y; y <= i1.y; ++y)
          for (int x = i0.x; x <= i1.x; ++x) bins_[index(x, y, z)].push_back(std::uint32_t(t));
    }
    stamp_.assign(tris.size(), 0);
  }

  std::uint32_t nearest(const glm::dvec3& p, const glm::dvec3& normal, double penalty) {
    ++query_;
    const glm::ivec3 c = bin(p);
    const double step = std::min({size_.x, size_.y, size_.z});
    double best = INFINITY;
    std::uint32_t best_t = 0;
    const int rings = std::max({n_[0], n_[1], n_[2]});
    for (int r = 0; r <= rings; ++r) {
      if (r > 0 && double(r - 1) * step > best) break;
      for (int z = c.z - r; z <= c.z + r; ++z)
        for (int y = c.y - r; y <= c.y + r; ++y)
          for (int x = c.x - r; x <= c.x + r; ++x) {
            if (std::max({std::abs(x - c.x), std::abs(y - c.y), std::abs(z - c.z)}) != r) continue;
            if (x < 0 || y < 0 || z < 0 || x >= n_[0] || y >= n_[1] || z >= n_[2]) continue;
            for (std::uint32_t t : bins_[index(x, y, z)]) {
              if (stamp_[t] == query_) continue;
              stamp_[t] = query_;
              const Tri& tri = tris_[t];
              const glm::dvec3 q =
                  closest_on_triangle(p, world_[tri.v[0]], world_[tri.v[1]], world_[tri.v[2]]);
              const double d =
                  glm::length(q - p) + (std::abs(glm::dot(tri.normal, normal)) < 0.7 ? penalty : 0.0);
              if (d < best || (d == best && t < best_t)) best = d, best_t = t;
            }
          }
    }
    return best_t;
  }

 private:
  glm::ivec3 bin(const glm::dvec3& p) const {
    const glm::dvec3 f = glm::floor((p - lo_) / size_);
    return glm::clamp(glm::ivec3(glm::clamp(f, glm::dvec3(-1.0), glm::dvec3(64.0))), glm::ivec3(0),
                      glm::ivec3(n_[0] - 1, n_[1] - 1, n_[2] - 1));
  }
  std::size_t index(int x, int y, int z) const {
    return (std::size_t(z) * std::size_t(n_[1]) + std::size_t(y)) * std::size_t(n_[0]) + std::size_t(x);
  }
  const std::vector<Tri>& tris_;
  const std::vector<glm::dvec3>& world_;
  glm::dvec3 lo_{0.0}, hi_{0.0}, size_{1.0};
  std::array<int, 3> n_{1, 1, 1};
  std::vector<std::vector<std::uint32_t>> bins_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t query_ = 0;
};

// Every edge (vertices welded by exact position) borders two triangles in opposite
// directions; otherwise the first offending edge.
std::string open_edge(const ClutterMesh& mesh) {
  std::map<std::array<double, 3>, std::uint32_t> weld;
  std::vector<std::uint32_t> id(mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::dvec3& p = mesh.positions[v];
    id[v] = weld.emplace(std::array<double, 3>{p.x, p.y, p.z}, std::uint32_t(weld.size())).first->second;
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> directed;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3)
    for (std::size_t k = 0; k < 3; ++k)
      directed.emplace_back(id[mesh.indices[t + k]], id[mesh.indices[t + (k + 1) % 3]]);
  std::sort(directed.begin(), directed.end());
  for (std::size_t i = 0; i < directed.size(); ++i) {
    const auto [a, b] = directed[i];
    const bool repeated = (i + 1 < directed.size() && directed[i + 1] == directed[i]);
    const bool reverse = std::binary_search(directed.begin(), directed.end(), std::pair{b, a});
    if (a == b || repeated || !reverse) {
      glm::dvec3 pa(0.0), pb(0.0);
      for (std::size_t v = 0; v < id.size(); ++v) {
        if (id[v] == a) pa = mesh.positions[v];
        if (id[v] == b) pb = mesh.positions[v];
      }
      return fmt(pa) + " - " + fmt(pb);
    }
  }
  return {};
}

}  // namespace

Result<ClutterImport> make_clutter_mesh_from_object(std::span<const glm::dvec3> positions,
                                                    std::span<const std::uint32_t> indices,
                                                    const ClutterImportSettings& settings,
                                                    const std::string& what) {
  // Settings.
  if (!(settings.res >= 1 && settings.res <= 1024))
    return bad(what, "res " + std::to_string(settings.res) + " is not 1..1024");
  if (!(settings.max_res >= 1 && settings.max_res <= 1024))
    return bad(what, "max_res " + std::to_string(settings.max_res) + " is not 1..1024");
  if (!(settings.gutter >= 0 && settings.gutter <= 8))
    return bad(what, "gutter " + std::to_string(settings.gutter) + " is not 0..8");
  if (!(std::isfinite(settings.texels_per_metre) && settings.texels_per_metre >= 0.0))
    return bad(what, "texels_per_metre " + fmt(settings.texels_per_metre) + " is not finite and >= 0");
  if (!(std::isfinite(settings.voxel_size) && settings.voxel_size > 0.0))
    return bad(what, "voxel_size " + fmt(settings.voxel_size) + " is not finite and > 0");
  if (!(settings.max_cells >= 2 && settings.max_cells <= 512))
    return bad(what, "max_cells " + std::to_string(settings.max_cells) + " is not 2..512");
  if (!(std::isfinite(settings.plane_merge) && settings.plane_merge >= 0.0 &&
        std::isfinite(settings.weld_distance) && settings.weld_distance >= 0.0 &&
        std::isfinite(settings.chart_step) && settings.chart_step >= 0.0))
    return bad(what, "plane_merge, weld_distance and chart_step must be finite and >= 0");

  // Input.
  if (indices.empty()) return bad(what, "no triangles");
  if (indices.size() % 3 != 0)
    return bad(what, std::to_string(indices.size()) + " indices is not a multiple of 3");
  const std::size_t input_triangles = indices.size() / 3;
  if (input_triangles > settings.max_triangles)
    return Status::error(ErrorCode::resource_limit, what + ": " + std::to_string(input_triangles) +
                                                        " triangles, more than the limit of " +
                                                        std::to_string(settings.max_triangles));
  std::vector<char> used(positions.size(), 0);
  for (std::size_t i = 0; i < indices.size(); ++i) {
    if (indices[i] >= positions.size())
      return bad(what, "triangle " + std::to_string(i / 3) + " uses vertex " + std::to_string(indices[i]) +
                           ", the object has " + std::to_string(positions.size()));
    used[indices[i]] = 1;
  }
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (std::size_t v = 0; v < positions.size(); ++v) {
    if (!used[v]) continue;
    const glm::dvec3& p = positions[v];
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)))
      return bad(what, "vertex " + std::to_string(v) + " has a NaN or Inf position");
    if (std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) > 1e30)
      return bad(what, "vertex " + std::to_string(v) + " lies beyond float range (|coordinate| > 1e30)");
    lo = glm::min(lo, p), hi = glm::max(hi, p);
  }
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  if (!(extent > 0.0)) return bad(what, "all vertices lie at one point " + fmt(lo));

  // 1. Weld; drop degenerate triangles; components through shared edges; closedness.
  std::vector<glm::dvec3> world;
  const std::vector<std::uint32_t> id =
      weld(positions, used, lo, std::max(settings.weld_distance, extent * 1e-9), world);
  std::vector<Tri> tris;
  ClutterImport out;
  for (std::size_t t = 0; t < input_triangles; ++t) {
    Tri tri;
    for (std::size_t k = 0; k < 3; ++k) tri.v[k] = id[indices[3 * t + k]];
    tri.source = std::uint32_t(t);
    const glm::dvec3 n = glm::cross(world[tri.v[1]] - world[tri.v[0]], world[tri.v[2]] - world[tri.v[0]]);
    tri.area = 0.5 * glm::length(n);
    if (tri.v[0] == tri.v[1] || tri.v[1] == tri.v[2] || tri.v[0] == tri.v[2] ||
        !(tri.area > 1e-18 * extent * extent)) {
      ++out.skipped_triangles;
      continue;
    }
    tri.normal = n / (2.0 * tri.area);
    tris.push_back(tri);
  }
  if (tris.empty()) return bad(what, "every triangle is degenerate (zero area after welding)");
  std::vector<std::array<std::uint32_t, 3>> edges;  // (low vertex, high vertex, triangle)
  edges.reserve(3 * tris.size());
  for (std::size_t t = 0; t < tris.size(); ++t)
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t a = tris[t].v[k], b = tris[t].v[(k + 1) % 3];
      edges.push_back({std::min(a, b), std::max(a, b), std::uint32_t(t)});
    }
  std::sort(edges.begin(), edges.end());
  // Triangles join through edges that exactly two triangles use: boxes that merely share an
  // edge (four uses) stay apart, so each part's parity is its own (union, not exclusive or).
  std::vector<int> parent(tris.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j][0] == edges[i][0] && edges[j][1] == edges[i][1]) ++j;
    if (j - i == 2)
      parent[std::size_t(find_root(parent, int(edges[i + 1][2])))] = find_root(parent, int(edges[i][2]));
    i = j;
  }
  std::map<int, std::size_t> component_of_root;
  std::vector<std::vector<std::uint32_t>> components;
  std::vector<std::size_t> component_of(tris.size());
  for (std::size_t t = 0; t < tris.size(); ++t) {
    const auto [it, inserted] = component_of_root.emplace(find_root(parent, int(t)), components.size());
    if (inserted) components.emplace_back();
    components[it->second].push_back(std::uint32_t(t));
    component_of[t] = it->second;
  }
  // Closed: each edge borders an even number of the component's triangles.
  std::vector<char> open(components.size(), 0);
  std::size_t open_edge_at = edges.size();
  std::vector<std::size_t> uses;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    uses.clear();
    while (j < edges.size() && edges[j][0] == edges[i][0] && edges[j][1] == edges[i][1])
      uses.push_back(component_of[edges[j++][2]]);
    std::sort(uses.begin(), uses.end());
    for (std::size_t k = 0; k < uses.size();) {
      std::size_t m = k;
      while (m < uses.size() && uses[m] == uses[k]) ++m;
      if ((m - k) % 2 == 1) {
        open[uses[k]] = 1;
        if (open_edge_at == edges.size()) open_edge_at = i;
      }
      k = m;
    }
    i = j;
  }
  out.components = int(components.size());
  out.open_components = int(std::count(open.begin(), open.end(), 1));
  if (out.open_components > 0 && settings.open_surfaces == Settings::OpenSurfaces::refuse) {
    const auto& e = edges[open_edge_at];
    return bad(what, std::to_string(out.open_components) + " of " + std::to_string(components.size()) +
                         " parts are not closed (the edge " + fmt(world[e[0]]) + " - " + fmt(world[e[1]]) +
                         " borders an odd number of triangles); close them or let the importer thicken them");
  }

  // 2. Frame and local coordinates (origin: the bounds' centre).
  const glm::dmat3 frame = settings.align_to_object ? object_frame(tris) : glm::dmat3(1.0);
  const glm::dmat3 to_local = glm::transpose(frame);
  const glm::dvec3 origin = 0.5 * (lo + hi);
  std::vector<glm::dvec3> local(world.size());
  glm::dvec3 llo(INFINITY), lhi(-INFINITY);
  for (std::size_t v = 0; v < world.size(); ++v) {
    local[v] = to_local * (world[v] - origin);
    llo = glm::min(llo, local[v]), lhi = glm::max(lhi, local[v]);
  }

  // 3. and 4. Grid and inside cells. A union of boxes in the frame needs no cells between its
  // planes, unless joining parts that touch only along an edge would fill such large cells:
  // then it is voxelized again with subdivisions.
  std::array<std::vector<std::pair<double, double>>, 3> planes;
  bool all_aligned = true;
  for (const Tri& t : tris) {
    const glm::dvec3 n = to_local * t.normal;
    bool aligned = false;
    for (int k = 0; k < 3; ++k)
      if (std::abs(n[k]) > 1.0 - 1e-9) {
        planes[std::size_t(k)].emplace_back((local[t.v[0]][k] + local[t.v[1]][k] + local[t.v[2]][k]) / 3.0,
                                            t.area);
        aligned = true;
      }
    all_aligned = all_aligned && aligned;
  }
  Grid g;
  auto voxelize = [&](bool subdivide) {
    g = Grid{};
    out.cell_size = 0.0;
    const double local_extent = std::max({lhi.x - llo.x, lhi.y - llo.y, lhi.z - llo.z});
    for (int k = 0; k < 3; ++k) {
      double a = llo[k], b = lhi[k];
      if (b - a <= 1e-6 * local_extent) {  // a flat sheet: one cell of voxel_size across it
        const double mid = 0.5 * (a + b);
        a = mid - 0.5 * settings.voxel_size, b = mid + 0.5 * settings.voxel_size;
      }
      g.lines[std::size_t(k)] =
          axis_lines(planes[std::size_t(k)], a, b, subdivide ? settings.voxel_size : INFINITY,
                     settings.max_cells, std::min(settings.plane_merge, 0.01 * local_extent));
      std::vector<double>& l = g.lines[std::size_t(k)];
      g.n[std::size_t(k)] = int(l.size()) - 1;
      g.dim[std::size_t(k)] = g.n[std::size_t(k)] + 2;
      for (std::size_t i = 0; i + 1 < l.size(); ++i) {
        g.centre[std::size_t(k)].push_back(0.5 * (l[i] + l[i + 1]));
        out.cell_size = std::max(out.cell_size, l[i + 1] - l[i]);
      }
    }
    g.inside.assign(std::size_t(g.dim[0]) * std::size_t(g.dim[1]) * std::size_t(g.dim[2]), 0);
    out.frame = frame;
    out.cells = glm::ivec3(g.n[0], g.n[1], g.n[2]);

    // 4. Inside: centres by parity along axis 1, thin spans along every axis; open parts' shells.
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<Interval> spans;
      for (std::size_t c = 0; c < components.size(); ++c)
        if (!open[c]) component_intervals(axis, g, tris, local, components[c], spans);
      std::sort(spans.begin(), spans.end(), [](const Interval& a, const Interval& b) {
        return a.column != b.column ? a.column < b.column : a.lo != b.lo ? a.lo < b.lo : a.hi < b.hi;
      });
      const int b = (axis + 1) % 3, c = (axis + 2) % 3;
      const int nc = g.n[std::size_t(c)];
      const std::vector<double>& centres = g.centre[std::size_t(axis)];
      auto mark = [&](const Interval& s) {
        if (!(s.hi - s.lo > 1e-9 * extent)) return;  // a ray grazing an edge or a vertex
        GridPoint cell{};
        cell[std::size_t(b)] = int(s.column) / nc;
        cell[std::size_t(c)] = int(s.column) % nc;
        const int k0 = int(std::lower_bound(centres.begin(), centres.end(), s.lo) - centres.begin());
        const int k1 = int(std::upper_bound(centres.begin(), centres.end(), s.hi) - centres.begin());
        if (k0 >= k1) {  // too thin to hold a centre: the cell holding its middle
          cell[std::size_t(axis)] = g.cell_of(axis, 0.5 * (s.lo + s.hi));
          g.set(cell);
        } else if (axis == 1) {
          for (int k = k0; k < k1; ++k) cell[std::size_t(axis)] = k, g.set(cell);
        }
      };
      for (std::size_t i = 0; i < spans.size();) {  // union of the components' intervals
        Interval merged = spans[i++];
        while (i < spans.size() && spans[i].column == merged.column && spans[i].lo <= merged.hi)
          merged.hi = std::max(merged.hi, spans[i++].hi);
        mark(merged);
      }
    }
    double min_cell = INFINITY;
    for (int k = 0; k < 3; ++k)
      for (std::size_t i = 0; i + 1 < g.lines[std::size_t(k)].size(); ++i)
        min_cell = std::min(min_cell, g.lines[std::size_t(k)][i + 1] - g.lines[std::size_t(k)][i]);
    for (std::size_t c = 0; c < components.size(); ++c) {
      if (!open[c]) continue;
      for (std::uint32_t ti : components[c]) {
        const Tri& t = tris[ti];
        const glm::dvec3 &p0 = local[t.v[0]], &p1 = local[t.v[1]], &p2 = local[t.v[2]];
        const double longest = std::max({glm::length(p1 - p0), glm::length(p2 - p1), glm::length(p0 - p2)});
        const int n =
            std::clamp(int(std::min(std::ceil(longest / (0.5 * min_cell)), 1e6)), 1, 2 * settings.max_cells);
        for (int i = 0; i <= n; ++i)
          for (int j = 0; i + j <= n; ++j) {
            const glm::dvec3 q = p0 + (p1 - p0) * (double(i) / n) + (p2 - p0) * (double(j) / n);
            // A point on a grid line marks the cells on both sides (a sheet on a plane of the
            // grid is thickened symmetrically).
            std::array<std::array<int, 2>, 3> cand;
            for (int k = 0; k < 3; ++k) {
              const int cell = g.cell_of(k, q[k]);
              const bool on_line = cell > 0 && q[k] == g.lines[std::size_t(k)][std::size_t(cell)];
              cand[std::size_t(k)] = {cell, on_line ? cell - 1 : cell};
            }
            for (int m = 0; m < 8; ++m)
              g.set({cand[0][std::size_t(m & 1)], cand[1][std::size_t(m >> 1 & 1)],
                     cand[2][std::size_t(m >> 2)]});
          }
      }
    }
    return close_and_make_manifold(g);
  };
  if (voxelize(!all_aligned) > 0 && all_aligned) voxelize(true);
  if (std::none_of(g.inside.begin(), g.inside.end(), [](std::uint8_t x) { return x != 0; }))
    return bad(what, "nothing of the object is solid at a " + fmt(out.cell_size) +
                         " m cell (its closed parts hold no cell centre)");

  // 5. and 6. Charts, rectangles and their packing. Charts as the settings ask; when they fill
  // less than a quarter of the atlas (many small charts of a curved or clustered object: each
  // has its gutter), charts joined across higher steps, then across any step, and the result
  // that fills the atlas best.
  std::vector<Rect> rects;
  std::vector<Chart> charts;
  int res = settings.res;
  double scale = 0.0;
  {
    struct Attempt {
      double step, min_fill;
    };
    const std::array<Attempt, 3> attempts{
        {{settings.chart_step, 0.5}, {4.0 * settings.chart_step + 0.1, 0.5}, {INFINITY, 0.0}}};
    double best_use = -1.0;
    Status failure;
    for (const Attempt& attempt : attempts) {
      std::vector<Rect> try_rects;
      std::vector<Chart> try_charts;
      for (int axis = 0; axis < 3; ++axis)
        for (int dir : {1, -1})
          direction_charts(g, axis, dir, attempt.step, attempt.min_fill, try_rects, try_charts);
      double chart_area = 0.0;
      for (const Chart& c : try_charts) chart_area += c.w * c.h;
      int try_res = settings.res;
      double try_scale = 0.0;
      if (settings.texels_per_metre > 0.0) {
        try_scale = settings.texels_per_metre;
        try_res = std::clamp(int(std::floor(std::sqrt(chart_area) * try_scale)), 1, settings.max_res);
        while (try_res <= settings.max_res && !shelf_pack(try_charts, try_scale, try_res, settings.gutter))
          ++try_res;
        if (try_res > settings.max_res) {
          failure = Status::error(ErrorCode::resource_limit,
                                  what + ": " + std::to_string(try_charts.size()) + " charts at " +
                                      fmt(try_scale) + " texels per metre do not fit a " +
                                      std::to_string(settings.max_res) + "^2 atlas");
          continue;
        }
      } else {
        double s_lo = 1e-9, s_hi = 2.0 * try_res / std::sqrt(chart_area);
        if (!shelf_pack(try_charts, s_lo, try_res, settings.gutter)) {
          failure = Status::error(ErrorCode::resource_limit,
                                  what + ": " + std::to_string(try_charts.size()) +
                                      " charts (with a gutter of " + std::to_string(settings.gutter) +
                                      ") do not fit a " + std::to_string(try_res) +
                                      "^2 atlas even at one texel each; raise res or voxel_size");
          continue;
        }
        for (int it = 0; it < 50; ++it) {
          const double mid = 0.5 * (s_lo + s_hi);
          (shelf_pack(try_charts, mid, try_res, settings.gutter) ? s_lo : s_hi) = mid;
        }
        try_scale = s_lo;
        shelf_pack(try_charts, try_scale, try_res, settings.gutter);
      }
      // Chart texels over atlas texels.
      double surface = 0.0;
      for (const Rect& r : try_rects) {
        const int b = (r.axis + 1) % 3, c = (r.axis + 2) % 3;
        surface += (g.lines[std::size_t(b)][std::size_t(r.u1)] - g.lines[std::size_t(b)][std::size_t(r.u0)]) *
                   (g.lines[std::size_t(c)][std::size_t(r.v1)] - g.lines[std::size_t(c)][std::size_t(r.v0)]);
      }
      const double use = surface * try_scale * try_scale / (double(try_res) * double(try_res));
      if (use > best_use) {
        best_use = use;
        rects = std::move(try_rects), charts = std::move(try_charts);
        res = try_res, scale = try_scale;
      }
      if (use >= 0.25) break;
    }
    if (best_use < 0.0) return failure;
  }
  out.chart_count = int(charts.size());
  out.res = res;
  out.texels_per_metre = scale;

  // Output mesh: rectangles triangulated through every rectangle corner on their edges.
  auto grid_point = [](int axis, int plane, int u, int v) {
    GridPoint p{};
    p[std::size_t(axis)] = plane;
    p[std::size_t((axis + 1) % 3)] = u;
    p[std::size_t((axis + 2) % 3)] = v;
    return p;
  };
  auto corners = [&](const Rect& r) {
    std::array<GridPoint, 4> c{
        grid_point(r.axis, r.plane, r.u0, r.v0), grid_point(r.axis, r.plane, r.u1, r.v0),
        grid_point(r.axis, r.plane, r.u1, r.v1), grid_point(r.axis, r.plane, r.u0, r.v1)};
    if (r.dir < 0) std::swap(c[1], c[3]);  // counter-clockwise seen from outside
    return c;
  };
  auto edge_axis = [](const GridPoint& a, const GridPoint& b) {
    int d = 0;
    while (a[std::size_t(d)] == b[std::size_t(d)]) ++d;
    return d;
  };
  auto line_of = [](int d, const GridPoint& p) {
    return std::array<int, 3>{d, p[std::size_t((d + 1) % 3)], p[std::size_t((d + 2) % 3)]};
  };
  // Grid lines carrying rectangle edges. Within a chart, faces on different planes meet in UV
  // though not in space (the treads of a stair): their shared UV edges must be split at the
  // same points, or the chart would fall apart into UV islands (separate DRT charts). Lines
  // whose edges overlap on one UV line of a chart therefore share their points, transitively
  // (those points then split the neighbouring charts' edges too, keeping the mesh closed).
  std::map<std::array<int, 3>, int> line_id;
  std::vector<int> line_parent;
  {
    struct UvEdge {
      std::array<int, 3> uv_line;  // chart, axis, fixed in-plane index
      int p0, p1, line;
      bool operator<(const UvEdge& o) const {
        return uv_line != o.uv_line ? uv_line < o.uv_line : p0 != o.p0 ? p0 < o.p0 : line < o.line;
      }
    };
    std::vector<UvEdge> uv_edges;
    for (const Rect& r : rects) {
      const std::array<GridPoint, 4> c = corners(r);
      for (std::size_t k = 0; k < 4; ++k) {
        const GridPoint &a = c[k], &b = c[(k + 1) % 4];
        const int d = edge_axis(a, b);
        const auto [it, inserted] = line_id.try_emplace(line_of(d, a), int(line_parent.size()));
        if (inserted) line_parent.push_back(it->second);
        const int in_plane = d == (r.axis + 1) % 3 ? (r.axis + 2) % 3 : (r.axis + 1) % 3;
        uv_edges.push_back({{r.chart, d, a[std::size_t(in_plane)]},
                            std::min(a[std::size_t(d)], b[std::size_t(d)]),
                            std::max(a[std::size_t(d)], b[std::size_t(d)]),
                            it->second});
      }
    }
    std::sort(uv_edges.begin(), uv_edges.end());
    for (std::size_t i = 0; i < uv_edges.size();) {
      std::size_t j = i + 1;
      int reach = uv_edges[i].p1;
      while (j < uv_edges.size() && uv_edges[j].uv_line == uv_edges[i].uv_line && uv_edges[j].p0 < reach) {
        line_parent[std::size_t(find_root(line_parent, uv_edges[j].line))] =
            find_root(line_parent, uv_edges[i].line);
        reach = std::max(reach, uv_edges[j].p1);
        ++j;
      }
      i = j;
    }
  }
  // Each class of lines: the positions of every rectangle corner on its lines.
  std::vector<std::vector<int>> class_points(line_parent.size());
  for (const Rect& r : rects)
    for (const GridPoint& p : corners(r))
      for (int d = 0; d < 3; ++d)
        if (const auto it = line_id.find(line_of(d, p)); it != line_id.end())
          class_points[std::size_t(find_root(line_parent, it->second))].push_back(p[std::size_t(d)]);
  for (std::vector<int>& points : class_points) {
    std::sort(points.begin(), points.end());
    points.erase(std::unique(points.begin(), points.end()), points.end());
  }
  auto local_point = [&](const GridPoint& p) {
    return glm::dvec3(g.lines[0][std::size_t(p[0])], g.lines[1][std::size_t(p[1])],
                      g.lines[2][std::size_t(p[2])]);
  };
  auto to_world = [&](const glm::dvec3& l) { return origin + frame * l; };
  std::map<std::pair<int, GridPoint>, std::uint32_t> vertex_of;
  auto add_vertex = [&](const Rect& r, const glm::dvec3& l) {
    const Chart& c = charts[std::size_t(r.chart)];
    double pu = l[(r.axis + 1) % 3] - c.u_lo, pv = l[(r.axis + 2) % 3] - c.v_lo;
    if (c.rotated) std::swap(pu, pv);
    out.mesh.positions.push_back(to_world(l));
    out.mesh.uvs.push_back(
        glm::clamp(glm::dvec2((c.x + pu * scale) / res, (c.y + pv * scale) / res), 0.0, 1.0));
    glm::dvec3 n(0.0);
    n[r.axis] = r.dir;
    out.normals.push_back(frame * n);
    return std::uint32_t(out.mesh.positions.size() - 1);
  };
  auto vertex = [&](const Rect& r, const GridPoint& p) {
    const auto [it, inserted] = vertex_of.try_emplace({r.chart, p}, 0);
    if (inserted) it->second = add_vertex(r, local_point(p));
    return it->second;
  };
  for (const Rect& r : rects) {
    const std::array<GridPoint, 4> c = corners(r);
    // The boundary: each corner, then the grid points strictly inside the edge to the next.
    std::vector<GridPoint> ring;
    std::array<bool, 4> split{};
    for (std::size_t k = 0; k < 4; ++k) {
      ring.push_back(c[k]);
      const GridPoint &a = c[k], &b = c[(k + 1) % 4];
      const int d = edge_axis(a, b);
      const std::vector<int>& points =
          class_points[std::size_t(find_root(line_parent, line_id.at(line_of(d, a))))];
      const int p0 = std::min(a[std::size_t(d)], b[std::size_t(d)]),
                p1 = std::max(a[std::size_t(d)], b[std::size_t(d)]);
      std::vector<GridPoint> mid;
      for (auto it = std::upper_bound(points.begin(), points.end(), p0); it != points.end() && *it < p1;
           ++it) {
        GridPoint q = a;
        q[std::size_t(d)] = *it;
        mid.push_back(q);
      }
      if (a[std::size_t(d)] > b[std::size_t(d)]) std::reverse(mid.begin(), mid.end());
      split[k] = !mid.empty();
      ring.insert(ring.end(), mid.begin(), mid.end());
    }
    std::vector<std::uint32_t> ids;
    for (const GridPoint& p : ring) ids.push_back(vertex(r, p));
    auto triangle = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c2) {
      out.mesh.indices.insert(out.mesh.indices.end(), {a, b, c2});
    };
    // Fan from a corner whose two edges are not split (their far edges hold every extra
    // point, so no fan triangle is degenerate), or from the rectangle's centre.
    int fan = -1;
    for (int k = 0; k < 4 && fan < 0; ++k)
      if (!split[std::size_t(k)] && !split[std::size_t((k + 3) % 4)]) fan = k;
    const std::size_t m = ring.size();
    if (fan >= 0) {
      std::size_t start = 0;
      while (ring[start] != c[std::size_t(fan)]) ++start;
      for (std::size_t i = 1; i + 1 < m; ++i)
        triangle(ids[start], ids[(start + i) % m], ids[(start + i + 1) % m]);
    } else {
      const glm::dvec3 centre = 0.5 * (local_point(c[0]) + local_point(c[2]));
      const std::uint32_t mid = add_vertex(r, centre);
      for (std::size_t i = 0; i < m; ++i) triangle(mid, ids[i], ids[(i + 1) % m]);
    }
  }

  if (const std::string edge = open_edge(out.mesh); !edge.empty())
    return Status::error(ErrorCode::internal_error,
                         what + ": the generated clutter mesh is not closed at the edge " + edge);
  // Volume and centroid (tetrahedra against the origin of the bounds).
  glm::dvec3 moment(0.0);
  for (std::size_t t = 0; t < out.mesh.indices.size(); t += 3) {
    const glm::dvec3 a = out.mesh.positions[out.mesh.indices[t]] - origin,
                     b = out.mesh.positions[out.mesh.indices[t + 1]] - origin,
                     c = out.mesh.positions[out.mesh.indices[t + 2]] - origin;
    const double v = glm::dot(a, glm::cross(b, c)) / 6.0;
    out.volume += v;
    moment += v * (a + b + c) / 4.0;
  }
  out.centroid = origin + (out.volume > 0.0 ? moment / out.volume : glm::dvec3(0.0));

  // Source triangles for materials and texture coordinates.
  TriangleBins bins(tris, world);
  out.source_triangle.reserve(out.mesh.indices.size() / 3);
  for (std::size_t t = 0; t < out.mesh.indices.size(); t += 3) {
    const glm::dvec3 centre =
        (out.mesh.positions[out.mesh.indices[t]] + out.mesh.positions[out.mesh.indices[t + 1]] +
         out.mesh.positions[out.mesh.indices[t + 2]]) /
        3.0;
    const std::uint32_t nearest = bins.nearest(centre, out.normals[out.mesh.indices[t]], 2.0 * out.cell_size);
    out.source_triangle.push_back(tris[nearest].source);
  }
  return out;
}

int clutter_owner_block(const LevelDescription& level, const glm::dvec3& p) {
  int best = -1;
  double best_outside = INFINITY;
  for (std::size_t b = 0; b < level.blocks.size(); ++b) {
    const std::array<glm::dvec3, 8> c = block_corners(level, level.blocks[b]);
    // Newton on the trilinear warp from the centre, Jacobian by its partial derivatives.
    glm::dvec3 q(0.5);
    for (int it = 0; it < 24; ++it) {
      const double x = q.x, y = q.y, z = q.z;
      const glm::dvec3 dx = (1 - y) * (1 - z) * (c[1] - c[0]) + y * (1 - z) * (c[3] - c[2]) +
                            (1 - y) * z * (c[5] - c[4]) + y * z * (c[7] - c[6]);
      const glm::dvec3 dy = (1 - x) * (1 - z) * (c[2] - c[0]) + x * (1 - z) * (c[3] - c[1]) +
                            (1 - x) * z * (c[6] - c[4]) + x * z * (c[7] - c[5]);
      const glm::dvec3 dz = (1 - x) * (1 - y) * (c[4] - c[0]) + x * (1 - y) * (c[5] - c[1]) +
                            (1 - x) * y * (c[6] - c[2]) + x * y * (c[7] - c[3]);
      const glm::dmat3 jac(dx, dy, dz);
      if (!(std::abs(glm::determinant(jac)) > 0.0)) break;
      const glm::dvec3 step = glm::inverse(jac) * (trilinear(c, q) - p);
      q -= step;
      if (!(glm::length(step) > 1e-13)) break;
    }
    if (!(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z))) continue;
    const double outside = glm::length(glm::max(glm::dvec3(0.0), -q) + glm::max(glm::dvec3(0.0), q - 1.0));
    if (outside < best_outside) best_outside = outside, best = int(b);
  }
  return best;
}

}  // namespace modrt::precompute
