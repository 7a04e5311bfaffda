#include "modrt/precompute/dictionary_cache.h"

#include <bit>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <filesystem>

#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"

namespace modrt::precompute {

std::string default_cache_dir() {
  if (const char* dir = std::getenv("MODRT_CACHE_DIR"); dir && *dir) return dir;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::string(xdg) + "/modrt";
  if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.cache/modrt";
  return ".modrt-cache";
}

std::string cache_file_name(const DictionarySettings& s) {
  // Hash every setting so that any change selects another file.
  const std::uint32_t fields[] = {s.res,          s.kd,         s.kb,         s.rays,
                                  s.enrichment_iterations, s.prior_grid, s.light_samples, s.sh_rays,
                                  s.probe_grid,   std::uint32_t(s.seed), std::uint32_t(s.seed >> 32),
                                  std::bit_cast<std::uint32_t>(s.light_radius), s.lightfield_spatial,
                                  s.lightfield_directional, s.lightfield_supersample, s.krlf, s.kr,
                                  s.interface_enrichment_iterations, s.response_rays, kDictionaryFormatVersion};
  const std::uint32_t hash = crc32(std::as_bytes(std::span(fields)));
  char name[128];
  std::snprintf(name, sizeof name, "dict-res%u-kd%u-kb%u-r%u-%08x.modrt", s.res, s.kd, s.kb, s.rays, hash);
  return name;
}

Result<Dictionary> load_or_bake_dictionary(const DictionarySettings& settings, const std::string& cache_dir,
                                           const BakeProgress& progress,
                                           const std::function<void(const std::string&)>& log) {
  const std::string path = (std::filesystem::path(cache_dir) / cache_file_name(settings)).string();
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) {
    Result<Dictionary> loaded = load_dictionary(path);
    if (loaded.ok() && loaded->settings == settings) {
      if (log) log("loaded cached dictionary " + path);
      return loaded;
    }
    if (log)
      log("cached dictionary " + path + " is unusable (" +
          (loaded.ok() ? std::string("other settings") : loaded.status().to_string()) + "); re-baking");
  }
  if (log) log("baking dictionary into " + path);
  Result<Dictionary> baked = bake_dictionary(settings, progress);
  if (!baked.ok()) return baked;
  if (Status s = save_dictionary(path, baked.value()); !s.ok()) return s;
  return baked;
}

}  // namespace modrt::precompute
