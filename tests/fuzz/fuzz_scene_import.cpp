// SPDX-License-Identifier: MIT
// libFuzzer harness: a glTF file without modrt markup, imported on the fly (the demo's loader
// through scene_import_glue into precompute::import_scene, docs/import.md) from arbitrary
// bytes. Anything accepted must give a level whose blocks have finite corners and per-face
// albedo in [0, 1], a finite proxy depth, and meshes whose arrays agree; everything else must
// be an error, never a crash or a hang. The plan raster and triangle count are capped to keep
// each input cheap.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "gltf_fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace modrt::demo;
  const std::string& path = fuzz::write_input("modrt-fuzz-import", data, size);
  GltfSceneOptions options;
  options.max_vertices = 100'000;
  options.max_image_side = 256;
  options.import_settings.max_triangles = 20'000;
  options.import_settings.max_plan_side = 512;
  modrt::Result<DemoScene> scene = load_gltf_scene(path, options);
  if (!scene.ok()) return 0;
  if (!std::isfinite(scene->proxy_depth) || scene->proxy_depth < 0.0f) std::abort();
  for (const modrt::BlockDescription& b : scene->level.blocks) {
    for (const glm::dvec3& c : b.corners)
      if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z)) std::abort();
    for (const glm::dvec3& a : b.albedo)
      for (int k = 0; k < 3; ++k)
        if (!(a[k] >= 0.0 && a[k] <= 1.0)) std::abort();
  }
  fuzz::check_meshes(scene.value());
  return 0;
}
