// SPDX-License-Identifier: MIT
// What the glTF harnesses (fuzz_gltf, fuzz_scene_import) share: the input written to a file
// (the loader reads files; buffers and images resolve relative to them) and the check that
// an accepted scene's meshes agree with themselves and with its materials.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <unistd.h>

#include "scene/gltf_scene.h"

namespace modrt::demo::fuzz {

// Writes the input to /tmp/<prefix>-<pid>.gltf (one file per process, rewritten per input)
// and returns its path; aborts when the file cannot be written.
inline const std::string& write_input(const char* prefix, const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/tmp/" + std::string(prefix) + "-" + std::to_string(::getpid()) + ".gltf";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

// Aborts unless every mesh's arrays agree (normals and UVs per position, indices in range)
// and names an existing material.
inline void check_meshes(const DemoScene& scene) {
  for (const Mesh& m : scene.meshes) {
    if (m.normal.size() != m.position.size() || (!m.uv.empty() && m.uv.size() != m.position.size()))
      std::abort();
    for (std::uint32_t i : m.indices)
      if (i >= m.position.size()) std::abort();
    if (m.material < 0 || std::size_t(m.material) >= scene.materials.size()) std::abort();
  }
}

}  // namespace modrt::demo::fuzz
