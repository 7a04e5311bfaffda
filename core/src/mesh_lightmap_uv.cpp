// SPDX-License-Identifier: MIT
// modrt — lightmap coordinates for an app's own static meshes (mesh_lightmap_uv.h).
#include "modrt/mesh_lightmap_uv.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>

#include "modrt/checked_arithmetic.h"
#include "modrt/cube.h"
#include "modrt/level_geometry.h"

namespace modrt {

glm::vec3 StridedVec3::operator[](std::size_t i) const {
  float f[3];
  std::memcpy(f, static_cast<const unsigned char*>(data) + i * stride, sizeof f);
  return {f[0], f[1], f[2]};
}

namespace {

// Surfaces are classified this fraction of a block in front of themselves (header): more
// than a warped wall's flat triangles stray from its bilinear surface.
constexpr double kFrontOffset = 0.02;
// Points within this fraction of a block of a face's plane lie on it (both sides).
constexpr double kPlaneTolerance = 1e-9;
// Pieces and fan triangles with less than this fraction of their source triangle's area are
// rounding slivers at a cut: dropped (their total is below 1e-8 of the triangle).
constexpr double kSliverArea = 1e-10;
// Twice the area below this fraction of the longest edge squared: a zero-area triangle.
constexpr double kZeroArea = 1e-12;
// A normal shorter than this is refused (not a direction).
constexpr double kMinNormalLength = 1e-6;
// How far (in blocks) a region reaches past a face that does not cut exactly (BlockRegion).
constexpr double kReach = 0.25;
// A point at most this far outside a block's canonical cube (in block units) is inside it:
// the demo's threshold for a triangle outside every block.
constexpr double kInsideCanonical = 1e-6;
// A (warped) block whose box covers more acceleration cells than this is tested against
// every triangle instead of being listed in each cell.
constexpr std::size_t kMaxCellsPerBlock = 64;

std::string vec_text(const glm::vec3& v) {
  char text[96];
  std::snprintf(text, sizeof text, "(%g, %g, %g)", double(v.x), double(v.y), double(v.z));
  return text;
}

Status mesh_error(ErrorCode code, const std::string& what) {
  return Status::error(code, "mesh lightmap: " + what);
}

// Inside: dot(n, p) - d >= -tolerance; n is the unit inward normal.
struct Plane {
  glm::dvec3 n{0.0};
  double d = 0.0;
  double distance(const glm::dvec3& p) const { return glm::dot(n, p) - d; }
};

// The region a block cuts off a triangle with: one half-space per face. Along a flat face
// that it shares with a grid neighbour (a connected opening, or back-to-back walls: every
// such face of an unwarped block) the plane is the face itself, and the cut is exact.
// Elsewhere nothing needs cutting exactly, so the plane is pushed out by kReach blocks (plus
// the face's twist) and whole triangles stay whole there:
//   - a face with no block behind it (outer walls, floors, ceilings): no other tile is
//     there; a wall mesh standing a little proud of its proxy, or a box's bottom on the
//     floor, stays one triangle;
//   - a twisted (non-planar) face of a warped block: a planar cut would hand the strip
//     between the plane and the bilinear face to the wrong side (a wall's piece to the block
//     behind it, whose tile faces the other way); a triangle near it stays whole and goes,
//     as it always did, to the block containing its centroid (Mapper::assign).
// The reach keeps such regions from extending to blocks further away (they overlap their
// neighbours' instead, which the claiming order resolves).
//
// Where two flat outer faces meet at an edge (or three at a corner) and the block diagonally
// across it exists, their reach would overlap that block; a plane through the edge (corner),
// normal to the faces' mean normal, keeps the region out of it (exact for unwarped blocks).
// Not at twisted faces: there a triangle near the edge goes whole to the block containing
// its centroid, as it always did.
struct BlockRegion {
  std::vector<Plane> planes;                // the 6 faces (cube order), then the diagonal planes
  glm::dvec3 lo{0.0}, hi{0.0};              // box of the corners
  glm::dvec3 reach_lo{0.0}, reach_hi{0.0};  // box of the region (bounded by the reach)
};

// The trilinear cube's faces x = 0, x = 1, y = 0, y = 1, z = 0, z = 1 as corner loops
// (corner index x + 2y + 4z): the diagonals are (2 - 0) and (3 - 1). The corners are the
// grid cell's (cell + (x, y, z)) before a warp, so face f borders cell + kFaceStep[f].
constexpr int kFaceLoops[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                  {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
constexpr int kFaceStep[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};

// As the demo always had it: the size of block 0 (the level's blocks share a grid).
double level_block_size(const Level& level) {
  return glm::length(level.blocks[0].corners[7] - level.blocks[0].corners[0]) / std::sqrt(3.0);
}

Result<std::vector<BlockRegion>> block_regions(const Level& level) {
  const double block_size = level_block_size(level);
  std::vector<BlockRegion> regions(level.blocks.size());
  std::map<std::tuple<int, int, int>, std::size_t> by_cell;
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const glm::ivec3 c = level.blocks[bi].cell;
    by_cell.emplace(std::tuple(c.x, c.y, c.z), bi);
  }
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& b = level.blocks[bi];
    BlockRegion& r = regions[bi];
    glm::dvec3 centre(0.0);
    r.lo = r.hi = b.corners[0];
    for (const glm::dvec3& c : b.corners) {
      if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z))
        return mesh_error(ErrorCode::non_finite,
                          "level block " + std::to_string(bi) + " has a non-finite corner");
      centre += c / 8.0;
      r.lo = glm::min(r.lo, c);
      r.hi = glm::max(r.hi, c);
    }
    double grow = 0.0;
    std::array<bool, 6> reaching{};
    r.planes.resize(6);
    for (int f = 0; f < 6; ++f) {
      const int* loop = kFaceLoops[f];
      const glm::dvec3 mid = (b.corners[std::size_t(loop[0])] + b.corners[std::size_t(loop[1])] +
                              b.corners[std::size_t(loop[2])] + b.corners[std::size_t(loop[3])]) /
                             4.0;
      glm::dvec3 n = glm::cross(b.corners[std::size_t(loop[2])] - b.corners[std::size_t(loop[0])],
                                b.corners[std::size_t(loop[3])] - b.corners[std::size_t(loop[1])]);
      const double length = glm::length(n);
      if (!(length > 0.0) || !std::isfinite(length))
        return mesh_error(ErrorCode::invalid_argument,
                          "level block " + std::to_string(bi) + " has a degenerate face (zero area)");
      n /= length;
      if (glm::dot(n, centre - mid) < 0.0) n = -n;
      r.planes[std::size_t(f)] = {n, glm::dot(n, mid)};
      const glm::ivec3 next = b.cell + glm::ivec3(kFaceStep[f][0], kFaceStep[f][1], kFaceStep[f][2]);
      double twist = 0.0;
      for (int k = 0; k < 4; ++k)
        twist = std::max(twist, std::abs(r.planes[std::size_t(f)].distance(b.corners[std::size_t(loop[k])])));
      const bool flat = twist <= kPlaneTolerance * glm::length(r.hi - r.lo);
      if (!flat || by_cell.count(std::tuple(next.x, next.y, next.z)) == 0) {
        const double reach = kReach * block_size + twist;
        r.planes[std::size_t(f)].d -= reach;
        grow = std::max(grow, reach);
        reaching[std::size_t(f)] = flat;  // an outer face (the diagonal planes below)
      }
    }
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int step[3] = {dx, dy, dz};
          int axes = 0, corner = 0;
          bool all_reach = true;
          glm::dvec3 outward(0.0);
          for (int a = 0; a < 3; ++a) {
            if (step[a] == 0) continue;
            const int f = 2 * a + (step[a] > 0 ? 1 : 0);
            ++axes;
            all_reach = all_reach && reaching[std::size_t(f)];
            outward -= r.planes[std::size_t(f)].n;
            if (step[a] > 0) corner += 1 << a;
          }
          const glm::ivec3 diagonal = b.cell + glm::ivec3(dx, dy, dz);
          if (axes < 2 || !all_reach || by_cell.count(std::tuple(diagonal.x, diagonal.y, diagonal.z)) == 0)
            continue;
          const glm::dvec3 n = -glm::normalize(outward);
          r.planes.push_back({n, glm::dot(n, b.corners[std::size_t(corner)])});
        }
    r.reach_lo = r.lo - grow;
    r.reach_hi = r.hi + grow;
  }
  return regions;
}

