// SPDX-License-Identifier: MIT
// modrt demo — the built-in default scene (what `modrt-demo` renders with no arguments):
// the 11-block maze with warped blocks and red/green/blue walls, the walls themselves as
// meshes, detail geometry in every block (corner pillars, crates, ceiling beams, a bench),
// brick and tile normal maps in the first block, a light moving from the first block into the
// passage beyond it, and a dynamic sphere rolling through three blocks, lit by the probes.
#pragma once

#include "demo_scene.h"
#include "modrt/status.h"

namespace modrt::demo {

Result<DemoScene> default_scene();

// Meshes of the level's walls: every present face of every block as a `subdivisions`^2 grid
// of quads through the block's trilinear warp, one material per distinct albedo (appended to
// scene.materials). Used by default_scene and by glTF scenes that give only proxies.
void add_wall_meshes(DemoScene& scene, int subdivisions);

}  // namespace modrt::demo
