// SPDX-License-Identifier: MIT
// modrt::cpu — the CPU direct-light evaluator (architecture.md §5 step 1): ld = albedo * E / pi at every
// level sample, from point, spot and directional lights, optionally shadowed by the proxy walls,
// in the layout CpuLevelRuntime::evaluate takes (RGB interleaved, 3 x level.sample_count).
//
// Light models (E is irradiance at a sample x with unit inward normal n; w the unit direction
// and d the distance from x to the light; V visibility of the light's centre, 1 without shadows):
//   point        E = I V max(0, n.w) / max(d^2, r^2, A_b / (2 pi), 1e-12)  (precompute's
//                SphereLight with one visibility sample: r only bounds the 1/d^2 peak; it casts
//                hard shadows). A_b is the footprint area of the texels of the sample's block b
//                (modrt/light_policy.h: light_falloff_d2, block_texel_area): the bound a texel's
//                footprint puts on a point light's irradiance. A point or spot light whose
//                sphere is out of reach (light_in_reach: a coordinate beyond 1e15) gives 0.
//   spot         the point model times s(cos a), a the angle between the spot axis and -w,
//                s = smoothstep from cos(outer) (0) to cos(inner) (1): t = (cos a - cos outer) /
//                max(cos inner - cos outer, 1e-4), s = t^2 (3 - 2t), t clamped to [0, 1]
//   directional  E = I V max(0, -n.dir): I is the irradiance on a surface facing the light
// The result per sample is the sum over lights, in light order, of albedo * color * E / pi.
//
// Shadows. The walls are the present faces of every block: planar faces as two triangles, a
// face that the warp bends (its corners off one plane) as an m x m grid of its trilinear image
// (options.warped_face_subdivisions), two triangles per cell, wound so their normal is inward.
// As in precompute's Embree scene (level_scene.h) a wall only stops rays that leave its block
// through it (back-to-back walls of neighbours must not shadow each other's samples). A shadow
// ray is a segment from the sample to the light (or out of the level, for a directional light);
// it walks a uniform grid over the level (cells a third of a block wide, 3D DDA) and tests only the
// triangles binned in the cells it crosses, stopping at the first hit: its cost follows the
// path's length in blocks, not the level's size. Triangles are grown by 1e-5 of their edges so
// that a ray cannot slip between two walls that meet.
//
// Influence bounds. For each point or spot light and block, g = an upper bound on E / (pi I)
// over every sample of the block, from each present face's bounding box and bounding sphere:
//   0 when the light is behind the plane of every present planar face (by more than a rounding
//   margin; a bent face always counts as facing it) or, for a spot, when every face's bounding
//   sphere lies outside the outer cone (angle between the axis and the sphere's centre minus the
//   sphere's half-angle > outer angle, with a margin);
//   else max over facing faces of s(bound on cos a) / (pi max(dist(light, face box)^2, r^2,
//   A_b / (2 pi), 1e-12)); 0 for a light out of reach.
// With shadows, in a closed level (every missing face joins two blocks), g is also 0 for blocks
// no straight line from the light reaches through a chain of portals (connected missing faces):
// a portal walk from the light's block clips each portal by the frustum of the portals before
// it (direct_light.cpp, portal_visibility). A wall stops every ray leaving its block through it,
// so such blocks are in shadow and get exactly 0. The walk is skipped (every block counts as
// visible) for open levels, for a light not inside a block by a margin (bent faces: beyond their
// corners' spread about their mean plane), or when it grows past 64 visits per block or 64
// portals deep; a bent portal narrows the frustum to the cone over its corners' convex hull
// (the patch lies in their tetrahedron), or leaves it unchanged when the light is within that
// spread of the portal's plane.
// A block is culled for a light when g pi h^2 < influence_epsilon (h: the mean block size), i.e.
// when its bound is below influence_epsilon times the E / pi the light gives a surface facing it
// one block away. influence_epsilon = 0 culls only blocks with g = 0, which the light gives
// exactly 0 (the bounds keep rounding margins for that), so the output is bit-identical to no
// culling. The energy left out is bounded per
// block and channel by max albedo x color x I x g, summed over the lights that culled it, and
// reported (stats().ld_error_max, ld_error_l2). Directional lights reach every block.
//
// Incremental update. evaluate() compares each light with the one at the same index in the
// previous call; a light that changed (any field), appeared or disappeared dirties the blocks it
// reached then and the blocks it reaches now. Only dirty blocks are recomputed (every light that
// reaches them, in light order: the same bits as a full evaluation); every other block's ld is
// left untouched, bit for bit, so CpuLevelRuntime's skip (a) with ld_epsilon = 0 keeps its b.
// This relies on the caller passing back the ld buffer the previous evaluate() wrote, unchanged
// (another buffer address, set_albedo() or invalidate() make the next call compute every block).
//
// Everything is allocated by create(); evaluate() does not allocate (except to build an error
// message). One thread; a CpuDirectLight must not be used from two threads at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/cpu/isa.h"
#include "modrt/level.h"
#include "modrt/status.h"

