// SPDX-License-Identifier: MIT
#include "modrt/precompute/dictionary_cache.h"

#include <bit>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <span>

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
  const std::uint32_t fields[] = {s.res,
                                  s.kd,
                                  s.kb,
                                  s.rays,
                                  s.enrichment_iterations,
                                  s.prior_grid,
                                  s.light_samples,
                                  s.sh_rays,
                                  s.probe_grid,
                                  std::uint32_t(s.seed),
                                  std::uint32_t(s.seed >> 32),
                                  std::bit_cast<std::uint32_t>(s.light_radius),
                                  s.lightfield_spatial,
                                  s.lightfield_directional,
                                  s.lightfield_supersample,
                                  s.krlf,
                                  s.kr,
                                  s.interface_enrichment_iterations,
                                  s.response_rays,
                                  kDictionaryFormatVersion};
  const std::uint32_t hash = crc32(std::as_bytes(std::span(fields)));
  char name[128];
  std::snprintf(name, sizeof name, "dict-res%u-kd%u-kb%u-r%u-%08x.modrt", s.res, s.kd, s.kb, s.rays, hash);
  return name;
}

namespace {

// The cached dictionary at `path` when it loads and holds exactly `settings`; otherwise a
// Status saying why not (not_found-like io_error when absent).
Result<Dictionary> load_cached(const std::string& path, const DictionarySettings& settings,
                               const std::function<void(const std::string&)>& log) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    return Status::error(ErrorCode::io_error, path + ": not in the cache");
  Result<Dictionary> loaded = load_dictionary(path);
  if (loaded.ok() && loaded->settings == settings) return loaded;
  const std::string why = loaded.ok() ? std::string("other settings") : loaded.status().to_string();
  if (log) log("cached dictionary " + path + " is unusable (" + why + "); re-baking");
  return Status::error(ErrorCode::io_error, path + ": " + why);
}

}  // namespace

Status check_cache_dir(const std::string& cache_dir) {
  if (Status s = check_writable_directory(cache_dir); !s.ok())
    return Status::error(s.code(), "dictionary cache: " + s.message());
  return Status::success();
}

Result<Dictionary> load_or_bake_dictionary(const DictionarySettings& settings, const std::string& cache_dir,
                                           const BakeProgress& progress,
                                           const std::function<void(const std::string&)>& log) {
  if (Status s = validate_settings(settings); !s.ok()) return s;
  const std::string path = (std::filesystem::path(cache_dir) / cache_file_name(settings)).string();
  // A read-only cache that holds the entry is fine.
  if (Result<Dictionary> cached = load_cached(path, settings, {}); cached.ok()) {
    if (log) log("loaded cached dictionary " + path);
    return cached;
  }
  // From here on the entry is written: refuse an unwritable cache now, not after the bake.
  if (Status s = check_cache_dir(cache_dir); !s.ok()) return s;
  // One bake per entry: a concurrent first run waits here, then loads the first one's file.
  Result<FileLock> lock = FileLock::acquire(path + ".lock");
  if (!lock.ok()) return Status::error(lock.status().code(), "dictionary cache: " + lock.status().message());
  if (Result<Dictionary> cached = load_cached(path, settings, log); cached.ok()) {
    if (log) log("loaded cached dictionary " + path);
    return cached;
  }
  remove_stale_temporaries(cache_dir);  // a bake killed during its save
  if (log) log("baking dictionary into " + path);
  Result<Dictionary> baked = bake_dictionary(settings, progress);
  if (!baked.ok()) return baked;
  if (Status s = save_dictionary(path, baked.value()); !s.ok()) return s;
  return baked;
}

}  // namespace modrt::precompute
