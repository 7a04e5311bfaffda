// SPDX-License-Identifier: MIT
#include "image_io.h"

#include <dlfcn.h>

#include <filesystem>
#include <mutex>

namespace modrt::image_io {

namespace {

struct Loaded {
  const modrt_image_io_v1* table = nullptr;
  std::string error;
};

// Where the module is looked for: where an installed program's module lies (<libdir>/modrt,
// relative to the program's bin directory), beside the program in the build tree's layout
// (bin/, lib/), then where this build wrote it (MODRT_IMAGE_IO_MODULE_PATH; demo/image_io's
// CMakeLists.txt gives all three).
std::vector<std::filesystem::path> candidates() {
  namespace fs = std::filesystem;
  std::vector<fs::path> paths;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    paths.push_back(exe.parent_path() / MODRT_IMAGE_IO_INSTALLED_FROM_BIN / MODRT_IMAGE_IO_MODULE_NAME);
    paths.push_back(exe.parent_path().parent_path() / "lib" / MODRT_IMAGE_IO_MODULE_NAME);
  }
  paths.emplace_back(MODRT_IMAGE_IO_MODULE_PATH);
  return paths;
}

Loaded load() {
  Loaded loaded;
  std::string tried;
  for (const std::filesystem::path& path : candidates()) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) {
      tried += (tried.empty() ? "" : ", ") + path.string() + " (absent)";
      continue;
    }
    // RTLD_LOCAL: OpenImageIO's symbols stay out of the program's namespace. Never closed:
    // OpenImageIO's own exit-time destructors run from the loaded copy.
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* message = ::dlerror();
      tried +=
          (tried.empty() ? "" : ", ") + path.string() + " (" + (message ? message : "dlopen failed") + ")";
      continue;
    }
    using TableFn = const modrt_image_io_v1* (*)();
    auto table_fn = reinterpret_cast<TableFn>(::dlsym(handle, "modrt_image_io_v1_table"));
    if (!table_fn) {
      tried += (tried.empty() ? "" : ", ") + path.string() + " (no modrt_image_io_v1_table)";
      continue;
    }
    loaded.table = table_fn();
    return loaded;
  }
  loaded.error = "image I/O module " MODRT_IMAGE_IO_MODULE_NAME " not loaded: " + tried;
  return loaded;
}

}  // namespace

const modrt_image_io_v1* module(std::string* error) {
  static std::once_flag once;
  static Loaded loaded;
  std::call_once(once, [] { loaded = load(); });
  if (!loaded.table && error) *error = loaded.error;
  return loaded.table;
}

std::string write(const std::string& path, int width, int height, int channels,
                  modrt_image_io_type pixel_type, const void* pixels, modrt_image_io_type file_type,
                  const char* compression) {
  std::string error;
  const modrt_image_io_v1* io = module(&error);
  if (!io) return error;
  char message[512] = {};
  if (io->write(path.c_str(), width, height, channels, pixel_type, pixels, file_type, compression, message,
                sizeof message) != 0)
    return message[0] ? message : "image write failed";
  return {};
}

std::string read_float(const std::string& path, FloatImage& image) {
  std::string error;
  const modrt_image_io_v1* io = module(&error);
  if (!io) return error;
  char message[512] = {};
  int width = 0, height = 0, channels = 0;
  if (io->read_info(path.c_str(), &width, &height, &channels, message, sizeof message) != 0)
    return message[0] ? message : "image read failed";
  if (width <= 0 || height <= 0 || channels <= 0) return "empty image";
  std::vector<float> pixels(std::size_t(width) * std::size_t(height) * std::size_t(channels));
  if (io->read_float(path.c_str(), pixels.data(), pixels.size(), message, sizeof message) != 0)
    return message[0] ? message : "image read failed";
  image = FloatImage{width, height, channels, std::move(pixels)};
  return {};
}

}  // namespace modrt::image_io
