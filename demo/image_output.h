// modrt demo — writing images through OpenImageIO, atomically.
#pragma once

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
// The same for linear float RGB (rows top to bottom), e.g. OpenEXR by a ".exr" path, stored
// as half floats with lossless zip compression where the format has them.
Status write_rgb_float_image(const std::string& path, int width, int height, std::span<const float> rgb);

}  // namespace modrt::demo
