// SPDX-License-Identifier: MIT
// modrt demo — writing images through OpenImageIO (loaded on first use, image_io.h), atomically.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "modrt/status.h"

namespace modrt::demo {

// Linear RGB float -> sRGB 8-bit with exposure `scale` (values are multiplied first).
void encode_srgb8(std::span<const float> linear_rgb, float scale, std::span<std::uint8_t> out);

// Writes an RGB image (8-bit or float, by the extension's format) to a temporary file
// next to `path` and renames it into place.
Status write_rgb8_image(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb);
// The largest finite half float; a value beyond it would be stored as Inf.
inline constexpr float kHalfMax = 65504.0f;

// How many of `values` are NaN or Inf.
std::size_t count_non_finite(std::span<const float> values);

// The same for linear float RGB (rows top to bottom), e.g. OpenEXR by a ".exr" path, with
// lossless zip compression where the format has it: stored as half floats when every |value|
// is at most kHalfMax, else as float32 (*wrote_float32 says which). Refuses (non_finite, with
// the count) a buffer holding NaN or Inf: nothing non-finite is ever written.
Status write_rgb_float_image(const std::string& path, int width, int height, std::span<const float> rgb,
                             bool* wrote_float32 = nullptr);

}  // namespace modrt::demo
