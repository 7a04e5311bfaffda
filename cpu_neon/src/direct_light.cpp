// SPDX-License-Identifier: MIT
// modrt::cpu — the CPU direct-light evaluator (direct_light.h: models, shadows, bounds).
#include "modrt/cpu/direct_light.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <unordered_map>

#include <glm/geometric.hpp>

#include "modrt/cube.h"
#include "modrt/level_geometry.h"
#include "modrt/light_policy.h"

#include "simd_config.h"

namespace modrt::cpu {
namespace {

constexpr double kPi = 3.14159265358979323846;
// I max(1, color) / (pi max(r^2, 1e-12)) above this could overflow float ld once a few
// thousand lights are summed (FLT_MAX ~ 3.4e38).
constexpr double kMaxLightScale = 1e30;
// Barycentric growth of wall triangles: closes the cracks where walls meet (a ray along a shared
// edge could otherwise miss both triangles in float).
constexpr float kTriangleGrowth = 1e-5f;
// A spot's cone is widened by this (radians) before a face is culled, and the facing test keeps a
// face whose plane is within a relative rounding margin of the light: a culled pair must be one
// the kernel, in float, gives exactly 0 (influence_epsilon = 0 is bit-identical to no culling).
constexpr double kAngleMargin = 1e-4;
constexpr double kPlaneMargin = 1e-5;
// Bounds are raised by this relative slack for the kernel's float rounding.
constexpr double kBoundSlack = 1e-5;

std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}
std::string fmt(const glm::vec3& v) {
  char buf[120];
  std::snprintf(buf, sizeof buf, "(%.9g, %.9g, %.9g)", double(v.x), double(v.y), double(v.z));
  return buf;
}
bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

Status light_error(std::size_t index, const char* field, const std::string& problem) {
  return Status::error(ErrorCode::invalid_argument,
                       "direct light: light " + std::to_string(index) + ": " + field + " " + problem);
}

// The convex hull of 4 points as seen from `eye` (central projection onto the plane normal to
// `axis`, every point in front), written to `out` in order around it; returns its size (3 or 4).
int hull_from(const glm::dvec3& eye, const glm::dvec3& axis, const glm::dvec3* p, glm::dvec3* out) {
  const glm::dvec3 helper = std::abs(axis.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 u = glm::normalize(glm::cross(axis, helper)), v = glm::cross(axis, u);
  struct P2 {
    double x, y;
    int i;
  } q[4];
  for (int i = 0; i < 4; ++i) {
    const glm::dvec3 d = p[i] - eye;
    const double t = glm::dot(d, axis);
    q[i] = {glm::dot(d, u) / t, glm::dot(d, v) / t, i};
  }
  std::sort(q, q + 4, [](const P2& a, const P2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  // Andrew's monotone chain: lower then upper hull, counter-clockwise.
  auto cross = [](const P2& o, const P2& a, const P2& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
  };
  P2 h[8];
  int k = 0;
  for (int i = 0; i < 4; ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], q[i]) <= 0) --k;
    h[k++] = q[i];
  }
  for (int i = 2, lower = k + 1; i >= 0; --i) {
    while (k >= lower && cross(h[k - 2], h[k - 1], q[i]) <= 0) --k;
    h[k++] = q[i];
  }
  const int m = k - 1;  // the last point repeats the first
  for (int i = 0; i < m; ++i) out[i] = p[h[i].i];
  return m;
}

// ---- the per-sample kernel: E / pi of one light over a run of samples (SoA) ----
// One branch-free loop for every light type (direct_light.h, Prepared), so that it vectorises;
// the scalar twin is the same source with vectorisation off, the SIMD variants the same source
// compiled for their ISA. -ffp-contract=off (CMakeLists.txt) and IEEE sqrt/div make lanes round
// like the scalar code. The spot factor s is light_policy.h's spot_factor, in float.
#define MODRT_DIRECT_LIGHT_LOOP                                                                       \
  do {                                                                                                \
    for (std::size_t i = 0; i < n; ++i) {                                                             \
      const float wx = p.l[0] - p.pw * px[i], wy = p.l[1] - p.pw * py[i], wz = p.l[2] - p.pw * pz[i]; \
      const float d2 = wx * wx + wy * wy + wz * wz;                                                   \
      const float ndot = nx[i] * wx + ny[i] * wy + nz[i] * wz;                                        \
      const float inv_d = 1.0f / std::sqrt(std::max(d2, 1e-30f));                                     \
      const float ca = -(p.axis[0] * wx + p.axis[1] * wy + p.axis[2] * wz) * inv_d;                   \
      const float t = std::min(std::max((ca - p.cos_outer) * p.inv_range, 0.0f), 1.0f);               \
      const float s = t * t * (3.0f - 2.0f * t);                                                      \
      const float v = p.k * (ndot * inv_d) * s / std::max(d2, p.r2);                                  \
      e[i] = ndot > 0.0f ? v : 0.0f;                                                                  \
    }                                                                                                 \
  } while (false)

// acc_c += albedo_c * (color_c * e), planar (one channel array after the other).
#define MODRT_DIRECT_LIGHT_ACCUMULATE                                    \
  do {                                                                   \
    for (int c = 0; c < 3; ++c) {                                        \
      const float col = color[c];                                        \
      const float* a = albedo + std::size_t(c) * stride;                 \
      float* out = acc + std::size_t(c) * n;                             \
      for (std::size_t i = 0; i < n; ++i) out[i] += a[i] * (col * e[i]); \
    }                                                                    \
  } while (false)

#define MODRT_DIRECT_LIGHT_ACC_ARGS \
  const float *color, const float *albedo, std::size_t stride, const float *e, std::size_t n, float *acc

#define MODRT_DIRECT_LIGHT_ARGS                                                                          \
  const CpuDirectLight::Prepared &p, const float *px, const float *py, const float *pz, const float *nx, \
      const float *ny, const float *nz, std::size_t n, float *e

}  // namespace

