// SPDX-License-Identifier: MIT
// Errors, allocator, version, and loading dictionaries and levels.
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <span>

#include "c_api_internal.h"
#include "modrt/dictionary_io.h"
#include "modrt/file_io.h"
#include "modrt/level_io.h"

namespace modrt::capi {
namespace {

thread_local char t_message[1024] = "";

void* default_alloc(std::size_t size, std::size_t alignment, void*) {
  // aligned_alloc wants a size that is a multiple of the alignment.
  const std::size_t rounded = (size + alignment - 1) / alignment * alignment;
  return std::aligned_alloc(alignment, rounded == 0 ? alignment : rounded);
}
void default_free(void* p, std::size_t, void*) { std::free(p); }

}  // namespace

modrt_status Allocator::from(const char* function, const modrt_allocator* a, Allocator* out) {
  if (a) {
    if (modrt_status s = check_struct_size(function, "allocator", *a, "modrt_allocator"); s != MODRT_OK)
      return s;
  }
  if (a && a->alloc && a->free) {
    out->hook = *a;
    out->custom = true;
  } else {
    out->hook = {sizeof(modrt_allocator), default_alloc, default_free, nullptr};
    out->custom = false;
  }
  return MODRT_OK;
}

void* Allocator::allocate(std::size_t size, std::size_t alignment) const {
  return hook.alloc(size, alignment, hook.user);
}

void Allocator::release(void* p, std::size_t size) const {
  if (p) hook.free(p, size, hook.user);
}

modrt_status fail(modrt_status code, const char* message) {
  std::snprintf(t_message, sizeof t_message, "%s", message);
  return code;
}
modrt_status fail(modrt_status code, const std::string& message) { return fail(code, message.c_str()); }
modrt_status fail(const Status& status) { return fail(from_error_code(status.code()), status.message()); }

modrt_status from_error_code(ErrorCode code) {
  switch (code) {
    case ErrorCode::ok: return MODRT_OK;
    case ErrorCode::invalid_argument: return MODRT_ERROR_INVALID_ARGUMENT;
    case ErrorCode::io_error: return MODRT_ERROR_IO;
    case ErrorCode::format_error: return MODRT_ERROR_FORMAT;
    case ErrorCode::version_mismatch: return MODRT_ERROR_VERSION_MISMATCH;
    case ErrorCode::checksum_mismatch: return MODRT_ERROR_CHECKSUM_MISMATCH;
    case ErrorCode::non_finite: return MODRT_ERROR_NON_FINITE;
    case ErrorCode::resource_limit: return MODRT_ERROR_RESOURCE_LIMIT;
    case ErrorCode::internal_error: return MODRT_ERROR_INTERNAL;
  }
  return MODRT_ERROR_INTERNAL;
}

void retain(modrt_dictionary* d) { d->refs.fetch_add(1, std::memory_order_relaxed); }
void release(modrt_dictionary* d) {
  if (d->refs.fetch_sub(1, std::memory_order_acq_rel) == 1) destroy_handle(d);
}
void retain(modrt_level* l) { l->refs.fetch_add(1, std::memory_order_relaxed); }
void release(modrt_level* l) {
  if (l->refs.fetch_sub(1, std::memory_order_acq_rel) == 1) destroy_handle(l);
}

modrt_status read_whole_file(const char* path, std::uint64_t max_bytes, FileImage& out) {
  std::FILE* f = std::fopen(path, "rb");
  if (!f) return fail(MODRT_ERROR_IO, std::string(path) + ": cannot open: " + std::strerror(errno));
  struct Closer {
    std::FILE* f;
    ~Closer() { std::fclose(f); }
  } closer{f};
  // A directory opens; its "size" would be LONG_MAX. Core's rule: regular files only.
  if (Result<std::uint64_t> regular = regular_file_size(::fileno(f), path); !regular.ok())
    return fail(regular.status());
  if (std::fseek(f, 0, SEEK_END) != 0)
    return fail(MODRT_ERROR_IO, std::string(path) + ": cannot seek: " + std::strerror(errno));
  const long end = std::ftell(f);
  if (end < 0)
    return fail(MODRT_ERROR_IO, std::string(path) + ": cannot tell its size: " + std::strerror(errno));
  if (std::uint64_t(end) > max_bytes)
    return fail(MODRT_ERROR_RESOURCE_LIMIT, std::string(path) + ": " + std::to_string(end) +
                                                " bytes, more than the limit of " +
                                                std::to_string(max_bytes));
  std::rewind(f);
  out.size = std::size_t(end);
  out.data = static_cast<std::byte*>(out.alloc->allocate(out.size == 0 ? 1 : out.size, 16));
  if (!out.data) {
    out.size = 0;
    return fail(MODRT_ERROR_OUT_OF_MEMORY,
                std::string(path) + ": the allocator refused " + std::to_string(end) + " bytes");
  }
  if (out.size > 0 && std::fread(out.data, 1, out.size, f) != out.size)
    return fail(MODRT_ERROR_IO, std::string(path) + ": short read");
  return MODRT_OK;
}

modrt_status check_load_args(const char* function, const void* data, size_t size, void* out) {
  if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(function) + ": out is null");
  if (!data && size > 0) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(function) + ": data is null");
  return MODRT_OK;
}

