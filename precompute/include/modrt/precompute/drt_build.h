// SPDX-License-Identifier: MIT
// modrt precompute — the DRT operators of clutter objects (architecture.md §6, [Loos et al. 2012]
// §4–5), traced with Embree against the level's walls and the implicit lighting Limp of the
// dictionary, in parallel over scene samples and clutter texels (oneTBB).
//
// Every ray sees the walls and all clutter: a scene-sample ray is charged to the first object
// it enters (that object's dUb takes away the wall behind, its dUc adds its face), so
// overlapping shadows of two objects do not subtract the wall twice; a clutter-texel ray that
// enters another object before any wall brings that object's face light (Cc) instead of the
// wall's Limp (Cb). Moving one object therefore changes the others' operators too:
// rebuild_object re-traces exactly the scene samples, clutter texels (and probes) that lie
// inside the object or have a ray entering it, at its old or its new place, keeps the rest
// from the DrtBuildState of the previous build, and gives the same operators as a full build.
//
// Culling is exact: a sample or texel with all corners of an object's box behind its
// tangent plane does not test that object, and rays that miss the box's bounding sphere are
// not slab-tested; neither can skip a ray that enters the box.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "modrt/dictionary.h"
#include "modrt/drt.h"
#include "modrt/level.h"
#include "modrt/level_description.h"
#include "modrt/precompute/level_scene.h"

