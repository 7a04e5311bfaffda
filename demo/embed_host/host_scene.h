// SPDX-License-Identifier: MIT
// modrt-embed-host's scene mode (docs/embedding.md, "The example host's scene mode"): a small
// OpenGL ES 3 renderer of the app's own that draws a glTF scene lit every frame through the
// installed C API only: the point light moves, its cube shadow map gives ld at the proxy samples
// on the GPU (modrt_context_set_light_gpu), the update runs with multi-bounce, static meshes
// read the atlas at the lightmap coordinates of modrt_level_map_mesh (normal-mapped ones the
// vector irradiance), the dynamic object the probe texture, the clutter meshes their clutter
// lightmap; each frame is written as DIR/frame_NNNN.png.
#pragma once

#include <cstdint>
#include <string>

#include <modrt/modrt.h>

namespace modrt::host {

// options.bounces for the host's --bounces N: N feedback steps per update, or for N < 0 the
// converged multi-bounce (MODRT_BOUNCES_CONVERGED, the runtime's default).
inline std::uint32_t context_bounces(int bounces) {
  return bounces < 0 ? MODRT_BOUNCES_CONVERGED : std::uint32_t(bounces);
}

struct SceneModeOptions {
  std::string scene, dictionary, level, clutter, out_dir;
  int frames = 4, width = 480, height = 270;
  int bounces = -1;  // feedback steps per update; -1: the converged multi-bounce (context_bounces)
  float exposure = 1.0f;
  int shadow_size = 1024;  // texels per cube face
};

// Runs with the app's GL context current. Returns the exit status: 0, or 1 after printing an
// error that names the file or the call.
int run_scene_mode(const SceneModeOptions& options);

}  // namespace modrt::host
