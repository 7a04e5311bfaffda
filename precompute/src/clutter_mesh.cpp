#include "modrt/precompute/clutter_mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>

#include <glm/geometric.hpp>

namespace modrt::precompute {
namespace {

using Polygon = std::vector<glm::dvec2>;

double cross2(const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; }

double polygon_area(const Polygon& p) {
  double a = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) a += cross2(p[i], p[(i + 1) % p.size()]);
  return 0.5 * std::abs(a);
}

// Sutherland–Hodgman: the part of `p` on the side of the line where (q - o)·n >= 0.
Polygon clip(const Polygon& p, const glm::dvec2& o, const glm::dvec2& n) {
  Polygon out;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const glm::dvec2 &a = p[i], &b = p[(i + 1) % p.size()];
    const double da = glm::dot(a - o, n), db = glm::dot(b - o, n);
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

// UV area of a triangle inside the square [x0, x1] x [y0, y1].
double overlap_area(const std::array<glm::dvec2, 3>& t, double x0, double y0, double x1, double y1) {
  Polygon p(t.begin(), t.end());
  p = clip(p, {x0, 0}, {1, 0});
  if (p.size() >= 3) p = clip(p, {x1, 0}, {-1, 0});
  if (p.size() >= 3) p = clip(p, {0, y0}, {0, 1});
  if (p.size() >= 3) p = clip(p, {0, y1}, {0, -1});
  return p.size() >= 3 ? polygon_area(p) : 0.0;
}

// Barycentric coordinates of q in the UV triangle (signed area `area2` = twice its area).
glm::dvec3 barycentric(const std::array<glm::dvec2, 3>& t, double area2, const glm::dvec2& q) {
  const double w0 = cross2(t[1] - q, t[2] - q) / area2;
  const double w1 = cross2(t[2] - q, t[0] - q) / area2;
  return {w0, w1, 1.0 - w0 - w1};
}

glm::dvec2 closest_on_segment(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& q) {
  const glm::dvec2 d = b - a;
  const double t = std::clamp(glm::dot(q - a, d) / glm::dot(d, d), 0.0, 1.0);
  return a + d * t;
}

// The point of the UV triangle closest to q.
glm::dvec2 closest_in_triangle(const std::array<glm::dvec2, 3>& t, double area2, const glm::dvec2& q) {
  const glm::dvec3 w = barycentric(t, area2, q);
  if (w.x >= 0 && w.y >= 0 && w.z >= 0) return q;
  glm::dvec2 best = t[0];
  double best_d = INFINITY;
  for (int e = 0; e < 3; ++e) {
    const glm::dvec2 c = closest_on_segment(t[std::size_t(e)], t[std::size_t((e + 1) % 3)], q);
    const double d = glm::dot(c - q, c - q);
    if (d < best_d) best_d = d, best = c;
  }
  return best;
}

struct Triangle {
  std::array<glm::dvec2, 3> uv;
  std::array<glm::dvec3, 3> p;
  double uv_area2 = 0;      // signed, twice the UV area
  double world_per_uv = 0;  // world area / UV area
  glm::dvec3 normal{0};
};

int find_root(std::vector<int>& parent, int i) {
  while (parent[std::size_t(i)] != i)
    i = parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
  return i;
}

Status bad(const std::string& what, const std::string& problem) {
  return Status::error(ErrorCode::invalid_argument, what + ": " + problem);
}

}  // namespace

Result<ClutterMeshAtlas> rasterize_clutter_mesh(const ClutterMesh& mesh, int res, const std::string& what) {
  if (res < 1 || res > 1024) return bad(what, "res " + std::to_string(res) + " is not 1..1024");
  if (mesh.uvs.size() != mesh.positions.size())
    return bad(what, std::to_string(mesh.positions.size()) + " positions but " +
                         std::to_string(mesh.uvs.size()) + " lightmap UVs (one per position needed)");
  if (mesh.indices.empty() || mesh.indices.size() % 3 != 0)
    return bad(what, std::to_string(mesh.indices.size()) + " indices is not a positive multiple of 3");
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::dvec3& p = mesh.positions[v];
    const glm::dvec2& uv = mesh.uvs[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(uv.x) ||
        !std::isfinite(uv.y))
      return bad(what, "vertex " + std::to_string(v) + " has a NaN or Inf position or UV");
    if (uv.x < 0 || uv.x > 1 || uv.y < 0 || uv.y > 1)
      return bad(what, "vertex " + std::to_string(v) + ": UV (" + std::to_string(uv.x) + ", " +
                           std::to_string(uv.y) + ") is outside [0, 1]");
  }
  const std::size_t triangle_count = mesh.indices.size() / 3;
  std::vector<Triangle> tris(triangle_count);
  for (std::size_t t = 0; t < triangle_count; ++t) {
    Triangle& tri = tris[t];
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.indices[3 * t + k];
      if (v >= mesh.positions.size())
        return bad(what, "triangle " + std::to_string(t) + " uses vertex " + std::to_string(v) +
                             ", the mesh has " + std::to_string(mesh.positions.size()));
      tri.uv[k] = mesh.uvs[v];
      tri.p[k] = mesh.positions[v];
    }
    const glm::dvec3 n = glm::cross(tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
    const double world_area = 0.5 * glm::length(n);
    tri.uv_area2 = cross2(tri.uv[1] - tri.uv[0], tri.uv[2] - tri.uv[0]);
    // A texel of a 1024^2 grid has UV area ~1e-6; triangles far below that are degenerate.
    if (!(world_area > 1e-14) || !(std::abs(tri.uv_area2) > 1e-14))
      return bad(what, "triangle " + std::to_string(t) + " has zero world or UV area");
    tri.world_per_uv = world_area / (0.5 * std::abs(tri.uv_area2));
    tri.normal = n / (2.0 * world_area);
  }