namespace {

modrt_status make_dictionary(std::span<const std::byte> bytes, const std::string& what, const Allocator& a,
                             modrt_dictionary** out) {
  Result<Dictionary> d = parse_dictionary(bytes, what);
  if (!d.ok()) return fail(d.status());
  *out = make_handle<modrt_dictionary>(a, std::move(d).value());
  return MODRT_OK;
}

modrt_status make_level(std::span<const std::byte> bytes, const std::string& what, const Allocator& a,
                        modrt_level** out) {
  Result<Level> l = parse_level(bytes, what);
  if (!l.ok()) return fail(l.status());
  *out = make_handle<modrt_level>(a, std::move(l).value());
  return MODRT_OK;
}

}  // namespace
}  // namespace modrt::capi

using namespace modrt::capi;

extern "C" {

const char* modrt_status_name(modrt_status status) {
  switch (status) {
    case MODRT_OK: return "MODRT_OK";
    case MODRT_ERROR_INVALID_ARGUMENT: return "MODRT_ERROR_INVALID_ARGUMENT";
    case MODRT_ERROR_IO: return "MODRT_ERROR_IO";
    case MODRT_ERROR_FORMAT: return "MODRT_ERROR_FORMAT";
    case MODRT_ERROR_VERSION_MISMATCH: return "MODRT_ERROR_VERSION_MISMATCH";
    case MODRT_ERROR_CHECKSUM_MISMATCH: return "MODRT_ERROR_CHECKSUM_MISMATCH";
    case MODRT_ERROR_NON_FINITE: return "MODRT_ERROR_NON_FINITE";
    case MODRT_ERROR_RESOURCE_LIMIT: return "MODRT_ERROR_RESOURCE_LIMIT";
    case MODRT_ERROR_OUT_OF_MEMORY: return "MODRT_ERROR_OUT_OF_MEMORY";
    case MODRT_ERROR_UNSUPPORTED: return "MODRT_ERROR_UNSUPPORTED";
    case MODRT_ERROR_MISMATCH: return "MODRT_ERROR_MISMATCH";
    case MODRT_ERROR_GL: return "MODRT_ERROR_GL";
    case MODRT_ERROR_INTERNAL: return "MODRT_ERROR_INTERNAL";
    case MODRT_STATUS_MAX_ENUM: break;
  }
  return "MODRT_ERROR_UNKNOWN";
}

const char* modrt_last_error(void) { return t_message; }

uint32_t modrt_version(void) { return MODRT_VERSION; }

const char* modrt_version_string(void) {
#define MODRT_STR2(x) #x
#define MODRT_STR(x) MODRT_STR2(x)
  return MODRT_STR(MODRT_VERSION_MAJOR) "." MODRT_STR(MODRT_VERSION_MINOR) "." MODRT_STR(MODRT_VERSION_PATCH);
#undef MODRT_STR
#undef MODRT_STR2
}

modrt_status modrt_dictionary_load_memory(const void* data, size_t size, const char* name,
                                          const modrt_allocator* allocator, modrt_dictionary** out) {
  return guarded("modrt_dictionary_load_memory", [&] {
    if (modrt_status s = check_load_args("modrt_dictionary_load_memory", data, size, out); s != MODRT_OK)
      return s;
    *out = nullptr;
    Allocator a;
    if (modrt_status s = Allocator::from("modrt_dictionary_load_memory", allocator, &a); s != MODRT_OK)
      return s;
    return make_dictionary({static_cast<const std::byte*>(data), size}, name ? name : "dictionary", a, out);
  });
}

modrt_status modrt_dictionary_load_file(const char* path, const modrt_allocator* allocator,
                                        modrt_dictionary** out) {
  return guarded("modrt_dictionary_load_file", [&] {
    if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, "modrt_dictionary_load_file: out is null");
    *out = nullptr;
    if (!path) return fail(MODRT_ERROR_INVALID_ARGUMENT, "modrt_dictionary_load_file: path is null");
    Allocator a;
    if (modrt_status s = Allocator::from("modrt_dictionary_load_file", allocator, &a); s != MODRT_OK)
      return s;
    FileImage image{&a};
    if (modrt_status s = read_whole_file(path, modrt::kMaxDictionaryFileBytes, image); s != MODRT_OK)
      return s;
    return make_dictionary({image.data, image.size}, path, a, out);
  });
}

