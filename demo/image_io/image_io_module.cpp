// SPDX-License-Identifier: MIT
// The image I/O module (image_io_abi.h): OpenImageIO behind a plain C table, loaded only by a
// program that writes or reads an image. Exceptions never cross the C boundary.
#include <algorithm>
#include <cstring>
#include <exception>
#include <memory>
#include <string>

#include <OpenImageIO/imageio.h>

#include "image_io_abi.h"

namespace {

int fail(const std::string& message, char* error, size_t error_size) {
  if (error && error_size > 0) {
    const size_t n = std::min(message.size(), error_size - 1);
    std::memcpy(error, message.data(), n);
    error[n] = '\0';
  }
  return 1;
}

OIIO::TypeDesc type_desc(int type) {
  switch (type) {
    case MODRT_IMAGE_IO_UINT8: return OIIO::TypeDesc::UINT8;
    case MODRT_IMAGE_IO_HALF: return OIIO::TypeDesc::HALF;
    case MODRT_IMAGE_IO_FLOAT: return OIIO::TypeDesc::FLOAT;
    default: return OIIO::TypeDesc::UNKNOWN;
  }
}

int write_image(const char* path, int width, int height, int channels, int pixel_type, const void* pixels,
                int file_type, const char* compression, char* error, size_t error_size) try {
  const OIIO::TypeDesc memory = type_desc(pixel_type), file = type_desc(file_type);
  if (memory == OIIO::TypeDesc::UNKNOWN || file == OIIO::TypeDesc::UNKNOWN)
    return fail("unknown pixel type", error, error_size);
  if (width <= 0 || height <= 0 || channels <= 0 || !pixels)
    return fail("empty image (" + std::to_string(width) + " x " + std::to_string(height) + ")", error,
                error_size);
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(path);
  if (!out) return fail("no image writer: " + OIIO::geterror(), error, error_size);
  OIIO::ImageSpec spec(width, height, channels, file);
  if (compression) spec.attribute("compression", compression);
  if (!out->open(path, spec) || !out->write_image(memory, pixels) || !out->close())
    return fail(out->geterror(), error, error_size);
  return 0;
} catch (const std::exception& e) {
  return fail(e.what(), error, error_size);
}

int read_info(const char* path, int* width, int* height, int* channels, char* error, size_t error_size) try {
  std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path);
  if (!in) return fail(OIIO::geterror(), error, error_size);
  const OIIO::ImageSpec& spec = in->spec();
  *width = spec.width;
  *height = spec.height;
  *channels = spec.nchannels;
  return 0;
} catch (const std::exception& e) {
  return fail(e.what(), error, error_size);
}

int read_float(const char* path, float* pixels, size_t count, char* error, size_t error_size) try {
  std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path);
  if (!in) return fail(OIIO::geterror(), error, error_size);
  const OIIO::ImageSpec& spec = in->spec();
  const size_t needed = size_t(std::max(spec.width, 0)) * size_t(std::max(spec.height, 0)) *
                        size_t(std::max(spec.nchannels, 0));
  if (count < needed)
    return fail("buffer of " + std::to_string(count) + " values for an image of " + std::to_string(needed),
                error, error_size);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels))
    return fail(in->geterror(), error, error_size);
  return 0;
} catch (const std::exception& e) {
  return fail(e.what(), error, error_size);
}

constexpr modrt_image_io_v1 kTable = {write_image, read_info, read_float};

}  // namespace

extern "C" __attribute__((visibility("default"))) const modrt_image_io_v1* modrt_image_io_v1_table(void) {
  return &kTable;
}
