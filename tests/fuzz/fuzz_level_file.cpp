// SPDX-License-Identifier: MIT
// libFuzzer harness: the built-level file parser (core/level_io.h) on arbitrary bytes. Each
// input is parsed twice: as given (header, checksums) and resealed, with both CRC-32s
// recomputed over the mutated bytes, so that mutations reach the body decoder and the
// structural checks instead of stopping at a checksum. An accepted level must serialize back
// to exactly the bytes that were parsed; anything else must come back as an error, never a
// crash, a hang or an oversized allocation.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "binary_test_support.h"
#include "modrt/file_io.h"
#include "modrt/level_io.h"

namespace {

void check(std::span<const std::byte> bytes) {
  using namespace modrt;
  Result<Level> level = parse_level(bytes, "fuzz input");
  if (!level.ok()) return;
  Result<std::vector<std::byte>> again = serialize_level(level.value());
  if (!again.ok()) std::abort();  // accepted but not writable
  if (again->size() != bytes.size() || !std::equal(again->begin(), again->end(), bytes.begin()))
    std::abort();  // the format has one encoding per level
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace modrt;
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  check(bytes);
  if (size < kLevelFileHeaderBytes) return 0;
  std::vector<std::byte> sealed(bytes.begin(), bytes.end());
  test::put_sealed_body_size(sealed);
  test::reseal_sealed_file(sealed);
  check(sealed);
  return 0;
}