// A friend of CpuDirectLight (Prepared is private).
struct DirectLightKernels {
#if defined(__GNUC__) && !defined(__clang__)
  __attribute__((optimize("no-tree-vectorize"))) static void scalar(MODRT_DIRECT_LIGHT_ARGS) {
    MODRT_DIRECT_LIGHT_LOOP;
  }
  __attribute__((optimize("no-tree-vectorize"))) static void scalar_acc(MODRT_DIRECT_LIGHT_ACC_ARGS) {
    MODRT_DIRECT_LIGHT_ACCUMULATE;
  }
#else
  static void scalar(MODRT_DIRECT_LIGHT_ARGS) {
#pragma clang loop vectorize(disable) interleave(disable)
    MODRT_DIRECT_LIGHT_LOOP;
  }
  static void scalar_acc(MODRT_DIRECT_LIGHT_ACC_ARGS) {
#pragma clang loop vectorize(disable) interleave(disable)
    MODRT_DIRECT_LIGHT_ACCUMULATE;
  }
#endif
#if MODRT_CPU_X86
  MODRT_TARGET_SSE41 static void sse41(MODRT_DIRECT_LIGHT_ARGS) { MODRT_DIRECT_LIGHT_LOOP; }
  MODRT_TARGET_AVX2 static void avx2(MODRT_DIRECT_LIGHT_ARGS) { MODRT_DIRECT_LIGHT_LOOP; }
  MODRT_TARGET_SSE41 static void sse41_acc(MODRT_DIRECT_LIGHT_ACC_ARGS) { MODRT_DIRECT_LIGHT_ACCUMULATE; }
  MODRT_TARGET_AVX2 static void avx2_acc(MODRT_DIRECT_LIGHT_ACC_ARGS) { MODRT_DIRECT_LIGHT_ACCUMULATE; }
#endif
#if MODRT_CPU_NEON
  static void neon(MODRT_DIRECT_LIGHT_ARGS) { MODRT_DIRECT_LIGHT_LOOP; }
  static void neon_acc(MODRT_DIRECT_LIGHT_ACC_ARGS) { MODRT_DIRECT_LIGHT_ACCUMULATE; }
#endif
  static void accumulate(Isa isa, MODRT_DIRECT_LIGHT_ACC_ARGS) {
    switch (isa) {
#if MODRT_CPU_X86
      case Isa::avx2: return avx2_acc(color, albedo, stride, e, n, acc);
      case Isa::sse41: return sse41_acc(color, albedo, stride, e, n, acc);
#endif
#if MODRT_CPU_NEON
      case Isa::neon: return neon_acc(color, albedo, stride, e, n, acc);
#endif
      default: return scalar_acc(color, albedo, stride, e, n, acc);
    }
  }
  static void run(Isa isa, MODRT_DIRECT_LIGHT_ARGS) {
    switch (isa) {
#if MODRT_CPU_X86
      case Isa::avx2: return avx2(p, px, py, pz, nx, ny, nz, n, e);
      case Isa::sse41: return sse41(p, px, py, pz, nx, ny, nz, n, e);
#endif
#if MODRT_CPU_NEON
      case Isa::neon: return neon(p, px, py, pz, nx, ny, nz, n, e);
#endif
      default: return scalar(p, px, py, pz, nx, ny, nz, n, e);
    }
  }
};

#undef MODRT_DIRECT_LIGHT_LOOP
#undef MODRT_DIRECT_LIGHT_ARGS
#undef MODRT_DIRECT_LIGHT_ACCUMULATE
#undef MODRT_DIRECT_LIGHT_ACC_ARGS

Status CpuDirectLight::prepare_light(std::size_t index, const CpuLight& light, Prepared& out) {
  const int type = int(light.type);
  if (type < 0 || type > int(LightType::directional))
    return light_error(index, "type",
                       std::to_string(type) + " is not point (0), spot (1) or directional (2)");
  if (!finite(light.color) || light.color.x < 0 || light.color.y < 0 || light.color.z < 0)
    return light_error(index, "color", fmt(light.color) + " must be finite and >= 0");
  if (!std::isfinite(light.intensity) || light.intensity < 0)
    return light_error(index, "intensity", fmt(light.intensity) + " must be finite and >= 0");
  const bool positioned = light.type != LightType::directional;
  if (positioned) {
    if (!finite(light.position))
      return light_error(index, "position", fmt(light.position) + " is not finite");
    if (!std::isfinite(light.radius) || light.radius < 0)
      return light_error(index, "radius", fmt(light.radius) + " must be finite and >= 0");
  }
  glm::dvec3 dir(0.0);
  if (light.type != LightType::point) {
    if (!finite(light.direction))
      return light_error(index, "direction", fmt(light.direction) + " is not finite");
    dir = glm::dvec3(light.direction);
    const double length = glm::length(dir);
    if (!(length > 1e-6))
      return light_error(index, "direction",
                         fmt(light.direction) + " has length " + fmt(length) + " (must be > 1e-6)");
    dir /= length;
  }
  SpotFalloff cone;  // light_policy.h; the defaults give s = 1 (point, directional)
  if (light.type == LightType::spot) {
    const double inner = light.inner_angle, outer = light.outer_angle;
    if (!(outer > 0.0 && outer <= double(float(kPi))))  // float(pi) rounds up
      return light_error(index, "outer_angle", fmt(outer) + " must be in (0, pi]");
    if (!(inner >= 0.0 && inner <= outer))
      return light_error(index, "inner_angle",
                         fmt(inner) + " must be in [0, outer_angle = " + fmt(outer) + "]");
    cone = spot_falloff(inner, outer);
  }
  const double r2 = positioned ? light_falloff_d2(0.0, double(light.radius), 0.0) : 1.0;
  const double c_max = std::max({1.0, double(light.color.x), double(light.color.y), double(light.color.z)});
  const double scale = double(light.intensity) * c_max / (kPi * r2);
  if (!(scale <= kMaxLightScale))
    return light_error(index, "intensity",
                       fmt(light.intensity) + " x max(1, color) / (pi max(radius^2, 1e-12)) = " + fmt(scale) +
                           " exceeds " + fmt(kMaxLightScale) + ": ld could overflow float");
  Prepared p;
  if (positioned) {
    p.l[0] = light.position.x, p.l[1] = light.position.y, p.l[2] = light.position.z;
    p.pw = 1.0f;
  } else {
    p.l[0] = float(-dir.x), p.l[1] = float(-dir.y), p.l[2] = float(-dir.z);
    p.pw = 0.0f;
  }
  if (light.type == LightType::spot)
    p.axis[0] = float(dir.x), p.axis[1] = float(dir.y), p.axis[2] = float(dir.z);
  p.cos_outer = float(cone.cos_outer);
  p.inv_range = float(cone.inv_range);
  p.k = float(double(light.intensity) / kPi);
  p.r2 = float(r2);
  p.color[0] = light.color.x, p.color[1] = light.color.y, p.color[2] = light.color.z;
  p.shadows = light.shadows;
  // Out of reach (light_policy.h): contributes 0, as on every other path.
  p.in_reach = !positioned || light_in_reach(glm::dvec3(light.position), double(light.radius));
  if (!p.in_reach) p.k = 0.0f;
  out = p;
  return Status::success();
}

