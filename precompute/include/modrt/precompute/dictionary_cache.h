// SPDX-License-Identifier: MIT
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

// Whether dictionaries can be written into `cache_dir` (created when missing); io_error
// naming the directory otherwise. Tools call it before any long work.
Status check_cache_dir(const std::string& cache_dir);

// Loads <cache_dir>/<cache_file_name> when it exists and holds exactly `settings` (a
// read-only cache is fine then); otherwise checks that the cache is writable (io_error
// naming it, before baking), takes an exclusive flock on "<entry>.lock" (a concurrent first
// run waits, then loads the entry the first one saved instead of baking again), removes
// temporaries that killed savers left in the cache (remove_stale_temporaries), bakes, and
// saves atomically. A cache file that fails to load (corrupt, other format version) is
// reported through `log` and re-baked.
Result<Dictionary> load_or_bake_dictionary(const DictionarySettings& settings, const std::string& cache_dir,
                                           const BakeProgress& progress = {},
                                           const std::function<void(const std::string&)>& log = {});

// The companion of a cached dictionary that holds its interface basis Hrlf (S^2 D^2 x krlf
// float32, bake_dictionary's lightfield_basis) in a matrix file (matrix_file.h): the
// dictionary's name with ".lfbasis" for ".modrt". Only the level build reads it (shaped
// blocks' interfaces); apps never ship it.
std::string interface_basis_file_name(const DictionarySettings& settings);

// Hrlf of the dictionary `settings` describe. load_or_bake_dictionary saves it beside each
// dictionary it bakes; for a dictionary cached without it (older caches) this bakes the
// dictionary again under the entry's lock (the bake is deterministic: the same operators)
// and saves the basis, and the dictionary too where its interface operators differ from the
// re-bake's. invalid_argument when the settings have no interfaces.
Result<Matrix> load_or_bake_interface_basis(const DictionarySettings& settings, const std::string& cache_dir,
                                            const BakeProgress& progress = {},
                                            const std::function<void(const std::string&)>& log = {});

}  // namespace modrt::precompute
