// SPDX-License-Identifier: MIT
#include "image_output.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <unistd.h>

#include "image_io.h"

namespace modrt::demo {

void encode_srgb8(std::span<const float> linear_rgb, float scale, std::span<std::uint8_t> out) {
  for (std::size_t i = 0; i < linear_rgb.size(); ++i) {
    float v = linear_rgb[i] * scale;
    v = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
    const float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    out[i] = std::uint8_t(std::lround(s * 255.0f));
  }
}

namespace {

// Writes through a temporary file next to `path`, renamed into place.
Status write_image(const std::string& path, int width, int height, modrt_image_io_type type,
                   const void* pixels, modrt_image_io_type file_type) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path target(path);
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  // Keep the extension last so OpenImageIO picks the right writer for the temp file.
  const fs::path temp =
      target.parent_path() / (".tmp-" + std::to_string(::getpid()) + "-" + target.filename().string());
  // "zip" compression: EXR's lossless one, a fraction of the raw size (ignored by PNG).
  if (const std::string error =
          image_io::write(temp.string(), width, height, 3, type, pixels, file_type, "zip");
      !error.empty()) {
    fs::remove(temp, ec);
    return Status::error(ErrorCode::io_error, path + ": " + error);
  }
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    return Status::error(ErrorCode::io_error, path + ": rename failed: " + ec.message());
  }
  return Status::success();
}

}  // namespace

Status write_rgb8_image(const std::string& path, int width, int height, std::span<const std::uint8_t> rgb) {
  if (rgb.size() != 3 * std::size_t(width) * std::size_t(height))
    return Status::error(ErrorCode::invalid_argument, path + ": pixel buffer does not match the image size");
  return write_image(path, width, height, MODRT_IMAGE_IO_UINT8, rgb.data(), MODRT_IMAGE_IO_UINT8);
}

std::size_t count_non_finite(std::span<const float> values) {
  return std::size_t(std::count_if(values.begin(), values.end(), [](float v) { return !std::isfinite(v); }));
}

Status write_rgb_float_image(const std::string& path, int width, int height, std::span<const float> rgb,
                             bool* wrote_float32) {
  if (rgb.size() != 3 * std::size_t(width) * std::size_t(height))
    return Status::error(ErrorCode::invalid_argument, path + ": pixel buffer does not match the image size");
  // A linear frame with NaN or Inf is a wrong render, not an image: refused rather than
  // clamped, so that the fault shows (docs/demo.md, "Output").
  if (const std::size_t bad = count_non_finite(rgb); bad > 0)
    return Status::error(ErrorCode::non_finite, path + ": " + std::to_string(bad) + " of " +
                                                    std::to_string(rgb.size()) +
                                                    " values are not finite (NaN or Inf); not written");
  // Half floats (11-bit mantissa, the usual precision of linear HDR frames) while every value
  // fits their range; beyond it half would store Inf, so the frame is written as float32.
  float largest = 0.0f;
  for (const float v : rgb) largest = std::max(largest, std::abs(v));
  const bool float32 = largest > kHalfMax;
  if (wrote_float32) *wrote_float32 = float32;
  return write_image(path, width, height, MODRT_IMAGE_IO_FLOAT, rgb.data(),
                     float32 ? MODRT_IMAGE_IO_FLOAT : MODRT_IMAGE_IO_HALF);
}

}  // namespace modrt::demo
