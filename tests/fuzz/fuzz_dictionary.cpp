// SPDX-License-Identifier: MIT
// libFuzzer harness: the dictionary file parser (core/dictionary_io.h) on arbitrary bytes. A
// file it accepts must pass validate_dictionary and survive a save/parse round trip unchanged
// in settings and operator sizes; anything else must come back as an error, never a crash,
// a hang or an oversized allocation (ASan's allocation limit catches those).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "modrt/dictionary_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace modrt;
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  Result<Dictionary> dict = parse_dictionary(bytes, "fuzz input");
  if (!dict.ok()) return 0;
  if (!validate_dictionary(dict.value(), "fuzz input").ok()) std::abort();  // accepted but invalid
  Result<std::vector<std::byte>> again = serialize_dictionary(dict.value());
  if (!again.ok()) std::abort();
  Result<Dictionary> back = parse_dictionary(again.value(), "round trip");
  if (!back.ok() || !(back->settings == dict->settings) || back->shapes.size() != dict->shapes.size())
    std::abort();
  for (std::size_t i = 0; i < dict->shapes.size(); ++i)
    if (back->shapes[i].Ub.data.size() != dict->shapes[i].Ub.data.size()) std::abort();
  return 0;
}
