// SPDX-License-Identifier: MIT
// DRT operators built once (issue 23, item 6): a level's clutter operators (DrtBuilder) kept
// in a cache directory as .modrtdrt files (core's drt_io.h), named by a hash of everything the
// build reads: the built level (its serialized bytes), the dictionary's settings, every clutter
// object (box, faces, albedo, texel res, and a mesh's positions, lightmap UVs and indices) and
// the build settings. A second start with the same scene loads them instead of ray tracing; a
// moved or changed object, another level or other settings give another name, so a stale file
// is never applied. A file that fails to load or does not fit the level and objects
// (check_drt_operators, texel counts) is rebuilt and replaced, atomically.
//
// Next to the operators, the build state (drt_state_io.h, .modrtdrtstate) of the last build of
// the scene, named by a second hash of everything but the objects' placements (the level, the
// dictionary's settings, the build settings and the object count): when some objects moved or
// changed since, a start re-traces only what they change (DrtBuilder::rebuild_object, one
// object at a time, from the operators of the state's objects) instead of building every
// object's operators again; the result equals a full build.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

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

// FNV-1a 64 over the inputs of drt_cache_key except the objects themselves: their count stays
// in, their boxes, faces, albedo, res and meshes do not. The one build state kept per scene is
// named by it. DrtBuildSettings::sample_gather (kept data, not operators) is in it.
Result<std::uint64_t> drt_scene_key(const Level& level, const DictionarySettings& dict, std::size_t objects,
                                    const DrtBuildSettings& settings);

// "drt-state-<16 hex digits>.modrtdrtstate".
std::string drt_state_file_name(std::uint64_t scene_key);

// How load_or_build_drt obtained the operators.
enum class DrtCacheSource {
  built,        // a full build (no fitting file, or too many objects changed for a rebuild)
  loaded,       // read from the cache
  incremental,  // the cached operators of the scene's last build, re-traced where objects changed
};
const char* drt_cache_source_name(DrtCacheSource source);  // "built", "loaded", "rebuilt incrementally"

struct DrtCacheResult {
  DrtOperators operators;
  DrtCacheSource source = DrtCacheSource::built;
  std::string path;        // the cache file (empty without a cache directory)
  std::string state_path;  // the build state file of the scene (empty without a cache directory)
  // incremental: the objects that changed and were rebuilt (rebuild_object), in that order.
  std::vector<std::size_t> retraced;
  std::string rebuilt;  // why an operator file that was there was not used (it is replaced), or empty
  // Why the build state file was not used for an incremental rebuild (built), or empty: it was
  // used, or there was none.
  std::string state_unused;
};

// The operators of `clutter` in `level`: loaded from cache_dir when a fitting file is there;
// else, when the scene's build state is there and loads, fits and at most half of the objects
// differ from its objects (same count), the state's operators rebuilt for each changed object
// in turn; else built with DrtBuilder(level, dict, settings). Operators that were not loaded
// are saved there with the build state of the result (cache_dir empty: built, nothing saved).
// `log` (may be empty) gets one line per load, build, rebuild, save or file not used.
Result<DrtCacheResult> load_or_build_drt(const Level& level, const Dictionary& dict,
                                         std::span<const ClutterObject> clutter,
                                         const DrtBuildSettings& settings, const std::string& cache_dir,
                                         const std::function<void(const std::string&)>& log = {});

}  // namespace modrt::precompute