namespace modrt::precompute {

struct DrtBuildSettings {
  int rays = 1024;  // cosine-weighted stratified rays per scene sample and clutter texel
  // At most this many rays per clutter texel (Cb, Cc, the gather's Gs / Gt; not the vector
  // pass): min(rays, max_clutter_rays), 0 = rays. The clutter pass is nine tenths of a build,
  // and a texel's gather is an integral over the hemisphere that 512 rays estimate within the
  // path tracer's noise (docs/drt.md "Build time"), while the scene's shadow deltas keep 1024
  // (their mottling shows at 256, docs/demo.md).
  int max_clutter_rays = 512;
  int cb_modes = 5;     // modes kept of Cb's SVD (DRT §5: "5 x 16^2 values per clutter face")
  bool inpaint = true;  // DRT §5: samples inside clutter take their neighbours' shadowed Ub
  bool cull = true;     // box-behind-the-plane culling (exact; off only to test that it is)
  // dUb rows whose L2 norm is below this fraction of the object's largest row norm are
  // dropped (storage); a dropped row changes its sample by at most |row|_2 |b(block)|_2 per
  // channel. 0 keeps every row.
  double drop_tolerance = 0.0;
  // Also build dUb_vec and dUc_vec (OHLSH vector deltas, DRT §5) from a second set of
  // `rays` uniform-hemisphere rays per scene sample (the radiance SH projection needs a pdf
  // that does not vanish at the horizon; inpainted with Ub_vec, nothing dropped). Needs the
  // dictionary's Ub_vec.
  bool vector = false;
  // Also build U_dyn (clutter-aware volume probes, DRT §5) from `rays` uniform-sphere rays
  // per probe of the dictionary's probe grid (probes inside clutter get no delta).
  bool probes = false;
  // The basis of each object's c (DRT §4.2): 0 = constant light per face (box) or UV chart
  // (mesh), the paper's choice; n > 0 = a lighting prior per object (the paper's optional
  // prior, MRT §3.2's construction): n modes of the light of clutter_prior_grid^3 point lights
  // in the owning block, so that light varying across a face or a one-chart mesh (a sphere
  // lit from one side) reaches the scene and other clutter with its shape. c then has n
  // entries per object (DrtObjectOperators::face_count = n).
  int clutter_prior_modes = 0;
  int clutter_prior_grid = 4;
  // Also keep each clutter texel's gather weights per scene sample in the DrtBuildState
  // (DrtBuildState::sample_gather): what Cb's rays reach, before Limp turns it into a
  // function of b, so that the scene's real exitant radiance can be gathered instead (the DRT
  // issue's study, docs/drt.md "Gathering the real radiance"). Memory: one entry per texel
  // and sample its rays reach.
  bool sample_gather = false;
  // Build the real-radiance gather (DrtObjectOperators::Gs, Gt, H_sample, Hs, Ht; docs/drt.md
  // "The real-radiance gather") in place of Cb, Cc and the traced samples' dUb and dUc rows:
  // the clutter lightmap gathers the scene's and the other clutter's exitant radiance (never
  // below 0) and the scene's deltas take away and add the real radiance. The vector and probe
  // operators stay Limp's. The default: against the path tracer it cuts the clutter's error
  // five- to tenfold; false gives the paper's operators (Cb = Uc Vc, Cc), a tenth of the
  // storage, and the converged solve (which cannot express the gather).
  bool gather = true;
  std::uint64_t seed = 0x647274ull;
};

// rays in [1, kMaxSettingsRays], max_clutter_rays in [0, kMaxSettingsRays], clutter_prior_grid in [1,
// kMaxSettingsPriorGrid] (dictionary.h), cb_modes in [1, kMaxDrtModeCap] and clutter_prior_modes in [0,
// kMaxDrtModeCap] (caps: each is min'ed with the rank found, so a value above it keeps every
// mode and sizes nothing), drop_tolerance in [0, 1]; invalid_argument naming the setting.
// DrtBuilder checks it before allocating anything; build and rebuild_object return its error.
inline constexpr int kMaxDrtModeCap = 1 << 20;
Status validate_drt_build_settings(const DrtBuildSettings& settings);

struct DrtBuildReport {
  std::size_t traced_samples = 0;  // scene samples that shot rays
  std::size_t culled_samples = 0;  // scene samples with every object behind them
  std::size_t inside_samples = 0;  // scene samples inside clutter
  std::size_t inpainted_samples = 0;
  std::size_t dropped_rows = 0;   // dUb rows under drop_tolerance
  std::size_t traced_texels = 0;  // clutter texels that shot rays (all of them in a full build)
  // Wall-clock seconds of the scene-sample pass (dUb, dUc, inpainting) and of the clutter
  // texel pass (Cb and its SVD, Cc).
  double scene_seconds = 0.0, clutter_seconds = 0.0;
};

// A sparse operator over the scene samples, one row per clutter texel (CSR).
struct ClutterSampleGather {
  std::vector<std::uint32_t> row_start;  // texels + 1
  std::vector<std::uint32_t> sample;
  std::vector<float> weight;
};
// out (3 per texel) = gather radiance (3 per scene sample, RGB-interleaved): each texel's
// weighted sum of the scene's exitant radiance at the samples its rays reach.
void clutter_gather_radiance(const ClutterSampleGather& gather, std::span<const float> radiance,
                             std::span<float> out);

namespace drt_detail {
struct StateAccess;
}

// What a build traced (per scene sample and clutter texel, before inpainting, dropping and
// the SVD), the objects it traced and what it was built for (the level's sizes, the build
// settings), so that rebuild_object re-traces only what a move can change. Move-only; filled
// by DrtBuilder::build and rebuild_object, or read from a file (drt_state_io.h), which keeps
// it across program starts.
class DrtBuildState {
 public:
  DrtBuildState();
  ~DrtBuildState();
  DrtBuildState(DrtBuildState&&) noexcept;
  DrtBuildState& operator=(DrtBuildState&&) noexcept;
  bool empty() const;
  // The objects of the build (after a rebuild_object, with the moved one at its new place);
  // empty when empty().
  std::span<const ClutterObject> objects() const;
  // With DrtBuildSettings::sample_gather, per object (in the build's order): row t of its
  // clutter texels' gather, the weights of the scene samples their rays' first wall hits
  // reach (bilinear taps, 1 / rays a ray; rays that enter clutter first or leave the level
  // bring nothing); with clutter_texels, the weights of the other objects' texels (clutter-
  // wide texel order) their rays enter first instead. Empty without the setting.
  std::vector<ClutterSampleGather> sample_gather(bool clutter_texels = false) const;
  // The scene's side, one row per level sample (all objects together; empty rows for samples
  // inside clutter or that see none): the weights of the samples hidden behind clutter
  // (negative: the real radiance dUb b stands for) or, with clutter_texels, of the clutter
  // texels the sample's rays enter first (the real radiance dUc c stands for).
  ClutterSampleGather scene_sample_gather(bool clutter_texels = false) const;

