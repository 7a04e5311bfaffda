// SPDX-License-Identifier: MIT
#include "modrt/precompute/drt_cache.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <type_traits>
#include <vector>

#include "drt_gather.h"
#include "modrt/clutter_mesh.h"
#include "modrt/drt_io.h"
#include "modrt/level_io.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/drt_state_io.h"

namespace modrt::precompute {
namespace {

// FNV-1a 64, fed field by field (never a struct's bytes: padding is not a value).
class Fnv {
 public:
  void bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h_ = (h_ ^ p[i]) * 0x100000001b3ull;
  }
  template <class T>
  void value(const T& v) {
    static_assert(std::is_arithmetic_v<T>);
    bytes(&v, sizeof v);
  }
  void text(const std::string& s) {
    value(std::uint64_t(s.size()));
    bytes(s.data(), s.size());
  }
  void vec(const glm::dvec3& v) {
    for (int c = 0; c < 3; ++c) value(v[c]);
  }
  std::uint64_t digest() const { return h_; }

 private:
  std::uint64_t h_ = 0xcbf29ce484222325ull;
};

void hash_object(Fnv& f, const ClutterObject& o) {
  f.value(int(o.kind));
  f.value(o.block);
  f.vec(o.box.center);
  f.vec(o.box.half_extent);
  for (int c = 0; c < 3; ++c) f.vec(o.box.rotation[c]);
  f.value(std::uint32_t(o.faces));
  f.vec(o.albedo);
  f.value(o.res);
  f.value(std::uint8_t(o.mesh != nullptr));
  if (o.mesh) {
    // The atlas is made from these and the res (make_mesh_clutter).
    const ClutterMesh& m = o.mesh->mesh;
    f.value(std::uint64_t(m.positions.size()));
    for (const glm::dvec3& p : m.positions) f.vec(p);
    f.value(std::uint64_t(m.uvs.size()));
    for (const glm::dvec2& uv : m.uvs) f.value(uv.x), f.value(uv.y);
    f.value(std::uint64_t(m.indices.size()));
    for (std::uint32_t i : m.indices) f.value(i);
    f.value(o.mesh->atlas.res);
  }
}

void hash_settings(Fnv& f, const DrtBuildSettings& s) {
  f.value(s.rays);
  f.value(s.cb_modes);
  f.value(std::uint8_t(s.inpaint));
  f.value(std::uint8_t(s.cull));
  f.value(s.drop_tolerance);
  f.value(std::uint8_t(s.vector));
  f.value(std::uint8_t(s.probes));
  f.value(s.clutter_prior_modes);
  f.value(s.clutter_prior_grid);
  f.value(s.seed);
  f.value(std::uint8_t(s.gather));
  f.value(s.max_clutter_rays);
  // sample_gather is left out: it keeps extra data in the DrtBuildState, the operators are
  // the same.
}

// Why `drt` does not serve `clutter` in `level`, or empty.
std::string misfit(const Level& level, std::span<const ClutterObject> clutter, const DrtOperators& drt) {
  if (Status s = check_drt_operators(level, drt); !s.ok()) return s.message();
  if (drt.objects.size() != clutter.size())
    return std::to_string(drt.objects.size()) + " objects, the scene has " + std::to_string(clutter.size());
  const DrtBufferSizes sizes = drt_buffer_sizes(drt);
  std::size_t texels = 0;
  for (const ClutterObject& o : clutter) texels += std::size_t(clutter_texel_count(o));
  if (sizes.clutter_texels != texels)
    return std::to_string(sizes.clutter_texels) + " clutter texels, the objects have " +
           std::to_string(texels);
  return {};
}

// The inputs every key shares: the level's serialized bytes and the dictionary's settings.
void hash_scene(Fnv& f, const char* tag, std::span<const std::byte> level_bytes,
                const DictionarySettings& dict, std::size_t objects) {
  f.text(tag);
  f.value(std::uint64_t(level_bytes.size()));
  f.bytes(level_bytes.data(), level_bytes.size());
  f.text(cache_file_name(dict));
  f.value(std::uint64_t(objects));
}

std::uint64_t cache_key(std::span<const std::byte> level_bytes, const DictionarySettings& dict,
                        std::span<const ClutterObject> clutter, const DrtBuildSettings& settings) {
  Fnv f;
  hash_scene(f, "modrt-drt-cache-1", level_bytes, dict, clutter.size());
  for (const ClutterObject& o : clutter) hash_object(f, o);
  hash_settings(f, settings);
  return f.digest();
}

std::uint64_t scene_key(std::span<const std::byte> level_bytes, const DictionarySettings& dict,
                        std::size_t objects, const DrtBuildSettings& settings) {
  Fnv f;
  hash_scene(f, "modrt-drt-state-1", level_bytes, dict, objects);
  hash_settings(f, settings);
  f.value(std::uint8_t(settings.sample_gather));  // the state keeps more with it
  return f.digest();
}

std::string hex(std::uint64_t v) {
  char s[24];
  std::snprintf(s, sizeof s, "%016llx", static_cast<unsigned long long>(v));
  return s;
}

std::string object_list(const std::vector<std::size_t>& objects) {
  std::string s;
  for (std::size_t k : objects) s += (s.empty() ? "" : ", ") + std::to_string(k);
  return s;
}

// More than this share of the objects changed: a full build (each rebuild re-traces what sees
// its object, up to most of a build for objects seen from everywhere).
bool too_many_changed(std::size_t changed, std::size_t objects) { return 2 * changed > objects; }

// The operators of `clutter` from the scene's build state at state_path and the cached
// operators of the state's objects, rebuilt for each object that differs (rebuild_object, one
// at a time, each on the list with the earlier ones replaced): "" with drt, state and
// retraced filled, or why not (nothing filled).
std::string rebuild_from_state(const DrtBuilder& builder, const Level& level,
                               std::span<const std::byte> level_bytes, const DictionarySettings& dict,
                               std::span<const ClutterObject> clutter, const DrtBuildSettings& settings,
                               const std::string& cache_dir, const std::string& state_path,
                               std::uint64_t scene, DrtOperators& drt, DrtBuildState& state,
                               std::vector<std::size_t>& retraced) {
  Result<LoadedDrtBuildState> loaded = load_drt_build_state(state_path);
  if (!loaded.ok()) return loaded.status().to_string();
  if (loaded->scene_key != scene)
    return state_path + ": made for another scene (key " + hex(loaded->scene_key) + ", not " + hex(scene) +
           ")";
  const std::span<const ClutterObject> old = loaded->state.objects();
  if (old.size() != clutter.size())
    return state_path + ": " + std::to_string(old.size()) + " objects, the scene has " +
           std::to_string(clutter.size());
  std::vector<std::size_t> changed;
  for (std::size_t k = 0; k < clutter.size(); ++k)
    if (!drt_detail::same_object(old[k], clutter[k])) changed.push_back(k);
  if (changed.empty()) return state_path + ": its objects are the scene's, whose operators were not loaded";
  if (too_many_changed(changed.size(), clutter.size()))
    return std::to_string(changed.size()) + " of " + std::to_string(clutter.size()) +
           " objects changed since the state's build (a full build is cheaper)";
  const std::string old_path =
      (std::filesystem::path(cache_dir) / drt_cache_file_name(cache_key(level_bytes, dict, old, settings)))
          .string();
  Result<DrtOperators> ops = load_drt(old_path);
  if (!ops.ok()) return "the operators of the state's objects: " + ops.status().to_string();
  if (std::string why = misfit(level, old, ops.value()); !why.empty()) return old_path + ": " + why;
  std::vector<ClutterObject> working(old.begin(), old.end());
  for (std::size_t k : changed) {
    working[k] = clutter[k];
    if (Status s = builder.rebuild_object(working, k, ops.value(), loaded->state); !s.ok())
      return state_path + ": " + s.to_string();
  }
  if (std::string why = misfit(level, clutter, ops.value()); !why.empty())
    return "the rebuilt operators do not fit: " + why;
  drt = std::move(ops).value();
  state = std::move(loaded->state);
  retraced = std::move(changed);
  return {};
}

}  // namespace

