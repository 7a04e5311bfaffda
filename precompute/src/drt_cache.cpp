// SPDX-License-Identifier: MIT
#include "modrt/precompute/drt_cache.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <type_traits>
#include <vector>

#include "modrt/clutter_mesh.h"
#include "modrt/drt_io.h"
#include "modrt/level_io.h"
#include "modrt/precompute/dictionary_cache.h"

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

}  // namespace

Result<std::uint64_t> drt_cache_key(const Level& level, const DictionarySettings& dict,
                                    std::span<const ClutterObject> clutter,
                                    const DrtBuildSettings& settings) {
  Result<std::vector<std::byte>> bytes = serialize_level(level);
  if (!bytes.ok()) return bytes.status();
  Fnv f;
  f.text("modrt-drt-cache-1");
  f.value(std::uint64_t(bytes->size()));
  f.bytes(bytes->data(), bytes->size());
  f.text(cache_file_name(dict));
  f.value(std::uint64_t(clutter.size()));
  for (const ClutterObject& o : clutter) hash_object(f, o);
  hash_settings(f, settings);
  return f.digest();
}

std::string drt_cache_file_name(std::uint64_t key) {
  char name[40];
  std::snprintf(name, sizeof name, "drt-%016llx.modrtdrt", static_cast<unsigned long long>(key));
  return name;
}

Result<DrtCacheResult> load_or_build_drt(const Level& level, const Dictionary& dict,
                                         std::span<const ClutterObject> clutter,
                                         const DrtBuildSettings& settings, const std::string& cache_dir,
                                         const std::function<void(const std::string&)>& log) {
  DrtCacheResult out;
  if (!cache_dir.empty()) {
    Result<std::uint64_t> key = drt_cache_key(level, dict.settings, clutter, settings);
    if (!key.ok()) return key.status();
    out.path = (std::filesystem::path(cache_dir) / drt_cache_file_name(key.value())).string();
    std::error_code ec;
    if (std::filesystem::exists(out.path, ec)) {
      Result<DrtOperators> cached = load_drt(out.path);
      if (!cached.ok()) {
        out.rebuilt = cached.status().to_string();
      } else if (std::string why = misfit(level, clutter, cached.value()); !why.empty()) {
        out.rebuilt = out.path + ": " + why;
      } else {
        out.operators = std::move(cached).value();
        out.loaded = true;
        if (log) log("loaded DRT operators " + out.path);
        return out;
      }
      if (log) log("rebuilding DRT operators: " + out.rebuilt);
    }
  }
  Result<DrtOperators> built = DrtBuilder(level, dict, settings).build(clutter);
  if (!built.ok()) return built.status();
  out.operators = std::move(built).value();
  if (!out.path.empty()) {
    if (Status s = check_cache_dir(cache_dir); !s.ok()) return s;
    if (Status s = save_drt(out.path, out.operators); !s.ok()) return s;
    if (log) log("saved DRT operators " + out.path);
  }
  return out;
}

}  // namespace modrt::precompute
