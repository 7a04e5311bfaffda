#include "modrt/precompute/drt_build.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <Eigen/SVD>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/linalg.h"
#include "modrt/precompute/sampling.h"

namespace modrt::precompute {
namespace {

// Entry distance and entered face of the ray into the box, from outside (slab test).
struct BoxEntry {
  bool hit = false;
  double t = 0.0;
  int face = -1;
};
BoxEntry enter_box(const ClutterBox& box, const glm::dvec3& origin, const glm::dvec3& dir) {
  const glm::dmat3 Rt = glm::transpose(box.rotation);
  const glm::dvec3 o = Rt * (origin - box.center), d = Rt * dir;
  double t_min = -std::numeric_limits<double>::infinity(), t_max = std::numeric_limits<double>::infinity();
  int face = -1;
  for (int a = 0; a < 3; ++a) {
    const double h = box.half_extent[a];
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

bool ray_hits_sphere(const glm::dvec3& origin, const glm::dvec3& dir, const glm::dvec3& c, double r) {
  const glm::dvec3 oc = c - origin;
  const double along = glm::dot(oc, dir);
  const double d2 = glm::dot(oc, oc) - along * along;
  if (d2 > r * r) return false;
  return along + r > 0.0;
}

// Cosine-weighted stratified direction sets in a local frame (z = normal), made once per
// build and shared by all texels: a texel takes one of kSets sets and a random rotation about
// its normal. Its rays stay stratified and each is cosine-distributed (an unbiased gather),
// neighbouring texels' noise stays independent, and a ray costs a frame change instead of
// the sin, cos and sqrt of the square-to-hemisphere map (a third of the build's time).
class DirectionSets {
 public:
  static constexpr int kSets = 32;
  DirectionSets(int rays, std::uint64_t seed) : rays_(rays) {
    std::vector<glm::dvec2> strata;
    local_.reserve(std::size_t(kSets) * std::size_t(rays));
    for (int k = 0; k < kSets; ++k) {
      Rng rng(seed, std::uint64_t(k));
      stratified_square(rays, rng, strata);
      for (const glm::dvec2& u : strata) local_.push_back(cosine_hemisphere(u));
    }
  }
  int rays() const { return rays_; }
  // The world directions of work item `stream` (its own set and rotation) about unit normal n.
  void directions(std::uint64_t seed, std::uint64_t stream, const glm::dvec3& n,
                  std::vector<glm::dvec3>& out) const {
    Rng rng(seed, stream);
    const std::size_t set = std::size_t(rng.next_u64() % kSets);
    const double phi = 2.0 * std::numbers::pi * rng.next_double();
    glm::dvec3 t0, b0;
    tangent_frame(n, t0, b0);
    const glm::dvec3 t = std::cos(phi) * t0 + std::sin(phi) * b0, b = glm::cross(n, t);
    out.resize(std::size_t(rays_));
    const glm::dvec3* local = local_.data() + set * std::size_t(rays_);
    for (std::size_t r = 0; r < out.size(); ++r) out[r] = to_world(local[r], t, b, n);
  }

 private:
  int rays_;
  std::vector<glm::dvec3> local_;
};

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
    const BilinearTaps taps = bilinear_taps(hit.u, hit.v, level_.res);
    for (int k = 0; k < 4; ++k) {
      const std::size_t idx = hb.sample_offset + std::size_t(layout.index(hit.face, taps.i[k], taps.j[k]));
      if (!touched_flag_[idx]) {
        touched_flag_[idx] = 1;
        touched_.push_back(idx);
      }
      weight_[idx] += w * taps.w[k];
    }
  }
  // Adds the gathered Limp rows to `rows` and clears the gather. Samples are taken in the
  // order the rays first touched them, fixed by the work item's directions, so the sums do
  // not depend on scheduling.
  void flush(BlockRows& rows) {
    for (std::size_t idx : touched_) {
      const int blk = sample_block_[idx];
      const LevelBlock& lb = level_.blocks[std::size_t(blk)];
      const std::span<const float> limp =
          dict_.shapes[std::size_t(lb.shape)].Limp.row(std::uint32_t(idx - lb.sample_offset));
      std::vector<double>& row = rows[std::uint32_t(blk)];
      row.resize(level_.kb, 0.0);
      for (std::uint32_t c = 0; c < level_.kb; ++c) row[c] += weight_[idx] * double(limp[c]);
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

struct SampleResult {
  enum State : std::uint8_t { culled, traced, inside };
  State state = culled;
  BlockRows dUb;
  std::vector<double> dUc;  // f, empty when no ray hit the box
};

}  // namespace

DrtBuilder::DrtBuilder(const Level& level, const Dictionary& dict, const DrtBuildSettings& settings)
    : level_(level), dict_(dict), settings_(settings), walls_(level, level.res) {}

Result<DrtObjectOperators> DrtBuilder::build_object(const ClutterObject& object,
                                                    DrtBuildReport* report) const {
  if (Status s = validate_clutter(level_, std::span<const ClutterObject>(&object, 1)); !s.ok()) return s;
  for (const LevelBlock& b : level_.blocks) {
    const ShapeOperators& op = dict_.shapes[std::size_t(b.shape)];
    if (op.Limp.rows != b.sample_count || op.Limp.cols != level_.kb || op.Ub.cols != level_.kb)
      return Status::error(ErrorCode::invalid_argument,
                           "DRT build: dictionary Limp / Ub do not match the level");
  }
  const int rays = std::max(1, settings_.rays);
  const ClutterBox& box = object.box;
  const double radius = clutter_bounding_radius(box);
  const LevelSampleGeometry& g = walls_.samples();
  const std::size_t n = g.position.size();
  const int f_count = clutter_face_count(object);
  std::array<int, kFaceCount> face_slot{};
  for (int f = 0, slot = 0; f < kFaceCount; ++f)
    face_slot[std::size_t(f)] = face_present(object.faces, f) ? slot++ : -1;

  // dUb and dUc (DRT §4.1, §4.2): cosine-weighted gather rays from every scene sample that
  // can see the box; a ray that reaches the box before any wall is light the box takes away
  // (the wall behind it, lit by Limp b of its block) and light the box sends (its face).
  const auto t0 = std::chrono::steady_clock::now();
  const DirectionSets directions(rays, settings_.seed ^ 0x736574ull);
  // One gather per thread: each holds a weight per level sample, too large to make per task.
  tbb::enumerable_thread_specific<LimpGather> gathers([&] { return LimpGather(level_, dict_, g.block); });
  std::vector<SampleResult> result(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<glm::dvec3> dirs;
                      LimpGather& gather = gathers.local();
                      for (std::size_t s = range.begin(); s != range.end(); ++s) {
                        const glm::dvec3 x = g.position[s], nrm = g.normal[s];
                        if (clutter_contains(box, x, 1e-6)) {
                          result[s].state = SampleResult::inside;
                          continue;
                        }
                        if (settings_.cull && glm::dot(nrm, box.center - x) < -radius) continue;
                        result[s].state = SampleResult::traced;
                        directions.directions(settings_.seed, s, nrm, dirs);
                        const double w = 1.0 / rays;
                        for (const glm::dvec3& dir : dirs) {
                          if (!ray_hits_sphere(x, dir, box.center, radius)) continue;
                          const BoxEntry entry = enter_box(box, x, dir);
                          if (!entry.hit) continue;
                          const LevelHit wall = walls_.intersect(x, dir);
                          if (wall.block >= 0 && wall.t < entry.t) continue;  // a wall hides the box
                          if (wall.block >= 0) gather.add(wall, -w);
                          const int slot = face_slot[std::size_t(entry.face)];
                          if (slot >= 0) {
                            result[s].dUc.resize(std::size_t(f_count), 0.0);
                            result[s].dUc[std::size_t(slot)] += w;
                          }
                        }
                        gather.flush(result[s].dUb);
                      }
                    });

  // Inpainting (DRT §5): a sample inside the box takes the mean shadowed transport
  // Ub + dUb of its valid face neighbours, minus its own Ub; Jacobi passes so that samples
  // deep inside fill from the rim inwards, independent of the order.
  std::size_t inpainted = 0;
  if (settings_.inpaint) {
    std::vector<std::uint8_t> valid(n);
    for (std::size_t s = 0; s < n; ++s) valid[s] = result[s].state != SampleResult::inside;
    for (bool progress = true; progress;) {
      progress = false;
      std::vector<std::pair<std::size_t, SampleResult>> fills;
      for (std::size_t s = 0; s < n; ++s) {
        if (valid[s]) continue;
        const int blk = g.block[s];
        const LevelBlock& lb = level_.blocks[std::size_t(blk)];
        const ShapeOperators& op = dict_.shapes[std::size_t(lb.shape)];
        const SampleLayout layout = SampleLayout::make(dictionary_shape_mask(lb.shape), level_.res);
        const int local = int(s - lb.sample_offset), face = layout.face_of(local);
        const int within = local - layout.slot[std::size_t(face)] * level_.res * level_.res;
        const int i0 = within % level_.res, j0 = within / level_.res;
        std::vector<std::size_t> nbrs;
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int i = i0 + di, j = j0 + dj;
            if ((di == 0 && dj == 0) || i < 0 || j < 0 || i >= level_.res || j >= level_.res) continue;
            const std::size_t q = lb.sample_offset + std::size_t(layout.index(face, i, j));
            if (valid[q]) nbrs.push_back(q);
          }
        if (nbrs.empty()) continue;
        SampleResult fill;
        fill.state = SampleResult::inside;
        const double w = 1.0 / double(nbrs.size());
        std::vector<double>& own = fill.dUb[std::uint32_t(blk)];
        own.assign(level_.kb, 0.0);
        for (std::uint32_t c = 0; c < level_.kb; ++c) own[c] = -double(op.Ub(std::uint32_t(local), c));
        for (std::size_t q : nbrs) {
          const std::span<const float> ub = op.Ub.row(std::uint32_t(q - lb.sample_offset));
          for (std::uint32_t c = 0; c < level_.kb; ++c) own[c] += w * double(ub[c]);
          for (const auto& [src, row] : result[q].dUb) {
            std::vector<double>& dst = fill.dUb[src];
            dst.resize(level_.kb, 0.0);
            for (std::uint32_t c = 0; c < level_.kb; ++c) dst[c] += w * row[c];
          }
          if (!result[q].dUc.empty()) {
            fill.dUc.resize(std::size_t(f_count), 0.0);
            for (int f = 0; f < f_count; ++f) fill.dUc[std::size_t(f)] += w * result[q].dUc[std::size_t(f)];
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
  if (settings_.drop_tolerance > 0.0) {
    auto norm = [](const std::vector<double>& row) {
      double n2 = 0.0;
      for (double v : row) n2 += v * v;
      return std::sqrt(n2);
    };
    double largest = 0.0;
    for (const SampleResult& r : result)
      for (const auto& [blk, row] : r.dUb) largest = std::max(largest, norm(row));
    for (SampleResult& r : result)
      dropped += std::erase_if(
          r.dUb, [&](const auto& entry) { return norm(entry.second) < settings_.drop_tolerance * largest; });
  }

  const auto t1 = std::chrono::steady_clock::now();
  DrtObjectOperators op;
  op.texel_count = std::uint32_t(clutter_texel_count(object));
  op.face_count = std::uint32_t(f_count);
  std::size_t rows = 0, uc_rows = 0;
  for (const SampleResult& r : result) {
    rows += r.dUb.size();
    uc_rows += r.dUc.empty() ? 0 : 1;
  }
  op.dUb = Matrix(std::uint32_t(rows), rows > 0 ? level_.kb : 0);
  op.dUc = Matrix(std::uint32_t(uc_rows), uc_rows > 0 ? std::uint32_t(f_count) : 0);
  std::size_t row = 0, uc_row = 0;
  for (std::size_t s = 0; s < n; ++s) {
    for (const auto& [src, values] : result[s].dUb) {  // std::map: blocks ascending
      op.dUb_sample.push_back(std::uint32_t(s));
      op.dUb_block.push_back(src);
      for (std::uint32_t c = 0; c < level_.kb; ++c) op.dUb(std::uint32_t(row), c) = float(values[c]);
      ++row;
    }
    if (!result[s].dUc.empty()) {
      op.dUc_sample.push_back(std::uint32_t(s));
      for (int f = 0; f < f_count; ++f)
        op.dUc(std::uint32_t(uc_row), std::uint32_t(f)) = float(result[s].dUc[std::size_t(f)]);
      ++uc_row;
    }
  }

  // Td_c (DRT §4.2): the per-face constant basis, c_f = mean direct light over face f.
  const int res = object.res;
  op.Td_c = Matrix(op.face_count, op.texel_count);
  for (int f = 0; f < f_count; ++f)
    for (int t = 0; t < res * res; ++t)
      op.Td_c(std::uint32_t(f), std::uint32_t(f * res * res + t)) = float(1.0 / (res * res));

  // Cb (DRT §4.3): gather rays from the clutter texels average the Limp rows of the walls
  // they hit (per hit block); misses bring nothing.
  const ClutterTexelGeometry cg = clutter_texel_geometry(object);
  const std::size_t m = cg.position.size();
  std::vector<BlockRows> gathered(m);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m, 16),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      LimpGather& gather = gathers.local();
                      std::vector<glm::dvec3> dirs;
                      std::vector<LevelHit> hits;
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        directions.directions(settings_.seed ^ 0x436200ull, i, cg.normal[i], dirs);
                        // Off the face so that a float ray does not start behind it.
                        const glm::dvec3 x = cg.position[i] + 1e-6 * cg.normal[i];
                        hits.resize(dirs.size());
                        walls_.intersect_many(x, dirs, hits);
                        for (const LevelHit& wall : hits)
                          if (wall.block >= 0) gather.add(wall, 1.0 / rays);
                        gather.flush(gathered[i]);
                      }
                    });
  std::map<std::uint32_t, std::size_t> column_of;
  for (const BlockRows& r : gathered)
    for (const auto& [blk, values] : r) column_of.emplace(blk, 0);
  for (auto& [blk, col] : column_of) {
    col = op.Cb_blocks.size();
    op.Cb_blocks.push_back(blk);
  }
  const std::size_t kb = level_.kb;
  if (!op.Cb_blocks.empty()) {
    MatrixXd Cb = MatrixXd::Zero(Eigen::Index(m), Eigen::Index(kb * op.Cb_blocks.size()));
    for (std::size_t i = 0; i < m; ++i)
      for (const auto& [blk, values] : gathered[i])
        for (std::size_t c = 0; c < kb; ++c)
          Cb(Eigen::Index(i), Eigen::Index(column_of[blk] * kb + c)) = values[c];
    Eigen::BDCSVD<MatrixXd> svd(Cb, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const VectorXd sigma = svd.singularValues();
    int modes = 0;
    while (modes < std::min<int>(settings_.cb_modes, int(sigma.size())) && sigma[modes] > 0.0) ++modes;
    double total = 0.0, kept = 0.0;
    for (Eigen::Index q = 0; q < sigma.size(); ++q) {
      total += sigma[q] * sigma[q];
      if (q < modes) kept += sigma[q] * sigma[q];
      op.Cb_sigma.push_back(float(sigma[q]));
    }
    op.Cb_truncation_error = total > 0.0 ? float(std::sqrt(std::max(0.0, total - kept) / total)) : 0.0f;
    if (modes > 0) {
      op.Uc = to_float(svd.matrixU().leftCols(modes) * sigma.head(modes).asDiagonal());
      op.Vc = to_float(svd.matrixV().leftCols(modes).transpose());
    }
  }

  const auto t2 = std::chrono::steady_clock::now();
  if (report) {
    report->scene_seconds += std::chrono::duration<double>(t1 - t0).count();
    report->clutter_seconds += std::chrono::duration<double>(t2 - t1).count();
    for (const SampleResult& r : result) {
      report->traced_samples += r.state == SampleResult::traced;
      report->culled_samples += r.state == SampleResult::culled;
      report->inside_samples += r.state == SampleResult::inside;
    }
    report->inpainted_samples += inpainted;
    report->dropped_rows += dropped;
  }
  return op;
}

Result<DrtOperators> DrtBuilder::build(std::span<const ClutterObject> objects, DrtBuildReport* report) const {
  if (Status s = validate_clutter(level_, objects); !s.ok()) return s;
  DrtOperators drt;
  if (objects.empty()) return drt;
  drt.kb = level_.kb;
  for (const ClutterObject& o : objects) {
    Result<DrtObjectOperators> op = build_object(o, report);
    if (!op.ok()) return op.status();
    drt.objects.push_back(std::move(op).value());
  }
  return drt;
}

Status DrtBuilder::rebuild_object(std::span<const ClutterObject> objects, std::size_t index,
                                  DrtOperators& drt) const {
  if (index >= objects.size() || objects.size() != drt.objects.size())
    return Status::error(ErrorCode::invalid_argument,
                         "DRT rebuild: object " + std::to_string(index) + " is not one of the built objects");
  Result<DrtObjectOperators> op = build_object(objects[index]);
  if (!op.ok()) return op.status();
  drt.objects[index] = std::move(op).value();
  return Status::success();
}

std::vector<float> clutter_direct_light(const LevelScene& scene, std::span<const LightDescription> lights,
                                        int light_samples) {
  std::vector<float> out;
  auto occluded = [&](const glm::dvec3& a, const glm::dvec3& b) { return scene.occluded(a, b); };
  for (const ClutterObject& object : scene.clutter()) {
    const ClutterTexelGeometry cg = clutter_texel_geometry(object);
    const std::size_t base = out.size();
    out.resize(base + 3 * cg.position.size(), 0.0f);
    for (const LightDescription& light : lights) {
      const SphereLight sphere{light.position, light.radius, light.intensity};
      std::vector<glm::dvec3> points;
      sphere_light_points(light.position, light.radius, light_samples, points);
      tbb::parallel_for(
          tbb::blocked_range<std::size_t>(0, cg.position.size(), 64),
          [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t i = range.begin(); i != range.end(); ++i) {
              // Off the face: the clutter is two-sided, its own face must not shadow it.
              const glm::dvec3 x = cg.position[i] + 1e-5 * cg.normal[i];
              const double E_over_pi = sphere_light_E_over_pi(x, cg.normal[i], sphere, points, occluded);
              if (E_over_pi <= 0.0) continue;
              for (int c = 0; c < 3; ++c)
                out[base + 3 * i + std::size_t(c)] += float(object.albedo[c] * light.color[c] * E_over_pi);
            }
          });
    }
  }
  return out;
}

}  // namespace modrt::precompute
