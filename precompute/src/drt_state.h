// SPDX-License-Identifier: MIT
// modrt precompute (private) — what a DrtBuildState holds (DrtBuildState::Impl), shared by the
// build (drt_build.cpp) and the state file (drt_state_io.cpp), and the one check of its
// contents against what the assembly of the operators indexes, which both run: rebuild_object
// on the state it is given, the loader on a file's.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "drt_gather.h"
#include "modrt/precompute/drt_build.h"

namespace modrt::precompute {

struct DrtBuildState::Impl {
  // What the state was built for: rebuild_object refuses a state of another level or of
  // other build settings (a loaded file's).
  DrtBuildSettings settings;
  std::uint32_t kb = 0, level_blocks = 0, level_samples = 0;
  std::uint32_t probes_per_block = 0;  // the dictionary's probe_grid^3 with the probe pass, else 0
  std::vector<ClutterObject> objects;
  std::vector<drt_detail::SampleResult> samples;             // scene pass, before inpainting
  std::vector<drt_detail::SampleResult> vector_samples;      // vector scene pass (empty unless built)
  std::vector<drt_detail::SampleResult> probes;              // U_dyn pass (empty unless built)
  std::vector<std::vector<drt_detail::TexelResult>> texels;  // clutter pass, per object
  std::vector<std::vector<drt_detail::TexelResult>>
      vector_texels;                           // vector clutter pass (empty unless built)
  std::vector<ClutterTexelGeometry> geometry;  // per object
};

namespace drt_detail {

// DrtBuildState's private parts, for the state file.
struct StateAccess {
  using Impl = DrtBuildState::Impl;
  static DrtBuildState::Impl* get(const DrtBuildState& state) { return state.impl_.get(); }
  static void set(DrtBuildState& state, std::unique_ptr<DrtBuildState::Impl> impl) {
    state.impl_ = std::move(impl);
  }
};

// The rows that the kept results may hold: row lengths W kb, block indices below
// level_blocks, sample indices below level_samples, per object its texel count and the
// entries of its c (columns; with exact_columns false, only an upper bound: a lighting
// prior's rank is known once the prior is made).
struct StateBounds {
  std::uint32_t kb = 0, level_blocks = 0, level_samples = 0;
  std::vector<std::uint32_t> texels, columns;
  bool exact_columns = true;
};

// What in `state`'s traced results does not fit `bounds` ("scene pass sample 12: rows of
// object 7, of 4 objects"), or "" when all fits: every object, block, sample and texel index
// the assembly follows, every row length, the states of samples and the ordering the
// assembly relies on (each result's objects ascending). The sizes of the lists themselves
// (one result per sample, probe and texel) are the caller's.
std::string check_state_rows(const StateAccess::Impl& state, const StateBounds& bounds);

}  // namespace drt_detail
}  // namespace modrt::precompute