double box_distance(const glm::dvec3& p, const BlockRegion& r) {
  return glm::length(glm::max(glm::max(r.lo - p, p - r.hi), glm::dvec3(0.0)));
}

// How far canonical point p lies outside [0,1]^3 (0 inside).
double outside_unit_cube(const glm::dvec3& p) {
  double d = 0.0;
  for (int a = 0; a < 3; ++a) d = std::max({d, -p[a], p[a] - 1.0});
  return d;
}

// A uniform grid over the blocks' boxes, so that a triangle meets only the blocks near it.
class BlockGrid {
 public:
  BlockGrid(const std::vector<BlockRegion>& regions, double tolerance) : tolerance_(tolerance) {
    const std::size_t n = regions.size();
    glm::dvec3 lo = regions[0].reach_lo, hi = regions[0].reach_hi;
    std::vector<double> extents(n);
    for (std::size_t i = 0; i < n; ++i) {
      lo = glm::min(lo, regions[i].reach_lo);
      hi = glm::max(hi, regions[i].reach_hi);
      const glm::dvec3 e = regions[i].hi - regions[i].lo;
      extents[i] = std::max({e.x, e.y, e.z});
    }
    std::nth_element(extents.begin(), extents.begin() + std::ptrdiff_t(n / 2), extents.end());
    double h = extents[n / 2] > 0.0 ? extents[n / 2] : 1.0;  // a typical block
    const glm::dvec3 extent = hi - lo;
    const double max_cells = 4.0 * double(n) + 64.0;
    for (;;) {
      double total = 1.0;
      for (int a = 0; a < 3; ++a) {
        dims_[a] = int(std::clamp(std::ceil(extent[a] / h), 1.0, 1024.0 * 1024.0));
        total *= dims_[a];
      }
      if (total <= max_cells) break;
      h *= 2.0;
    }
    origin_ = lo;
    for (int a = 0; a < 3; ++a) cell_[a] = extent[a] > 0.0 ? extent[a] / dims_[a] : 1.0;
    const std::size_t cells = std::size_t(dims_.x) * std::size_t(dims_.y) * std::size_t(dims_.z);
    // Two passes (count, fill) into one index array per cell.
    std::vector<std::uint32_t> count(cells + 1, 0);
    std::vector<bool> large(n, false);
    for (int pass = 0; pass < 2; ++pass) {
      for (std::size_t i = 0; i < n; ++i) {
        const glm::ivec3 a = cell_of(regions[i].reach_lo - tolerance_),
                         b = cell_of(regions[i].reach_hi + tolerance_);
        if (pass == 0) {
          const std::size_t covered =
              std::size_t(b.x - a.x + 1) * std::size_t(b.y - a.y + 1) * std::size_t(b.z - a.z + 1);
          large[i] = covered > kMaxCellsPerBlock;
          if (large[i]) large_.push_back(std::uint32_t(i));
        }
        if (large[i]) continue;
        for (int z = a.z; z <= b.z; ++z)
          for (int y = a.y; y <= b.y; ++y)
            for (int x = a.x; x <= b.x; ++x) {
              const std::size_t c = index(x, y, z);
              if (pass == 0)
                ++count[c + 1];
              else
                items_[fill_[c]++] = std::uint32_t(i);
            }
      }
      if (pass == 0) {
        for (std::size_t c = 0; c < cells; ++c) count[c + 1] += count[c];
        start_ = count;
        fill_.assign(count.begin(), count.end() - 1);
        items_.resize(count[cells]);
      }
    }
    stamp_.assign(n, 0);
  }

