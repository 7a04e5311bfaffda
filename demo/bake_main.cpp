// SPDX-License-Identifier: MIT
// modrt-bake: bakes the 2D cube dictionary (six shapes) into one dictionary file.
#include <chrono>
#include <cstdio>
#include <string>
#include <utility>

#include <CLI/CLI.hpp>
#include "modrt/precompute/svd.h"

#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"
#include "modrt/precompute/bake.h"
#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/direct_light.h"
#include "modrt/precompute/reduction.h"

namespace {

using namespace modrt;

// MRT Table 2: modes needed for 80/90/95% of the energy of F, Ld and M (closed cube).
void print_energy_table(const DictionarySettings& settings) {
  std::printf(
      "\nsingular-value energy (closed cube, n = 6 x %u^2 samples; MRT Table 2: 164/22/1, 240/41/5, "
      "313/62/8)\n",
      settings.res);
  precompute::ShapeBake bake = precompute::bake_shape(dictionary_shape_mask(0), settings, false);
  const Eigen::BDCSVD<precompute::MatrixXd> svd_F(precompute::MatrixXd(bake.F));
  const Eigen::BDCSVD<precompute::MatrixXd> svd_Ld(bake.Ld);
  // The prior normalises each light's pattern (docs/precompute.md); the paper's Ld keeps
  // raw intensities, so print both.
  const precompute::BlockScene scene(dictionary_shape_mask(0));
  const Eigen::BDCSVD<precompute::MatrixXd> svd_raw(
      precompute::light_prior_matrix(scene, bake.layout, int(settings.prior_grid), settings.light_radius,
                                     int(settings.light_samples), false));
  const precompute::VectorXd& sF = svd_F.singularValues();
  const precompute::VectorXd& sL = svd_Ld.singularValues();
  const precompute::VectorXd& sR = svd_raw.singularValues();
  const precompute::VectorXd& sM = bake.raw_transfer.sigma_M;
  std::printf("  energy   F / Ld / M   (Ld with raw intensities)\n");
  for (double e : {0.80, 0.90, 0.95})
    std::printf("  %3.0f%%     %d / %d / %d   (%d)\n", e * 100, precompute::modes_for_energy(sF, e),
                precompute::modes_for_energy(sL, e), precompute::modes_for_energy(sM, e),
                precompute::modes_for_energy(sR, e));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modrt-bake: bake the modrt 2D cube dictionary (MRT §4, §6.4, §6.5, §7.1)"};
  DictionarySettings s;
  std::string out = "dictionary.modrt";
  std::string preset = "default";
  bool float16 = false;
  bool energy_table = false;
  bool energy_table_only = false;
  app.add_option("-o,--out", out, "output dictionary file (written atomically)");
  app.add_option("--preset", preset,
                 "settings preset: default (res 16, kb 32) or mobile (res 6, kb 12); "
                 "explicit flags override it")
      ->check(CLI::IsMember({"default", "mobile"}));
  auto* res = app.add_option("--res", s.res, "texels per face edge");
  auto* kb = app.add_option("--kb", s.kb, "indirect modes kept (columns of Ub)");
  app.add_option("--kd", s.kd, "prior modes kept (columns of P)");
  app.add_option("--rays", s.rays, "gather rays per sample for F");
  app.add_option("--enrich", s.enrichment_iterations, "basis enrichment iterations (MRT appendix A)");
  app.add_option("--prior-grid", s.prior_grid, "sphere lights per axis in the prior (grid^3 per cell)");
  app.add_option("--light-samples", s.light_samples, "shadow-ray points per prior sphere light");
  app.add_option("--light-radius", s.light_radius, "radius of the prior's sphere lights (block units)");
  app.add_option("--probe-grid", s.probe_grid, "volume probes per block axis (g^3)");
  app.add_option("--sh-rays", s.sh_rays, "rays per sample/probe for SH projections");
  app.add_option("--seed", s.seed, "sampling seed");
  app.add_option("--lightfield-spatial", s.lightfield_spatial,
                 "interface lightfield positions per edge (0: no interface operators, single blocks only)");
  app.add_option("--lightfield-directional", s.lightfield_directional, "interface direction bins per edge");
  app.add_option("--krlf", s.krlf, "reduced interface lightfield modes");
  app.add_option("--kr", s.kr, "interface response modes");
  app.add_option("--response-rays", s.response_rays, "gather rays per sample for the interface response");
  app.add_flag("--float16", float16, "store operators as float16");
  app.add_flag("--energy-table", energy_table, "also print the singular-value energy table (MRT Table 2)");
  app.add_flag("--energy-table-only", energy_table_only, "print the energy table and exit without baking");
  CLI11_PARSE(app, argc, argv);
  if (preset == "mobile") {
    if (res->count() == 0) s.res = 6;
    if (kb->count() == 0) s.kb = 12;
  }

  if (Status v = validate_settings(s); !v.ok()) {
    // The library's message names the setting ("settings.prior_grid = ..."); name the flag too.
    static const std::pair<const char*, const char*> kFlags[] = {
        {"res", "--res"},
        {"kd", "--kd"},
        {"kb", "--kb"},
        {"rays", "--rays"},
        {"enrichment_iterations", "--enrich"},
        {"prior_grid", "--prior-grid"},
        {"light_samples", "--light-samples"},
        {"light_radius", "--light-radius"},
        {"sh_rays", "--sh-rays"},
        {"probe_grid", "--probe-grid"},
        {"lightfield_spatial", "--lightfield-spatial"},
        {"lightfield_directional", "--lightfield-directional"},
        {"krlf", "--krlf"},
        {"kr", "--kr"},
        {"response_rays", "--response-rays"}};
    std::string flag;
    for (const auto& [field, name] : kFlags)
      if (v.message().rfind(std::string("settings.") + field + " = ", 0) == 0)
        flag = std::string(name) + ": ";
    std::fprintf(stderr, "modrt-bake: %s%s\n", flag.c_str(), v.to_string().c_str());
    return 2;
  }
  // Found now, not after the bake: an output that cannot be written.
  if (!energy_table_only) {
    if (Status w = check_writable_file(out); !w.ok()) {
      std::fprintf(stderr, "modrt-bake: --out: %s\n", w.to_string().c_str());
      return 1;
    }
  }
  if (energy_table_only) {
    try {
      print_energy_table(s);
      return 0;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "modrt-bake: energy table: %s\n", e.what());
      return 1;
    }
  }
  std::printf("baking: res %u, kd %u, kb %u, %u rays, %u enrichment pass(es), probes %u^3, %u SH rays\n",
              s.res, s.kd, s.kb, s.rays, s.enrichment_iterations, s.probe_grid, s.sh_rays);
  const auto start = std::chrono::steady_clock::now();
  precompute::BakeProgress progress;
  progress.on_stage = [](const std::string& stage, int shape, double seconds) {
    if (shape >= 0)
      std::printf("  shape %d (%s): %-18s %7.2f s\n", shape, dictionary_shape_name(shape), stage.c_str(),
                  seconds);
    else
      std::printf("  %-36s %7.2f s\n", stage.c_str(), seconds);
    std::fflush(stdout);
  };
  Result<Dictionary> dict = precompute::bake_dictionary(s, progress);
  if (!dict.ok()) {
    std::fprintf(stderr, "modrt-bake: %s\n", dict.status().to_string().c_str());
    return 1;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  DictionaryWriteOptions options;
  options.float16 = float16;
  if (Status w = save_dictionary(out, dict.value(), options); !w.ok()) {
    std::fprintf(stderr, "modrt-bake: %s\n", w.to_string().c_str());
    return 1;
  }
  std::printf("baked 6 shapes in %.2f s -> %s\n", seconds, out.c_str());
  if (energy_table) {
    try {
      print_energy_table(s);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "modrt-bake: energy table: %s\n", e.what());
      return 1;
    }
  }
  return 0;
}