  // Charts: triangles joined by an edge with the same UVs at both ends.
  std::vector<int> parent(triangle_count);
  std::iota(parent.begin(), parent.end(), 0);
  {
    auto key = [](const glm::dvec2& a) {
      return std::pair{std::llround(a.x * 1048576.0), std::llround(a.y * 1048576.0)};
    };
    std::map<std::pair<std::pair<long long, long long>, std::pair<long long, long long>>, int> edges;
    for (std::size_t t = 0; t < triangle_count; ++t)
      for (std::size_t e = 0; e < 3; ++e) {
        auto a = key(tris[t].uv[e]), b = key(tris[t].uv[(e + 1) % 3]);
        if (b < a) std::swap(a, b);
        auto [it, inserted] = edges.emplace(std::pair{a, b}, int(t));
        if (!inserted) parent[std::size_t(find_root(parent, int(t)))] = find_root(parent, it->second);
      }
  }
  std::vector<int> chart_of(triangle_count, -1);
  std::map<int, int> chart_index;
  for (std::size_t t = 0; t < triangle_count; ++t) {
    const int root = find_root(parent, int(t));
    auto [it, inserted] = chart_index.emplace(root, int(chart_index.size()));
    chart_of[t] = it->second;
  }

  const std::size_t cells = std::size_t(res) * std::size_t(res);
  const double cell = 1.0 / res;
  std::vector<std::int32_t> owner(cells, -1);     // triangle whose interior holds the centre
  std::vector<double> owner_depth(cells, -1.0);   // its smallest barycentric coordinate there
  std::vector<std::int32_t> fallback(cells, -1);  // conservative: triangle overlapping most
  std::vector<double> fallback_overlap(cells, 0.0);
  std::vector<double> area(cells, 0.0);
  for (std::size_t t = 0; t < triangle_count; ++t) {
    const Triangle& tri = tris[t];
    double x_lo = 1, y_lo = 1, x_hi = 0, y_hi = 0;
    for (const glm::dvec2& uv : tri.uv) {
      x_lo = std::min(x_lo, uv.x), x_hi = std::max(x_hi, uv.x);
      y_lo = std::min(y_lo, uv.y), y_hi = std::max(y_hi, uv.y);
    }
    const int i0 = std::clamp(int(std::floor(x_lo * res)), 0, res - 1),
              i1 = std::clamp(int(std::floor(x_hi * res)), 0, res - 1);
    const int j0 = std::clamp(int(std::floor(y_lo * res)), 0, res - 1),
              j1 = std::clamp(int(std::floor(y_hi * res)), 0, res - 1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const std::size_t c = std::size_t(j) * std::size_t(res) + std::size_t(i);
        const double overlap = overlap_area(tri.uv, i * cell, j * cell, (i + 1) * cell, (j + 1) * cell);
        if (overlap <= 0) continue;
        area[c] += overlap * tri.world_per_uv;
        const glm::dvec3 w = barycentric(tri.uv, tri.uv_area2, {(i + 0.5) * cell, (j + 0.5) * cell});
        const double depth = std::min({w.x, w.y, w.z});
        // Centres on a shared edge (depth ~ 0 in both triangles) go to either; a centre deep
        // inside two triangles means their UVs overlap.
        constexpr double kEdge = 1e-9;
        if (depth >= -kEdge) {
          if (owner[c] >= 0 && depth > kEdge && owner_depth[c] > kEdge)
            return bad(what, "triangles " + std::to_string(owner[c]) + " and " + std::to_string(t) +
                                 " overlap in UV space (both cover texel " + std::to_string(i) + ", " +
                                 std::to_string(j) + "): lightmap UVs must not overlap");
          if (depth > owner_depth[c]) owner[c] = std::int32_t(t), owner_depth[c] = depth;
        }
        if (overlap > fallback_overlap[c]) fallback[c] = std::int32_t(t), fallback_overlap[c] = overlap;
      }
  }

