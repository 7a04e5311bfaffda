// SPDX-License-Identifier: MIT
// modrt — core's scalar reference behind the Backend interface (architecture.md §5), the
// oracle every backend is held to: each frame runs the reference's stages item by item
// (level_runtime.h: b per block, r per slot, the lightmap tile and probes per block), only for
// what a changed ld reaches (level_dirty.h, exact), then the padded atlas; vector irradiance on
// request; the multi-bounce feedback of reference_runtime.h (apply_feedback, the bound of
// feedback_policy.h); DRT with drt.h's functions. Accumulates in double as the rest of core.
// Slow; for conformance, a build without SIMD or GL, and as the pipeline's plainest backend.
// Allocates at creation and in set_clutter; a frame without clutter does not (with clutter,
// drt.h's functions keep per-call scratch vectors; test FramesAllocateNothing).
#pragma once

#include <memory>

#include "modrt/backend.h"
#include "modrt/dictionary.h"
#include "modrt/level.h"

namespace modrt {

struct ReferenceBackendOptions {
  bool probes = true;          // evaluate the volume probes (when the dictionary has them)
  bool skip_unchanged = true;  // recompute only what a changed ld reaches (exact)
};

// `level` and `dict` are borrowed and must outlive the backend. Fails when the level does not
// match the dictionary (check_level_operators).
Result<std::unique_ptr<Backend>> create_reference_backend(const Level& level, const Dictionary& dict,
                                                          const ReferenceBackendOptions& options = {});

}  // namespace modrt
