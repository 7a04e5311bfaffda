// SPDX-License-Identifier: MIT
#include "modrt/precompute/drt_build.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <numbers>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include "modrt/precompute/svd.h"

#include "drt_gather.h"
#include "drt_state.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/linalg.h"
#include "modrt/precompute/sampling.h"
#include "modrt/precompute/sh_operators.h"
#include "modrt/sh.h"

namespace modrt::precompute {

using namespace drt_detail;

DrtBuildState::DrtBuildState() = default;
DrtBuildState::~DrtBuildState() = default;
DrtBuildState::DrtBuildState(DrtBuildState&&) noexcept = default;
DrtBuildState& DrtBuildState::operator=(DrtBuildState&&) noexcept = default;
bool DrtBuildState::empty() const { return !impl_; }
std::span<const ClutterObject> DrtBuildState::objects() const {
  return impl_ ? std::span<const ClutterObject>(impl_->objects) : std::span<const ClutterObject>();
}

namespace {

// Each object's first texel in the clutter-wide texel order.
std::vector<std::uint32_t> texel_bases(std::span<const ClutterObject> objects) {
  std::vector<std::uint32_t> base;
  std::uint32_t next = 0;
  for (const ClutterObject& o : objects) {
    base.push_back(next);
    next += std::uint32_t(clutter_texel_count(o));
  }
  return base;
}

// Recorded (object, texel) keys as clutter-wide texel indices.
void append_texels(const std::vector<std::pair<std::uint64_t, float>>& keyed,
                   const std::vector<std::uint32_t>& base,
                   std::vector<std::pair<std::uint32_t, float>>& out) {
  for (const auto& [key, weight] : keyed)
    out.emplace_back(base[cc_object(key)] + std::uint32_t(cc_slot(key)), weight);
}

}  // namespace

std::vector<ClutterSampleGather> DrtBuildState::sample_gather(bool clutter_texels) const {
  std::vector<ClutterSampleGather> out;
  if (!impl_) return out;
  const std::vector<std::uint32_t> base = texel_bases(impl_->objects);
  std::vector<std::pair<std::uint32_t, float>> entries;
  for (const std::vector<TexelResult>& texels : impl_->texels) {
    ClutterSampleGather& g = out.emplace_back();
    g.row_start.push_back(0);
    for (const TexelResult& t : texels) {
      entries.clear();
      if (clutter_texels) {
        append_texels(t.texels, base, entries);
      } else {
        entries = t.samples;
      }
      for (const auto& [index, weight] : entries) {
        g.sample.push_back(index);
        g.weight.push_back(weight);
      }
      g.row_start.push_back(std::uint32_t(g.sample.size()));
    }
  }
  return out;
}

ClutterSampleGather DrtBuildState::scene_sample_gather(bool clutter_texels) const {
  ClutterSampleGather g;
  if (!impl_) return g;
  const std::vector<std::uint32_t> base = texel_bases(impl_->objects);
  g.row_start.push_back(0);
  for (const SampleResult& sample : impl_->samples) {
    std::vector<std::pair<std::uint32_t, float>> entries;
    for (const ObjectRows& rows : sample.rows) {
      if (clutter_texels) {
        append_texels(rows.texels, base, entries);
      } else {
        entries.insert(entries.end(), rows.samples.begin(), rows.samples.end());
      }
    }
    merge_sorted_duplicates(entries);
    for (const auto& [index, weight] : entries) {
      g.sample.push_back(index);
      g.weight.push_back(weight);
    }
    g.row_start.push_back(std::uint32_t(g.sample.size()));
  }
  return g;
}

void clutter_gather_radiance(const ClutterSampleGather& gather, std::span<const float> radiance,
                             std::span<float> out) {
  for (std::size_t t = 0; t + 1 < gather.row_start.size(); ++t) {
    double sum[3] = {0, 0, 0};
    for (std::uint32_t e = gather.row_start[t]; e < gather.row_start[t + 1]; ++e)
      for (int ch = 0; ch < 3; ++ch)
        sum[ch] += double(gather.weight[e]) * double(radiance[3 * std::size_t(gather.sample[e]) + ch]);
    for (int ch = 0; ch < 3; ++ch) out[3 * t + ch] = float(sum[ch]);
  }
}

// One build or rebuild over a fixed list of objects.
struct DrtBuilder::Pass {
  const DrtBuilder& b;
  std::span<const ClutterObject> objects;
  ObjectQueries owned;
  const std::vector<ObjectQuery>& queries;
  tbb::enumerable_thread_specific<LimpGather> gathers;
  tbb::enumerable_thread_specific<std::vector<LimpGather>> vector_gathers;  // one per OHLSH coefficient
  tbb::enumerable_thread_specific<std::vector<LimpGather>> probe_gathers;   // one per SH9 coefficient

  Pass(const DrtBuilder& builder, std::span<const ClutterObject> objs, ObjectQueries q)
      : b(builder),
        objects(objs),
        owned(std::move(q)),
        queries(owned.queries),
        gathers([this] { return LimpGather(b.level_, b.dict_, b.walls_.samples().block); }),
        vector_gathers([this] {
          return std::vector<LimpGather>(kOhlshCount,
                                         LimpGather(b.level_, b.dict_, b.walls_.samples().block));
        }),
        probe_gathers([this] {
          return std::vector<LimpGather>(kSh9Count, LimpGather(b.level_, b.dict_, b.walls_.samples().block));
        }) {
    if (!b.settings_.sample_gather && !b.settings_.gather) return;
    texel_lookup.resize(objects.size());
    std::uint32_t base = 0;
    for (std::size_t k = 0; k < objects.size(); ++k) {
      texel_lookup[k].prepare(objects[k]);
      texel_base.push_back(base);
      base += std::uint32_t(clutter_texel_count(objects[k]));
    }
  }
  // With DrtBuildSettings::gather or sample_gather: each object's hit -> texel lookup and its first
  // texel among all objects' (clutter-wide texel order).
  std::vector<ObjectBasis> texel_lookup;
  std::vector<std::uint32_t> texel_base;
  // Whether the rays' weights per scene sample and clutter texel are recorded.
  bool records() const { return !texel_lookup.empty(); }

  std::span<const glm::dvec3> sets() const { return b.direction_sets_; }
  int rays() const { return int(b.direction_sets_.size() / kDirectionSets); }
  // The clutter texels' cosine-weighted sets (DrtBuildSettings::max_clutter_rays).
  std::span<const glm::dvec3> texel_sets() const { return b.texel_sets(); }
  int texel_rays() const { return int(texel_sets().size() / kDirectionSets); }

  // dUb and dUc (DRT §4.1, §4.2) of every object at scene sample s: cosine-weighted gather
  // rays; a ray that enters an object before any wall is light that object takes away (the
  // wall behind it, lit by Limp b of its block) and light it sends (its face).
  SampleResult trace_sample(std::size_t s, LimpGather& gather, Candidates& cand,
                            std::vector<glm::dvec3>& dirs, std::vector<glm::dvec3>& hit_dirs,
                            std::vector<LevelHit>& walls, std::vector<Candidates::Nearest>& nearest) const {
    SampleResult result;
    const LevelSampleGeometry& g = b.walls_.samples();
    const glm::dvec3 x = g.position[s], nrm = g.normal[s];
    for (std::size_t k = 0; k < objects.size(); ++k)
      if (queries[k].contains(x, nrm)) {
        result.state = SampleResult::inside;
        result.inside_of = int(k);
        return result;
      }
    cand.clear();
    for (std::size_t k = 0; k < objects.size(); ++k)
      if (!b.settings_.cull || queries[k].in_front(x, nrm)) cand.add(std::uint32_t(k), queries[k], x);
    if (cand.empty()) return result;
    result.state = SampleResult::traced;
    texel_directions(sets(), b.settings_.seed, s, nrm, dirs);
    hit_dirs.clear();
    nearest.clear();
    for (const glm::dvec3& dir : dirs) {
      const Candidates::Nearest n = cand.nearest(queries, dir);
      if (n.object < 0) continue;
      hit_dirs.push_back(dir);
      nearest.push_back(n);
    }
    if (hit_dirs.empty()) return result;
    walls.resize(hit_dirs.size());
    b.walls_.intersect_many(x, hit_dirs, walls);
    const double w = 1.0 / rays();
    // Object by object (ascending) so that each object's gather is flushed on its own.
    for (const Candidates::Entry& e : cand.entries) {
      const std::uint32_t k = e.object;
      ObjectRows* rows = nullptr;
      for (std::size_t r = 0; r < hit_dirs.size(); ++r) {
        if (nearest[r].object != int(k)) continue;
        const LevelHit& wall = walls[r];
        if (wall.block >= 0 && wall.t < nearest[r].entry.t) continue;  // a wall hides the box
        if (!rows) rows = &result.rows_of(k);
        if (wall.block >= 0) gather.add(wall, -w);
        queries[k].charge(nearest[r].entry, x, hit_dirs[r], [&](std::size_t col, double value) {
          rows->dUc.resize(std::size_t(queries[k].columns), 0.0);
          rows->dUc[col] += w * value;
        });
        if (!texel_lookup.empty()) {
          const int t = texel_lookup[k].texel_at(nearest[r].entry, x, hit_dirs[r]);
          if (t >= 0) rows->texels.emplace_back(cc_key(k, t), float(w));
        }
      }
      if (rows) {
        gather.flush(rows->dUb, records() ? &rows->samples : nullptr);
        merge_sorted_duplicates(rows->texels);
      }
    }
    return result;
  }