namespace {

Status check_albedo(std::span<const float> albedo, std::size_t samples) {
  if (albedo.size() != 3 * samples)
    return Status::error(ErrorCode::invalid_argument, "direct light: albedo has " +
                                                          std::to_string(albedo.size()) +
                                                          " floats, expected 3 x " + std::to_string(samples));
  for (std::size_t i = 0; i < albedo.size(); ++i)
    if (!std::isfinite(albedo[i]) || albedo[i] < 0.0f)
      return Status::error(ErrorCode::invalid_argument, "direct light: albedo of sample " +
                                                            std::to_string(i / 3) + " channel " +
                                                            std::to_string(i % 3) + " is " + fmt(albedo[i]) +
                                                            " (must be finite and >= 0)");
  return Status::success();
}

bool same_light(const CpuLight& a, const CpuLight& b) {
  return a.type == b.type && a.position == b.position && a.direction == b.direction && a.color == b.color &&
         a.intensity == b.intensity && a.radius == b.radius && a.inner_angle == b.inner_angle &&
         a.outer_angle == b.outer_angle && a.shadows == b.shadows;
}

}  // namespace

Result<CpuDirectLight> CpuDirectLight::create(const Level& level, std::span<const float> albedo,
                                              const CpuDirectLightOptions& options) {
  auto fail = [](const std::string& m) {
    return Status::error(ErrorCode::invalid_argument, "direct light: " + m);
  };
  if (options.max_lights < 1 || options.max_lights > 4096)
    return fail("max_lights " + std::to_string(options.max_lights) + " must be in [1, 4096]");
  if (!std::isfinite(options.influence_epsilon) || options.influence_epsilon < 0.0f)
    return fail("influence_epsilon " + fmt(options.influence_epsilon) + " must be finite and >= 0");
  if (options.warped_face_subdivisions < 1 || options.warped_face_subdivisions > 64)
    return fail("warped_face_subdivisions " + std::to_string(options.warped_face_subdivisions) +
                " must be in [1, 64]");
  const Isa isa = options.isa.value_or(active_isa());
  if (!isa_supported(isa)) return fail(std::string("ISA ") + isa_name(isa) + " is not supported here");
  if (Status s = check_albedo(albedo, level.sample_count); !s.ok()) return s;

  CpuDirectLight d;
  d.isa_ = isa;
  d.options_ = options;
  d.block_count_ = level.blocks.size();
  d.sample_count_ = level.sample_count;

  const LevelSampleGeometry g = level_sample_geometry(level);
  const std::size_t n = level.sample_count;
  for (auto* v : {&d.px_, &d.py_, &d.pz_, &d.nx_, &d.ny_, &d.nz_}) v->resize(n);
  for (std::size_t s = 0; s < n; ++s) {
    d.px_[s] = float(g.position[s].x), d.py_[s] = float(g.position[s].y), d.pz_[s] = float(g.position[s].z);
    d.nx_[s] = float(g.normal[s].x), d.ny_[s] = float(g.normal[s].y), d.nz_[s] = float(g.normal[s].z);
  }
  d.albedo_.assign(albedo.begin(), albedo.end());

  // Blocks: sample ranges, mean size h (mean edge of the corners' bounding boxes).
  double size_sum = 0.0, coord_max = 0.0;
  for (const LevelBlock& b : level.blocks) {
    d.block_offset_.push_back(b.sample_offset);
    d.block_samples_.push_back(b.sample_count);
    d.max_block_samples_ = std::max<std::size_t>(d.max_block_samples_, b.sample_count);
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (const glm::dvec3& c : b.corners) lo = glm::min(lo, c), hi = glm::max(hi, c);
    size_sum += (hi.x - lo.x + hi.y - lo.y + hi.z - lo.z) / 3.0;
    d.block_footprint_d2_.push_back(texel_footprint_d2(block_texel_area(b.corners, level.res)));
    for (int a = 0; a < 3; ++a) coord_max = std::max({coord_max, std::abs(lo[a]), std::abs(hi[a])});
  }
  d.h_ = d.block_count_ ? size_sum / double(d.block_count_) : 1.0;
  if (!(d.h_ > 0.0)) d.h_ = 1.0;
  d.margin_ = kPlaneMargin * (d.h_ + coord_max);
  d.block_albedo_max_.assign(3 * d.block_count_, 0.0f);

  // Faces (bounds) and wall triangles.
  std::vector<float> verts;
  for (std::size_t bi = 0; bi < d.block_count_; ++bi) {
    const LevelBlock& b = level.blocks[bi];
    d.block_face_begin_.push_back(std::uint32_t(d.faces_.size()));
    const FaceMask mask = dictionary_shape_mask(b.shape);
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(mask, f)) continue;
      const glm::dvec3 c00 = block_to_world(b, face_point(f, 0, 0)),
                       c10 = block_to_world(b, face_point(f, 1, 0));
      const glm::dvec3 c01 = block_to_world(b, face_point(f, 0, 1)),
                       c11 = block_to_world(b, face_point(f, 1, 1));
      Face face;
      face.block = std::uint32_t(bi);
      face.lo = glm::min(glm::min(c00, c10), glm::min(c01, c11));
      face.hi = glm::max(glm::max(c00, c10), glm::max(c01, c11));
      face.centre = 0.5 * (face.lo + face.hi);
      face.radius = 0.5 * glm::length(face.hi - face.lo);
      // Inward normal of the corners' mean plane (cube.h: normal = u_axis x v_axis).
      face.normal = glm::normalize(glm::cross(c10 - c00 + c11 - c01, c01 - c00 + c11 - c10));
      const glm::dvec3 mean = 0.25 * (c00 + c10 + c01 + c11);
      face.offset = glm::dot(face.normal, mean);
      double off_plane = 0.0;
      for (const glm::dvec3& c : {c00, c10, c01, c11})
        off_plane = std::max(off_plane, std::abs(glm::dot(face.normal, c - mean)));
      face.planar = off_plane <= 1e-9 * d.h_;
      d.faces_.push_back(face);

      const int m = face.planar ? 1 : options.warped_face_subdivisions;
      auto vertex = [&](int i, int j) {
        return block_to_world(b, face_point(f, double(i) / m, double(j) / m));
      };
      for (int j = 0; j < m; ++j)
        for (int i = 0; i < m; ++i) {
          const glm::dvec3 v00 = vertex(i, j), v10 = vertex(i + 1, j), v01 = vertex(i, j + 1),
                           v11 = vertex(i + 1, j + 1);
          // Embree's winding in level_scene.cpp: (v00, v10, v11), (v00, v11, v01), normal inward.
          for (const auto& [a, bb, c] : {std::array{v00, v10, v11}, std::array{v00, v11, v01}}) {
            const glm::vec3 v0(a), e1(bb - a), e2(c - a);
            const glm::vec3 nrm = glm::cross(e1, e2);
            verts.insert(verts.end(),
                         {v0.x, v0.y, v0.z, e1.x, e1.y, e1.z, e2.x, e2.y, e2.z, nrm.x, nrm.y, nrm.z});
            d.tri_face_.push_back(std::uint32_t(d.faces_.size() - 1));
          }
        }
    }
  }
  d.block_face_begin_.push_back(std::uint32_t(d.faces_.size()));
  d.tri_ = std::move(verts);

  // Back-to-back walls. Tessellations of a bent wall and of its neighbour's twin differ (other
  // diagonals, other parameter directions), so a sample on the exact surface can lie just
  // behind the twin's triangles and its ray would leave the neighbour there: the twin is
  // skipped (the ray enters the sample's block, so the twin cannot stop it legitimately).
  std::unordered_map<std::uint64_t, std::uint32_t> by_cell;
  auto cell_key = [](const glm::ivec3& c) {
    const auto pack = [](int v) {
      return std::uint64_t(std::int64_t(v) + (std::int64_t(1) << 20)) & 0x1FFFFF;
    };
    return pack(c.x) | (pack(c.y) << 21) | (pack(c.z) << 42);
  };
  for (std::size_t bi = 0; bi < d.block_count_; ++bi)
    by_cell.emplace(cell_key(level.blocks[bi].cell), std::uint32_t(bi));
  static constexpr int kStep[kFaceCount][3] = {{-1, 0, 0}, {1, 0, 0},  {0, -1, 0},
                                               {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};
  d.sample_twin_.assign(n, kNoFace);
  for (std::size_t bi = 0; bi < d.block_count_; ++bi) {
    const LevelBlock& b = level.blocks[bi];
    const FaceMask mask = dictionary_shape_mask(b.shape);
    std::uint32_t slot = 0;
    for (int f = 0; f < kFaceCount; ++f) {
      if (!face_present(mask, f)) continue;
      const std::uint32_t texels = std::uint32_t(level.res * level.res);
      const std::uint32_t first = b.sample_offset + slot * texels;
      ++slot;
      const int wf = rotate_face(f, b.quarter_turns);
      const auto it = by_cell.find(cell_key(b.cell + glm::ivec3(kStep[wf][0], kStep[wf][1], kStep[wf][2])));
      if (it == by_cell.end()) continue;
      const LevelBlock& nb = level.blocks[it->second];
      const int twin_face = rotate_face(wf ^ 1, -nb.quarter_turns);
      const FaceMask nmask = dictionary_shape_mask(nb.shape);
      if (!face_present(nmask, twin_face)) continue;
      std::uint32_t twin = d.block_face_begin_[it->second];
      for (int k = 0; k < twin_face; ++k) twin += face_present(nmask, k);
      std::fill(d.sample_twin_.begin() + first, d.sample_twin_.begin() + first + texels, twin);
    }
  }

  // Uniform grid over the triangles, cells a third of a block wide unless that makes too many.
  const std::size_t tris = d.triangle_count();
  double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
  if (tris > 0) {
    for (int a = 0; a < 3; ++a) lo[a] = std::numeric_limits<double>::max(), hi[a] = -lo[a];
    for (std::size_t t = 0; t < tris; ++t) {
      const float* T = &d.tri_[kTriFloats * t];
      for (int a = 0; a < 3; ++a) {
        for (const double v : {double(T[a]), double(T[a]) + T[3 + a], double(T[a]) + T[6 + a]}) {
          lo[a] = std::min(lo[a], v);
          hi[a] = std::max(hi[a], v);
        }
      }
    }
  }
  const double pad = 1e-3 * d.h_;
  // A third of a block per cell: a ray then tests the walls near its path only (modrt-bench-cpu,
  // ray walk on maze41: 1.5x faster than one block per cell, 2.7x on a warped maze; a quarter
  // is no faster).
  double cell = d.h_ / 3.0;
  const std::size_t max_cells = std::max<std::size_t>(4096, 64 * d.block_count_);
  for (;;) {
    std::size_t total = 1;
    for (int a = 0; a < 3; ++a) {
      d.dims_[a] = std::max(1, int(std::ceil((hi[a] - lo[a] + 2 * pad) / cell)));
      total *= std::size_t(d.dims_[a]);
    }
    if (total <= max_cells) break;
    cell *= 1.25;
  }
  for (int a = 0; a < 3; ++a) {
    d.grid_lo_[a] = float(lo[a] - pad);
    d.grid_hi_[a] = float(lo[a] - pad + cell * d.dims_[a]);
  }
  d.cell_size_ = float(cell);
  d.far_ = float(4.0 * (cell * (d.dims_[0] + d.dims_[1] + d.dims_[2]) + coord_max + d.h_));
  d.t_min_world_ = float(1e-4 * d.h_);
  const std::size_t cells = std::size_t(d.dims_[0]) * std::size_t(d.dims_[1]) * std::size_t(d.dims_[2]);
  // A triangle goes into every cell its slightly grown box touches, so a ray along a cell
  // boundary finds it from either side.
  auto cell_range = [&](std::size_t t, int* c0, int* c1) {
    const float* T = &d.tri_[kTriFloats * t];
    for (int a = 0; a < 3; ++a) {
      const double v0 = T[a], v1 = double(T[a]) + T[3 + a], v2 = double(T[a]) + T[6 + a];
      const double tlo = std::min({v0, v1, v2}) - pad, thi = std::max({v0, v1, v2}) + pad;
      c0[a] = std::clamp(int(std::floor((tlo - d.grid_lo_[a]) / cell)), 0, d.dims_[a] - 1);
      c1[a] = std::clamp(int(std::floor((thi - d.grid_lo_[a]) / cell)), 0, d.dims_[a] - 1);
    }
  };
  d.cell_begin_.assign(cells + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<std::uint32_t> fill;
    if (pass == 1) {
      for (std::size_t c = 0; c < cells; ++c) d.cell_begin_[c + 1] += d.cell_begin_[c];
      d.cell_tris_.assign(d.cell_begin_[cells], 0);
      fill.assign(d.cell_begin_.begin(), d.cell_begin_.end() - 1);
    }
    for (std::size_t t = 0; t < tris; ++t) {
      int c0[3], c1[3];
      cell_range(t, c0, c1);
      for (int z = c0[2]; z <= c1[2]; ++z)
        for (int y = c0[1]; y <= c1[1]; ++y)
          for (int x = c0[0]; x <= c1[0]; ++x) {
            const std::size_t c =
                (std::size_t(z) * d.dims_[1] + std::size_t(y)) * d.dims_[0] + std::size_t(x);
            if (pass == 0)
              ++d.cell_begin_[c + 1];
            else
              d.cell_tris_[fill[c]++] = std::uint32_t(t);
          }
    }
  }

  // Portals and face planes for the portal walk (see portal_visibility).
  d.closed_ = true;
  d.block_planes_.resize(d.block_count_);
  for (std::size_t bi = 0; bi < d.block_count_; ++bi) {
    const LevelBlock& b = level.blocks[bi];
    const FaceMask mask = dictionary_shape_mask(b.shape);
    d.block_portal_begin_.push_back(std::uint32_t(d.portals_.size()));
    BlockPlanes& bp = d.block_planes_[bi];
    bp.planar = true;
    for (int f = 0; f < kFaceCount; ++f) {
      const glm::dvec3 c[4] = {block_to_world(b, face_point(f, 0, 0)), block_to_world(b, face_point(f, 1, 0)),
                               block_to_world(b, face_point(f, 1, 1)),
                               block_to_world(b, face_point(f, 0, 1))};
      const glm::dvec3 nrm = glm::normalize(glm::cross(c[1] - c[0] + c[2] - c[3], c[3] - c[0] + c[2] - c[1]));
      const glm::dvec3 mean = 0.25 * (c[0] + c[1] + c[2] + c[3]);
      double off_plane = 0.0;
      for (const glm::dvec3& v : c) off_plane = std::max(off_plane, std::abs(glm::dot(nrm, v - mean)));
      const bool planar = off_plane <= 1e-9 * d.h_;
      bp.normal[f] = nrm;
      bp.offset[f] = glm::dot(nrm, mean);
      bp.deviation[f] = off_plane;
      bp.planar = bp.planar && planar;
      if (face_present(mask, f)) continue;
      const int nb = b.neighbour[std::size_t(f)];
      if (nb < 0) {
        d.closed_ = false;  // a missing face onto empty space
        continue;
      }
      Portal portal;
      portal.to = std::uint32_t(nb);
      portal.face = f;
      portal.entry =
          rotate_face(rotate_face(f, b.quarter_turns) ^ 1, -level.blocks[std::size_t(nb)].quarter_turns);
      portal.planar = planar;
      for (int k = 0; k < 4; ++k) portal.corner[k] = c[k];
      d.portals_.push_back(portal);
    }
  }
  // Convex: planar faces and every corner on the inner side of every face plane (a segment
  // between two points of the block then stays inside it).
  for (std::size_t bi = 0; bi < d.block_count_; ++bi) {
    BlockPlanes& bp = d.block_planes_[bi];
    bp.convex = bp.planar;
    for (const glm::dvec3& c : level.blocks[bi].corners)
      for (int f = 0; f < kFaceCount; ++f)
        bp.convex = bp.convex && glm::dot(bp.normal[f], c) - bp.offset[f] >= -1e-9 * d.h_;
  }
  d.block_portal_begin_.push_back(std::uint32_t(d.portals_.size()));
  d.visible_.assign(d.block_count_, 0);
  // Up to 1024 frusta per light (~300 KB); a walk that needs more falls back to the ray walk.
  d.frustum_cap_ =
      options.shadows && options.portal_frusta ? std::min<std::size_t>(4 * d.block_count_ + 256, 1024) : 0;
  d.frusta_.assign(options.max_lights * d.frustum_cap_, Frustum{});
  d.frustum_planes_.assign(options.max_lights * d.frustum_cap_ * kMaxPlanes * 3, 0.0);
  d.frustum_count_.assign(options.max_lights, 0);
  d.frustum_exact_.assign(options.max_lights, 0);
  d.sample_visible_.assign(std::max<std::size_t>(d.max_block_samples_, 1), 0);

  d.last_.assign(options.max_lights, CpuLight{});
  d.prepared_.assign(options.max_lights, Prepared{});
  d.staging_.assign(options.max_lights, Prepared{});
  d.bound_.assign(options.max_lights * d.block_count_, 0.0);
  d.reach_.assign(options.max_lights * d.block_count_, 0);
  d.dirty_.assign(d.block_count_, 0);
  d.culled_.assign(options.max_lights, 0);
  d.e_.assign(std::max<std::size_t>(d.max_block_samples_, 1), 0.0f);
  d.acc_.assign(3 * std::max<std::size_t>(d.max_block_samples_, 1), 0.0f);
  d.albedo_planar_.assign(3 * n, 0.0f);
  if (Status s = d.set_albedo(albedo); !s.ok()) return s;
  return d;
}

