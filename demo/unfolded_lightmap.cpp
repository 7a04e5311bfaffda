// SPDX-License-Identifier: MIT
#include "unfolded_lightmap.h"

#include <algorithm>
#include <cmath>

namespace modrt::demo {
namespace {

struct Cell {
  int face, col, row;
};
constexpr Cell kCells[] = {{kFacePosY, 0, 0}, {kFaceNegZ, 0, 1}, {kFacePosX, 1, 1},
                           {kFacePosZ, 2, 1}, {kFaceNegX, 3, 1}, {kFaceNegY, 0, 2}};

}  // namespace

UnfoldedImage unfold_lightmap(const SampleLayout& layout, std::span<const float> signal,
                              int pixels_per_texel) {
  const int res = layout.res;
  const int cell = res * pixels_per_texel;
  UnfoldedImage img;
  img.width = 4 * cell;
  img.height = 3 * cell;
  img.rgb.assign(std::size_t(img.width) * img.height * 3, 0.0f);
  for (const Cell& c : kCells) {
    const bool present = face_present(layout.mask, c.face);
    for (int py = 0; py < cell; ++py)
      for (int px = 0; px < cell; ++px) {
        float* dst =
            &img.rgb[(std::size_t(c.row * cell + py) * img.width + std::size_t(c.col * cell + px)) * 3];
        if (!present) {
          dst[0] = dst[1] = dst[2] = 0.02f;
          continue;
        }
        // Image rows grow downward, face v grows upward.
        const double x = (px + 0.5) / pixels_per_texel - 0.5;
        const double y = (cell - py - 0.5) / pixels_per_texel - 0.5;
        const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
        const double ax = x - x0, ay = y - y0;
        for (int ch = 0; ch < 3; ++ch) {
          double v = 0.0;
          for (int b = 0; b < 2; ++b)
            for (int a = 0; a < 2; ++a) {
              const int i = std::clamp(x0 + a, 0, res - 1), j = std::clamp(y0 + b, 0, res - 1);
              v += (a ? ax : 1 - ax) * (b ? ay : 1 - ay) *
                   signal[3 * std::size_t(layout.index(c.face, i, j)) + ch];
            }
          dst[ch] = float(v);
        }
      }
  }
  return img;
}

}  // namespace modrt::demo