namespace modrt::cpu {

struct DirectLightKernels;  // src/direct_light.cpp

enum class LightType : std::uint8_t { point = 0, spot = 1, directional = 2 };

struct CpuLight {
  LightType type = LightType::point;
  glm::vec3 position{0.5f};                // point, spot: world position (finite)
  glm::vec3 direction{0.0f, -1.0f, 0.0f};  // spot: cone axis; directional: direction light travels
                                           // (finite, length > 1e-6; normalised internally)
  glm::vec3 color{1.0f};                   // linear RGB, finite, >= 0
  float intensity = 1.0f;                  // point, spot: W/sr; directional: irradiance; finite, >= 0
  float radius = 0.0f;                     // point, spot: 1/d^2 clamp (see above); finite, >= 0
  float inner_angle = 0.5f;                // spot: half-angles in radians, 0 <= inner <= outer,
  float outer_angle = 0.7f;                //       0 < outer <= pi
  bool shadows = true;                     // cast shadows (when the evaluator has them on)
};

struct CpuDirectLightOptions {
  std::optional<Isa> isa;            // none: active_isa(); an unsupported ISA fails create()
  std::size_t max_lights = 8;        // evaluate() accepts up to this many lights (1 to 4096;
                                     // with shadows and portal_frusta, ~300 KB of frusta per light)
  bool shadows = true;               // shadow rays against the walls
  bool influence = true;             // per-light block culling (off: every light reaches every block)
  float influence_epsilon = 0.0f;    // relative culling threshold (see above), finite, >= 0
  int warped_face_subdivisions = 4;  // m for bent faces (1 to 64)
  bool portal_frusta = true;         // shadows by portal frusta where exact (false: always the ray walk)
};

// What the last evaluate() did.
struct CpuDirectLightStats {
  std::size_t lights_changed = 0;     // lights that differ from the previous call (all on a full update)
  std::size_t blocks_recomputed = 0;  // blocks whose ld was rewritten
  std::size_t blocks_kept = 0;        // blocks whose ld was left untouched
  std::size_t pairs_evaluated = 0;    // (light, block) contributions computed
  std::size_t shadow_rays = 0;        // samples whose visibility a ray walk decided
  std::size_t frustum_tests = 0;      // samples whose visibility the portal frusta decided
  bool full_update = false;           // every block recomputed (first call, new buffer, ...)
  // Bounds on the light left out by culling, over the whole ld (every block, culled by a light
  // that changed this frame or not): max |ld - ld without culling| over samples and channels,
  // and ||ld - ld without culling||_2 over all channels. 0 with influence_epsilon = 0.
  double ld_error_max = 0.0;
  double ld_error_l2 = 0.0;
};

class CpuDirectLight {
 public:
  // Builds the sample geometry (level_geometry.h), the wall triangles and their grid, and every
  // buffer. albedo: 3 x level.sample_count (RGB interleaved, finite, >= 0), copied. The level
  // is borrowed for create() only. Fails with invalid_argument on bad options or albedo.
  static Result<CpuDirectLight> create(const Level& level, std::span<const float> albedo,
                                       const CpuDirectLightOptions& options = {});