Status CpuDirectLight::set_albedo(std::span<const float> albedo) {
  if (Status s = check_albedo(albedo, sample_count_); !s.ok()) return s;
  std::copy(albedo.begin(), albedo.end(), albedo_.begin());
  for (std::size_t i = 0; i < sample_count_; ++i)
    for (std::size_t c = 0; c < 3; ++c) albedo_planar_[c * sample_count_ + i] = albedo_[3 * i + c];
  for (std::size_t b = 0; b < block_count_; ++b)
    for (int c = 0; c < 3; ++c) {
      float m = 0.0f;
      for (std::size_t s = block_offset_[b]; s < block_offset_[b] + block_samples_[b]; ++s)
        m = std::max(m, albedo_[3 * s + std::size_t(c)]);
      block_albedo_max_[3 * b + std::size_t(c)] = m;
    }
  valid_ = false;
  return Status::success();
}

// Portal walk (Luebke and Georges 1995). In a closed level (every missing face joins two blocks)
// a wall stops every segment that leaves a block through it, so an unshadowed segment from the
// light to a sample passes from block to block only through portals. Starting in the block that
// holds the light, each portal is clipped by the frustum of the portals before it (planes through
// the light and the clipped polygon's edges); a block reached by a non-empty polygon may see the
// light, every other block gets exactly 0 from it. The frustum is widened by a relative 1e-6
// (the shadow test's triangles are grown by 1e-5: an edge-grazing ray is stopped there), a bent
// portal clips the cone over its corners' convex hull, and the walk gives up (every block
// visible) when the light is not inside a block by a margin, or the walk grows too large.
bool CpuDirectLight::portal_visibility(std::size_t l, const glm::dvec3& L) {
  std::fill(visible_.begin(), visible_.end(), std::uint8_t(0));
  frustum_count_[l] = 0;
  frustum_exact_[l] = 0;
  if (!closed_) return false;
  const double inside = 2.0 * double(t_min_world_) + margin_;
  for (std::size_t b = 0; b < block_count_; ++b) {
    const BlockPlanes& bp = block_planes_[b];
    bool in = true;
    // A bent face lies within `deviation` of its corners' mean plane.
    for (int f = 0; f < kFaceCount && in; ++f)
      in = glm::dot(bp.normal[f], L) - bp.offset[f] > inside + bp.deviation[f];
    if (!in) continue;
    portal_work_ = 0;
    portal_gave_up_ = false;
    walk_light_ = l;
    walk_exact_ = true;
    visit_portals(std::uint32_t(b), -1, L, nullptr, 0, 0);
    frustum_exact_[l] = options_.portal_frusta && walk_exact_ && !portal_gave_up_;
    return !portal_gave_up_;
  }
  return false;
}