void modrt_dictionary_destroy(modrt_dictionary* dictionary) {
  if (dictionary) release(dictionary);
}

modrt_status modrt_level_load_memory(const void* data, size_t size, const char* name,
                                     const modrt_allocator* allocator, modrt_level** out) {
  return guarded("modrt_level_load_memory", [&] {
    if (modrt_status s = check_load_args("modrt_level_load_memory", data, size, out); s != MODRT_OK) return s;
    *out = nullptr;
    Allocator a;
    if (modrt_status s = Allocator::from("modrt_level_load_memory", allocator, &a); s != MODRT_OK) return s;
    return make_level({static_cast<const std::byte*>(data), size}, name ? name : "level", a, out);
  });
}

modrt_status modrt_level_load_file(const char* path, const modrt_allocator* allocator, modrt_level** out) {
  return guarded("modrt_level_load_file", [&] {
    if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, "modrt_level_load_file: out is null");
    *out = nullptr;
    if (!path) return fail(MODRT_ERROR_INVALID_ARGUMENT, "modrt_level_load_file: path is null");
    Allocator a;
    if (modrt_status s = Allocator::from("modrt_level_load_file", allocator, &a); s != MODRT_OK) return s;
    FileImage image{&a};
    if (modrt_status s = read_whole_file(path, modrt::kMaxLevelFileBytes, image); s != MODRT_OK) return s;
    return make_level({image.data, image.size}, path, a, out);
  });
}

void modrt_level_destroy(modrt_level* level) {
  if (level) release(level);
}

modrt_status modrt_level_get_info(const modrt_level* level, modrt_level_info* out) {
  return guarded("modrt_level_get_info", [&] {
    if (!level || !out)
      return fail(MODRT_ERROR_INVALID_ARGUMENT, "modrt_level_get_info: level or out is null");
    if (modrt_status s = check_struct_size("modrt_level_get_info", "out", *out, "modrt_level_info");
        s != MODRT_OK)
      return s;
    const modrt::Level& l = level->level;
    modrt_level_info info{};
    info.struct_size = sizeof info;
    info.block_count = std::uint32_t(l.blocks.size());
    info.sample_count = l.sample_count;
    info.res = std::uint32_t(l.res);
    info.atlas_width = std::uint32_t(l.atlas.width);
    info.atlas_height = std::uint32_t(l.atlas.height);
    for (int a = 0; a < 3; ++a) info.bounds_min[a] = info.bounds_max[a] = 0.0f;
    bool first = true;
    for (const modrt::LevelBlock& b : l.blocks)
      for (const glm::dvec3& c : b.corners)
        for (int a = 0; a < 3; ++a) {
          const float v = float(c[a]);
          if (first || v < info.bounds_min[a]) info.bounds_min[a] = v;
          if (first || v > info.bounds_max[a]) info.bounds_max[a] = v;
          if (a == 2) first = false;
        }
    *out = info;
    return MODRT_OK;
  });
}

}  // extern "C"