  // The blocks whose box may overlap [lo, hi], in ascending index order.
  void query(const glm::dvec3& lo, const glm::dvec3& hi, std::vector<std::uint32_t>& out) {
    out.clear();
    if (++tick_ == 0) {  // wrapped: forget every stamp
      std::fill(stamp_.begin(), stamp_.end(), 0u);
      tick_ = 1;
    }
    const glm::ivec3 a = cell_of(lo - tolerance_), b = cell_of(hi + tolerance_);
    for (int z = a.z; z <= b.z; ++z)
      for (int y = a.y; y <= b.y; ++y)
        for (int x = a.x; x <= b.x; ++x) {
          const std::size_t c = index(x, y, z);
          for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
            const std::uint32_t block = items_[k];
            if (stamp_[block] != tick_) stamp_[block] = tick_, out.push_back(block);
          }
        }
    out.insert(out.end(), large_.begin(), large_.end());
    std::sort(out.begin(), out.end());
  }

 private:
  glm::ivec3 cell_of(const glm::dvec3& p) const {
    glm::ivec3 c;
    for (int a = 0; a < 3; ++a)
      c[a] = int(std::clamp(std::floor((p[a] - origin_[a]) / cell_[a]), 0.0, double(dims_[a] - 1)));
    return c;
  }
  std::size_t index(int x, int y, int z) const {
    return (std::size_t(z) * std::size_t(dims_.y) + std::size_t(y)) * std::size_t(dims_.x) + std::size_t(x);
  }

  double tolerance_;
  glm::dvec3 origin_{0.0}, cell_{1.0};
  glm::ivec3 dims_{1};
  std::vector<std::uint32_t> start_, fill_, items_, large_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t tick_ = 0;
};