void CpuDirectLight::visit_portals(std::uint32_t block, int entry, const glm::dvec3& L,
                                   const glm::dvec3* planes, int count, int depth) {
  // Each level of recursion keeps ~1.1 KB of polygons and planes on the stack: 64 levels stay
  // within a small thread stack; a deeper chain gives up (every block visible, ray walk).
  constexpr int kMaxDepth = 64;
  visible_[block] = 1;
  if (portal_gave_up_) return;
  if (++portal_work_ > 64 * block_count_ + 1024 || depth > kMaxDepth) {
    portal_gave_up_ = true;
    return;
  }
  const BlockPlanes& bp = block_planes_[block];
  // Record the frustum that reaches this block: with convex blocks and planar portals, a sample
  // of the block sees the light iff it lies in one of them (the segment from the light then
  // runs through the chain's portals and convex blocks only).
  if (walk_exact_) {
    std::uint32_t& nf = frustum_count_[walk_light_];
    if (!bp.convex || nf == frustum_cap_) {
      walk_exact_ = false;
    } else {
      Frustum& fr = frusta_[walk_light_ * frustum_cap_ + nf];
      fr.block = block;
      fr.count = std::uint32_t(count);
      double* dst = frustum_planes_.data() + (((walk_light_ * frustum_cap_) + nf) * kMaxPlanes * 3);
      for (int i = 0; i < count; ++i)
        for (int a = 0; a < 3; ++a) dst[3 * i + a] = planes[i][a];
      ++nf;
    }
  }
  for (std::uint32_t k = block_portal_begin_[block]; k < block_portal_begin_[block + 1]; ++k) {
    const Portal& portal = portals_[k];
    if (portal.face == entry) continue;
    const glm::dvec3& pn = bp.normal[portal.face];
    const double side = glm::dot(pn, L) - bp.offset[portal.face], dev = bp.deviation[portal.face];
    glm::dvec3 poly[4 + kMaxPlanes], next[4 + kMaxPlanes];
    int n = 4;
    for (int i = 0; i < 4; ++i) poly[i] = portal.corner[i];
    if (portal.planar) {
      // A line crosses the portal's plane once: the light must be on this block's side of it.
      if (!(side > -margin_)) continue;
    } else {
      walk_exact_ = false;
      if (side < -(dev + margin_)) continue;  // the light is beyond the whole bent portal
      if (side <= dev + margin_) {            // in its slab: no narrower cone than the one so far
        visit_portals(portal.to, portal.entry, L, planes, count, depth + 1);
        continue;
      }
      // Lines from the light through the bent portal stay in the cone over its corners' hull
      // (the patch lies in their tetrahedron): the hull of the corners seen from the light.
      n = hull_from(L, -pn, portal.corner, poly);
    }
    // Clip the portal by each plane: keep n . (p - L) >= -1e-6 |p - L|.
    for (int pl = 0; pl < count && n >= 3; ++pl) {
      const glm::dvec3& nrm = planes[pl];
      int m = 0;
      if (n + 1 > 4 + kMaxPlanes) walk_exact_ = false;  // the clipped polygon could be truncated
      for (int i = 0; i < n && m < 4 + kMaxPlanes; ++i) {
        const glm::dvec3 &a = poly[i], &b = poly[(i + 1) % n];
        const double da = glm::dot(nrm, a - L) + 1e-6 * glm::length(a - L);
        const double db = glm::dot(nrm, b - L) + 1e-6 * glm::length(b - L);
        if (da >= 0.0) next[m++] = a;
        if ((da >= 0.0) != (db >= 0.0) && m < 4 + kMaxPlanes) next[m++] = a + (da / (da - db)) * (b - a);
      }
      n = m;
      for (int i = 0; i < n; ++i) poly[i] = next[i];
    }
    if (n < 3) continue;
    // The new frustum: planes through the light and each edge, facing the polygon's centroid.
    glm::dvec3 centroid(0.0);
    for (int i = 0; i < n; ++i) centroid += poly[i];
    centroid /= double(n);
    glm::dvec3 frustum[kMaxPlanes];
    int planes_out = 0;
    for (int i = 0; i < n && planes_out < kMaxPlanes; ++i) {
      glm::dvec3 nrm = glm::cross(poly[i] - L, poly[(i + 1) % n] - L);
      const double len = glm::length(nrm);
      if (!(len > 1e-12 * glm::dot(poly[i] - L, poly[i] - L))) continue;  // a degenerate edge: no plane
      nrm /= len;
      if (glm::dot(nrm, centroid - L) < 0.0) nrm = -nrm;
      frustum[planes_out++] = nrm;  // fewer planes than edges only widens the frustum
    }
    if (n > kMaxPlanes) walk_exact_ = false;
    visit_portals(portal.to, portal.entry, L, frustum, planes_out, depth + 1);
  }
}

