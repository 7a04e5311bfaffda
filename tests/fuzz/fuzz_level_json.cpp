// SPDX-License-Identifier: MIT
// libFuzzer harness: the level JSON parser (precompute/level_json.h) on arbitrary text. A level
// it accepts must validate (validate_level) and round-trip: level_to_json of it parses again
// to a level with the same blocks and lights. Anything else must be an error, never a crash.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "modrt/precompute/level_json.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace modrt;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  Result<LevelDescription> level = precompute::parse_level_json(text, "fuzz input");
  if (!level.ok()) return 0;
  if (!validate_level(level.value()).ok()) std::abort();  // accepted but invalid
  const std::string json = precompute::level_to_json(level.value());
  Result<LevelDescription> back = precompute::parse_level_json(json, "round trip");
  if (!back.ok() || back->blocks.size() != level->blocks.size() ||
      back->lights.size() != level->lights.size())
    std::abort();
  for (std::size_t i = 0; i < level->blocks.size(); ++i)
    if (back->blocks[i].cell != level->blocks[i].cell || back->blocks[i].faces != level->blocks[i].faces)
      std::abort();
  return 0;
}
