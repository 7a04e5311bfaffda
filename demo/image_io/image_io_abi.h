// SPDX-License-Identifier: MIT
// modrt demo — the plain C interface of the image I/O module (libmodrt_image_io.so).
//
// The programs write and read images through OpenImageIO, whose start-up (static initialisers
// of OpenImageIO and the libraries it links, OpenVDB among them) costs about 0.4 s per process
// on a Debian 12 desktop: more than most runs of modrt-level or a hostile case take. The
// programs therefore load OpenImageIO only when they write or read an image, through this
// module (image_io.h loads it with dlopen). Versioned by the symbol name: a change of the
// table is a new symbol.
#pragma once

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

// Pixel types in memory and in the file.
enum modrt_image_io_type { MODRT_IMAGE_IO_UINT8 = 0, MODRT_IMAGE_IO_HALF = 1, MODRT_IMAGE_IO_FLOAT = 2 };

// Every call returns 0 on success, or non-zero with a NUL-terminated message in `error`
// (truncated to `error_size` bytes; `error` may be null when `error_size` is 0).
typedef struct modrt_image_io_v1 {
  // Writes `pixels` (width * height * channels values of `pixel_type`, rows top to bottom) to
  // `path` as `file_type`; the format follows the extension. `compression` (may be null) is
  // passed as the "compression" attribute (e.g. "zip" for EXR).
  int (*write)(const char* path, int width, int height, int channels, int pixel_type, const void* pixels,
               int file_type, const char* compression, char* error, size_t error_size);
  // The size of the first subimage of `path`.
  int (*read_info)(const char* path, int* width, int* height, int* channels, char* error, size_t error_size);
  // Reads the first subimage of `path` as float into `pixels`, which holds `count` values: at
  // least width * height * channels of read_info, else the call fails.
  int (*read_float)(const char* path, float* pixels, size_t count, char* error, size_t error_size);
} modrt_image_io_v1;

// The module's one exported symbol.
const modrt_image_io_v1* modrt_image_io_v1_table(void);

#ifdef __cplusplus
}
#endif