  // dUb_vec and dUc_vec at scene sample s (DRT §5, vector response): the scalar gather's
  // charging with uniform-hemisphere rays in the sample's face frame, each ray weighted by
  // 2 pi / rays times the OHLSH coefficients of its direction. Rows are 4 kb per block and
  // 4 f for dUc, coefficient-major.
  SampleResult trace_sample_vector(std::size_t s, std::vector<LimpGather>& gather, Candidates& cand,
                                   std::vector<glm::dvec3>& local, std::vector<glm::dvec3>& dirs,
                                   std::vector<glm::dvec3>& hit_dirs, std::vector<LevelHit>& walls,
                                   std::vector<Candidates::Nearest>& nearest,
                                   std::vector<std::array<double, kOhlshCount>>& weights) const {
    SampleResult result;
    const LevelSampleGeometry& g = b.walls_.samples();
    const glm::dvec3 x = g.position[s], nrm = g.normal[s];
    for (std::size_t k = 0; k < objects.size(); ++k)
      if (queries[k].contains(x, nrm)) {
        result.state = SampleResult::inside;
        result.inside_of = int(k);
        return result;
      }
    cand.clear();
    for (std::size_t k = 0; k < objects.size(); ++k)
      if (!b.settings_.cull || queries[k].in_front(x, nrm)) cand.add(std::uint32_t(k), queries[k], x);
    if (cand.empty()) return result;
    result.state = SampleResult::traced;
    glm::dvec3 u, v, n;
    sample_frame(b.level_, g, s, u, v, n);
    frame_directions(b.uniform_sets_, vector_seed(), s, u, v, n, local, dirs);
    hit_dirs.clear();
    nearest.clear();
    weights.clear();
    for (std::size_t r = 0; r < dirs.size(); ++r) {
      const Candidates::Nearest hit = cand.nearest(queries, dirs[r]);
      if (hit.object < 0) continue;
      hit_dirs.push_back(dirs[r]);
      nearest.push_back(hit);
      weights.push_back(ohlsh_weights(local[r]));
    }
    if (hit_dirs.empty()) return result;
    walls.resize(hit_dirs.size());
    b.walls_.intersect_many(x, hit_dirs, walls);
    const double w = 2.0 * std::numbers::pi / double(dirs.size());  // uniform pdf 1 / (2 pi)
    const std::uint32_t kb = b.level_.kb;
    for (const Candidates::Entry& e : cand.entries) {
      const std::uint32_t k = e.object;
      const std::size_t f_count = std::size_t(queries[k].columns);
      ObjectRows* rows = nullptr;
      for (std::size_t r = 0; r < hit_dirs.size(); ++r) {
        if (nearest[r].object != int(k)) continue;
        const LevelHit& wall = walls[r];
        if (wall.block >= 0 && wall.t < nearest[r].entry.t) continue;  // a wall hides the box
        if (!rows) rows = &result.rows_of(k);
        for (int i = 0; i < kOhlshCount; ++i)
          if (wall.block >= 0) gather[std::size_t(i)].add(wall, -w * weights[r][std::size_t(i)]);
        queries[k].charge(nearest[r].entry, x, hit_dirs[r], [&](std::size_t col, double value) {
          rows->dUc.resize(kOhlshCount * f_count, 0.0);
          for (int i = 0; i < kOhlshCount; ++i)
            rows->dUc[std::size_t(i) * f_count + col] += w * weights[r][std::size_t(i)] * value;
        });
      }
      if (!rows) continue;
      for (int i = 0; i < kOhlshCount; ++i) {
        BlockRows coefficient;
        gather[std::size_t(i)].flush(coefficient);
        for (const auto& [blk, values] : coefficient) {
          std::vector<double>& dst = rows->dUb[blk];
          dst.resize(kOhlshCount * std::size_t(kb), 0.0);
          std::copy(values.begin(), values.end(), dst.begin() + std::ptrdiff_t(i) * kb);
        }
      }
    }
    return result;
  }
  std::uint64_t vector_seed() const { return b.settings_.seed ^ 0x766563ull; }
  std::uint64_t probe_seed() const { return b.settings_.seed ^ 0x70726full; }
  int probes_per_block() const {
    const int g = int(b.dict_.settings.probe_grid);
    return g * g * g;
  }
  // World position of global probe p and the frame of its SH (the block's canonical frame).
  void probe_frame(std::size_t p, glm::dvec3& x, glm::dvec3& u, glm::dvec3& v, glm::dvec3& n) const {
    const int count = probes_per_block();
    const LevelBlock& blk = b.level_.blocks[p / std::size_t(count)];
    x = block_to_world(blk, probe_position(int(p % std::size_t(count)), int(b.dict_.settings.probe_grid)));
    u = rotate_direction(glm::dvec3(1, 0, 0), blk.quarter_turns);
    v = rotate_direction(glm::dvec3(0, 1, 0), blk.quarter_turns);
    n = rotate_direction(glm::dvec3(0, 0, 1), blk.quarter_turns);
  }

