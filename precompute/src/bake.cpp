// SPDX-License-Identifier: MIT
#include "modrt/precompute/bake.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

#include "modrt/checked_arithmetic.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/interfaces.h"
#include "modrt/precompute/sh_operators.h"
#include "modrt/precompute/symmetry.h"
#include "modrt/precompute/transport.h"

namespace modrt::precompute {
namespace {

class StageTimer {
 public:
  StageTimer(const BakeProgress& progress, int shape) : progress_(progress), shape_(shape) {}
  void done(const char* stage) {
    const auto now = std::chrono::steady_clock::now();
    if (progress_.on_stage)
      progress_.on_stage(stage, shape_, std::chrono::duration<double>(now - start_).count());
    start_ = now;
  }

 private:
  const BakeProgress& progress_;
  int shape_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

int shape_index_of(FaceMask mask) {
  for (int s = 0; s < kDictionaryShapeCount; ++s)
    if (dictionary_shape_mask(s) == mask) return s;
  return -1;
}

}  // namespace

DictionarySettings quick_dictionary_settings(std::uint32_t res) {
  DictionarySettings s;
  s.res = res;
  s.rays = 1024;
  s.sh_rays = 256;
  s.probe_grid = 2;
  s.lightfield_spatial = 6;
  s.lightfield_directional = 12;
  s.lightfield_supersample = 3;
  s.response_rays = 1024;
  return s;
}

InterfaceSettings interface_settings(const DictionarySettings& s) {
  InterfaceSettings is;
  is.spatial = int(s.lightfield_spatial);
  is.directional = int(s.lightfield_directional);
  is.supersample = int(s.lightfield_supersample);
  is.krlf = int(s.krlf);
  is.kr = int(s.kr);
  is.enrichment_iterations = int(s.interface_enrichment_iterations);
  is.response_rays = int(s.response_rays);
  is.probe_grid = int(s.probe_grid);
  is.probe_rays = int(s.sh_rays);
  is.seed = s.seed ^ 0x1f1f1f1full;
  return is;
}

namespace {

// bake_shape and bake_shape_with_prior: `given_Ld` null lights the settings' prior lattice.
ShapeBake bake_shape_from(FaceMask mask, const glm::dvec3& extent, const DictionarySettings& settings,
                          const MatrixXd* given_Ld, bool with_sh, const BakeProgress& progress) {
  if (Status s = validate_settings(settings); !s.ok()) throw std::invalid_argument(s.message());
  ShapeBake bake;
  bake.mask = mask;
  bake.extent = extent;
  bake.layout = SampleLayout::make(mask, int(settings.res));
  const BlockScene scene(mask, extent);
  StageTimer timer(progress, shape_index_of(mask));
  const std::uint64_t shape_seed = settings.seed ^ (std::uint64_t(mask) << 40);

  if (given_Ld) {
    if (given_Ld->rows() != bake.layout.sample_count() || given_Ld->cols() < 1 || !given_Ld->allFinite())
      throw std::invalid_argument("bake_shape_with_prior: Ld must be finite with one row per sample (" +
                                  std::to_string(bake.layout.sample_count()) + ") and at least one column");
    bake.Ld = *given_Ld;
  } else {
    bake.Ld = light_prior_matrix(scene, bake.layout, int(settings.prior_grid), settings.light_radius,
                                 int(settings.light_samples));
  }
  bake.raw_prior = truncated_left_svd(bake.Ld, int(settings.kd));
  timer.done("prior");

  bake.F = gather_transport(scene, bake.layout, int(settings.rays), shape_seed);
  symmetrize_transport(bake.F, bake.layout, extent);
  timer.done("F");

  bake.raw_transfer = reduce_transfer(bake.F, bake.raw_prior, int(settings.kb));
  bake.prior = bake.raw_prior;
  bake.transfer = bake.raw_transfer;
  const MatrixXd face_constants = face_constant_columns(bake.layout);
  for (std::uint32_t it = 0; it < settings.enrichment_iterations; ++it) {
    bake.prior = enrich_prior(bake.prior, face_constants, bake.transfer.Ub, int(settings.kd));
    bake.transfer = reduce_transfer(bake.F, bake.prior, int(settings.kb));
  }
  timer.done("reduce+enrich");

  if (with_sh) {
    bake.Ub_vec = vector_irradiance_operator(scene, bake.layout, bake.transfer.Limp, int(settings.sh_rays),
                                             shape_seed ^ 0x5A5Aull);
    timer.done("vector irradiance");
    bake.Ubvol = volume_probe_operator(scene, bake.layout, bake.transfer.Limp, int(settings.probe_grid),
                                       int(settings.sh_rays), shape_seed ^ 0xA5A5ull);
    timer.done("volume probes");
  }
  return bake;
}

}  // namespace

ShapeBake bake_shape(FaceMask mask, const DictionarySettings& settings, bool with_sh,
                     const BakeProgress& progress) {
  return bake_shape_from(mask, glm::dvec3(1.0), settings, nullptr, with_sh, progress);
}

ShapeBake bake_box_shape(FaceMask mask, const glm::dvec3& extent, const DictionarySettings& settings,
                         bool with_sh, const BakeProgress& progress) {
  return bake_shape_from(mask, extent, settings, nullptr, with_sh, progress);
}

ShapeBake bake_shape_with_prior(FaceMask mask, const DictionarySettings& settings, const MatrixXd& Ld,
                                bool with_sh, const BakeProgress& progress) {
  return bake_shape_from(mask, glm::dvec3(1.0), settings, &Ld, with_sh, progress);
}

ShapeOperators to_operators(const ShapeBake& bake) {
  ShapeOperators op;
  op.face_mask = bake.mask;
  op.Ub = to_float(bake.transfer.Ub);
  op.Td_b = to_float(bake.transfer.Td_b);
  op.Limp = to_float(bake.transfer.Limp);
  op.Ub_vec = to_float(bake.Ub_vec);
  op.Ubvol = to_float(bake.Ubvol);
  op.sigma_M.resize(std::size_t(bake.transfer.sigma_M.size()));
  for (Eigen::Index i = 0; i < bake.transfer.sigma_M.size(); ++i)
    op.sigma_M[std::size_t(i)] = float(bake.transfer.sigma_M(i));
  return op;
}

BakeMemoryEstimate estimate_bake_memory(const DictionarySettings& s) {
  constexpr std::uint64_t kDouble = sizeof(double);
  const std::uint64_t res2 = saturating_product({s.res, s.res});
  const std::uint64_t n = saturating_product({6, res2}), n_dead = saturating_product({5, res2});
  BakeMemoryEstimate e;
  // F (n x n) and the product M = F P S with its SVD working copy (reduce_transfer).
  e.transport = saturating_product({2, kDouble, n, n});
  // The prior of the cross shape (four open sides) lights its own cell and its four
  // neighbours: 5 grid^3 lights. Ld (n x lights), BDCSVD's working copy of it, its thin U
  // (n x min(n, lights)) and the light positions (lattice and all, 2 x 24 bytes per light).
  const std::uint64_t lights = saturating_product({5, s.prior_grid, s.prior_grid, s.prior_grid});
  e.prior = saturating_add(saturating_add(saturating_product({2, kDouble, n, lights}),
                                          saturating_product({kDouble, n, std::min(n, lights)})),
                           saturating_product({48, lights}));
  // Per worker thread: the stratified directions of one sample (16 bytes per ray, the
  // largest ray count of F, SH and interface response) and one prior light's visibility
  // points (24 bytes per sample).
  const std::uint64_t rays = std::max({s.rays, s.sh_rays, s.lightfield_spatial > 0 ? s.response_rays : 0u});
  const std::uint64_t threads = std::max(1u, std::thread::hardware_concurrency());
  e.thread_buffers = saturating_product(
      {threads, saturating_add(saturating_product({16, rays}), saturating_product({24, s.light_samples}))});
  // Kept per shape until the dictionary is assembled: Ub, Limp, Td_b and P (n x kd), Ub_vec
  // (4n x kb) and the probes' Ubvol (9 g^3 x kb); six shapes.
  const std::uint64_t probes = saturating_product({9, s.probe_grid, s.probe_grid, s.probe_grid});
  e.shape_operators = saturating_product(
      {6, kDouble,
       saturating_add(saturating_product({n, saturating_add(saturating_product({7, s.kb}), s.kd)}),
                      saturating_product({probes, s.kb}))});
  // With interfaces, the dead end's lightfield response (n_dead x S^2 D^2) and its copy.
  if (s.lightfield_spatial > 0)
    e.lightfield = saturating_product({2, kDouble, n_dead, s.lightfield_spatial, s.lightfield_spatial,
                                       s.lightfield_directional, s.lightfield_directional});
  e.total = saturating_add(saturating_add(saturating_add(e.transport, e.prior), e.thread_buffers),
                           saturating_add(e.shape_operators, e.lightfield));
  return e;
}

std::uint64_t estimate_bake_bytes(const DictionarySettings& s) { return estimate_bake_memory(s).total; }

Result<Dictionary> bake_dictionary(const DictionarySettings& settings, const BakeProgress& progress,
                                   std::uint64_t memory_budget, Matrix* lightfield_basis) {
  if (Status s = validate_settings(settings); !s.ok()) return s;
  if (const BakeMemoryEstimate need = estimate_bake_memory(settings); need.total > memory_budget) {
    constexpr double kGiB = double(1u << 30);
    char text[512];
    std::snprintf(
        text, sizeof text,
        "bake: res %u, prior_grid %u, %u rays and a %u x %u x %u^2 interface lightfield need about "
        "%.1f GiB (transport %.1f, prior lattice %.1f, ray buffers %.1f, operators %.1f, lightfield "
        "%.1f), over the memory budget of %.1f GiB: lower res, prior_grid, the ray counts, "
        "lightfield_spatial or lightfield_directional, or raise the budget",
        settings.res, settings.prior_grid, std::max(settings.rays, settings.sh_rays),
        settings.lightfield_spatial, settings.lightfield_spatial, settings.lightfield_directional,
        double(need.total) / kGiB, double(need.transport) / kGiB, double(need.prior) / kGiB,
        double(need.thread_buffers) / kGiB, double(need.shape_operators) / kGiB,
        double(need.lightfield) / kGiB, double(memory_budget) / kGiB);
    return Status::error(ErrorCode::resource_limit, text);
  }
  try {
    Dictionary dict;
    dict.settings = settings;
    std::vector<ShapeBake> bakes;
    for (int s = 0; s < kDictionaryShapeCount; ++s) {
      bakes.push_back(bake_shape(dictionary_shape_mask(s), settings, true, progress));
      bakes.back().F.resize(0, 0);  // the largest intermediates; not needed any more
      bakes.back().Ld.resize(0, 0);
      dict.shapes.push_back(to_operators(bakes.back()));
    }
    if (settings.lightfield_spatial > 0) {
      ShapeLimps limps{};
      for (int s = 0; s < kDictionaryShapeCount; ++s)
        limps[std::size_t(s)] = &bakes[std::size_t(s)].transfer.Limp;
      const InterfaceBake ib = bake_interfaces(limps, int(settings.res), interface_settings(settings),
                                               [&](const std::string& stage, double seconds) {
                                                 if (progress.on_stage)
                                                   progress.on_stage("interfaces: " + stage, -1, seconds);
                                               });
      for (int s = 0; s < kDictionaryShapeCount; ++s)
        for (int f = 0; f < kFaceCount; ++f)
          if (ib.Rb_rlf[std::size_t(s)][std::size_t(f)].size() > 0)
            dict.shapes[std::size_t(s)].Rb_rlf[std::size_t(f)] =
                to_float(ib.Rb_rlf[std::size_t(s)][std::size_t(f)]);
      dict.interfaces.R_straight = to_float(ib.R[0]);
      dict.interfaces.R_left = to_float(ib.R[1]);
      dict.interfaces.R_right = to_float(ib.R[2]);
      dict.interfaces.Trlf_r = to_float(ib.Trlf_r);
      dict.interfaces.Ur = to_float(ib.Ur);
      dict.interfaces.Urvol = to_float(ib.Urvol);
      dict.interfaces.Ur_vec = to_float(ib.Ur_vec);
      if (lightfield_basis) *lightfield_basis = to_float(ib.Hrlf);
    }
    if (Status v = validate_dictionary(dict, "baked dictionary"); !v.ok()) return v;
    return dict;
  } catch (const std::bad_alloc&) {
    return Status::error(ErrorCode::resource_limit, "bake: out of memory");
  } catch (const std::exception& e) {
    return Status::error(ErrorCode::internal_error, std::string("bake: ") + e.what());
  }
}

}  // namespace modrt::precompute
