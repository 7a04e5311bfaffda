// SPDX-License-Identifier: MIT
// modrt precompute (private to drt_build.cpp) — the pieces of the DRT gathers: analytic
// ray-box queries with exact culling, the shared stratified direction sets, the Limp gather
// by tap weights, and the per-sample / per-texel results a build keeps for rebuilds.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <glm/vec2.hpp>

#include "modrt/clutter_mesh.h"
#include "modrt/dictionary.h"
#include "modrt/drt.h"
#include "modrt/level.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/clutter_mesh.h"
#include "modrt/precompute/level_scene.h"
#include "modrt/precompute/sampling.h"
#include "modrt/sh.h"

namespace modrt::precompute::drt_detail {

inline constexpr int kDirectionSets = 32;

// Entry distance and entered face of a ray into a box, from outside (for a mesh: the chart,
// and the entered triangle with the barycentrics of its second and third vertex).
struct BoxEntry {
  bool hit = false;
  double t = 0.0;
  int face = -1;
  std::uint32_t triangle = 0;
  double u = 0.0, v = 0.0;
};

// A clutter box prepared for many ray queries from one origin: the origin in the box frame
// is computed once per origin, a ray then costs a rotation (none for an axis-aligned box)
// and the slab test.
struct BoxQuery {
  glm::dvec3 center, half;
  glm::dmat3 Rt;  // world -> box frame
  double radius;
  bool axis_aligned;  // Rt is the identity: the slab test skips the rotation
  explicit BoxQuery(const ClutterBox& box)
      : center(box.center),
        half(box.half_extent),
        Rt(glm::transpose(box.rotation)),
        radius(clutter_bounding_radius(box)),
        axis_aligned(box.rotation == glm::dmat3(1.0)) {}
  // Exact culling: no ray from x into the hemisphere of n can reach the box when all its
  // corners lie strictly behind the tangent plane (tighter than the bounding sphere, whose
  // radius is half a floor-to-ceiling pillar's height).
  bool in_front(const glm::dvec3& x, const glm::dvec3& n) const {
    const glm::dvec3 nl = Rt * n;
    return glm::dot(n, center - x) + half.x * std::abs(nl.x) + half.y * std::abs(nl.y) +
               half.z * std::abs(nl.z) >=
           0.0;
  }
  glm::dvec3 local(const glm::dvec3& origin) const { return Rt * (origin - center); }
  // Slab test with the origin already in the box frame (o = local(origin)).
  BoxEntry enter(const glm::dvec3& o, const glm::dvec3& dir) const {
    const glm::dvec3 d = axis_aligned ? dir : Rt * dir;
    double t_min = -std::numeric_limits<double>::infinity(), t_max = std::numeric_limits<double>::infinity();
    int face = -1;
    for (int a = 0; a < 3; ++a) {
      const double h = half[a];
      if (std::abs(d[a]) < 1e-300) {
        if (std::abs(o[a]) > h) return {};
        continue;
      }
      double t1 = (-h - o[a]) / d[a], t2 = (h - o[a]) / d[a];
      if (t1 > t2) std::swap(t1, t2);
      if (t1 > t_min) {
        t_min = t1;
        face = 2 * a + (d[a] > 0.0 ? 0 : 1);
      }
      t_max = std::min(t_max, t2);
    }
    if (t_min > t_max || t_min <= 0.0 || face < 0) return {};
    return {true, t_min, face};
  }
};

// A clutter object's lighting-prior basis for c (DRT §4.2's optional prior, as MRT §3.2):
// `count` functions over its texels, B(t, k) = U(t, k) / sqrt(area_t) from the SVD of the
// area-weighted prior light, so that Td_c = U^T diag(sqrt(area)) projects onto them (Td_c B
// = I). texel_at finds the texel a ray enters, whose B row is the light the ray brings per c.
struct ObjectBasis {
  int count = 0;
  std::vector<double> B;  // m x count, row-major
  Matrix Td_c;            // count x m
  // Hit -> texel. Box: per face its slot among the lit faces, corner and edge vectors.
  int res = 0;
  std::array<int, kFaceCount> slot{};
  std::array<glm::dvec3, kFaceCount> p00{}, pu{}, pv{};
  // Mesh: per atlas cell its texel (padding cells their source), and a texel per triangle.
  const ClutterMeshData* mesh = nullptr;
  std::vector<std::int32_t> cell;
  std::vector<std::int32_t> triangle_texel;