  // U_dyn at global probe p (DRT §5): uniform-sphere rays; a ray whose first hit is clutter
  // object k adds to k's rows -Limp(wall behind) and its face, weighted by 4 pi / rays times
  // the SH9 basis of its direction in the block frame. Rows are 9 kb per block and 9 f for
  // the faces, coefficient-major.
  SampleResult trace_probe(std::size_t p, std::vector<LimpGather>& gather, std::vector<glm::dvec3>& local,
                           std::vector<glm::dvec3>& dirs, std::vector<glm::dvec3>& hit_dirs,
                           std::vector<glm::dvec3>& hit_local, std::vector<LevelHit>& walls,
                           std::vector<Candidates::Nearest>& nearest) const {
    SampleResult result;
    glm::dvec3 x, u, v, n;
    probe_frame(p, x, u, v, n);
    for (std::size_t k = 0; k < objects.size(); ++k)
      if (queries[k].contains(x, glm::dvec3(0.0))) {
        result.state = SampleResult::inside;
        result.inside_of = int(k);
        return result;
      }
    Candidates cand;
    for (std::size_t k = 0; k < objects.size(); ++k) cand.add(std::uint32_t(k), queries[k], x);
    result.state = SampleResult::traced;
    frame_directions(b.sphere_sets_, probe_seed(), p, u, v, n, local, dirs);
    hit_dirs.clear();
    hit_local.clear();
    nearest.clear();
    for (std::size_t r = 0; r < dirs.size(); ++r) {
      const Candidates::Nearest hit = cand.nearest(queries, dirs[r]);
      if (hit.object < 0) continue;
      hit_dirs.push_back(dirs[r]);
      hit_local.push_back(local[r]);
      nearest.push_back(hit);
    }
    if (hit_dirs.empty()) return result;
    walls.resize(hit_dirs.size());
    b.walls_.intersect_many(x, hit_dirs, walls);
    const double w = 4.0 * std::numbers::pi / double(dirs.size());  // uniform pdf 1 / (4 pi)
    const std::uint32_t kb = b.level_.kb;
    for (std::size_t k = 0; k < objects.size(); ++k) {
      const std::size_t f_count = std::size_t(queries[k].columns);
      ObjectRows* rows = nullptr;
      for (std::size_t r = 0; r < hit_dirs.size(); ++r) {
        if (nearest[r].object != int(k)) continue;
        const LevelHit& wall = walls[r];
        if (wall.block >= 0 && wall.t < nearest[r].entry.t) continue;  // a wall hides the box
        if (!rows) rows = &result.rows_of(std::uint32_t(k));
        double y[kSh9Count];
        sh9_eval(hit_local[r], y);
        for (int j = 0; j < kSh9Count; ++j)
          if (wall.block >= 0) gather[std::size_t(j)].add(wall, -w * y[j]);
        queries[k].charge(nearest[r].entry, x, hit_dirs[r], [&](std::size_t col, double value) {
          rows->dUc.resize(kSh9Count * f_count, 0.0);
          for (int j = 0; j < kSh9Count; ++j) rows->dUc[std::size_t(j) * f_count + col] += w * y[j] * value;
        });
      }
      if (!rows) continue;
      for (int j = 0; j < kSh9Count; ++j) {
        BlockRows coefficient;
        gather[std::size_t(j)].flush(coefficient);
        for (const auto& [blk, values] : coefficient) {
          std::vector<double>& dst = rows->dUb[blk];
          dst.resize(kSh9Count * std::size_t(kb), 0.0);
          std::copy(values.begin(), values.end(), dst.begin() + std::ptrdiff_t(j) * kb);
        }
      }
    }
    return result;
  }
  bool probe_depends_on(std::size_t p, const ObjectQuery& query, std::vector<glm::dvec3>& local,
                        std::vector<glm::dvec3>& dirs) const {
    glm::dvec3 x, u, v, n;
    probe_frame(p, x, u, v, n);
    if (query.contains(x, glm::dvec3(0.0))) return true;
    frame_directions(b.sphere_sets_, probe_seed(), p, u, v, n, local, dirs);
    const std::vector<ObjectQuery> one{query};
    Candidates cand;
    cand.add(0, query, x);
    for (const glm::dvec3& dir : dirs)
      if (cand.nearest(one, dir).object >= 0) return true;
    return false;
  }
  void probe_pass(std::vector<SampleResult>& probes, const std::vector<std::uint8_t>& retrace) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, probes.size(), 1),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        std::vector<LimpGather>& gather = probe_gathers.local();
                        std::vector<glm::dvec3> local, dirs, hit_dirs, hit_local;
                        std::vector<LevelHit> walls;
                        std::vector<Candidates::Nearest> nearest;
                        for (std::size_t p = range.begin(); p != range.end(); ++p)
                          if (retrace.empty() || retrace[p])
                            probes[p] =
                                trace_probe(p, gather, local, dirs, hit_dirs, hit_local, walls, nearest);
                      });
  }
  // Udyn and Udyn_c of every object from the traced probes.
  void assemble_probes(const std::vector<SampleResult>& probes, DrtOperators& drt) const {
    const std::uint32_t kb = b.level_.kb;
    drt.probes_per_block = std::uint32_t(probes_per_block());
    for (std::size_t k = 0; k < objects.size(); ++k) {
      DrtObjectOperators& op = drt.objects[k];
      const std::uint32_t f_count = std::uint32_t(queries[k].columns);
      std::size_t rows = 0, c_rows = 0;
      for (const SampleResult& r : probes)
        if (const ObjectRows* o = r.find(std::uint32_t(k))) {
          rows += o->dUb.size();
          c_rows += o->dUc.empty() ? 0 : 1;
        }
      op.Udyn_probe.clear();
      op.Udyn_block.clear();
      op.Udyn_c_probe.clear();
      op.Udyn = Matrix(std::uint32_t(kSh9Count * rows), rows > 0 ? kb : 0);
      op.Udyn_c = Matrix(std::uint32_t(kSh9Count * c_rows), c_rows > 0 ? f_count : 0);
      std::size_t row = 0, c_row = 0;
      for (std::size_t p = 0; p < probes.size(); ++p) {
        const ObjectRows* o = probes[p].find(std::uint32_t(k));
        if (!o) continue;
        for (const auto& [src, values] : o->dUb) {
          op.Udyn_probe.push_back(std::uint32_t(p));
          op.Udyn_block.push_back(src);
          for (std::uint32_t j = 0; j < kSh9Count; ++j)
            for (std::uint32_t c = 0; c < kb; ++c)
              op.Udyn(std::uint32_t(kSh9Count * row + j), c) = float(values[j * kb + c]);
          ++row;
        }
        if (!o->dUc.empty()) {
          op.Udyn_c_probe.push_back(std::uint32_t(p));
          for (std::uint32_t j = 0; j < kSh9Count; ++j)
            for (std::uint32_t f = 0; f < f_count; ++f)
              op.Udyn_c(std::uint32_t(kSh9Count * c_row + j), f) = float(o->dUc[j * f_count + f]);
          ++c_row;
        }
      }
    }
  }

  // Cb (DRT §4.3) and Cc of texel i of object k: gather rays from the texel average the Limp
  // rows of the walls they reach (per hit block); a ray that enters another object first
  // brings that object's face instead; misses bring nothing. A texel inside another object
  // is hidden and gathers nothing. A mesh can be concave: a ray that re-enters the object
  // itself is shadowed and brings nothing (its own interreflection is left out, so Cc never
  // names the object itself).
  TexelResult trace_texel(std::size_t k, std::size_t i, const ClutterTexelGeometry& cg, LimpGather& gather,
                          Candidates& cand, std::vector<glm::dvec3>& dirs,
                          std::vector<LevelHit>& walls) const {
    TexelResult result;
    const glm::dvec3 n = cg.normal[i];
    glm::dvec3 x;
    if (!texel_candidates(k, cg.position[i], n, cand, x)) return result;
    texel_directions(texel_sets(), b.settings_.seed ^ 0x436200ull, texel_stream(k, i), n, dirs);
    walls.resize(dirs.size());
    b.walls_.intersect_many(x, dirs, walls);
    const double w = 1.0 / texel_rays();
    for (std::size_t r = 0; r < dirs.size(); ++r) {
      const LevelHit& wall = walls[r];
      if (!cand.empty()) {
        const Candidates::Nearest hit = cand.nearest(queries, dirs[r]);
        if (hit.object >= 0 && !(wall.block >= 0 && wall.t < hit.entry.t)) {
          if (std::size_t(hit.object) == k) continue;  // a concave mesh shadows itself
          // An unlit face (resting on a wall) sends nothing.
          queries[std::size_t(hit.object)].charge(hit.entry, x, dirs[r], [&](std::size_t col, double value) {
            result.add_cc(cc_key(std::uint32_t(hit.object), int(col)), w * value);
          });
          if (!texel_lookup.empty()) {
            const int t = texel_lookup[std::size_t(hit.object)].texel_at(hit.entry, x, dirs[r]);
            if (t >= 0) result.texels.emplace_back(cc_key(std::uint32_t(hit.object), t), float(w));
          }
          continue;
        }
      }
      if (wall.block >= 0) gather.add(wall, w);
    }
    // The gather builds no Cb: its texels keep the weights alone.
    gather.flush(result.cb, records() ? &result.samples : nullptr, !b.settings_.gather);
    std::sort(result.cc.begin(), result.cc.end());
    merge_sorted_duplicates(result.texels);
    return result;
  }

  // The start of texel gathers from surface point p (normal n) of object k: false when p lies
  // inside another object (hidden: it gathers nothing); else the rays' origin x, just off the
  // face so that a float ray does not start behind it, and the objects the rays test (the
  // object itself too when it is a mesh, which can be concave).
  bool texel_candidates(std::size_t k, const glm::dvec3& p, const glm::dvec3& n, Candidates& cand,
                        glm::dvec3& x) const {
    for (std::size_t j = 0; j < objects.size(); ++j)
      if (j != k && queries[j].contains(p, n)) return false;
    x = p + 1e-6 * n;
    cand.clear();
    for (std::size_t j = 0; j < objects.size(); ++j)
      if ((j != k || queries[j].mesh) && (!b.settings_.cull || queries[j].in_front(p, n)))
        cand.add(std::uint32_t(j), queries[j], x);
    return true;
  }

  // Vector Cb and Cc (DRT §5) of texel i of object k: trace_texel's charging with
  // uniform-hemisphere rays in the texel's frame (tangent, cross(normal, tangent), normal),
  // each ray weighted by 2 pi / rays times the OHLSH coefficients of its direction. cb rows
  // are 4 kb per block and cc slots 4 col + i (coefficient-major, assemble_cb_cc).
  TexelResult trace_texel_vector(std::size_t k, std::size_t i, const ClutterTexelGeometry& cg,
                                 std::vector<LimpGather>& gather, Candidates& cand,
                                 std::vector<glm::dvec3>& local, std::vector<glm::dvec3>& dirs,
                                 std::vector<LevelHit>& walls) const {
    TexelResult result;
    const glm::dvec3 n = cg.normal[i], t = cg.tangent[i];
    glm::dvec3 x;
    if (!texel_candidates(k, cg.position[i], n, cand, x)) return result;
    frame_directions(b.uniform_sets_, vector_seed() ^ 0x436200ull, texel_stream(k, i), t, glm::cross(n, t), n,
                     local, dirs);
    walls.resize(dirs.size());
    b.walls_.intersect_many(x, dirs, walls);
    const double w = 2.0 * std::numbers::pi / double(dirs.size());  // uniform pdf 1 / (2 pi)
    for (std::size_t r = 0; r < dirs.size(); ++r) {
      const LevelHit& wall = walls[r];
      const std::array<double, kOhlshCount> a = ohlsh_weights(local[r]);
      if (!cand.empty()) {
        const Candidates::Nearest hit = cand.nearest(queries, dirs[r]);
        if (hit.object >= 0 && !(wall.block >= 0 && wall.t < hit.entry.t)) {
          if (std::size_t(hit.object) == k) continue;  // a concave mesh shadows itself
          queries[std::size_t(hit.object)].charge(hit.entry, x, dirs[r], [&](std::size_t col, double value) {
            for (int q = 0; q < kOhlshCount; ++q)
              result.add_cc(cc_key(std::uint32_t(hit.object), int(kOhlshCount * col) + q),
                            w * a[std::size_t(q)] * value);
          });
          continue;
        }
      }
      if (wall.block >= 0)
        for (int q = 0; q < kOhlshCount; ++q) gather[std::size_t(q)].add(wall, w * a[std::size_t(q)]);
    }
    const std::uint32_t kb = b.level_.kb;
    for (int q = 0; q < kOhlshCount; ++q) {
      BlockRows coefficient;
      gather[std::size_t(q)].flush(coefficient);
      for (const auto& [blk, values] : coefficient) {
        std::vector<double>& dst = result.cb[blk];
        dst.resize(kOhlshCount * std::size_t(kb), 0.0);
        std::copy(values.begin(), values.end(), dst.begin() + std::ptrdiff_t(q) * kb);
      }
    }
    std::sort(result.cc.begin(), result.cc.end());
    return result;
  }

  // Whether the result of a work item (rays from origin about n) can depend on `box`: the
  // origin lies in it (inside test of the trace) or one of its rays enters it (the only
  // rays whose nearest object can change). Exact: an item for which this is false for a
  // box's old and new place gives the same result before and after the move.
  bool depends_on(const ObjectQuery& query, const glm::dvec3& p, const glm::dvec3& origin,
                  const glm::dvec3& n, std::span<const glm::dvec3> direction_sets, std::uint64_t seed,
                  std::uint64_t stream, std::vector<glm::dvec3>& dirs) const {
    if (query.contains(p, n)) return true;
    if (b.settings_.cull && !query.in_front(p, n)) return false;
    texel_directions(direction_sets, seed, stream, n, dirs);
    const std::vector<ObjectQuery> one{query};
    Candidates cand;
    cand.add(0, query, origin);
    for (const glm::dvec3& dir : dirs)
      if (cand.nearest(one, dir).object >= 0) return true;
    return false;
  }
  // The same for the vector pass's rays of sample s.
  bool sample_vector_depends_on(std::size_t s, const ObjectQuery& query, std::vector<glm::dvec3>& local,
                                std::vector<glm::dvec3>& dirs) const {
    const LevelSampleGeometry& g = b.walls_.samples();
    if (query.contains(g.position[s], g.normal[s])) return true;
    if (b.settings_.cull && !query.in_front(g.position[s], g.normal[s])) return false;
    glm::dvec3 u, v, n;
    sample_frame(b.level_, g, s, u, v, n);
    frame_directions(b.uniform_sets_, vector_seed(), s, u, v, n, local, dirs);
    const std::vector<ObjectQuery> one{query};
    Candidates cand;
    cand.add(0, query, g.position[s]);
    for (const glm::dvec3& dir : dirs)
      if (cand.nearest(one, dir).object >= 0) return true;
    return false;
  }
  bool sample_depends_on(std::size_t s, const ObjectQuery& query, std::vector<glm::dvec3>& dirs) const {
    const LevelSampleGeometry& g = b.walls_.samples();
    return depends_on(query, g.position[s], g.position[s], g.normal[s], sets(), b.settings_.seed, s, dirs);
  }
  bool texel_depends_on(std::size_t k, std::size_t i, const ClutterTexelGeometry& cg,
                        const ObjectQuery& query, std::vector<glm::dvec3>& dirs) const {
    return depends_on(query, cg.position[i], cg.position[i] + 1e-6 * cg.normal[i], cg.normal[i], texel_sets(),
                      b.settings_.seed ^ 0x436200ull, texel_stream(k, i), dirs);
  }
  // The same for the vector clutter pass's rays of texel i of object k.
  bool texel_vector_depends_on(std::size_t k, std::size_t i, const ClutterTexelGeometry& cg,
                               const ObjectQuery& query, std::vector<glm::dvec3>& local,
                               std::vector<glm::dvec3>& dirs) const {
    const glm::dvec3 p = cg.position[i], n = cg.normal[i], t = cg.tangent[i];
    if (query.contains(p, n)) return true;
    if (b.settings_.cull && !query.in_front(p, n)) return false;
    frame_directions(b.uniform_sets_, vector_seed() ^ 0x436200ull, texel_stream(k, i), t, glm::cross(n, t), n,
                     local, dirs);
    const std::vector<ObjectQuery> one{query};
    Candidates cand;
    cand.add(0, query, p + 1e-6 * n);
    for (const glm::dvec3& dir : dirs)
      if (cand.nearest(one, dir).object >= 0) return true;
    return false;
  }
  static std::uint64_t texel_stream(std::size_t k, std::size_t i) {
    return (std::uint64_t(k) << 32) | std::uint64_t(i);
  }

  // Traces the scene samples with retrace[s] != 0 (all when empty) into `samples`.
  void scene_pass(std::vector<SampleResult>& samples, const std::vector<std::uint8_t>& retrace) {
    const std::size_t n = samples.size();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        LimpGather& gather = gathers.local();
                        Candidates cand;
                        std::vector<glm::dvec3> dirs, hit_dirs;
                        std::vector<LevelHit> walls;
                        std::vector<Candidates::Nearest> nearest;
                        for (std::size_t s = range.begin(); s != range.end(); ++s)
                          if (retrace.empty() || retrace[s])
                            samples[s] = trace_sample(s, gather, cand, dirs, hit_dirs, walls, nearest);
                      });
  }

  // The vector pass over the scene samples with retrace[s] != 0 (all when empty).
  void scene_pass_vector(std::vector<SampleResult>& samples, const std::vector<std::uint8_t>& retrace) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, samples.size(), 16),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        std::vector<LimpGather>& gather = vector_gathers.local();
                        Candidates cand;
                        std::vector<glm::dvec3> local, dirs, hit_dirs;
                        std::vector<LevelHit> walls;
                        std::vector<Candidates::Nearest> nearest;
                        std::vector<std::array<double, kOhlshCount>> weights;
                        for (std::size_t s = range.begin(); s != range.end(); ++s)
                          if (retrace.empty() || retrace[s])
                            samples[s] = trace_sample_vector(s, gather, cand, local, dirs, hit_dirs, walls,
                                                             nearest, weights);
                      });
  }

  // Traces the texels listed in `work` (object, texel) into `texels`, and into
  // `vector_texels` when it is not empty (the vector pass).
  void clutter_pass(std::vector<std::vector<TexelResult>>& texels,
                    std::vector<std::vector<TexelResult>>& vector_texels,
                    const std::vector<ClutterTexelGeometry>& geometry,
                    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& work) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, work.size(), 16),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        LimpGather& gather = gathers.local();
                        Candidates cand;
                        std::vector<glm::dvec3> dirs, local;
                        std::vector<LevelHit> walls;
                        for (std::size_t w = range.begin(); w != range.end(); ++w) {
                          const auto [k, i] = work[w];
                          texels[k][i] = trace_texel(k, i, geometry[k], gather, cand, dirs, walls);
                          if (!vector_texels.empty())
                            vector_texels[k][i] = trace_texel_vector(
                                k, i, geometry[k], vector_gathers.local(), cand, local, dirs, walls);
                        }
                      });
  }

  // Inpainting (DRT §5), dropping and assembly of every object's dUb and dUc from the traced
  // samples (which are not changed).
  //
  // vector: the rows are OHLSH (trace_sample_vector: 4 kb per block, 4 f for dUc, i-major),
  // the unshadowed transport is Ub_vec, nothing is dropped, and the result goes to the
  // *_vec operators with 4 matrix rows per entry.
  void assemble_scene(const std::vector<SampleResult>& traced, DrtOperators& drt, DrtBuildReport* report,
                      bool vector = false) const {
    const Level& level = b.level_;
    const Dictionary& dict = b.dict_;
    const LevelSampleGeometry& g = b.walls_.samples();
    const std::size_t n = traced.size();
    const std::uint32_t W = vector ? 4 : 1, kb = level.kb;
    std::vector<SampleResult> result = traced;
    // Row i, column c of a sample's unshadowed transport, i < W (Ub or Ub_vec).
    // Zero past the block's modes (block_kb; the rows are level.kb wide).
    auto unshadowed = [&](const ShapeOperators& op, int local, std::uint32_t i, std::uint32_t c) {
      if (c >= op.Ub.cols) return 0.0;
      return vector ? double(op.Ub_vec(std::uint32_t(4 * local) + i, c))
                    : double(op.Ub(std::uint32_t(local), c));
    };
    // A sample inside clutter takes the mean shadowed transport Ub + sum of dUb of its valid
    // face neighbours, minus its own Ub (charged to the object containing it), and their
    // mean dUc; Jacobi passes fill samples deep inside from the rim inwards, independent of
    // the order.
    std::size_t inpainted = 0;
    if (b.settings_.inpaint) {
      std::vector<std::uint8_t> valid(n);
      for (std::size_t s = 0; s < n; ++s) valid[s] = result[s].state != SampleResult::inside;
      for (bool progress = true; progress;) {
        progress = false;
        std::vector<std::pair<std::size_t, SampleResult>> fills;
        for (std::size_t s = 0; s < n; ++s) {
          if (valid[s]) continue;
          const int blk = g.block[s];
          const LevelBlock& lb = level.blocks[std::size_t(blk)];
          const ShapeOperators& op = block_operators(dict, level, lb);
          const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(lb.shape), level.res);
          const int local = int(s - lb.sample_offset), face = layout.face_of(local);
          const int within = local - layout.slot[std::size_t(face)] * level.res * level.res;
          const int i0 = within % level.res, j0 = within / level.res;
          std::vector<std::size_t> nbrs;
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              const int i = i0 + di, j = j0 + dj;
              if ((di == 0 && dj == 0) || i < 0 || j < 0 || i >= level.res || j >= level.res) continue;
              const std::size_t q = lb.sample_offset + std::size_t(layout.index(face, i, j));
              if (valid[q]) nbrs.push_back(q);
            }
          if (nbrs.empty()) continue;
          SampleResult fill;
          fill.state = SampleResult::inside;
          fill.inside_of = result[s].inside_of;
          const double w = 1.0 / double(nbrs.size());
          {
            std::vector<double>& own = fill.rows_of(std::uint32_t(fill.inside_of)).dUb[std::uint32_t(blk)];
            own.assign(W * kb, 0.0);
            for (std::uint32_t i = 0; i < W; ++i)
              for (std::uint32_t c = 0; c < kb; ++c) {
                own[i * kb + c] = -unshadowed(op, local, i, c);
                for (std::size_t q : nbrs)
                  own[i * kb + c] += w * unshadowed(op, int(q - lb.sample_offset), i, c);
              }
          }
          for (std::size_t q : nbrs)
            for (const ObjectRows& src : result[q].rows) {
              ObjectRows& dst = fill.rows_of(src.object);
              for (const auto& [from, row] : src.dUb) {
                std::vector<double>& d = dst.dUb[from];
                d.resize(row.size(), 0.0);
                for (std::size_t c = 0; c < row.size(); ++c) d[c] += w * row[c];
              }
              if (!src.dUc.empty()) {
                dst.dUc.resize(src.dUc.size(), 0.0);
                for (std::size_t f = 0; f < src.dUc.size(); ++f) dst.dUc[f] += w * src.dUc[f];
              }
            }
          fills.emplace_back(s, std::move(fill));
        }
        for (auto& [s, fill] : fills) {
          result[s] = std::move(fill);
          valid[s] = 1;
          ++inpainted;
          progress = true;
        }
      }
    }

    std::size_t dropped = 0;
    if (b.settings_.drop_tolerance > 0.0 && !vector) {
      auto norm = [](const std::vector<double>& row) {
        double n2 = 0.0;
        for (double v : row) n2 += v * v;
        return std::sqrt(n2);
      };
      std::vector<double> largest(objects.size(), 0.0);
      for (const SampleResult& r : result)
        for (const ObjectRows& o : r.rows)
          for (const auto& [blk, row] : o.dUb) largest[o.object] = std::max(largest[o.object], norm(row));
      for (SampleResult& r : result)
        for (ObjectRows& o : r.rows)
          dropped += std::erase_if(o.dUb, [&](const auto& entry) {
            return norm(entry.second) < b.settings_.drop_tolerance * largest[o.object];
          });
    }

    // The real-radiance gather (DrtBuildSettings::gather): the traced samples' rows become
    // Hs / Ht, and only the inpainted ones stay in dUb / dUc.
    if (b.settings_.gather && !vector) {
      for (std::size_t k = 0; k < objects.size(); ++k) assemble_scene_gather(k, result, drt.objects[k]);
      for (SampleResult& r : result)
        if (r.state == SampleResult::traced) r.rows.clear();
    }

    for (std::size_t k = 0; k < objects.size(); ++k) {
      DrtObjectOperators& op = drt.objects[k];
      const std::uint32_t f_count = std::uint32_t(queries[k].columns);
      std::size_t rows = 0, uc_rows = 0;
      for (const SampleResult& r : result)
        if (const ObjectRows* o = r.find(std::uint32_t(k))) {
          rows += o->dUb.size();
          uc_rows += o->dUc.empty() ? 0 : 1;
        }
      std::vector<std::uint32_t>& ub_sample = vector ? op.dUb_vec_sample : op.dUb_sample;
      std::vector<std::uint32_t>& ub_block = vector ? op.dUb_vec_block : op.dUb_block;
      std::vector<std::uint32_t>& uc_sample = vector ? op.dUc_vec_sample : op.dUc_sample;
      Matrix& dUb = vector ? op.dUb_vec : op.dUb;
      Matrix& dUc = vector ? op.dUc_vec : op.dUc;
      ub_sample.clear();
      ub_block.clear();
      uc_sample.clear();
      dUb = Matrix(std::uint32_t(W * rows), rows > 0 ? kb : 0);
      dUc = Matrix(std::uint32_t(W * uc_rows), uc_rows > 0 ? f_count : 0);
      std::size_t row = 0, uc_row = 0;
      for (std::size_t s = 0; s < n; ++s) {
        const ObjectRows* o = result[s].find(std::uint32_t(k));
        if (!o) continue;
        for (const auto& [src, values] : o->dUb) {  // std::map: blocks ascending
          ub_sample.push_back(std::uint32_t(s));
          ub_block.push_back(src);
          for (std::uint32_t i = 0; i < W; ++i)
            for (std::uint32_t c = 0; c < kb; ++c)
              dUb(std::uint32_t(W * row + i), c) = float(values[i * kb + c]);
          ++row;
        }
        if (!o->dUc.empty()) {
          uc_sample.push_back(std::uint32_t(s));
          for (std::uint32_t i = 0; i < W; ++i)
            for (std::uint32_t f = 0; f < f_count; ++f)
              dUc(std::uint32_t(W * uc_row + i), f) = float(o->dUc[std::size_t(i * f_count + f)]);
          ++uc_row;
        }
      }
    }
    if (report && !vector) {
      for (const SampleResult& r : traced) {
        report->traced_samples += r.state == SampleResult::traced;
        report->culled_samples += r.state == SampleResult::culled;
        report->inside_samples += r.state == SampleResult::inside;
      }
      report->inpainted_samples += inpainted;
      report->dropped_rows += dropped;
    }
  }

  // Hs and Ht of object k: per traced sample charged to it, the hidden samples' weights (the
  // rays' negative Limp taps, stored positive) and its texels' (clutter-wide index).
  void assemble_scene_gather(std::size_t k, const std::vector<SampleResult>& result,
                             DrtObjectOperators& op) const {
    op.H_sample.clear();
    op.Hs = DrtSparseRows{};
    op.Ht = DrtSparseRows{};
    for (std::size_t s = 0; s < result.size(); ++s) {
      if (result[s].state != SampleResult::traced) continue;
      const ObjectRows* o = result[s].find(std::uint32_t(k));
      if (!o || (o->samples.empty() && o->texels.empty())) continue;
      if (op.H_sample.empty()) op.Hs.start.push_back(0), op.Ht.start.push_back(0);
      op.H_sample.push_back(std::uint32_t(s));
      for (const auto& [sample, weight] : o->samples) {
        if (weight >= 0.0f) continue;  // a hidden sample's taps are negative (the wall taken away)
        op.Hs.index.push_back(sample);
        op.Hs.weight.push_back(-weight);
      }
      for (const auto& [key, weight] : o->texels) {
        op.Ht.index.push_back(texel_base[cc_object(key)] + std::uint32_t(cc_slot(key)));
        op.Ht.weight.push_back(weight);
      }
      op.Hs.start.push_back(std::uint32_t(op.Hs.index.size()));
      op.Ht.start.push_back(std::uint32_t(op.Ht.index.size()));
    }
  }

  // Gs and Gt of an object from its traced texels (the real-radiance gather).
  void assemble_clutter_gather(const std::vector<TexelResult>& texels, DrtObjectOperators& op) const {
    op.Gs = DrtSparseRows{};
    op.Gt = DrtSparseRows{};
    op.Gs.start.push_back(0);
    op.Gt.start.push_back(0);
    for (const TexelResult& t : texels) {
      for (const auto& [sample, weight] : t.samples) {
        op.Gs.index.push_back(sample);
        op.Gs.weight.push_back(std::max(weight, 0.0f));
      }
      for (const auto& [key, weight] : t.texels) {
        op.Gt.index.push_back(texel_base[cc_object(key)] + std::uint32_t(cc_slot(key)));
        op.Gt.weight.push_back(weight);
      }
      op.Gs.start.push_back(std::uint32_t(op.Gs.index.size()));
      op.Gt.start.push_back(std::uint32_t(op.Gt.index.size()));
    }
  }

  // Td_c, Cb (SVD-compressed to cb_modes) and Cc of object k from its traced texels.
  void assemble_clutter(std::size_t k, const std::vector<TexelResult>& texels, DrtObjectOperators& op) const {
    const ClutterObject& object = objects[k];
    const int f_count = queries[k].columns;
    op.texel_count = std::uint32_t(clutter_texel_count(object));
    op.face_count = std::uint32_t(f_count);
    // Where the texels are, for an app's own direct light at the clutter (drt.h).
    const ClutterTexelGeometry geometry = clutter_texel_geometry(object);
    op.texel_position.assign(3 * geometry.position.size(), 0.0f);  // a rebuild reassembles op in place
    op.texel_normal.assign(3 * geometry.position.size(), 0.0f);
    for (std::size_t t = 0; t < geometry.position.size(); ++t)
      for (int a = 0; a < 3; ++a) {
        op.texel_position[3 * t + std::size_t(a)] = float(geometry.position[t][a]);
        op.texel_normal[3 * t + std::size_t(a)] = float(geometry.normal[t][a]);
      }
    // And the lightmap cell each stands for, so that an app addresses the clutter lightmap
    // from its mesh's UVs (drt.h, clutter_texel_cells).
    const ClutterTexelCells cells = clutter_texel_cells(object);
    op.cell_res = std::uint32_t(cells.res);
    op.texel_cell.assign(3 * cells.face.size(), 0u);
    for (std::size_t t = 0; t < cells.face.size(); ++t) {
      op.texel_cell[3 * t] = std::uint32_t(cells.face[t]);
      op.texel_cell[3 * t + 1] = std::uint32_t(cells.cell[t].x);
      op.texel_cell[3 * t + 2] = std::uint32_t(cells.cell[t].y);
    }
    // Td_c (DRT §4.2): the per-face constant basis, c_f = mean direct light over face f; over
    // a mesh chart the mean is weighted by texel area (border texels cover less).
    op.Td_c = Matrix(op.face_count, op.texel_count);
    if (queries[k].basis) {
      op.Td_c = queries[k].basis->Td_c;  // the lighting prior's projection
    } else if (object.kind == ClutterKind::mesh) {
      const ClutterMeshAtlas& atlas = object.mesh->atlas;
      std::vector<double> chart_area(std::size_t(f_count), 0.0);
      for (std::size_t t = 0; t < atlas.area.size(); ++t)
        chart_area[std::size_t(atlas.texels.face[t])] += atlas.area[t];
      for (std::size_t t = 0; t < atlas.area.size(); ++t) {
        const int f = atlas.texels.face[t];
        op.Td_c(std::uint32_t(f), std::uint32_t(t)) = float(atlas.area[t] / chart_area[std::size_t(f)]);
      }
    } else {
      const int res = object.res;
      for (int f = 0; f < f_count; ++f)
        for (int t = 0; t < res * res; ++t)
          op.Td_c(std::uint32_t(f), std::uint32_t(f * res * res + t)) = float(1.0 / (res * res));
    }

    if (b.settings_.gather) {  // the gather takes the place of Cb and Cc
      op.Cb_blocks.clear();
      op.Cb_sigma.clear();
      op.Uc = op.Vc = op.Cc = Matrix();
      op.Cb_truncation_error = 0.0f;
      op.Cc_objects.clear();
      assemble_clutter_gather(texels, op);
      return;
    }
    op.Gs = op.Gt = DrtSparseRows{};
    assemble_cb_cc(texels, 1, op.Cb_blocks, op.Uc, op.Vc, &op.Cb_sigma, op.Cb_truncation_error, op.Cc_objects,
                   op.Cc);
  }

  // Cb (SVD-compressed to cb_modes) and Cc from traced texels with W rows each (1, or the 4
  // OHLSH coefficients of the vector pass: cb rows W kb per block and cc slots W col + i,
  // coefficient-major), into matrices with W rows per texel.
  void assemble_cb_cc(const std::vector<TexelResult>& texels, std::size_t W,
                      std::vector<std::uint32_t>& blocks, Matrix& U, Matrix& V, std::vector<float>* sigmas,
                      float& truncation, std::vector<std::uint32_t>& cc_objects, Matrix& Cc) const {
    const std::size_t kb = b.level_.kb;
    const std::size_t m = texels.size();
    std::map<std::uint32_t, std::size_t> column_of;
    for (const TexelResult& r : texels)
      for (const auto& [blk, values] : r.cb) column_of.emplace(blk, 0);
    blocks.clear();
    if (sigmas) sigmas->clear();
    U = Matrix();
    V = Matrix();
    truncation = 0.0f;
    for (auto& [blk, col] : column_of) {
      col = blocks.size();
      blocks.push_back(blk);
    }
    if (!blocks.empty()) {
      MatrixXd Cb = MatrixXd::Zero(Eigen::Index(W * m), Eigen::Index(kb * blocks.size()));
      for (std::size_t i = 0; i < m; ++i)
        for (const auto& [blk, values] : texels[i].cb)
          for (std::size_t w = 0; w < W; ++w)
            for (std::size_t c = 0; c < kb; ++c)
              Cb(Eigen::Index(W * i + w), Eigen::Index(column_of[blk] * kb + c)) = values[w * kb + c];
      Eigen::BDCSVD<MatrixXd> svd(Cb, Eigen::ComputeThinU | Eigen::ComputeThinV);
      const VectorXd sigma = svd.singularValues();
      int modes = 0;
      while (modes < std::min<int>(b.settings_.cb_modes, int(sigma.size())) && sigma[modes] > 0.0) ++modes;
      double total = 0.0, kept = 0.0;
      for (Eigen::Index q = 0; q < sigma.size(); ++q) {
        total += sigma[q] * sigma[q];
        if (q < modes) kept += sigma[q] * sigma[q];
        if (sigmas) sigmas->push_back(float(sigma[q]));
      }
      truncation = total > 0.0 ? float(std::sqrt(std::max(0.0, total - kept) / total)) : 0.0f;
      if (modes > 0) {
        U = to_float(svd.matrixU().leftCols(modes) * sigma.head(modes).asDiagonal());
        V = to_float(svd.matrixV().leftCols(modes).transpose());
      }
    }

    // Cc: columns are the c entries of every source object any texel saw, sources ascending.
    cc_objects.clear();
    Cc = Matrix();
    std::vector<std::size_t> col0(objects.size(), 0);
    for (const TexelResult& r : texels)
      for (const auto& [key, w] : r.cc) cc_objects.push_back(cc_object(key));
    std::sort(cc_objects.begin(), cc_objects.end());
    cc_objects.erase(std::unique(cc_objects.begin(), cc_objects.end()), cc_objects.end());
    std::size_t cols = 0;
    for (std::uint32_t src : cc_objects) {
      col0[src] = cols;
      cols += std::size_t(queries[src].columns);
    }
    if (cols > 0) {
      Cc = Matrix(std::uint32_t(W * m), std::uint32_t(cols));
      for (std::size_t i = 0; i < m; ++i)
        for (const auto& [key, w] : texels[i].cc)
          Cc(std::uint32_t(W * i + cc_slot(key) % W),
             std::uint32_t(col0[cc_object(key)] + cc_slot(key) / W)) = float(w);
    }
  }

  // The vector Cb and Cc of object k (DRT §5) from its vector-traced texels.
  void assemble_clutter_vector(const std::vector<TexelResult>& texels, DrtObjectOperators& op) const {
    assemble_cb_cc(texels, kOhlshCount, op.Cb_vec_blocks, op.Uc_vec, op.Vc_vec, nullptr,
                   op.Cb_vec_truncation_error, op.Cc_vec_objects, op.Cc_vec);
  }

  // The clutter operators of the objects flagged in `dirty`, in parallel over objects.
  void assemble_clutter_all(const std::vector<std::vector<TexelResult>>& texels,
                            const std::vector<std::vector<TexelResult>>& vector_texels,
                            const std::vector<std::uint8_t>& dirty, DrtOperators& drt) const {
    tbb::parallel_for(std::size_t(0), objects.size(), [&](std::size_t k) {
      if (!dirty[k]) return;
      assemble_clutter(k, texels[k], drt.objects[k]);
      if (!vector_texels.empty()) assemble_clutter_vector(vector_texels[k], drt.objects[k]);
    });
  }
};

