// SPDX-License-Identifier: MIT
// modrt demo — image I/O through the lazily loaded OpenImageIO module (image_io_abi.h).
//
// The first call loads libmodrt_image_io.so (dlopen) from the program's ../lib directory, as
// in the build tree, or else from the path the build wrote it to; a program that writes no
// image never loads OpenImageIO. Thread-safe; the module stays loaded until exit.
#pragma once

#include <string>
#include <vector>

#include "image_io_abi.h"

namespace modrt::image_io {

// The module's table, or null with `*error` naming the module and the loader's message.
const modrt_image_io_v1* module(std::string* error);

// Writes an image (image_io_abi.h's write); returns "" on success, else the error message.
std::string write(const std::string& path, int width, int height, int channels,
                  modrt_image_io_type pixel_type, const void* pixels, modrt_image_io_type file_type,
                  const char* compression = nullptr);

struct FloatImage {
  int width = 0, height = 0, channels = 0;
  std::vector<float> pixels;  // width * height * channels, rows top to bottom
};

// Reads the first subimage of `path` as float; returns "" on success, else the error message.
std::string read_float(const std::string& path, FloatImage& image);

}  // namespace modrt::image_io
