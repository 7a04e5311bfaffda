// SPDX-License-Identifier: MIT
// libFuzzer harness: the DRT build state file parser (precompute/drt_state_io.h) on arbitrary
// bytes. As fuzz_drt_file: each input is parsed as given and again resealed (both CRC-32s
// recomputed over the mutated bytes), so that mutations reach the body decoder, the objects'
// checks (a mesh rasterized again) and the index checks of the traced results. An accepted
// state must serialize back to exactly the bytes that were parsed; anything else must come
// back as an error, never a crash, a hang or an oversized allocation.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "binary_test_support.h"
#include "modrt/precompute/drt_state_io.h"

namespace {

void check(std::span<const std::byte> bytes) {
  using namespace modrt;
  Result<precompute::LoadedDrtBuildState> state = precompute::parse_drt_build_state(bytes, "fuzz input");
  if (!state.ok()) return;
  Result<std::vector<std::byte>> again =
      precompute::serialize_drt_build_state(state->state, state->scene_key);
  if (!again.ok()) std::abort();  // accepted but not writable
  if (again->size() != bytes.size() || !std::equal(again->begin(), again->end(), bytes.begin()))
    std::abort();  // the format has one encoding per state
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace modrt;
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  check(bytes);
  if (size < precompute::kDrtStateFileHeaderBytes) return 0;
  std::vector<std::byte> sealed(bytes.begin(), bytes.end());
  test::put_sealed_body_size(sealed);
  test::reseal_sealed_file(sealed);
  check(sealed);
  return 0;
}