// A convex polygon of one triangle's plane: positions moved in front of the surface (the
// classification space), and barycentric coordinates in the source triangle.
struct PolyVertex {
  glm::dvec3 p;
  glm::dvec3 bary;
};
using Polygon = std::vector<PolyVertex>;

double polygon_area(const Polygon& poly) {
  glm::dvec3 sum(0.0);
  for (std::size_t i = 1; i + 1 < poly.size(); ++i)
    sum += glm::cross(poly[i].p - poly[0].p, poly[i + 1].p - poly[0].p);
  return 0.5 * glm::length(sum);
}

glm::dvec3 polygon_centroid(const Polygon& poly) {
  glm::dvec3 c(0.0);
  for (const PolyVertex& v : poly) c += v.p;
  return c / double(poly.size());
}

// Splits `poly` by `plane` into its parts inside and outside; vertices within `tolerance`
// of the plane belong to both, and a polygon on one side goes there whole (no cut).
void split(const Polygon& poly, const Plane& plane, double tolerance, Polygon& in, Polygon& out) {
  in.clear();
  out.clear();
  bool any_in = false, any_out = false;
  for (const PolyVertex& v : poly) {
    const double d = plane.distance(v.p);
    any_in = any_in || d > tolerance;
    any_out = any_out || d < -tolerance;
  }
  if (!any_out) {
    in = poly;
    return;
  }
  if (!any_in) {
    out = poly;
    return;
  }
  auto side = [&](double d) { return d > tolerance ? 1 : d < -tolerance ? -1 : 0; };
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const PolyVertex& a = poly[i];
    const PolyVertex& b = poly[(i + 1) % poly.size()];
    const double da = plane.distance(a.p), db = plane.distance(b.p);
    const int sa = side(da), sb = side(db);
    if (sa >= 0) in.push_back(a);
    if (sa <= 0) out.push_back(a);
    if (sa * sb < 0) {
      const double t = da / (da - db);  // |da|, |db| > tolerance, opposite signs: t in (0, 1)
      const PolyVertex cut{a.p + t * (b.p - a.p), a.bary + t * (b.bary - a.bary)};
      in.push_back(cut);
      out.push_back(cut);
    }
  }
}

// One run over the mesh: counts, and emits when `emit` is set (the same code, so the count
// is exact).
class Mapper {
 public:
  Mapper(const Level& level, const MeshLightmapInput& mesh, std::vector<BlockRegion> regions,
         const MappedTriangleFn* emit)
      : level_(level),
        mesh_(mesh),
        regions_(std::move(regions)),
        block_size_(level_block_size(level)),
        tolerance_(kPlaneTolerance * block_size_),
        grid_(regions_, tolerance_),
        emit_(emit) {}

  Status run() {
    const std::size_t triangles = mesh_.indices.size() / 3;
    stats_.triangles = triangles;
    for (std::size_t t = 0; t < triangles; ++t) map_triangle(std::uint32_t(t));
    if (corners_ > std::numeric_limits<std::size_t>::max())
      return mesh_error(ErrorCode::resource_limit, "the mapped mesh has more corners than can be counted");
    stats_.corners = std::size_t(corners_);
    return Status::success();
  }
  const MeshLightmapStats& stats() const { return stats_; }

 private:
  struct Triangle {
    std::uint32_t index = 0;
    std::array<glm::vec3, 3> position, normal;  // as given
    std::array<glm::dvec3, 3> p;
    glm::dvec3 n{0.0};  // unit surface normal
    double area = 0.0;
  };

