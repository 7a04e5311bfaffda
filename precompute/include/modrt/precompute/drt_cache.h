// SPDX-License-Identifier: MIT
// DRT operators built once (issue 23, item 6): a level's clutter operators (DrtBuilder) kept
// in a cache directory as .modrtdrt files (core's drt_io.h), named by a hash of everything the
// build reads: the built level (its serialized bytes), the dictionary's settings, every clutter
// object (box, faces, albedo, texel res, and a mesh's positions, lightmap UVs and indices) and
// the build settings. A second start with the same scene loads them instead of ray tracing; a
// moved or changed object, another level or other settings give another name, so a stale file
// is never applied. A file that fails to load or does not fit the level and objects
// (check_drt_operators, texel counts) is rebuilt and replaced, atomically.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>

#include "modrt/dictionary.h"
#include "modrt/drt.h"
#include "modrt/level.h"
#include "modrt/precompute/drt_build.h"
#include "modrt/status.h"

namespace modrt::precompute {

// FNV-1a 64 over the inputs listed above (the level's serialized bytes, so any block, sample
// or operator change shows). Fails only when the level cannot be serialized.
Result<std::uint64_t> drt_cache_key(const Level& level, const DictionarySettings& dict,
                                    std::span<const ClutterObject> clutter, const DrtBuildSettings& settings);

// "drt-<16 hex digits>.modrtdrt".
std::string drt_cache_file_name(std::uint64_t key);

struct DrtCacheResult {
  DrtOperators operators;
  std::string path;     // the cache file (empty without a cache directory)
  bool loaded = false;  // read from the cache, not built
  std::string rebuilt;  // why a file that was there was not used (it is replaced), or empty
};

// The operators of `clutter` in `level`: loaded from cache_dir when a fitting file is there,
// else built with DrtBuilder(level, dict, settings) and saved there (cache_dir empty: built,
// not saved). `log` (may be empty) gets one line per load, build or replacement.
Result<DrtCacheResult> load_or_build_drt(const Level& level, const Dictionary& dict,
                                         std::span<const ClutterObject> clutter,
                                         const DrtBuildSettings& settings, const std::string& cache_dir,
                                         const std::function<void(const std::string&)>& log = {});

}  // namespace modrt::precompute