Status validate_drt_build_settings(const DrtBuildSettings& s) {
  auto bad = [](const char* field, const std::string& value, const std::string& range) {
    return Status::error(ErrorCode::invalid_argument, std::string("DRT build settings: ") + field + " = " +
                                                          value + ": must be in " + range);
  };
  auto range = [](std::int64_t lo, std::int64_t hi) {
    return "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  };
  if (s.rays < 1 || std::int64_t(s.rays) > std::int64_t(kMaxSettingsRays))
    return bad("rays", std::to_string(s.rays), range(1, kMaxSettingsRays));
  if (s.cb_modes < 1 || s.cb_modes > kMaxDrtModeCap)
    return bad("cb_modes", std::to_string(s.cb_modes), range(1, kMaxDrtModeCap));
  if (s.clutter_prior_modes < 0 || s.clutter_prior_modes > kMaxDrtModeCap)
    return bad("clutter_prior_modes", std::to_string(s.clutter_prior_modes), range(0, kMaxDrtModeCap));
  if (s.clutter_prior_grid < 1 || std::int64_t(s.clutter_prior_grid) > std::int64_t(kMaxSettingsPriorGrid))
    return bad("clutter_prior_grid", std::to_string(s.clutter_prior_grid), range(1, kMaxSettingsPriorGrid));
  if (s.max_clutter_rays < 0 || std::int64_t(s.max_clutter_rays) > std::int64_t(kMaxSettingsRays))
    return bad("max_clutter_rays", std::to_string(s.max_clutter_rays), range(0, kMaxSettingsRays));
  if (!(s.drop_tolerance >= 0.0 && s.drop_tolerance <= 1.0))
    return bad("drop_tolerance", std::to_string(s.drop_tolerance), "[0, 1]");
  return Status::success();
}

DrtBuilder::DrtBuilder(const Level& level, const Dictionary& dict, const DrtBuildSettings& settings)
    : level_(level),
      dict_(dict),
      settings_(settings),
      settings_status_(validate_drt_build_settings(settings)),
      walls_(level, level.res) {
  if (!settings_status_.ok()) return;  // build and rebuild_object report it; nothing allocated
  direction_sets_ = make_direction_sets(settings.rays, settings.seed ^ 0x736574ull);
  // The texels' own sets only when they have fewer rays (else the same sets as the samples).
  if (settings.max_clutter_rays > 0 && settings.max_clutter_rays < settings.rays)
    texel_sets_ = make_direction_sets(settings.max_clutter_rays, settings.seed ^ 0x746578ull);
  if (settings.vector)
    uniform_sets_ = make_direction_sets(settings.rays, settings.seed ^ 0x756e69ull, Directions::hemisphere);
  if (settings.probes)
    sphere_sets_ = make_direction_sets(settings.rays, settings.seed ^ 0x737068ull, Directions::sphere);
}

namespace {

// The first setting in which a and b differ ("rays"), or "": those a state records and a
// rebuild must share (every field changes what is traced or kept).
std::string settings_difference(const DrtBuildSettings& a, const DrtBuildSettings& b) {
  if (a.rays != b.rays) return "rays";
  if (a.max_clutter_rays != b.max_clutter_rays) return "max_clutter_rays";
  if (a.cb_modes != b.cb_modes) return "cb_modes";
  if (a.inpaint != b.inpaint) return "inpaint";
  if (a.cull != b.cull) return "cull";
  if (a.drop_tolerance != b.drop_tolerance) return "drop_tolerance";
  if (a.vector != b.vector) return "vector";
  if (a.probes != b.probes) return "probes";
  if (a.clutter_prior_modes != b.clutter_prior_modes) return "clutter_prior_modes";
  if (a.clutter_prior_grid != b.clutter_prior_grid) return "clutter_prior_grid";
  if (a.sample_gather != b.sample_gather) return "sample_gather";
  if (a.gather != b.gather) return "gather";
  if (a.seed != b.seed) return "seed";
  return {};
}

Status check_dictionary(const Level& level, const Dictionary& dict, bool vector) {
  for (const LevelBlock& b : level.blocks) {
    const ShapeOperators& op = block_operators(dict, level, b);
    if (op.Limp.rows != b.sample_count || op.Limp.cols != op.Ub.cols || op.Ub.cols > level.kb)
      return Status::error(ErrorCode::invalid_argument,
                           "DRT build: dictionary Limp / Ub do not match the level");
    if (vector && (op.Ub_vec.rows != 4 * b.sample_count || op.Ub_vec.cols != op.Ub.cols))
      return Status::error(
          ErrorCode::invalid_argument,
          "DRT build: vector operators asked for, but the dictionary has no Ub_vec of 4n x kb");
  }
  return Status::success();
}

// The lighting prior of each object's c (DRT §4.2's optional prior, the construction of MRT
// §3.2): the irradiance of clutter_prior_grid^3 unit point lights on a grid of the owning
// block (lights inside the object left out) at every texel, shadowed by the walls and by the
// object itself (a concave mesh), each light's column scaled to unit area-weighted norm; the
// first clutter_prior_modes left singular vectors of diag(sqrt(area)) L are the basis. Other
// objects' shadows are left out, so an object's basis depends on itself alone (moving one
// object leaves the others' bases as they were).
void attach_priors(const Level& level, const LevelScene& walls, const DrtBuildSettings& settings,
                   std::span<const ClutterObject> objects, ObjectQueries& q) {
  if (settings.clutter_prior_modes <= 0) return;
  q.bases.resize(objects.size());
  const int g = std::max(1, settings.clutter_prior_grid);
  for (std::size_t k = 0; k < objects.size(); ++k) {
    const ClutterObject& object = objects[k];
    const ClutterTexelGeometry geo = clutter_texel_geometry(object);
    const std::vector<double> area = clutter_texel_area(object);
    const std::size_t m = geo.position.size();
    std::vector<glm::dvec3> lights;
    const LevelBlock& block = level.blocks[std::size_t(object.block)];
    for (int z = 0; z < g; ++z)
      for (int y = 0; y < g; ++y)
        for (int x = 0; x < g; ++x) {
          const glm::dvec3 p = block_to_world(block, (glm::dvec3(x, y, z) + 0.5) / double(g));
          if (!q.queries[k].contains(p, glm::dvec3(0.0))) lights.push_back(p);
        }
    const ObjectQuery& self = q.queries[k];
    MatrixXd L = MatrixXd::Zero(Eigen::Index(m), Eigen::Index(std::max<std::size_t>(lights.size(), 1)));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m, 16),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t t = range.begin(); t != range.end(); ++t) {
                          const glm::dvec3 x = geo.position[t] + 1e-5 * geo.normal[t];
                          for (std::size_t l = 0; l < lights.size(); ++l) {
                            const glm::dvec3 d = lights[l] - x;
                            const double r2 = glm::dot(d, d), r = std::sqrt(r2);
                            const double cosine = glm::dot(geo.normal[t], d) / r;
                            if (!(cosine > 0.0) || walls.occluded(x, lights[l])) continue;
                            const BoxEntry hit = self.enter(x, self.bounds.local(x), d / r);
                            if (hit.hit && hit.t < r) continue;  // the object shadows itself
                            L(Eigen::Index(t), Eigen::Index(l)) = std::sqrt(area[t]) * cosine / r2;
                          }
                        }
                      });
    for (Eigen::Index l = 0; l < L.cols(); ++l) {
      const double norm = L.col(l).norm();
      if (norm > 0.0) L.col(l) /= norm;
    }
    Eigen::BDCSVD<MatrixXd> svd(L, Eigen::ComputeThinU);
    const VectorXd sigma = svd.singularValues();
    int modes = 0;
    while (modes < std::min<int>(settings.clutter_prior_modes, int(sigma.size())) &&
           sigma[modes] > 1e-9 * std::max(sigma[0], 1e-300))
      ++modes;
    MatrixXd U;
    if (modes == 0) {  // no prior light reaches the object: one constant over it
      U = MatrixXd(Eigen::Index(m), 1);
      double total = 0.0;
      for (double a : area) total += a;
      for (std::size_t t = 0; t < m; ++t) U(Eigen::Index(t), 0) = std::sqrt(area[t] / total);
      modes = 1;
    } else {
      U = svd.matrixU().leftCols(modes);
    }
    auto basis = std::make_unique<ObjectBasis>();
    basis->prepare(object);
    basis->count = modes;
    basis->B.resize(m * std::size_t(modes));
    basis->Td_c = Matrix(std::uint32_t(modes), std::uint32_t(m));
    for (std::size_t t = 0; t < m; ++t)
      for (int c = 0; c < modes; ++c) {
        const double u = U(Eigen::Index(t), c), sa = std::sqrt(area[t]);
        basis->B[t * std::size_t(modes) + std::size_t(c)] = u / sa;
        basis->Td_c(std::uint32_t(c), std::uint32_t(t)) = float(u * sa);
      }
    q.queries[k].basis = basis.get();
    q.queries[k].columns = modes;
    q.bases[k] = std::move(basis);
  }
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