  // ld (3 x samples) for `lights`. Fails with invalid_argument naming the light index and field
  // for a bad light (NaN or Inf, negative intensity, radius or color, zero direction, bad cone
  // angles, E / pi that could overflow float, unknown type), more than max_lights lights or a
  // wrong ld size; then nothing is written and the next call compares against the last good one.
  Status evaluate(std::span<const CpuLight> lights, std::span<float> ld);

  // The checks evaluate() makes of light `index` (the error names the index and field), for a
  // caller that evaluates the light elsewhere, such as the GPU pass (gles::GlesDirectLight).
  static Status check_light(std::size_t index, const CpuLight& light) {
    Prepared unused;
    return prepare_light(index, light, unused);
  }

  // Replaces the albedo (same checks as create()); the next evaluate() recomputes every block.
  Status set_albedo(std::span<const float> albedo);
  // The next evaluate() recomputes every block (the caller changed the ld buffer).
  void invalidate() { valid_ = false; }

  const CpuDirectLightStats& stats() const { return stats_; }
  // Per light of the last evaluate(): blocks it was culled from (its influence bound below the
  // threshold, or 0), and whether it reaches block `block`.
  std::span<const std::uint32_t> blocks_culled() const { return {culled_.data(), light_count_}; }
  bool reaches(std::size_t light, std::size_t block) const {
    return reach_[light * block_count_ + block] != 0;
  }
  // The influence bound g of light `light` on block `block` (E / (pi I), see above).
  double influence_bound(std::size_t light, std::size_t block) const {
    return bound_[light * block_count_ + block];
  }

  Isa isa() const { return isa_; }
  std::size_t triangle_count() const { return tri_.size() / kTriFloats; }
  float block_size() const { return float(h_); }

 private:
  friend struct DirectLightKernels;
  CpuDirectLight() = default;
  static constexpr std::size_t kTriFloats = 12;  // v0, e1, e2, inward normal e1 x e2

  // A validated light in the kernel's form: w = l - pw x (pw = 0: directional, l = -dir),
  // spot factor from cos a = -(axis . w) / |w|, E / pi = k max(0, n.w / |w|) s / max(|w|^2, r2).
  struct Prepared {
    float l[3] = {0, 0, 0}, pw = 1.0f, axis[3] = {0, 0, 0};
    float cos_outer = -2.0f, inv_range = 1.0f, k = 0.0f, r2 = 1e-12f;
    float color[3] = {0, 0, 0};
    bool shadows = false;
    bool in_reach = true;  // light_in_reach (a directional light always is)
  };
  static Status prepare_light(std::size_t index, const CpuLight& light, Prepared& out);
  void update_bounds(std::size_t light);
  void evaluate_block(std::size_t block, std::span<float> ld);
  bool occluded(const float* origin, const float* dir, std::uint32_t skip_face) const;
  void compute_error_bounds();
  bool portal_visibility(std::size_t light_index, const glm::dvec3& light);
  void visit_portals(std::uint32_t block, int entry, const glm::dvec3& light, const glm::dvec3* planes,
                     int count, int depth);

