// SPDX-License-Identifier: MIT
// What a loaded level tells an app: its samples' albedo and geometry and its blocks, so that
// the app can compute ld itself and place its own content (modrt.h, "Dictionary and level").
#include <string>

#include "c_api_internal.h"
#include "modrt/cube.h"
#include "modrt/level_geometry.h"

using namespace modrt;
using namespace modrt::capi;

namespace {

modrt_status check_records(const char* fn, const char* what, size_t count, size_t expected,
                           const char* unit) {
  if (count == expected) return MODRT_OK;
  return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": " + what + " has " + std::to_string(count) +
                                                " " + unit + ", the level needs " + std::to_string(expected));
}

}  // namespace

extern "C" {

modrt_status modrt_level_get_albedo(const modrt_level* level, float* out, size_t count) {
  return guarded("modrt_level_get_albedo", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_level_get_albedo";
    if (!level) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": level is null");
    if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out is null");
    if (modrt_status s = check_records(fn, "out", count, 3 * size_t(level->level.sample_count), "floats");
        s != MODRT_OK)
      return s;
    level_sample_albedo(level->level, {out, count});
    return MODRT_OK;
  });
}

modrt_status modrt_level_get_samples(const modrt_level* level, modrt_level_sample* out, size_t count) {
  return guarded("modrt_level_get_samples", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_level_get_samples";
    if (!level) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": level is null");
    if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out is null");
    if (modrt_status s = check_records(fn, "out", count, level->level.sample_count, "records"); s != MODRT_OK)
      return s;
    const LevelSampleGeometry g = level_sample_geometry(level->level);  // before writing: may throw
    for (size_t i = 0; i < count; ++i) {
      modrt_level_sample& o = out[i];
      for (int a = 0; a < 3; ++a) {
        o.position[a] = float(g.position[i][a]);
        o.normal[a] = float(g.normal[i][a]);
      }
      o.block = std::uint32_t(g.block[i]);
      o.face = std::uint32_t(g.face[i]);
    }
    return MODRT_OK;
  });
}

modrt_status modrt_level_get_block(const modrt_level* level, uint32_t index, modrt_level_block* out) {
  return guarded("modrt_level_get_block", [&]() -> modrt_status {
    constexpr const char* fn = "modrt_level_get_block";
    if (!level) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": level is null");
    if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out is null");
    if (modrt_status s = check_struct_size(fn, "out", *out, "modrt_level_block"); s != MODRT_OK) return s;
    const Level& l = level->level;
    if (index >= l.blocks.size())
      return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": index " + std::to_string(index) +
                                                    " is not below the block count " +
                                                    std::to_string(l.blocks.size()));
    const LevelBlock& b = l.blocks[index];
    modrt_level_block r{};
    r.struct_size = sizeof r;
    r.shape = std::uint32_t(b.shape);
    r.quarter_turns = std::uint32_t(b.quarter_turns);
    r.face_mask = dictionary_shape_mask(b.shape);
    for (int a = 0; a < 3; ++a) r.cell[a] = b.cell[a];
    for (int c = 0; c < 8; ++c)
      for (int a = 0; a < 3; ++a) r.corners[c][a] = float(b.corners[std::size_t(c)][a]);
    const bool tiles = index < l.atlas.tile_origin_x.size() && index < l.atlas.tile_origin_y.size();
    for (int f = 0; f < kFaceCount; ++f) {
      const std::size_t fi = std::size_t(f);
      r.world_face[f] = std::uint32_t(rotate_face(f, b.quarter_turns));
      r.neighbour[f] = b.neighbour[fi];
      for (int c = 0; c < 3; ++c) r.albedo[f][c] = b.albedo[fi][c];
      r.tile_x[f] = tiles ? l.atlas.tile_origin_x[index][fi] : -1;
      r.tile_y[f] = tiles ? l.atlas.tile_origin_y[index][fi] : -1;
    }
    r.sample_offset = b.sample_offset;
    r.sample_count = b.sample_count;
    *out = r;
    return MODRT_OK;
  });
}

}  // extern "C"
