// SPDX-License-Identifier: MIT
// libFuzzer harness: the demo's glTF scene import (demo/scene/gltf_scene.h) on arbitrary
// bytes, as a .gltf or .glb file (tinygltf tells them apart by the magic), with the proxy
// blocks from a fixed level file (MODRT_FUZZ_LEVEL, the sample scene's sidecar) so that
// inputs get past the "no proxy blocks" check. Anything the loader accepts must have meshes
// whose arrays agree; everything else must be an error, never a crash or a hang.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "scene/gltf_scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace modrt::demo;
  // The loader reads files (buffers and images resolve relative to them); one per process.
  static const std::string path = "/tmp/modrt-fuzz-gltf-" + std::to_string(::getpid()) + ".gltf";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  GltfSceneOptions options;
  options.level_path = MODRT_FUZZ_LEVEL;
  options.max_vertices = 1'000'000;  // keep each input cheap
  options.max_image_side = 1024;
  modrt::Result<DemoScene> scene = load_gltf_scene(path, options);
  if (!scene.ok()) return 0;
  for (const Mesh& m : scene->meshes) {
    if (m.normal.size() != m.position.size() || (!m.uv.empty() && m.uv.size() != m.position.size()))
      std::abort();
    for (std::uint32_t i : m.indices)
      if (i >= m.position.size()) std::abort();
    if (m.material < 0 || std::size_t(m.material) >= scene->materials.size()) std::abort();
  }
  return 0;
}