// The influence bound of light `l` (already in last_ / prepared_) on every block (direct_light.h).
void CpuDirectLight::update_bounds(std::size_t l) {
  const CpuLight& light = last_[l];
  double* bound = bound_.data() + (l * block_count_);
  std::uint8_t* reach = reach_.data() + (l * block_count_);
  std::uint32_t culled = 0;
  frustum_count_[l] = 0;
  frustum_exact_[l] = 0;
  if (light.type == LightType::directional) {
    std::fill(bound, bound + block_count_, 1.0 / kPi);
    std::fill(reach, reach + block_count_, std::uint8_t(1));
    culled_[l] = 0;
    return;
  }
  if (!prepared_[l].in_reach) {
    std::fill(bound, bound + block_count_, 0.0);
    std::fill(reach, reach + block_count_, std::uint8_t(0));
    culled_[l] = std::uint32_t(block_count_);
    return;
  }
  const glm::dvec3 L(light.position);
  const double r2_light = light_falloff_d2(0.0, double(light.radius), 0.0);
  const double margin = margin_ + kPlaneMargin * std::max({std::abs(L.x), std::abs(L.y), std::abs(L.z)});
  const bool spot = light.type == LightType::spot;
  glm::dvec3 axis(0.0);
  double outer = kPi;
  SpotFalloff cone;
  if (spot) {
    axis = glm::normalize(glm::dvec3(light.direction));
    outer = light.outer_angle;
    cone = spot_falloff(double(light.inner_angle), outer);
  }
  const double threshold = double(options_.influence_epsilon) / (kPi * h_ * h_);
  // The walk also decides shadows (evaluate_block), so it runs with influence off too.
  const bool walked = options_.shadows && light.shadows && portal_visibility(l, L);
  const bool portals = options_.influence && walked;
  for (std::size_t b = 0; b < block_count_; ++b) {
    const double r2 = std::max(r2_light, block_footprint_d2_[b]);
    double g = 0.0;
    for (std::uint32_t fi = block_face_begin_[b]; fi < block_face_begin_[b + 1]; ++fi) {
      const Face& f = faces_[fi];
      // Behind the plane of a planar face: n . (L - x) <= 0 for every x of the face.
      if (f.planar && glm::dot(f.normal, L) - f.offset < -margin) continue;
      double s = 1.0;
      if (spot) {
        const glm::dvec3 v = f.centre - L;
        const double dist = glm::length(v);
        if (dist > f.radius) {
          const double phi = std::acos(std::clamp(glm::dot(v, axis) / dist, -1.0, 1.0));
          const double alpha = std::asin(std::min(1.0, f.radius / dist));
          const double psi = phi - alpha - kAngleMargin;  // least angle to the axis over the sphere
          if (psi > outer) continue;
          s = spot_factor(cone, std::cos(std::max(psi, 0.0)));
          // The kernel ramps from a float cos_outer: a sphere just inside the cone keeps s > 0.
          s = std::max(s, 1e-12);
        }
      }
      const glm::dvec3 gap = glm::max(glm::max(f.lo - L, L - f.hi), glm::dvec3(0.0));
      g = std::max(g, s / (kPi * std::max(glm::dot(gap, gap), r2)));
    }
    if (portals && !visible_[b]) g = 0.0;  // shadowed: exactly 0
    bound[b] = g * (1.0 + kBoundSlack);
    const bool r = !options_.influence || (g > 0.0 && bound[b] >= threshold);
    reach[b] = r;
    culled += !r;
  }
  culled_[l] = culled;
}