  void map_triangle(std::uint32_t t) {
    Triangle& tri = tri_;
    tri.index = t;
    glm::dvec3 sum(0.0);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh_.indices[3 * std::size_t(t) + std::size_t(k)];
      tri.position[std::size_t(k)] = mesh_.positions[v];
      tri.normal[std::size_t(k)] = mesh_.normals[v];
      tri.p[std::size_t(k)] = glm::dvec3(tri.position[std::size_t(k)]);
      sum += glm::dvec3(tri.normal[std::size_t(k)]);
    }
    const glm::dvec3 cross = glm::cross(tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
    // The vertex normals' mean says which side the surface faces; where they cancel, the
    // winding does; where that is zero too (no area), the first vertex's normal (not zero).
    glm::dvec3 n = sum;
    if (glm::dot(n, n) < 1e-20) n = cross;
    if (glm::dot(n, n) == 0.0) n = glm::dvec3(tri.normal[0]);
    tri.n = glm::normalize(n);
    tri.area = 0.5 * glm::length(cross);
    const double longest = std::max({glm::dot(tri.p[1] - tri.p[0], tri.p[1] - tri.p[0]),
                                     glm::dot(tri.p[2] - tri.p[1], tri.p[2] - tri.p[1]),
                                     glm::dot(tri.p[0] - tri.p[2], tri.p[0] - tri.p[2])});
    const bool zero_area = !(2.0 * tri.area > kZeroArea * longest);
    const glm::dvec3 offset = kFrontOffset * block_size_ * tri.n;
    Polygon whole = {
        {tri.p[0] + offset, {1, 0, 0}}, {tri.p[1] + offset, {0, 1, 0}}, {tri.p[2] + offset, {0, 0, 1}}};
    pieces_ = 0;
    piece_outside_ = false;
    sliver_ = kSliverArea * tri.area;

    if (zero_area) {
      // Covers nothing: not cut, output whole where its centroid is.
      emit_piece(whole, -1, true);
    } else {
      glm::dvec3 lo = whole[0].p, hi = whole[0].p;
      for (const PolyVertex& v : whole) lo = glm::min(lo, v.p), hi = glm::max(hi, v.p);
      grid_.query(lo, hi, candidates_);
      remaining_.clear();
      remaining_.push_back(std::move(whole));
      // Each block in index order cuts off what lies inside it of what is left.
      for (std::uint32_t b : candidates_) {
        if (remaining_.empty()) break;
        const BlockRegion& region = regions_[b];
        next_.clear();
        for (Polygon& poly : remaining_) {
          if (!overlaps(poly, region)) {
            next_.push_back(std::move(poly));
            continue;
          }
          cut_.clear();
          current_ = poly;
          for (const Plane& plane : region.planes) {
            split(current_, plane, tolerance_, in_, out_);
            if (out_.size() >= 3 && polygon_area(out_) > sliver_) cut_.push_back(out_);
            std::swap(current_, in_);
            if (current_.size() < 3) break;
          }
          if (current_.size() < 3 || polygon_area(current_) <= sliver_) {
            next_.push_back(std::move(poly));  // touches the block at most: left uncut
            continue;
          }
          emit_piece(current_, std::int64_t(b), false);
          for (Polygon& c : cut_) next_.push_back(std::move(c));
        }
        std::swap(remaining_, next_);
      }
      // In no block's planes: outside the level, or (warped) between mid-planes and faces.
      for (const Polygon& poly : remaining_)
        if (polygon_area(poly) > sliver_) emit_piece(poly, -1, false);
    }
    if (pieces_ > 1) ++stats_.split_triangles;
    if (piece_outside_) ++stats_.triangles_outside;
  }

  bool overlaps(const Polygon& poly, const BlockRegion& r) const {
    glm::dvec3 lo = poly[0].p, hi = poly[0].p;
    for (const PolyVertex& v : poly) lo = glm::min(lo, v.p), hi = glm::max(hi, v.p);
    return !glm::any(glm::lessThan(hi, r.reach_lo - tolerance_)) &&
           !glm::any(glm::greaterThan(lo, r.reach_hi + tolerance_));
  }