  void prepare(const ClutterObject& object) {
    res = object.res;
    if (object.kind == ClutterKind::mesh) {
      mesh = object.mesh.get();
      const ClutterMeshAtlas& a = mesh->atlas;
      cell = a.cell_texel;
      for (const auto& [to, from] : a.padding) cell[to] = a.cell_texel[from];
      triangle_texel.assign(mesh->mesh.indices.size() / 3, -1);
      for (std::size_t t = a.triangle.size(); t-- > 0;) triangle_texel[a.triangle[t]] = std::int32_t(t);
      return;
    }
    for (int f = 0, s = 0; f < kFaceCount; ++f) {
      slot[std::size_t(f)] = face_present(object.faces, f) ? s++ : -1;
      p00[std::size_t(f)] = clutter_face_point(object.box, f, 0.0, 0.0);
      pu[std::size_t(f)] = clutter_face_point(object.box, f, 1.0, 0.0) - p00[std::size_t(f)];
      pv[std::size_t(f)] = clutter_face_point(object.box, f, 0.0, 1.0) - p00[std::size_t(f)];
    }
  }
  // The texel where a ray from `origin` along `dir` enters through e; -1: an unlit box face.
  int texel_at(const BoxEntry& e, const glm::dvec3& origin, const glm::dvec3& dir) const {
    if (mesh) {
      const std::uint32_t* idx = mesh->mesh.indices.data() + 3 * std::size_t(e.triangle);
      const glm::dvec2 uv = (1.0 - e.u - e.v) * mesh->mesh.uvs[idx[0]] + e.u * mesh->mesh.uvs[idx[1]] +
                            e.v * mesh->mesh.uvs[idx[2]];
      const int i = std::clamp(int(std::floor(uv.x * res)), 0, res - 1);
      const int j = std::clamp(int(std::floor(uv.y * res)), 0, res - 1);
      const std::int32_t t = cell[std::size_t(j) * std::size_t(res) + std::size_t(i)];
      return t >= 0 ? t : triangle_texel[e.triangle];
    }
    const std::size_t f = std::size_t(e.face);
    if (slot[f] < 0) return -1;
    const glm::dvec3 x = origin + e.t * dir - p00[f];
    const int i = std::clamp(int(std::floor(glm::dot(x, pu[f]) / glm::dot(pu[f], pu[f]) * res)), 0, res - 1);
    const int j = std::clamp(int(std::floor(glm::dot(x, pv[f]) / glm::dot(pv[f], pv[f]) * res)), 0, res - 1);
    return (slot[f] * res + j) * res + i;
  }
};

// One clutter object's ray queries: a box's analytic slab test, or a mesh's Embree scene
// (ClutterMeshShape) behind the culling and sphere tests of its bounds. The entry's `face`
// is a box face or a mesh chart; slot() turns it into the column of the object's c (-1: an
// unlit box face, which sends nothing).
struct ObjectQuery {
  BoxQuery bounds;  // the box itself, or a mesh's axis-aligned bounds
  const ClutterMeshShape* mesh = nullptr;
  std::array<int, kFaceCount> slots{};
  const ObjectBasis* basis = nullptr;  // a lighting prior for c; none: a constant per face / chart
  int columns = 0;                     // entries of the object's c (per channel)
  ObjectQuery(const ClutterObject& object, const ClutterMeshShape* shape)
      : bounds(object.box), mesh(shape), columns(clutter_face_count(object)) {
    for (int f = 0, s = 0; f < kFaceCount; ++f)
      slots[std::size_t(f)] = face_present(object.faces, f) ? s++ : -1;
  }
  // The light a ray entering through e brings, per entry of c: add(column, weight) for the
  // entered face's (chart's) constant, or for every prior function's value at the entered
  // texel. An unlit box face brings nothing.
  template <class Add>
  void charge(const BoxEntry& e, const glm::dvec3& origin, const glm::dvec3& dir, Add&& add) const {
    if (!basis) {
      const int s = slot(e.face);
      if (s >= 0) add(std::size_t(s), 1.0);
      return;
    }
    const int t = basis->texel_at(e, origin, dir);
    if (t < 0) return;
    const double* row = basis->B.data() + std::size_t(t) * std::size_t(basis->count);
    for (int k = 0; k < basis->count; ++k) add(std::size_t(k), row[k]);
  }
  bool in_front(const glm::dvec3& x, const glm::dvec3& n) const { return bounds.in_front(x, n); }
  // origin_local = bounds.local(origin), precomputed per origin for boxes.
  BoxEntry enter(const glm::dvec3& origin, const glm::dvec3& origin_local, const glm::dvec3& dir) const {
    if (!mesh) return bounds.enter(origin_local, dir);
    const ClutterMeshShape::Entry e = mesh->enter(origin, dir);
    return {e.hit, e.t, e.chart, e.triangle, e.u, e.v};
  }
  int slot(int face) const { return mesh ? face : slots[std::size_t(face)]; }
  // Whether surface point p (unit normal n; zero for a point in the air) is inside or on the
  // object: a box grown by 1e-6, a mesh tested just off p along n, where a floor sample
  // under an object resting on the floor is inside it.
  bool contains(const glm::dvec3& p, const glm::dvec3& n) const {
    if (mesh) return mesh->contains(p + 1e-5 * n);
    const glm::dvec3 q = bounds.local(p);
    for (int a = 0; a < 3; ++a)
      if (std::abs(q[a]) > bounds.half[a] + 1e-6) return false;
    return true;
  }
};

// The queries of a list of objects, owning the mesh objects' Embree scenes and the objects'
// lighting-prior bases (DrtBuilder attaches them).
struct ObjectQueries {
  std::vector<std::unique_ptr<ClutterMeshShape>> meshes;
  std::vector<std::unique_ptr<ObjectBasis>> bases;
  std::vector<ObjectQuery> queries;
  static Result<ObjectQueries> make(std::span<const ClutterObject> objects) {
    ObjectQueries q;
    q.meshes.resize(objects.size());
    for (std::size_t k = 0; k < objects.size(); ++k) {
      const ClutterObject& o = objects[k];
      if (o.kind == ClutterKind::mesh) {
        Result<ClutterMeshShape> shape = ClutterMeshShape::create(o.mesh->mesh, o.mesh->chart_of_triangle,
                                                                  "clutter object " + std::to_string(k));
        if (!shape.ok()) return shape.status();
        q.meshes[k] = std::make_unique<ClutterMeshShape>(std::move(shape.value()));
      }
      q.queries.emplace_back(o, q.meshes[k].get());
    }
    return q;
  }
};

// The objects a sample or texel tests (those whose bounds are in front of it), with its
// origin in each box frame; the nearest entry over them, ties to the lower object index.
// Before the entry test, the bounding-sphere test (a ray that misses the sphere misses the
// object) with its per-origin terms computed once; skipped for an origin well inside the
// sphere, where it always passes.
struct Candidates {
  struct Entry {
    std::uint32_t object;
    glm::dvec3 origin, origin_local, oc;
    double oc2;
    bool in_sphere;
  };
  std::vector<Entry> entries;
  void clear() { entries.clear(); }
  bool empty() const { return entries.empty(); }
  void add(std::uint32_t object, const ObjectQuery& query, const glm::dvec3& origin) {
    const BoxQuery& box = query.bounds;
    const glm::dvec3 oc = box.center - origin;
    const double oc2 = glm::dot(oc, oc);
    entries.push_back(
        {object, origin, box.local(origin), oc, oc2, oc2 < box.radius * box.radius * (1.0 - 1e-9)});
  }
  struct Nearest {
    int object = -1;
    BoxEntry entry;
  };
  Nearest nearest(const std::vector<ObjectQuery>& queries, const glm::dvec3& dir) const {
    Nearest best;
    for (const Entry& c : entries) {
      const ObjectQuery& query = queries[c.object];
      const BoxQuery& box = query.bounds;
      if (!c.in_sphere) {
        const double along = glm::dot(c.oc, dir);
        if (c.oc2 - along * along > box.radius * box.radius || !(along + box.radius > 0.0)) continue;
      }
      const BoxEntry e = query.enter(c.origin, c.origin_local, dir);
      if (e.hit && (best.object < 0 || e.t < best.entry.t)) best = {int(c.object), e};
    }
    return best;
  }
};

// Cosine-weighted stratified direction sets in a local frame (z = normal), made once per
// builder and shared by all texels: a texel takes one of kDirectionSets sets and a random
// rotation about its normal. Its rays stay stratified and each is cosine-distributed (an
// unbiased gather), neighbouring texels' noise stays independent, and a ray costs a frame
// change instead of the sin, cos and sqrt of the square-to-hemisphere map.
enum class Directions { cosine, hemisphere, sphere };
inline std::vector<glm::dvec3> make_direction_sets(int rays, std::uint64_t seed,
                                                   Directions kind = Directions::cosine) {
  std::vector<glm::dvec3> local;
  std::vector<glm::dvec2> strata;
  local.reserve(std::size_t(kDirectionSets) * std::size_t(rays));
  for (int k = 0; k < kDirectionSets; ++k) {
    Rng rng(seed, std::uint64_t(k));
    stratified_square(rays, rng, strata);
    for (const glm::dvec2& u : strata)
      local.push_back(kind == Directions::cosine       ? cosine_hemisphere(u)
                      : kind == Directions::hemisphere ? uniform_hemisphere(u)
                                                       : uniform_sphere(u));
  }
  return local;
}

// The directions of work item `stream` in the fixed frame (u, v, n): `local` in that frame
// (for the SH projection), `world` in world space.
inline void frame_directions(std::span<const glm::dvec3> sets, std::uint64_t seed, std::uint64_t stream,
                             const glm::dvec3& u, const glm::dvec3& v, const glm::dvec3& n,
                             std::vector<glm::dvec3>& local, std::vector<glm::dvec3>& world) {
  const std::size_t rays = sets.size() / kDirectionSets;
  Rng rng(seed, stream);
  const std::size_t set = std::size_t(rng.next_u64() % kDirectionSets);
  const double phi = 2.0 * std::numbers::pi * rng.next_double(), cp = std::cos(phi), sp = std::sin(phi);
  local.resize(rays);
  world.resize(rays);
  const glm::dvec3* d = sets.data() + set * rays;
  for (std::size_t r = 0; r < rays; ++r) {
    local[r] = glm::dvec3(cp * d[r].x - sp * d[r].y, sp * d[r].x + cp * d[r].y, d[r].z);
    world[r] = to_world(local[r], u, v, n);
  }
}

// OHLSH coefficients of E/pi (sh.h) per unit radiance arriving from local direction d, per
// steradian: ohlsh(irradiance(y(d))), linear in the radiance SH projection.
inline std::array<double, kOhlshCount> ohlsh_weights(const glm::dvec3& d) {
  double y[kSh9Count], a[kOhlshCount];
  sh9_eval(d, y);
  irradiance_from_radiance_sh9(y, y);
  ohlsh_from_sh9(y, a);
  return {a[0], a[1], a[2], a[3]};
}

// A level sample's face frame in world space, that of level_compute_vector_irradiance: the
// canonical face frame turned with the block, made orthonormal to the sample's normal.
inline void sample_frame(const Level& level, const LevelSampleGeometry& g, std::size_t s, glm::dvec3& u,
                         glm::dvec3& v, glm::dvec3& n) {
  const FaceFrame& cf = face_frame(g.face[s]);
  const int turns = level.blocks[std::size_t(g.block[s])].quarter_turns;
  n = g.normal[s];
  u = rotate_direction(cf.u_axis, turns);
  u = glm::normalize(u - glm::dot(u, n) * n);
  v = rotate_direction(cf.v_axis, turns);
  v = glm::normalize(v - glm::dot(v, n) * n - glm::dot(v, u) * u);
}

// The world directions of work item `stream` (its own set and rotation) about unit normal n.
inline void texel_directions(std::span<const glm::dvec3> sets, std::uint64_t seed, std::uint64_t stream,
                             const glm::dvec3& n, std::vector<glm::dvec3>& out) {
  const std::size_t rays = sets.size() / kDirectionSets;
  Rng rng(seed, stream);
  const std::size_t set = std::size_t(rng.next_u64() % kDirectionSets);
  const double phi = 2.0 * std::numbers::pi * rng.next_double();
  glm::dvec3 t0, b0;
  tangent_frame(n, t0, b0);
  const glm::dvec3 t = std::cos(phi) * t0 + std::sin(phi) * b0, b = glm::cross(n, t);
  out.resize(rays);
  const glm::dvec3* local = sets.data() + set * rays;
  for (std::size_t r = 0; r < rays; ++r) out[r] = to_world(local[r], t, b, n);
}

// Per source block, the kb-wide accumulation of Limp rows (DRT §4.1, §4.3).
using BlockRows = std::map<std::uint32_t, std::vector<double>>;

// Sums of w * Limp(hit) (bilinear on the hit face's texel grid) per hit block. Hits are
// first gathered as tap weights per level sample and applied to Limp once per texel, so a
// ray costs four adds instead of four kb-wide rows.
class LimpGather {
 public:
  LimpGather(const Level& level, const Dictionary& dict, std::span<const int> sample_block)
      : level_(level),
        dict_(dict),
        sample_block_(sample_block),
        weight_(level.sample_count, 0.0),
        touched_flag_(level.sample_count, 0) {
    for (const LevelBlock& b : level.blocks)
      layouts_.push_back(SampleLayout::make(dictionary_shape_mask(b.shape), level.res));
  }
  void add(const LevelHit& hit, double w) {
    const LevelBlock& hb = level_.blocks[std::size_t(hit.block)];
    const SampleLayout& layout = layouts_[std::size_t(hit.block)];
    const BilinearTaps taps = taps_of(hit.u, hit.v);
    for (int k = 0; k < 4; ++k) {
      const std::size_t idx = hb.sample_offset + std::size_t(layout.index(hit.face, taps.i[k], taps.j[k]));
      if (!touched_flag_[idx]) {
        touched_flag_[idx] = 1;
        touched_.push_back(idx);
      }
      weight_[idx] += w * taps.w[k];
    }
  }
  // bilinear_taps (block_scene.h), inlined: it is called four times per gathered ray.
  BilinearTaps taps_of(double u, double v) const {
    const int res = level_.res;
    BilinearTaps taps;
    const double x = u * res - 0.5, y = v * res - 0.5;
    const double fx0 = std::floor(x), fy0 = std::floor(y);
    const double ax = x - fx0, ay = y - fy0;
    const int x0 = int(fx0), y0 = int(fy0);
    const int xs[2] = {std::clamp(x0, 0, res - 1), std::clamp(x0 + 1, 0, res - 1)};
    const int ys[2] = {std::clamp(y0, 0, res - 1), std::clamp(y0 + 1, 0, res - 1)};
    const double wx[2] = {1.0 - ax, ax}, wy[2] = {1.0 - ay, ay};
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        taps.i[2 * b + a] = xs[a];
        taps.j[2 * b + a] = ys[b];
        taps.w[2 * b + a] = wx[a] * wy[b];
      }
    return taps;
  }
  // Adds the gathered Limp rows to `rows` and clears the gather. Samples are taken in the
  // order the rays first touched them, fixed by the work item's directions, so the sums do
  // not depend on scheduling. `samples`, when given, also receives each touched sample's
  // weight itself (DrtBuildSettings::gather or sample_gather), ascending by sample. Without
  // `with_limp` the Limp rows are not formed (the gather's clutter texels need the weights alone).
  void flush(BlockRows& rows, std::vector<std::pair<std::uint32_t, float>>* samples = nullptr,
             bool with_limp = true) {
    if (samples) {
      for (std::size_t idx : touched_) samples->emplace_back(std::uint32_t(idx), float(weight_[idx]));
      std::sort(samples->begin(), samples->end());
    }
    if (!with_limp) {
      for (std::size_t idx : touched_) weight_[idx] = 0.0, touched_flag_[idx] = 0;
      touched_.clear();
      return;
    }
    for (std::size_t idx : touched_) {
      const int blk = sample_block_[idx];
      const LevelBlock& lb = level_.blocks[std::size_t(blk)];
      const std::span<const float> limp =
          block_operators(dict_, level_, lb).Limp.row(std::uint32_t(idx - lb.sample_offset));
      std::vector<double>& row = rows[std::uint32_t(blk)];
      row.resize(level_.kb, 0.0);  // level.kb wide; a block with fewer modes leaves the rest 0
      for (std::size_t c = 0; c < limp.size(); ++c) row[c] += weight_[idx] * double(limp[c]);
      weight_[idx] = 0.0;
      touched_flag_[idx] = 0;
    }
    touched_.clear();
  }