Result<DrtOperators> DrtBuilder::build(std::span<const ClutterObject> objects, DrtBuildReport* report,
                                       DrtBuildState* state) const {
  if (!settings_status_.ok()) return settings_status_;
  if (Status s = validate_clutter(level_, objects); !s.ok()) return s;
  if (Status s = check_dictionary(level_, dict_, settings_.vector); !s.ok()) return s;
  DrtOperators drt;
  auto impl = std::make_unique<DrtBuildState::Impl>();
  impl->settings = settings_;
  impl->kb = level_.kb;
  impl->level_blocks = std::uint32_t(level_.blocks.size());
  impl->level_samples = std::uint32_t(walls_.samples().position.size());
  const std::uint32_t g = dict_.settings.probe_grid;
  impl->probes_per_block = settings_.probes ? g * g * g : 0;
  impl->objects.assign(objects.begin(), objects.end());
  if (!objects.empty()) {
    drt.kb = level_.kb;
    drt.level_blocks = std::uint32_t(level_.blocks.size());
    drt.level_samples = level_.sample_count;
    drt.objects.resize(objects.size());
    Result<ObjectQueries> queries = ObjectQueries::make(impl->objects);
    if (!queries.ok()) return queries.status();
    attach_priors(level_, walls_, settings_, impl->objects, queries.value());
    Pass pass(*this, impl->objects, std::move(queries.value()));

    const auto t0 = std::chrono::steady_clock::now();
    impl->samples.resize(walls_.samples().position.size());
    pass.scene_pass(impl->samples, {});
    pass.assemble_scene(impl->samples, drt, report);
    if (settings_.vector) {
      impl->vector_samples.resize(impl->samples.size());
      pass.scene_pass_vector(impl->vector_samples, {});
      pass.assemble_scene(impl->vector_samples, drt, nullptr, true);
    }
    if (settings_.probes) {
      impl->probes.resize(level_.blocks.size() * std::size_t(pass.probes_per_block()));
      pass.probe_pass(impl->probes, {});
      pass.assemble_probes(impl->probes, drt);
    }

    const auto t1 = std::chrono::steady_clock::now();
    std::vector<std::pair<std::uint32_t, std::uint32_t>> work;
    impl->texels.resize(objects.size());
    for (std::size_t k = 0; k < objects.size(); ++k) {
      impl->geometry.push_back(clutter_texel_geometry(objects[k]));
      impl->texels[k].resize(impl->geometry[k].position.size());
      if (settings_.vector) {
        impl->vector_texels.resize(objects.size());
        impl->vector_texels[k].resize(impl->geometry[k].position.size());
      }
      for (std::size_t i = 0; i < impl->texels[k].size(); ++i)
        work.emplace_back(std::uint32_t(k), std::uint32_t(i));
    }
    pass.clutter_pass(impl->texels, impl->vector_texels, impl->geometry, work);
    pass.assemble_clutter_all(impl->texels, impl->vector_texels, std::vector<std::uint8_t>(objects.size(), 1),
                              drt);
    if (report) {
      report->scene_seconds += std::chrono::duration<double>(t1 - t0).count();
      report->clutter_seconds += seconds_since(t1);
      report->traced_texels += work.size();
    }
  }
  if (state) state->impl_ = std::move(impl);
  return drt;
}