 private:
  friend class DrtBuilder;
  friend struct drt_detail::StateAccess;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class DrtBuilder {
 public:
  // Throws std::runtime_error when Embree fails (as LevelScene). Settings that fail
  // validate_drt_build_settings make build / rebuild_object return that error.
  DrtBuilder(const Level& level, const Dictionary& dict, const DrtBuildSettings& settings = {});

  // Validates the objects (validate_clutter) and the dictionary's Limp sizes. `state`, when
  // given, receives what rebuild_object needs.
  Result<DrtOperators> build(std::span<const ClutterObject> objects, DrtBuildReport* report = nullptr,
                             DrtBuildState* state = nullptr) const;
  // The operators of one object alone in the level (build of a one-object list).
  Result<DrtObjectOperators> build_object(const ClutterObject& object,
                                          DrtBuildReport* report = nullptr) const;
  // Incremental: objects[index] changed (moved, turned, resized, new albedo or faces) since
  // the build that filled `state` and `drt`; every other object must be as it was then.
  // Re-traces the scene samples and the other objects' texels that can see the object at its
  // old or new place and all of its own texels, and rebuilds every object's operators from
  // the kept and re-traced results: equal to build(objects). Updates `state`.
  // invalid_argument, with `drt` and `state` untouched, when the state is not one of this
  // level, these settings and these objects (sizes, the settings it records); format_error,
  // with `drt` untouched and `state` spent (discard it), when a kept result indexes past the
  // objects, texels, blocks or samples (a damaged state file).
  Status rebuild_object(std::span<const ClutterObject> objects, std::size_t index, DrtOperators& drt,
                        DrtBuildState& state, DrtBuildReport* report = nullptr) const;

  const LevelScene& walls() const { return walls_; }

 private:
  struct Pass;
  const Level& level_;
  const Dictionary& dict_;
  DrtBuildSettings settings_;
  Status settings_status_;  // validate_drt_build_settings(settings_)
  LevelScene walls_;
  // Cosine-weighted stratified direction sets in the local frame (z = normal), shared by the
  // gathers (drt_build.cpp, DirectionSets).
  std::vector<glm::dvec3> direction_sets_;
  // The clutter texels' (max_clutter_rays below rays), else empty: they use direction_sets_.
  std::vector<glm::dvec3> texel_sets_;
  std::span<const glm::dvec3> texel_sets() const {
    return texel_sets_.empty() ? direction_sets_ : texel_sets_;
  }
  std::vector<glm::dvec3> uniform_sets_;  // the same, uniform over the hemisphere (vector)
  std::vector<glm::dvec3> sphere_sets_;   // the same, uniform over the sphere (probes)
};

// Direct light on the clutter texels (albedo * E / pi, RGB, 3 per texel, objects in order),
// the light model of level_direct_light, shadowed by the walls and all clutter of `scene`.
std::vector<float> clutter_direct_light(const LevelScene& scene, std::span<const LightDescription> lights,
                                        int light_samples);

// The same for a directional light (the sun): `direction` the way its light travels,
// `irradiance` per channel on a surface facing it (cpu::CpuLight's directional model:
// albedo * irradiance * max(0, -n.direction) * visibility / pi), shadowed as above.
std::vector<float> clutter_directional_light(const LevelScene& scene, const glm::dvec3& direction,
                                             const glm::dvec3& irradiance);

}  // namespace modrt::precompute