 private:
  const Level& level_;
  const Dictionary& dict_;
  std::span<const int> sample_block_;
  std::vector<SampleLayout> layouts_;
  std::vector<double> weight_;
  std::vector<std::uint8_t> touched_flag_;
  std::vector<std::size_t> touched_;
};

// One object's share of a scene sample's rays (DRT §4.1, §4.2).
struct ObjectRows {
  std::uint32_t object = 0;
  BlockRows dUb;
  std::vector<double> dUc;  // face_count of the object; empty when no ray entered it
  // With DrtBuildSettings::gather or sample_gather: the same rays' weights per hidden scene
  // sample (negative: dUb's taps) and per clutter texel they enter (cc_key(object, texel):
  // an object's own texel numbers stay valid when another object's texel count changes),
  // ascending.
  std::vector<std::pair<std::uint32_t, float>> samples;
  std::vector<std::pair<std::uint64_t, float>> texels;
};

struct SampleResult {
  enum State : std::uint8_t { culled, traced, inside };
  State state = culled;
  int inside_of = -1;            // the first object containing the sample
  std::vector<ObjectRows> rows;  // ascending object

  ObjectRows& rows_of(std::uint32_t object) {
    auto it = std::lower_bound(rows.begin(), rows.end(), object,
                               [](const ObjectRows& r, std::uint32_t o) { return r.object < o; });
    if (it == rows.end() || it->object != object) it = rows.insert(it, ObjectRows{object, {}, {}, {}, {}});
    return *it;
  }
  const ObjectRows* find(std::uint32_t object) const {
    for (const ObjectRows& r : rows)
      if (r.object == object) return &r;
    return nullptr;
  }
};