  ClutterMeshAtlas atlas;
  atlas.res = res;
  atlas.chart_count = int(chart_index.size());
  atlas.cell_texel.assign(cells, -1);
  for (std::size_t c = 0; c < cells; ++c) {
    const std::int32_t t = owner[c] >= 0 ? owner[c] : fallback[c];
    if (t < 0) continue;
    const Triangle& tri = tris[std::size_t(t)];
    const glm::dvec2 centre{(double(c % std::size_t(res)) + 0.5) * cell,
                            (double(c / std::size_t(res)) + 0.5) * cell};
    const glm::dvec3 w = barycentric(tri.uv, tri.uv_area2, closest_in_triangle(tri.uv, tri.uv_area2, centre));
    atlas.cell_texel[c] = std::int32_t(atlas.triangle.size());
    atlas.texels.position.push_back(w.x * tri.p[0] + w.y * tri.p[1] + w.z * tri.p[2]);
    atlas.texels.normal.push_back(tri.normal);
    atlas.texels.face.push_back(chart_of[std::size_t(t)]);
    atlas.triangle.push_back(std::uint32_t(t));
    atlas.area.push_back(area[c]);
  }

  // One ring of padding: 4-neighbours first, then diagonals, in a fixed order.
  constexpr std::array<std::array<int, 2>, 8> kNeighbours{
      {{-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {1, -1}, {-1, 1}, {1, 1}}};
  for (int j = 0; j < res; ++j)
    for (int i = 0; i < res; ++i) {
      const std::size_t c = std::size_t(j) * std::size_t(res) + std::size_t(i);
      if (atlas.cell_texel[c] >= 0) continue;
      for (const auto& [di, dj] : kNeighbours) {
        const int ni = i + di, nj = j + dj;
        if (ni < 0 || nj < 0 || ni >= res || nj >= res) continue;
        const std::size_t n = std::size_t(nj) * std::size_t(res) + std::size_t(ni);
        if (atlas.cell_texel[n] >= 0) {
          atlas.padding.emplace_back(std::uint32_t(c), std::uint32_t(n));
          break;
        }
      }
    }
  return atlas;
}

}  // namespace modrt::precompute
