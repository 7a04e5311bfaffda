// SPDX-License-Identifier: MIT
// libFuzzer harness: the demo's glTF scene import (demo/scene/gltf_scene.h) on arbitrary
// bytes, as a .gltf or .glb file (tinygltf tells them apart by the magic), with the proxy
// blocks from a fixed level file (MODRT_FUZZ_LEVEL, the sample scene's sidecar) so that
// inputs get past the "no proxy blocks" check. Anything the loader accepts must have meshes
// whose arrays agree; everything else must be an error, never a crash or a hang.
#include <cstddef>
#include <cstdint>

#include "gltf_fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace modrt::demo;
  const std::string& path = fuzz::write_input("modrt-fuzz-gltf", data, size);
  GltfSceneOptions options;
  options.level_path = MODRT_FUZZ_LEVEL;
  options.max_vertices = 1'000'000;  // keep each input cheap
  options.max_image_side = 1024;
  modrt::Result<DemoScene> scene = load_gltf_scene(path, options);
  if (scene.ok()) fuzz::check_meshes(scene.value());
  return 0;
}