// One clutter texel's gather (DRT §4.3 and clutter-to-clutter light).
struct TexelResult {
  BlockRows cb;  // Limp sums of the walls its rays reach, per block
  // The same rays' weight per scene sample (bilinear taps of the wall hits), ascending by
  // sample; recorded only with DrtBuildSettings::gather or sample_gather.
  std::vector<std::pair<std::uint32_t, float>> samples;
  // And per clutter texel (cc_key(object, texel)) the weight of the rays that enter it first.
  std::vector<std::pair<std::uint64_t, float>> texels;
  // (source object, face slot) -> weight of the rays that enter that face first, ascending.
  std::vector<std::pair<std::uint64_t, double>> cc;
  // Adds w to key's entry (few distinct keys per texel: a linear search).
  void add_cc(std::uint64_t key, double w) {
    auto it = std::find_if(cc.begin(), cc.end(), [&](const auto& e) { return e.first == key; });
    if (it == cc.end()) {
      cc.emplace_back(key, w);
    } else {
      it->second += w;
    }
  }
};
// Sorts (key, weight) pairs and adds up the weights of equal keys.
template <class Key>
void merge_sorted_duplicates(std::vector<std::pair<Key, float>>& entries) {
  std::sort(entries.begin(), entries.end());
  std::size_t out = 0;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (out > 0 && entries[out - 1].first == entries[i].first) {
      entries[out - 1].second += entries[i].second;
    } else {
      entries[out++] = entries[i];
    }
  }
  entries.resize(out);
}
// A mesh can have many charts: 32 bits each.
inline std::uint64_t cc_key(std::uint32_t object, int slot) {
  return (std::uint64_t(object) << 32) | std::uint64_t(std::uint32_t(slot));
}
inline std::uint32_t cc_object(std::uint64_t key) { return std::uint32_t(key >> 32); }
inline std::uint32_t cc_slot(std::uint64_t key) { return std::uint32_t(key & 0xFFFFFFFFull); }

inline bool same_mesh(const ClutterObject& a, const ClutterObject& b) {
  if (a.mesh == b.mesh) return true;
  if (!a.mesh || !b.mesh) return false;
  return a.mesh->mesh.positions == b.mesh->mesh.positions && a.mesh->mesh.uvs == b.mesh->mesh.uvs &&
         a.mesh->mesh.indices == b.mesh->mesh.indices;
}

inline bool same_object(const ClutterObject& a, const ClutterObject& b) {
  return a.kind == b.kind && a.block == b.block && a.box.center == b.box.center &&
         a.box.half_extent == b.box.half_extent && a.box.rotation == b.box.rotation && a.faces == b.faces &&
         a.albedo == b.albedo && a.res == b.res && same_mesh(a, b);
}

}  // namespace modrt::precompute::drt_detail