Result<DrtObjectOperators> DrtBuilder::build_object(const ClutterObject& object,
                                                    DrtBuildReport* report) const {
  Result<DrtOperators> drt = build(std::span<const ClutterObject>(&object, 1), report);
  if (!drt.ok()) return drt.status();
  return std::move(drt.value().objects[0]);
}

Status DrtBuilder::rebuild_object(std::span<const ClutterObject> objects, std::size_t index,
                                  DrtOperators& drt, DrtBuildState& state, DrtBuildReport* report) const {
  if (!settings_status_.ok()) return settings_status_;
  auto fail = [&](const std::string& what) {
    return Status::error(ErrorCode::invalid_argument,
                         "DRT rebuild of object " + std::to_string(index) + ": " + what);
  };
  if (index >= objects.size()) return fail("not one of the objects");
  if (!state.impl_ || state.impl_->objects.size() != objects.size() || drt.objects.size() != objects.size())
    return fail("the build state and operators are not those of these objects");
  for (std::size_t k = 0; k < objects.size(); ++k)
    if (k != index && !same_object(objects[k], state.impl_->objects[k]))
      return fail("object " + std::to_string(k) + " changed too (rebuild one object at a time)");
  if (Status s = validate_clutter(level_, objects); !s.ok()) return s;
  DrtBuildState::Impl& st = *state.impl_;
  // A state from another level or from a builder with other passes would leave stale rows.
  const std::size_t samples = walls_.samples().position.size();
  const int g = int(dict_.settings.probe_grid);
  if (st.samples.size() != samples || st.vector_samples.size() != (settings_.vector ? samples : 0) ||
      st.probes.size() != (settings_.probes ? level_.blocks.size() * std::size_t(g * g * g) : 0))
    return fail("the build state was made for another level or with other vector / probe settings");
  if (st.kb != level_.kb || st.level_blocks != level_.blocks.size() || st.level_samples != samples ||
      st.probes_per_block != (settings_.probes ? std::uint32_t(g * g * g) : 0u))
    return fail("the build state was made for another level (kb " + std::to_string(st.kb) + ", " +
                std::to_string(st.level_blocks) + " blocks, " + std::to_string(st.level_samples) +
                " samples; the level has " + std::to_string(level_.kb) + ", " +
                std::to_string(level_.blocks.size()) + ", " + std::to_string(samples) + ")");
  if (const std::string field = settings_difference(st.settings, settings_); !field.empty())
    return fail("the build state was made with another " + field + " (DrtBuildSettings)");
  // One result per texel of every object, as the passes below index them.
  if (st.texels.size() != objects.size() || st.geometry.size() != objects.size() ||
      st.vector_texels.size() != (settings_.vector ? objects.size() : 0))
    return fail("the build state's texel results are not one list per object");
  for (std::size_t k = 0; k < objects.size(); ++k)
    if (st.texels[k].size() != st.geometry[k].position.size() ||
        st.geometry[k].position.size() != std::size_t(clutter_texel_count(st.objects[k])) ||
        (settings_.vector && st.vector_texels[k].size() != st.texels[k].size()))
      return fail("the build state's texel results of object " + std::to_string(k) +
                  " do not match its texel count");
  // The moved object's queries at its old and new place.
  Result<ObjectQueries> old_q = ObjectQueries::make(std::span<const ClutterObject>(&st.objects[index], 1));
  Result<ObjectQueries> new_q = ObjectQueries::make(objects.subspan(index, 1));
  if (!old_q.ok()) return old_q.status();
  if (!new_q.ok()) return new_q.status();
  const ObjectQuery &old_box = old_q->queries[0], &new_box = new_q->queries[0];
  st.objects[index] = objects[index];
  Result<ObjectQueries> queries = ObjectQueries::make(st.objects);
  if (!queries.ok()) return queries.status();
  attach_priors(level_, walls_, settings_, st.objects, queries.value());
  Pass pass(*this, st.objects, std::move(queries.value()));

  // Scene samples: only those inside the object or with a ray entering it, at its old or
  // new place, can change.
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = walls_.samples().position.size();
  std::vector<std::uint8_t> retrace(n, 0);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, 32), [&](const tbb::blocked_range<std::size_t>& range) {
        std::vector<glm::dvec3> dirs;
        for (std::size_t s = range.begin(); s != range.end(); ++s)
          retrace[s] = pass.sample_depends_on(s, old_box, dirs) || pass.sample_depends_on(s, new_box, dirs);
      });
  const std::size_t retraced = std::size_t(std::count(retrace.begin(), retrace.end(), 1));
  if (retraced > 0) pass.scene_pass(st.samples, retrace);
  if (settings_.vector) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 32),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        std::vector<glm::dvec3> local, dirs;
                        for (std::size_t s = range.begin(); s != range.end(); ++s)
                          retrace[s] = pass.sample_vector_depends_on(s, old_box, local, dirs) ||
                                       pass.sample_vector_depends_on(s, new_box, local, dirs);
                      });
    pass.scene_pass_vector(st.vector_samples, retrace);
  }
  if (settings_.probes) {
    std::vector<std::uint8_t> again(st.probes.size(), 0);
    tbb::parallel_for(std::size_t(0), again.size(), [&](std::size_t p) {
      std::vector<glm::dvec3> local, dirs;
      again[p] =
          pass.probe_depends_on(p, old_box, local, dirs) || pass.probe_depends_on(p, new_box, local, dirs);
    });
    pass.probe_pass(st.probes, again);
  }

  // Clutter texels: all of the moved object's, and the others' that can see it.
  const auto t1 = std::chrono::steady_clock::now();
  st.geometry[index] = clutter_texel_geometry(objects[index]);
  st.texels[index].assign(st.geometry[index].position.size(), TexelResult{});
  if (!st.vector_texels.empty())
    st.vector_texels[index].assign(st.geometry[index].position.size(), TexelResult{});
  std::vector<std::pair<std::uint32_t, std::uint32_t>> work, candidates;
  for (std::size_t k = 0; k < objects.size(); ++k)
    for (std::size_t i = 0; i < st.geometry[k].position.size(); ++i)
      (k == index ? work : candidates).emplace_back(std::uint32_t(k), std::uint32_t(i));
  std::vector<std::uint8_t> affected(candidates.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, candidates.size(), 32),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<glm::dvec3> dirs, local;
                      for (std::size_t c = range.begin(); c != range.end(); ++c) {
                        const auto [k, i] = candidates[c];
                        affected[c] =
                            pass.texel_depends_on(k, i, st.geometry[k], old_box, dirs) ||
                            pass.texel_depends_on(k, i, st.geometry[k], new_box, dirs) ||
                            (settings_.vector &&
                             (pass.texel_vector_depends_on(k, i, st.geometry[k], old_box, local, dirs) ||
                              pass.texel_vector_depends_on(k, i, st.geometry[k], new_box, local, dirs)));
                      }
                    });
  std::vector<std::uint8_t> dirty(objects.size(), 0);
  dirty[index] = 1;
  for (std::size_t c = 0; c < candidates.size(); ++c)
    if (affected[c]) {
      work.push_back(candidates[c]);
      dirty[candidates[c].first] = 1;
    }
  pass.clutter_pass(st.texels, st.vector_texels, st.geometry, work);
  const auto t2 = std::chrono::steady_clock::now();

  // The kept results must fit what the assembly indexes: always so for a state this builder
  // filled, not for a damaged file's (drt_state_io.h checks what it can without the level).
  StateBounds bounds{level_.kb, std::uint32_t(level_.blocks.size()), std::uint32_t(n), {}, {}, true};
  for (std::size_t k = 0; k < objects.size(); ++k) {
    bounds.texels.push_back(std::uint32_t(st.geometry[k].position.size()));
    bounds.columns.push_back(std::uint32_t(pass.queries[k].columns));
  }
  if (const std::string why = check_state_rows(st, bounds); !why.empty())
    return Status::error(ErrorCode::format_error, "DRT rebuild of object " + std::to_string(index) +
                                                      ": the build state does not fit: " + why);

  DrtBuildReport scene_report;
  pass.assemble_scene(st.samples, drt, &scene_report);
  if (settings_.vector) pass.assemble_scene(st.vector_samples, drt, nullptr, true);
  if (settings_.probes) pass.assemble_probes(st.probes, drt);
  const auto t3 = std::chrono::steady_clock::now();
  // The gather's Gt names texels by their clutter-wide index, which a new texel count of the
  // moved object shifts for every object after it: all are reassembled (copies of kept rows).
  if (settings_.gather) std::fill(dirty.begin(), dirty.end(), std::uint8_t(1));
  pass.assemble_clutter_all(st.texels, st.vector_texels, dirty, drt);
  if (report) {
    report->traced_samples += retraced;
    report->inside_samples += scene_report.inside_samples;
    report->inpainted_samples += scene_report.inpainted_samples;
    report->dropped_rows += scene_report.dropped_rows;
    report->traced_texels += work.size();
    using Seconds = std::chrono::duration<double>;
    report->scene_seconds += Seconds(t1 - t0).count() + Seconds(t3 - t2).count();
    report->clutter_seconds += Seconds(t2 - t1).count() + seconds_since(t3);
  }
  return Status::success();
}