  // The block a piece with (moved) centroid p is output in, and whether p lies in no block.
  // Decided exactly, through the trilinear warp, as the demo always decided it for whole
  // triangles: `claimed` (the block that cut the piece off, -1 for none) when it contains p
  // (always, up to rounding, for a piece cut on all sides by its block's faces), else the
  // block containing p (a piece reaching across a twisted face), else the nearest block: the
  // claiming one (a piece beyond an outer face), or by canonical distance outside [0,1]^3
  // among the blocks within a block of p, else by distance to the blocks' boxes; the last
  // three are "outside".
  std::pair<std::uint32_t, bool> assign(const glm::dvec3& p, std::int64_t claimed) {
    if (claimed >= 0 && outside_unit_cube(canonical(std::uint32_t(claimed), p)) <= kInsideCanonical)
      return {std::uint32_t(claimed), false};
    grid_.query(p - block_size_, p + block_size_, near_);
    std::uint32_t block = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::uint32_t b : near_) {
      const double o = outside_unit_cube(canonical(b, p));
      if (o < best) best = o, block = b;
      if (o == 0.0) break;
    }
    if (best <= kInsideCanonical) return {block, false};
    if (claimed >= 0) return {std::uint32_t(claimed), true};  // a box's bottom below the floor
    if (near_.empty()) {
      double nearest = std::numeric_limits<double>::infinity();
      for (std::size_t bi = 0; bi < regions_.size(); ++bi)
        if (const double d = box_distance(p, regions_[bi]); d < nearest)
          nearest = d, block = std::uint32_t(bi);
    }
    return {block, true};
  }

  // Canonical coordinates of world point x in block b. Newton on the warp is exact for an
  // affine (e.g. sheared) block at any distance and converges near any block. Only when it
  // does not converge (a far point of a trilinear warp) is x clamped to the block's box grown
  // by a block first, which keeps q finite; such a point's projection is clamped onto the face
  // anyway. (Clamping every far point in world space moved a sheared block's projections: the
  // world axes are not the canonical ones.)
  glm::dvec3 canonical(std::uint32_t b, const glm::dvec3& x) const {
    const BlockRegion& r = regions_[b];
    const LevelBlock& blk = level_.blocks[b];
    const glm::dvec3 q = world_to_block(blk, x);
    const glm::dvec3 lo = r.lo - block_size_, hi = r.hi + block_size_;
    const bool near = glm::all(glm::greaterThanEqual(x, lo)) && glm::all(glm::lessThanEqual(x, hi));
    if (near) return q;
    const bool finite = std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
    if (finite && glm::length(block_to_world(blk, q) - x) <= 1e-9 * (block_size_ + glm::length(x - r.lo)))
      return q;
    return world_to_block(blk, glm::clamp(x, lo, hi));
  }

  // Outputs `poly` (fan triangles) in its block (assign) on the face the surface faces.
  void emit_piece(const Polygon& poly, std::int64_t claimed, bool keep_zero_area) {
    const glm::dvec3 centroid = polygon_centroid(poly);
    const auto [b, outside] = assign(centroid, claimed);
    const LevelBlock& blk = level_.blocks[b];
    // Face choice: the present face whose inward normal the surface faces alike (a floor
    // rug maps to the floor, a shelf's front to the wall behind it), the nearer on ties.
    const glm::dvec3 centre = canonical(b, centroid);
    const glm::dvec3 n_canonical = rotate_direction(tri_.n, -blk.quarter_turns);
    const FaceMask mask = dictionary_shape_mask(blk.shape);
    int face = -1;
    double best_score = -std::numeric_limits<double>::infinity();
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(mask, f)) continue;
      const FaceFrame& fr = face_frame(f);
      const double distance = std::abs(glm::dot(centre - fr.origin, fr.normal));
      const double score = glm::dot(n_canonical, fr.normal) - 0.25 * distance;
      if (score > best_score) best_score = score, face = f;
    }
    std::size_t emitted = 0;
    std::array<MappedCorner, 3> corners;
    for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
      const PolyVertex* fan[3] = {&poly[0], &poly[k], &poly[k + 1]};
      if (!keep_zero_area &&
          0.5 * glm::length(glm::cross(fan[1]->p - fan[0]->p, fan[2]->p - fan[0]->p)) <= sliver_)
        continue;
      ++emitted;
      corners_ = saturating_add(corners_, 3);
      if (!emit_) continue;
      for (int c = 0; c < 3; ++c) corners[std::size_t(c)] = corner(*fan[c], b, face, outside);
      (*emit_)(corners);
    }
    if (emitted > 0) {
      ++pieces_;
      piece_outside_ = piece_outside_ || outside;
    }
  }

  MappedCorner corner(const PolyVertex& v, std::uint32_t b, int face, bool outside) const {
    const LevelBlock& blk = level_.blocks[b];
    const FaceFrame& fr = face_frame(face);
    MappedCorner c;
    // An input vertex keeps its position and normal bit for bit.
    int vertex = -1;
    for (int k = 0; k < 3; ++k)
      if (v.bary[k] == 1.0 && v.bary[(k + 1) % 3] == 0.0 && v.bary[(k + 2) % 3] == 0.0) vertex = k;
    glm::dvec3 p;
    if (vertex >= 0) {
      c.position = tri_.position[std::size_t(vertex)];
      c.normal = tri_.normal[std::size_t(vertex)];
      p = tri_.p[std::size_t(vertex)];
    } else {
      p = v.bary[0] * tri_.p[0] + v.bary[1] * tri_.p[1] + v.bary[2] * tri_.p[2];
      const glm::dvec3 n = v.bary[0] * glm::dvec3(tri_.normal[0]) + v.bary[1] * glm::dvec3(tri_.normal[1]) +
                           v.bary[2] * glm::dvec3(tri_.normal[2]);
      const double length = glm::length(n);
      c.position = glm::vec3(p);
      c.normal = glm::vec3(length > kMinNormalLength ? n / length : tri_.n);
    }
    // Orthographic projection onto the face, kept on the tile's interior so that bilinear
    // taps stay within the tile and its padding.
    const glm::dvec3 q = canonical(b, p);
    double u = glm::dot(q - fr.origin, fr.u_axis), w = glm::dot(q - fr.origin, fr.v_axis);
    u = std::isfinite(u) ? std::clamp(u, 0.0, 1.0) : 0.5;  // finite for clamped points; the
    w = std::isfinite(w) ? std::clamp(w, 0.0, 1.0) : 0.5;  // guard keeps NaN out regardless
    const double res = level_.res;
    const double ox = level_.atlas.tile_origin_x[b][std::size_t(face)] + 1;
    const double oy = level_.atlas.tile_origin_y[b][std::size_t(face)] + 1;
    c.lightmap = glm::vec2(float(ox + u * res), float(oy + w * res));
    c.face_u = glm::vec3(glm::normalize(rotate_direction(fr.u_axis, blk.quarter_turns)));
    c.face_v = glm::vec3(glm::normalize(rotate_direction(fr.v_axis, blk.quarter_turns)));
    c.barycentric = glm::vec3(v.bary);
    c.triangle = tri_.index;
    c.block = b;
    c.face = face;
    c.outside = outside;
    return c;
  }

  const Level& level_;
  const MeshLightmapInput& mesh_;
  std::vector<BlockRegion> regions_;
  double block_size_, tolerance_;
  BlockGrid grid_;
  const MappedTriangleFn* emit_;
  MeshLightmapStats stats_;
  std::uint64_t corners_ = 0;
  // Per triangle.
  Triangle tri_;
  std::size_t pieces_ = 0;
  bool piece_outside_ = false;
  double sliver_ = 0.0;
  // Scratch, kept between triangles.
  std::vector<std::uint32_t> candidates_, near_;
  std::vector<Polygon> remaining_, next_, cut_;
  Polygon current_, in_, out_;
};