  Isa isa_ = Isa::scalar;
  CpuDirectLightOptions options_;
  std::size_t block_count_ = 0, sample_count_ = 0, max_block_samples_ = 0;
  double h_ = 1.0;     // mean block size
  double margin_ = 0;  // rounding margin of the facing test (world units)
  // Per block: the footprint floor of the falloff, A_b / (2 pi) (light_policy.h).
  std::vector<double> block_footprint_d2_;
  // Per block: sample range; per block and channel: max albedo.
  std::vector<std::uint32_t> block_offset_, block_samples_;
  std::vector<float> block_albedo_max_;
  // Samples, SoA: position and unit inward normal; albedo interleaved.
  std::vector<float> px_, py_, pz_, nx_, ny_, nz_, albedo_;
  // Present faces: owning block, box, bounding sphere, plane (planar faces only).
  struct Face {
    std::uint32_t block = 0;
    bool planar = false;
    glm::dvec3 lo{0.0}, hi{0.0}, centre{0.0}, normal{0.0};
    double radius = 0.0, offset = 0.0;  // plane: normal . x = offset
  };
  std::vector<Face> faces_;
  std::vector<std::uint32_t> block_face_begin_;  // faces of block i: [begin[i], begin[i + 1])
  // Per sample: the wall back to back with its face (the grid neighbour's coincident face), whose
  // triangles its shadow rays skip, or kNoFace. Per triangle: its face.
  static constexpr std::uint32_t kNoFace = 0xFFFFFFFFu;
  std::vector<std::uint32_t> sample_twin_, tri_face_;
  // Wall triangles and the uniform grid over them (CSR: triangles of cell c in
  // cell_tris_[cell_begin_[c] .. cell_begin_[c + 1])).
  std::vector<float> tri_;
  std::vector<std::uint32_t> cell_begin_, cell_tris_;
  float grid_lo_[3] = {0, 0, 0}, grid_hi_[3] = {0, 0, 0}, cell_size_ = 1.0f;
  int dims_[3] = {1, 1, 1};
  float far_ = 1.0f;  // a length that crosses the whole grid (directional shadow rays)
  float t_min_world_ = 0.0f;
  // Lights: the previous call's (compared for changes), prepared forms, and per (light, block)
  // the influence bound and whether the light reaches the block, plus per light the cull count.
  std::vector<CpuLight> last_;
  std::vector<Prepared> prepared_, staging_;
  std::vector<double> bound_;
  std::vector<std::uint8_t> reach_, dirty_;
  std::vector<std::uint32_t> culled_;
  // Portal visibility (closed levels, shadowed lights): per block its 6 face planes (inward
  // normal, offset; missing faces too) and whether all are planar; per block its portals
  // (connected missing faces) in CSR; the blocks the last portal walk reached.
  struct BlockPlanes {
    glm::dvec3 normal[6];
    double offset[6] = {0, 0, 0, 0, 0, 0};
    double deviation[6] = {0, 0, 0, 0, 0, 0};  // max distance of a corner from the plane
    bool planar = false, convex = false;
  };
  struct Portal {
    std::uint32_t to = 0;
    int face = 0, entry = 0;  // canonical face in this block; the face it enters `to` through
    bool planar = false;
    glm::dvec3 corner[4];  // c00, c10, c11, c01: around the quad
  };
  std::vector<BlockPlanes> block_planes_;
  std::vector<Portal> portals_;
  std::vector<std::uint32_t> block_portal_begin_;
  std::vector<std::uint8_t> visible_;
  bool closed_ = false;
  std::size_t portal_work_ = 0;
  bool portal_gave_up_ = false;
  // Portal frusta as the shadow test (direct_light.cpp, evaluate_block): per light up to
  // frustum_cap_ frusta (block, planes through the light: 3 doubles each, kMaxPlanes per
  // frustum), their count, and whether they are exact (every block and portal of the walk convex
  // and planar, nothing truncated); the walk in progress records into light walk_light_.
  static constexpr int kMaxPlanes = 12;
  struct Frustum {
    std::uint32_t block = 0, count = 0;
  };
  std::size_t frustum_cap_ = 0, walk_light_ = 0;
  bool walk_exact_ = false;
  std::vector<Frustum> frusta_;
  std::vector<double> frustum_planes_;
  std::vector<std::uint32_t> frustum_count_;
  std::vector<std::uint8_t> frustum_exact_, sample_visible_;
  std::vector<float> e_;              // E / pi of one light over one block
  std::vector<float> acc_;            // ld of one block, planar (3 x its samples)
  std::vector<float> albedo_planar_;  // 3 x samples, channel after channel
  std::size_t light_count_ = 0;
  const float* last_ld_ = nullptr;
  bool valid_ = false;
  CpuDirectLightStats stats_;
};

}  // namespace modrt::cpu