std::vector<float> clutter_direct_light(const LevelScene& scene, std::span<const LightDescription> lights,
                                        int light_samples) {
  std::vector<float> out;
  auto occluded = [&](const glm::dvec3& a, const glm::dvec3& b) { return scene.occluded(a, b); };
  for (const ClutterObject& object : scene.clutter()) {
    const ClutterTexelGeometry cg = clutter_texel_geometry(object);
    const std::vector<double> texel_area = clutter_texel_area(object);
    const std::size_t base = out.size();
    out.resize(base + 3 * cg.position.size(), 0.0f);
    for (const LightDescription& light : lights) {
      const SphereLight sphere{light.position, light.radius, light.intensity};
      std::vector<glm::dvec3> points;
      sphere_light_points(light.position, light.radius, light_samples, points);
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cg.position.size(), 64),
                        [&](const tbb::blocked_range<std::size_t>& range) {
                          for (std::size_t i = range.begin(); i != range.end(); ++i) {
                            // Off the face: the clutter is two-sided, its own face must not shadow it.
                            const glm::dvec3 x = cg.position[i] + 1e-5 * cg.normal[i];
                            const double E_over_pi = sphere_light_E_over_pi(x, cg.normal[i], sphere, points,
                                                                            texel_area[i], occluded);
                            if (E_over_pi <= 0.0) continue;
                            for (int c = 0; c < 3; ++c)
                              out[base + 3 * i + std::size_t(c)] +=
                                  float(object.albedo[c] * light.color[c] * E_over_pi);
                          }
                        });
    }
  }
  return out;
}