Result<std::uint64_t> drt_cache_key(const Level& level, const DictionarySettings& dict,
                                    std::span<const ClutterObject> clutter,
                                    const DrtBuildSettings& settings) {
  Result<std::vector<std::byte>> bytes = serialize_level(level);
  if (!bytes.ok()) return bytes.status();
  return cache_key(bytes.value(), dict, clutter, settings);
}

std::string drt_cache_file_name(std::uint64_t key) { return "drt-" + hex(key) + ".modrtdrt"; }

Result<std::uint64_t> drt_scene_key(const Level& level, const DictionarySettings& dict, std::size_t objects,
                                    const DrtBuildSettings& settings) {
  Result<std::vector<std::byte>> bytes = serialize_level(level);
  if (!bytes.ok()) return bytes.status();
  return scene_key(bytes.value(), dict, objects, settings);
}

std::string drt_state_file_name(std::uint64_t key) { return "drt-state-" + hex(key) + ".modrtdrtstate"; }

const char* drt_cache_source_name(DrtCacheSource source) {
  switch (source) {
    case DrtCacheSource::loaded: return "loaded";
    case DrtCacheSource::incremental: return "rebuilt incrementally";
    case DrtCacheSource::built: break;
  }
  return "built";
}

Result<DrtCacheResult> load_or_build_drt(const Level& level, const Dictionary& dict,
                                         std::span<const ClutterObject> clutter,
                                         const DrtBuildSettings& settings, const std::string& cache_dir,
                                         const std::function<void(const std::string&)>& log) {
  auto say = [&](const std::string& line) {
    if (log) log(line);
  };
  DrtCacheResult out;
  std::vector<std::byte> level_bytes;
  std::uint64_t scene = 0;
  std::error_code ec;
  if (!cache_dir.empty()) {
    Result<std::vector<std::byte>> bytes = serialize_level(level);
    if (!bytes.ok()) return bytes.status();
    level_bytes = std::move(bytes).value();
    scene = scene_key(level_bytes, dict.settings, clutter.size(), settings);
    out.path = (std::filesystem::path(cache_dir) /
                drt_cache_file_name(cache_key(level_bytes, dict.settings, clutter, settings)))
                   .string();
    out.state_path = (std::filesystem::path(cache_dir) / drt_state_file_name(scene)).string();
    if (std::filesystem::exists(out.path, ec)) {
      Result<DrtOperators> cached = load_drt(out.path);
      if (!cached.ok()) {
        out.rebuilt = cached.status().to_string();
      } else if (std::string why = misfit(level, clutter, cached.value()); !why.empty()) {
        out.rebuilt = out.path + ": " + why;
      } else {
        out.operators = std::move(cached).value();
        out.source = DrtCacheSource::loaded;
        say("loaded DRT operators " + out.path);
        return out;
      }
      say("rebuilding DRT operators: " + out.rebuilt);
    }
  }
  const DrtBuilder builder(level, dict, settings);
  DrtBuildState state;
  if (!cache_dir.empty() && std::filesystem::exists(out.state_path, ec)) {
    out.state_unused =
        rebuild_from_state(builder, level, level_bytes, dict.settings, clutter, settings, cache_dir,
                           out.state_path, scene, out.operators, state, out.retraced);
    if (out.state_unused.empty()) {
      out.source = DrtCacheSource::incremental;
      say("rebuilt DRT operators incrementally from " + out.state_path + ": re-traced object" +
          (out.retraced.size() == 1 ? " " : "s ") + object_list(out.retraced) + " of " +
          std::to_string(clutter.size()));
    } else {
      say("DRT build state not used: " + out.state_unused);
    }
  }
  if (out.source == DrtCacheSource::built) {
    Result<DrtOperators> built = builder.build(clutter, nullptr, cache_dir.empty() ? nullptr : &state);
    if (!built.ok()) return built.status();
    out.operators = std::move(built).value();
    say("built DRT operators of " + std::to_string(clutter.size()) + " objects");
  }
  if (!out.path.empty()) {
    if (Status s = check_cache_dir(cache_dir); !s.ok()) return s;
    if (Status s = save_drt(out.path, out.operators); !s.ok()) return s;
    say("saved DRT operators " + out.path);
    // Without the state the next change is a full build again; the operators are good.
    if (Status s = save_drt_build_state(out.state_path, state, scene); !s.ok()) {
      say("DRT build state not saved: " + s.to_string());
    } else {
      say("saved DRT build state " + out.state_path);
    }
  }
  return out;
}

}  // namespace modrt::precompute