void CpuDirectLight::compute_error_bounds() {
  double max_err = 0.0, sum_sq = 0.0;
  for (std::size_t b = 0; b < block_count_; ++b) {
    double drop[3] = {0, 0, 0};
    for (std::size_t l = 0; l < light_count_; ++l) {
      const std::size_t k = l * block_count_ + b;
      if (reach_[k] || bound_[k] <= 0.0) continue;
      for (int c = 0; c < 3; ++c)
        drop[c] += double(block_albedo_max_[3 * b + std::size_t(c)]) * last_[l].color[c] *
                   last_[l].intensity * bound_[k];
    }
    for (int c = 0; c < 3; ++c) {
      max_err = std::max(max_err, drop[c]);
      sum_sq += drop[c] * drop[c] * double(block_samples_[b]);
    }
  }
  stats_.ld_error_max = max_err;
  stats_.ld_error_l2 = std::sqrt(sum_sq);
}

// Segment origin + t dir, t in (t_min, 1 - t_min) with t_min = t_min_world / |dir|: does it leave
// a block through one of its walls? 3D DDA over the grid, any hit ends the walk.
bool CpuDirectLight::occluded(const float* o, const float* d, std::uint32_t skip_face) const {
  const float len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(len > 0.0f)) return false;
  const float t_lo = t_min_world_ / len, t_hi = 1.0f - t_lo;
  float t0 = t_lo, t1 = t_hi;
  for (int a = 0; a < 3; ++a) {
    if (d[a] != 0.0f) {
      float ta = (grid_lo_[a] - o[a]) / d[a], tb = (grid_hi_[a] - o[a]) / d[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    } else if (o[a] < grid_lo_[a] || o[a] > grid_hi_[a]) {
      return false;
    }
  }
  if (t0 > t1) return false;
  int ix[3], step[3];
  float t_next[3], t_delta[3];
  for (int a = 0; a < 3; ++a) {
    const float p = o[a] + t0 * d[a];
    ix[a] = std::clamp(int(std::floor((p - grid_lo_[a]) / cell_size_)), 0, dims_[a] - 1);
    if (d[a] > 0.0f) {
      step[a] = 1;
      t_next[a] = (grid_lo_[a] + float(ix[a] + 1) * cell_size_ - o[a]) / d[a];
      t_delta[a] = cell_size_ / d[a];
    } else if (d[a] < 0.0f) {
      step[a] = -1;
      t_next[a] = (grid_lo_[a] + float(ix[a]) * cell_size_ - o[a]) / d[a];
      t_delta[a] = -cell_size_ / d[a];
    } else {
      step[a] = 0;
      t_next[a] = t_delta[a] = std::numeric_limits<float>::infinity();
    }
  }
  for (;;) {
    const std::size_t c =
        (std::size_t(ix[2]) * std::size_t(dims_[1]) + std::size_t(ix[1])) * std::size_t(dims_[0]) +
        std::size_t(ix[0]);
    for (std::uint32_t k = cell_begin_[c]; k < cell_begin_[c + 1]; ++k) {
      if (tri_face_[cell_tris_[k]] == skip_face) continue;
      const float* T = &tri_[kTriFloats * cell_tris_[k]];
      // One-sided (level_scene.cpp): only a ray leaving the block through the wall is stopped.
      if (d[0] * T[9] + d[1] * T[10] + d[2] * T[11] >= 0.0f) continue;
      // Moller-Trumbore; det = e1 . (d x e2) = -d . n > 0 here.
      const float pv[3] = {d[1] * T[8] - d[2] * T[7], d[2] * T[6] - d[0] * T[8], d[0] * T[7] - d[1] * T[6]};
      const float det = T[3] * pv[0] + T[4] * pv[1] + T[5] * pv[2];
      if (!(det > 0.0f)) continue;
      const float inv = 1.0f / det;
      const float tv[3] = {o[0] - T[0], o[1] - T[1], o[2] - T[2]};
      const float u = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) * inv;
      if (u < -kTriangleGrowth || u > 1.0f + kTriangleGrowth) continue;
      const float qv[3] = {tv[1] * T[5] - tv[2] * T[4], tv[2] * T[3] - tv[0] * T[5],
                           tv[0] * T[4] - tv[1] * T[3]};
      const float v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) * inv;
      if (v < -kTriangleGrowth || u + v > 1.0f + kTriangleGrowth) continue;
      const float t = (T[6] * qv[0] + T[7] * qv[1] + T[8] * qv[2]) * inv;
      if (t > t_lo && t < t_hi) return true;
    }
    int a = 0;
    if (t_next[1] < t_next[a]) a = 1;
    if (t_next[2] < t_next[a]) a = 2;
    if (t_next[a] > t1) return false;
    ix[a] += step[a];
    if (ix[a] < 0 || ix[a] >= dims_[a]) return false;
    t_next[a] += t_delta[a];
  }
}