std::vector<float> clutter_directional_light(const LevelScene& scene, const glm::dvec3& direction,
                                             const glm::dvec3& irradiance) {
  std::vector<float> out;
  const double length = glm::length(direction);
  if (!(length > 1e-12) || !std::isfinite(length)) {
    for (const ClutterObject& object : scene.clutter())
      out.resize(out.size() + 3 * clutter_texel_geometry(object).position.size(), 0.0f);
    return out;
  }
  const glm::dvec3 to_light = -direction / length;
  // A shadow ray long enough to leave any level (the rays' far end outside every wall).
  constexpr double kSunDistance = 1.0e4;
  for (const ClutterObject& object : scene.clutter()) {
    const ClutterTexelGeometry cg = clutter_texel_geometry(object);
    const std::size_t base = out.size();
    out.resize(base + 3 * cg.position.size(), 0.0f);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cg.position.size(), 64),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t i = range.begin(); i != range.end(); ++i) {
                          const double cosine = glm::dot(cg.normal[i], to_light);
                          if (!(cosine > 0.0)) continue;
                          const glm::dvec3 x = cg.position[i] + 1e-5 * cg.normal[i];
                          if (scene.occluded(x, x + kSunDistance * to_light)) continue;
                          for (int c = 0; c < 3; ++c)
                            out[base + 3 * i + std::size_t(c)] =
                                float(object.albedo[c] * irradiance[c] * cosine / std::numbers::pi);
                        }
                      });
  }
  return out;
}

}  // namespace modrt::precompute
