// SPDX-License-Identifier: MIT
// modrt demo — a block's per-face texel signal unfolded into a cross image, seen from
// inside: ceiling on top, the side walls -Z, +X, +Z, -X in the middle row (each wall's
// right edge meets the next wall's left edge), floor at the bottom. Missing faces are
// drawn dark grey.
#pragma once

#include <span>
#include <vector>

#include "modrt/cube.h"

namespace modrt::demo {

struct UnfoldedImage {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  // linear, row 0 at the top
};

// `signal` is 3n interleaved RGB over layout's samples; each texel is drawn as
// `pixels_per_texel` pixels, bilinearly filtered within the face.
UnfoldedImage unfold_lightmap(const SampleLayout& layout, std::span<const float> signal,
                              int pixels_per_texel);

}  // namespace modrt::demo