void CpuDirectLight::evaluate_block(std::size_t b, std::span<float> ld) {
  const std::size_t off = block_offset_[b], n = block_samples_[b];
  float* out = ld.data() + 3 * off;
  // Summed planar (vector adds), in light order, then interleaved once.
  float* acc = acc_.data();
  std::fill(acc, acc + 3 * n, 0.0f);
  float* e = e_.data();
  for (std::size_t l = 0; l < light_count_; ++l) {
    if (!reach_[l * block_count_ + b]) continue;
    ++stats_.pairs_evaluated;
    // The falloff floor of this block's texels (light_policy.h light_falloff_d2).
    Prepared p = prepared_[l];
    if (p.pw != 0.0f) p.r2 = std::max(p.r2, float(block_footprint_d2_[b]));
    DirectLightKernels::run(isa_, p, px_.data() + off, py_.data() + off, pz_.data() + off, nx_.data() + off,
                            ny_.data() + off, nz_.data() + off, n, e);
    if (options_.shadows && p.shadows && frustum_exact_[l]) {
      // Visible iff inside one of the frusta that reached this block (visit_portals); in double,
      // widened by a relative 1e-9, so only rays within that of a portal edge count as grazing.
      std::uint8_t* vis = sample_visible_.data();
      std::fill(vis, vis + n, std::uint8_t(0));
      const Frustum* fr = frusta_.data() + (l * frustum_cap_);
      const glm::dvec3 L(p.l[0], p.l[1], p.l[2]);
      for (std::uint32_t k = 0; k < frustum_count_[l]; ++k) {
        if (fr[k].block != b) continue;
        const double* pl = frustum_planes_.data() + ((l * frustum_cap_ + k) * kMaxPlanes * 3);
        for (std::size_t i = 0; i < n; ++i) {
          if (vis[i] || !(e[i] > 0.0f)) continue;
          const double dx = px_[off + i] - L.x, dy = py_[off + i] - L.y, dz = pz_[off + i] - L.z;
          const double slack = -1e-9 * std::sqrt(dx * dx + dy * dy + dz * dz);
          bool in = true;
          for (std::uint32_t q = 0; q < fr[k].count && in; ++q)
            in = pl[3 * q] * dx + pl[3 * q + 1] * dy + pl[3 * q + 2] * dz >= slack;
          vis[i] = in;
        }
      }
      for (std::size_t i = 0; i < n; ++i) {
        if (!(e[i] > 0.0f)) continue;
        ++stats_.frustum_tests;
        if (!vis[i]) e[i] = 0.0f;
      }
    } else if (options_.shadows && p.shadows) {
      const float reach = p.pw == 0.0f ? far_ : 1.0f;
      for (std::size_t i = 0; i < n; ++i) {
        if (!(e[i] > 0.0f)) continue;
        const float o[3] = {px_[off + i], py_[off + i], pz_[off + i]};
        const float dir[3] = {(p.l[0] - p.pw * o[0]) * reach, (p.l[1] - p.pw * o[1]) * reach,
                              (p.l[2] - p.pw * o[2]) * reach};
        ++stats_.shadow_rays;
        if (occluded(o, dir, sample_twin_[off + i])) e[i] = 0.0f;
      }
    }
    DirectLightKernels::accumulate(isa_, p.color, albedo_planar_.data() + off, sample_count_, e, n, acc);
  }
  for (std::size_t i = 0; i < n; ++i) {
    out[3 * i] = acc[i];
    out[3 * i + 1] = acc[n + i];
    out[3 * i + 2] = acc[2 * n + i];
  }
}

Status CpuDirectLight::evaluate(std::span<const CpuLight> lights, std::span<float> ld) {
  if (lights.size() > options_.max_lights)
    return Status::error(ErrorCode::invalid_argument,
                         "direct light: " + std::to_string(lights.size()) +
                             " lights, more than max_lights = " + std::to_string(options_.max_lights));
  if (ld.size() != 3 * sample_count_)
    return Status::error(ErrorCode::invalid_argument, "direct light: ld has " + std::to_string(ld.size()) +
                                                          " floats, expected 3 x " +
                                                          std::to_string(sample_count_));
  for (std::size_t l = 0; l < lights.size(); ++l)
    if (Status s = prepare_light(l, lights[l], staging_[l]); !s.ok()) return s;

  const bool full = !valid_ || ld.data() != last_ld_;
  stats_ = CpuDirectLightStats{};
  stats_.full_update = full;
  std::fill(dirty_.begin(), dirty_.end(), std::uint8_t(full));
  const std::size_t old_count = valid_ ? light_count_ : 0;
  for (std::size_t l = 0; l < std::max(old_count, lights.size()); ++l) {
    const bool changed = full || l >= old_count || l >= lights.size() || !same_light(last_[l], lights[l]);
    if (!changed) continue;
    ++stats_.lights_changed;
    std::uint8_t* reach = reach_.data() + (l * block_count_);
    if (!full && l < old_count)
      for (std::size_t b = 0; b < block_count_; ++b) dirty_[b] |= reach[b];
    if (l < lights.size()) {
      last_[l] = lights[l];
      prepared_[l] = staging_[l];
      update_bounds(l);
      if (!full)
        for (std::size_t b = 0; b < block_count_; ++b) dirty_[b] |= reach[b];
    } else {
      std::fill(reach, reach + block_count_, std::uint8_t(0));
      culled_[l] = 0;
    }
  }
  light_count_ = lights.size();
  for (std::size_t b = 0; b < block_count_; ++b) {
    if (!dirty_[b]) continue;
    evaluate_block(b, ld);
    ++stats_.blocks_recomputed;
  }
  stats_.blocks_kept = block_count_ - stats_.blocks_recomputed;
  compute_error_bounds();
  last_ld_ = ld.data();
  valid_ = true;
  return Status::success();
}

}  // namespace modrt::cpu

#include "simd_config_end.h"