Status check_array(const StridedVec3& a, std::size_t count, const char* name) {
  if (count == 0) return Status::success();
  if (!a.data)
    return mesh_error(ErrorCode::invalid_argument,
                      std::string(name) + " is null (" + std::to_string(count) + " vertices)");
  if (a.stride < 3 * sizeof(float))
    return mesh_error(ErrorCode::invalid_argument,
                      std::string(name) + ": stride of " + std::to_string(a.stride) +
                          " bytes is less than one element (12 bytes: 3 floats)");
  // The array, (count - 1) * stride + 12 bytes from data, must be an object: at most
  // PTRDIFF_MAX bytes, not wrapping the address space.
  const std::uint64_t room = std::min<std::uint64_t>(
      std::numeric_limits<std::ptrdiff_t>::max(),
      std::numeric_limits<std::uintptr_t>::max() - reinterpret_cast<std::uintptr_t>(a.data));
  std::uint64_t span = 0;
  if (!checked_mul(count - 1, a.stride, span) || span > room || room - span < 3 * sizeof(float))
    return mesh_error(ErrorCode::invalid_argument,
                      std::string(name) + ": " + std::to_string(count) + " vertices at a stride of " +
                          std::to_string(a.stride) + " bytes do not fit in memory");
  return Status::success();
}

