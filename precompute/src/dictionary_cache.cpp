// SPDX-License-Identifier: MIT
#include "modrt/precompute/dictionary_cache.h"

#include <bit>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <span>

#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"
#include "modrt/precompute/matrix_file.h"

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

std::string interface_basis_tag(const DictionarySettings& settings) {
  return "modrt interface basis Hrlf of " + cache_file_name(settings);
}

Result<Matrix> load_basis(const std::string& path, const DictionarySettings& settings) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    return Status::error(ErrorCode::io_error, path + ": not in the cache");
  Result<std::vector<NamedMatrix>> loaded = load_matrix_file(path, interface_basis_tag(settings));
  if (!loaded.ok()) return loaded.status();
  const std::uint64_t rows = std::uint64_t(settings.lightfield_spatial) * settings.lightfield_spatial *
                             settings.lightfield_directional * settings.lightfield_directional;
  std::vector<NamedMatrix>& m = loaded.value();
  if (m.size() != 1 || m[0].name != "Hrlf" || m[0].matrix.rows != rows || m[0].matrix.cols != settings.krlf)
    return Status::error(ErrorCode::format_error, path + ": expected one matrix Hrlf of " +
                                                      std::to_string(rows) + " x " +
                                                      std::to_string(settings.krlf));
  return std::move(m[0].matrix);
}

Status save_basis(const std::string& path, const DictionarySettings& settings, const Matrix& Hrlf) {
  const MatrixRef ref{"Hrlf", &Hrlf};
  return save_matrix_file(path, interface_basis_tag(settings), std::span(&ref, 1));
}

}  // namespace

std::string interface_basis_file_name(const DictionarySettings& settings) {
  std::string name = cache_file_name(settings);
  name.resize(name.size() - std::string(".modrt").size());
  return name + ".lfbasis";
}

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
  Matrix Hrlf;
  Result<Dictionary> baked = bake_dictionary(settings, progress, kDefaultBakeMemoryBudget, &Hrlf);
  if (!baked.ok()) return baked;
  if (Status s = save_dictionary(path, baked.value()); !s.ok()) return s;
  if (!Hrlf.empty())
    if (Status s =
            save_basis((std::filesystem::path(cache_dir) / interface_basis_file_name(settings)).string(),
                       settings, Hrlf);
        !s.ok())
      return s;
  return baked;
}

Result<Matrix> load_or_bake_interface_basis(const DictionarySettings& settings, const std::string& cache_dir,
                                            const BakeProgress& progress,
                                            const std::function<void(const std::string&)>& log) {
  if (Status s = validate_settings(settings); !s.ok()) return s;
  if (settings.lightfield_spatial == 0)
    return Status::error(
        ErrorCode::invalid_argument,
        "interface basis: the dictionary settings have no interfaces (lightfield_spatial = 0)");
  const std::filesystem::path dir(cache_dir);
  const std::string path = (dir / interface_basis_file_name(settings)).string();
  const std::string dict_path = (dir / cache_file_name(settings)).string();
  if (Result<Matrix> cached = load_basis(path, settings); cached.ok()) return cached;
  if (Status s = check_cache_dir(cache_dir); !s.ok()) return s;
  Result<FileLock> lock = FileLock::acquire(dict_path + ".lock");
  if (!lock.ok()) return Status::error(lock.status().code(), "dictionary cache: " + lock.status().message());
  if (Result<Matrix> cached = load_basis(path, settings); cached.ok()) return cached;
  remove_stale_temporaries(cache_dir);
  if (log) log("baking the dictionary again for its interface basis " + path);
  Matrix Hrlf;
  Result<Dictionary> baked = bake_dictionary(settings, progress, kDefaultBakeMemoryBudget, &Hrlf);
  if (!baked.ok()) return baked.status();
  const Result<Dictionary> cached = load_cached(dict_path, settings, {});
  const bool same = cached.ok() && cached->interfaces.R_straight.data == baked->interfaces.R_straight.data &&
                    cached->interfaces.Trlf_r.data == baked->interfaces.Trlf_r.data;
  if (!same) {
    if (log && cached.ok())
      log("the re-bake's interface operators differ from " + dict_path + "; replacing it");
    if (Status s = save_dictionary(dict_path, baked.value()); !s.ok()) return s;
  }
  if (Status s = save_basis(path, settings, Hrlf); !s.ok()) return s;
  return Hrlf;
}

}  // namespace modrt::precompute
