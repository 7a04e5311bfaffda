// SPDX-License-Identifier: MIT
// modrt demo — a glTF scene without modrt markup gets its proxy blocks from its own geometry
// (precompute/scene_import.h, docs/import.md): the static meshes, with their materials'
// albedo (base colour times the texture's mean), become the importer's objects, one per glTF
// node; the level comes back with the scene's point and spot lights; triangles the importer
// found facing into solid are turned round (winding and normals) so that they face the room.
#pragma once

#include "demo_scene.h"
#include "modrt/precompute/scene_import.h"
#include "modrt/status.h"

namespace modrt::demo {

// The diffuse albedo the importer sees for `material`: linear base colour times the mean of
// its base-colour texture (sRGB decoded), each channel clamped to [0, 1].
glm::dvec3 material_albedo(const DemoScene& scene, int material);

// Fills scene.level from the scene's static meshes (Mesh::source_node groups them into
// objects) and turns round the meshes' flipped triangles. Fails as import_scene does.
Result<precompute::SceneImport> import_scene_level(DemoScene& scene,
                                                   const precompute::ImportSettings& settings = {});

}  // namespace modrt::demo