Status check_mesh(const MeshLightmapInput& mesh) {
  const std::size_t n = mesh.vertex_count;
  if (Status s = check_array(mesh.positions, n, "positions"); !s.ok()) return s;
  if (Status s = check_array(mesh.normals, n, "normals"); !s.ok()) return s;
  if (mesh.indices.size() % 3 != 0)
    return mesh_error(ErrorCode::invalid_argument,
                      "index count " + std::to_string(mesh.indices.size()) + " is not a multiple of 3");
  if (mesh.indices.size() / 3 > std::numeric_limits<std::uint32_t>::max())
    return mesh_error(ErrorCode::resource_limit,
                      std::to_string(mesh.indices.size() / 3) +
                          " triangles, more than 4294967295 (the corners' triangle index)");
  for (std::size_t i = 0; i < n; ++i) {
    const glm::vec3 p = mesh.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return mesh_error(ErrorCode::non_finite,
                        "positions[" + std::to_string(i) + "] = " + vec_text(p) + " is not finite");
    const glm::vec3 v = mesh.normals[i];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      return mesh_error(ErrorCode::non_finite,
                        "normals[" + std::to_string(i) + "] = " + vec_text(v) + " is not finite");
    if (!(glm::length(glm::dvec3(v)) > kMinNormalLength))
      return mesh_error(ErrorCode::invalid_argument, "normals[" + std::to_string(i) + "] = " + vec_text(v) +
                                                         " has (almost) zero length: not a direction");
  }
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= n)
      return mesh_error(ErrorCode::invalid_argument,
                        "indices[" + std::to_string(i) + "] = " + std::to_string(mesh.indices[i]) +
                            " is out of range (" + std::to_string(n) + " vertices)");
  return Status::success();
}

Result<MeshLightmapStats> run(const Level& level, const MeshLightmapInput& mesh,
                              const MappedTriangleFn* emit) {
  if (Status s = check_level_for_mesh_lightmap(level); !s.ok()) return s;
  if (Status s = check_mesh(mesh); !s.ok()) return s;
  Result<std::vector<BlockRegion>> regions = block_regions(level);
  if (!regions.ok()) return regions.status();
  Mapper mapper(level, mesh, std::move(regions).value(), emit);
  if (Status s = mapper.run(); !s.ok()) return s;
  return mapper.stats();
}

}  // namespace

Status check_level_for_mesh_lightmap(const Level& level) {
  if (level.blocks.empty()) return mesh_error(ErrorCode::invalid_argument, "the level has no blocks");
  const LightmapAtlas& atlas = level.atlas;
  if (level.res <= 0 || atlas.tile_origin_x.size() != level.blocks.size() ||
      atlas.tile_origin_y.size() != level.blocks.size())
    return mesh_error(ErrorCode::invalid_argument, "the level has no lightmap atlas");
  for (std::size_t bi = 0; bi < level.blocks.size(); ++bi) {
    const LevelBlock& b = level.blocks[bi];
    if (b.shape < 0 || b.shape >= kDictionaryShapeCount)
      return mesh_error(ErrorCode::invalid_argument, "level block " + std::to_string(bi) + " has shape " +
                                                         std::to_string(b.shape) + ", not one of the " +
                                                         std::to_string(kDictionaryShapeCount) +
                                                         " dictionary shapes");
    const FaceMask mask = dictionary_shape_mask(b.shape);
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(mask, f)) continue;
      const std::int64_t x = atlas.tile_origin_x[bi][std::size_t(f)],
                         y = atlas.tile_origin_y[bi][std::size_t(f)];
      if (x < 0 || y < 0 || x + level.res + 2 > atlas.width || y + level.res + 2 > atlas.height)
        return mesh_error(ErrorCode::invalid_argument, "level block " + std::to_string(bi) + ": face " +
                                                           face_name(f) + " has no tile inside the atlas");
    }
  }
  return Status::success();
}

Result<MeshLightmapStats> mesh_lightmap_corner_count(const Level& level, const MeshLightmapInput& mesh) {
  return run(level, mesh, nullptr);
}

Result<MeshLightmapStats> map_mesh_lightmap(const Level& level, const MeshLightmapInput& mesh,
                                            const MappedTriangleFn& triangle) {
  return run(level, mesh, &triangle);
}

Result<MeshLightmapStats> map_mesh_lightmap(const Level& level, const MeshLightmapInput& mesh,
                                            std::span<MappedCorner> out) {
  Result<MeshLightmapStats> count = run(level, mesh, nullptr);
  if (!count.ok()) return count.status();
  if (count->corners > out.size())
    return mesh_error(ErrorCode::invalid_argument,
                      "the output holds " + std::to_string(out.size()) + " corners; the mapped mesh has " +
                          std::to_string(count->corners) + " (mesh_lightmap_corner_count)");
  std::size_t written = 0;
  const MappedTriangleFn write = [&](const std::array<MappedCorner, 3>& corners) {
    for (const MappedCorner& c : corners)
      if (written < out.size()) out[written++] = c;  // always: the runs are the same
  };
  return run(level, mesh, &write);
}

}  // namespace modrt
