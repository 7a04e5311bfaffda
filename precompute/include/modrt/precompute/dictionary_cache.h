// modrt precompute — bake the dictionary on first use and cache it on disk.
#pragma once

#include <string>

#include "modrt/dictionary.h"
#include "modrt/precompute/bake.h"

namespace modrt::precompute {

// Default cache directory: $MODRT_CACHE_DIR, else $XDG_CACHE_HOME/modrt, else ~/.cache/modrt.
std::string default_cache_dir();

// File name that identifies the settings, e.g. "dict-res16-kd64-kb32-r16384-<hash>.modrt".
std::string cache_file_name(const DictionarySettings& settings);

// Loads <cache_dir>/<cache_file_name> when it exists and holds exactly `settings`;
// otherwise bakes, saves atomically and returns the new dictionary. A cache file that fails
// to load (corrupt, other format version) is reported through `log` and re-baked.
Result<Dictionary> load_or_bake_dictionary(const DictionarySettings& settings, const std::string& cache_dir,
                                           const BakeProgress& progress = {},
                                           const std::function<void(const std::string&)>& log = {});

}  // namespace modrt::precompute
