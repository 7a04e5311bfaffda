// SPDX-License-Identifier: MIT
// modrt precompute — the level file format (JSON, docs/level-format.md): parsing with
// errors that name the file, the JSON path and the problem, and writing.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "modrt/level_description.h"
#include "modrt/status.h"

namespace modrt::precompute {

// Value of the top-level "format" field.
inline constexpr const char* kLevelFormatName = "modrt-level";
// Files (and texts) larger than this are refused with resource_limit.
inline constexpr std::size_t kMaxLevelFileBytes = std::size_t(64) << 20;

// Parses a level from JSON text; `what` names the source in messages (a path, "<memory>").
// Error codes: format_error (malformed JSON, missing field, wrong type or array length,
// unknown field or face name, duplicate key), version_mismatch (version != 1, or another
// "format"), invalid_argument (a number out of range, or a validate_level failure; the
// message then names the block as "block N" = blocks[N]), resource_limit (text > 64 MiB).
// The result has passed validate_level. Never throws.
Result<LevelDescription> parse_level_json(std::string_view text, const std::string& what);

// Reads `path` (io_error when it cannot be read, resource_limit when > 64 MiB) and parses it.
Result<LevelDescription> load_level_json(const std::string& path);

// Serialises a level (any level; an invalid one may not parse back). Doubles are written
// with round-trip precision, so parse_level_json(level_to_json(l)) reproduces l exactly
// (for a valid l; block albedos are written relative to a "default_albedo").
std::string level_to_json(const LevelDescription& level);

// Writes level_to_json(level) to `path` atomically (write_file_atomic).
Status save_level_json(const std::string& path, const LevelDescription& level);

}  // namespace modrt::precompute
