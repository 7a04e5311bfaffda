// SPDX-License-Identifier: MIT
// The C API's shared plumbing: the allocator hook as an STL allocator, handle allocation,
// the per-thread error message, Status -> modrt_status, and the boundary that keeps every
// exception inside the library.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "modrt/dictionary.h"
#include "modrt/drt.h"
#include "modrt/level.h"
#include "modrt/modrt.h"
#include "modrt/status.h"

namespace modrt::capi {

// The int a C caller stored in an enum field or passed as an enum argument. C allows any int
// there, but in C++ reading an enum object whose value is outside the enumeration's range is
// undefined (clang's -fsanitize=enum, found by fuzz_c_api), so the object is read as the int
// the C ABI passes it as, and only that int is compared.
template <class CEnum>
int c_enum_value(const CEnum& value) {
  static_assert(sizeof(CEnum) == sizeof(int), "a C enum is passed as an int");
  int bits;
  std::memcpy(&bits, &value, sizeof bits);
  return bits;
}

// The hook as given, or malloc/free. Copied into every handle, so the caller's struct need
// not outlive the call.
struct Allocator {
  modrt_allocator hook{};
  bool custom = false;

  // The caller's hook (checked: struct_size) into *out; a null hook, or one with a null
  // alloc or free, is malloc/free.
  static modrt_status from(const char* function, const modrt_allocator* a, Allocator* out);
  void* allocate(std::size_t size, std::size_t alignment) const;  // null on failure
  void release(void* p, std::size_t size) const;
};

// std::allocator replacement that routes through the hook (throws std::bad_alloc on failure,
// which the API boundary turns into MODRT_ERROR_OUT_OF_MEMORY).
template <class T>
struct HookAllocator {
  using value_type = T;
  const Allocator* owner = nullptr;

  explicit HookAllocator(const Allocator* a) : owner(a) {}
  template <class U>
  HookAllocator(const HookAllocator<U>& o) : owner(o.owner) {}  // NOLINT: rebinding
  T* allocate(std::size_t n) {
    if (n > std::size_t(-1) / sizeof(T)) throw std::bad_alloc();
    void* p = owner->allocate(n * sizeof(T), alignof(T) < 16 ? 16 : alignof(T));
    if (!p) throw std::bad_alloc();
    return static_cast<T*>(p);
  }
  void deallocate(T* p, std::size_t n) { owner->release(p, n * sizeof(T)); }
  template <class U>
  bool operator==(const HookAllocator<U>& o) const {
    return owner == o.owner;
  }
};
template <class T>
using HookVector = std::vector<T, HookAllocator<T>>;

// Constructs a T in memory from the hook (T's first member must be an Allocator named
// `alloc`, which the handle frees itself with). Throws std::bad_alloc.
template <class T, class... Args>
T* make_handle(const Allocator& a, Args&&... args) {
  void* p = a.allocate(sizeof(T), alignof(T));
  if (!p) throw std::bad_alloc();
  try {
    return new (p) T(a, std::forward<Args>(args)...);
  } catch (...) {
    a.release(p, sizeof(T));
    throw;
  }
}
template <class T>
void destroy_handle(T* h) {
  const Allocator a = h->alloc;
  h->~T();
  a.release(h, sizeof(T));
}

// Per-thread message of the last failure: a fixed buffer, so that recording an error does
// not allocate either.
modrt_status fail(modrt_status code, const char* message);
modrt_status fail(modrt_status code, const std::string& message);
modrt_status fail(const Status& status);  // maps the ErrorCode
modrt_status from_error_code(ErrorCode code);

// The layout an earlier version of modrt.h gave a struct that has grown since (modrt.h,
// "Structs"): its size then, or 0 when the struct has one layout.
template <class T>
inline constexpr std::size_t kEarlierStructSize = 0;
template <>  // 0.2: up to gl_loader_user
inline constexpr std::size_t kEarlierStructSize<modrt_context_options> = offsetof(modrt_context_options,
                                                                                  bounces);
template <>  // 0.3: up to light_blocks_kept
inline constexpr std::size_t kEarlierStructSize<modrt_skip_stats> = offsetof(modrt_skip_stats, tiles_hidden);
template <>  // 0.2: up to update_ns
inline constexpr std::size_t kEarlierStructSize<modrt_timings> = offsetof(modrt_timings, feedback_ns);
template <>  // 0.3: up to far_plane
inline constexpr std::size_t kEarlierStructSize<modrt_shadow_cube> = offsetof(modrt_shadow_cube,
                                                                              normal_offset);

// The struct_size rule of modrt.h ("Structs"), for every struct passed in or out: struct_size
// must be sizeof(T) or the struct's earlier layout (kEarlierStructSize). `what` names the
// argument ("options", "lights[3]").
template <class T>
modrt_status check_struct_size(const char* function, const std::string& what, const T& s, const char* type,
                               const char* init = nullptr) {
  static_assert(std::is_standard_layout_v<T>, "a C struct");
  if (s.struct_size == sizeof(T)) return MODRT_OK;
  if (kEarlierStructSize<T> != 0 && s.struct_size == kEarlierStructSize<T>) return MODRT_OK;
  return fail(MODRT_ERROR_INVALID_ARGUMENT,
              std::string(function) + ": " + what + ".struct_size is " + std::to_string(s.struct_size) +
                  ", expected " + std::to_string(sizeof(T)) + " (set it to sizeof(" + type + ")" +
                  (init ? std::string(", or call ") + init : std::string()) + ")");
}

// Copies the caller's struct (checked by check_struct_size) over `defaults`, up to its
// struct_size: fields an earlier layout lacks keep their defaults.
template <class T>
T read_sized(const T& in, T defaults) {
  std::memcpy(&defaults, &in,
              std::size_t(in.struct_size) < sizeof(T) ? std::size_t(in.struct_size) : sizeof(T));
  defaults.struct_size = sizeof(T);
  return defaults;
}
// Writes `value` into the caller's struct up to its struct_size (checked), which it keeps.
template <class T>
void write_sized(T* out, const T& value) {
  const std::uint32_t size = out->struct_size;
  std::memcpy(out, &value, std::size_t(size) < sizeof(T) ? std::size_t(size) : sizeof(T));
  out->struct_size = size;
}

// Runs f() (returning modrt_status) with every exception turned into a status.
template <class F>
modrt_status guarded(const char* function, F&& f) noexcept {
  try {
    return f();
  } catch (const std::bad_alloc&) {
    return fail(MODRT_ERROR_OUT_OF_MEMORY, std::string(function) + ": out of memory");
  } catch (const std::exception& e) {
    return fail(MODRT_ERROR_INTERNAL, std::string(function) + ": " + e.what());
  } catch (...) {
    return fail(MODRT_ERROR_INTERNAL, std::string(function) + ": unknown exception");
  }
}

}  // namespace modrt::capi

// The handles: refcounted so that a context keeps its dictionary and level alive.
struct modrt_dictionary {
  modrt::capi::Allocator alloc;
  std::atomic<int> refs{1};
  modrt::Dictionary dict;
  modrt_dictionary(const modrt::capi::Allocator& a, modrt::Dictionary d) : alloc(a), dict(std::move(d)) {}
};
struct modrt_level {
  modrt::capi::Allocator alloc;
  std::atomic<int> refs{1};
  modrt::Level level;
  modrt_level(const modrt::capi::Allocator& a, modrt::Level l) : alloc(a), level(std::move(l)) {}
};

// A built clutter's operators (.modrtdrt) and where each object's texels start.
struct modrt_clutter {
  modrt::capi::Allocator alloc;
  std::atomic<int> refs{1};
  modrt::DrtOperators drt;
  std::vector<std::uint32_t> first_texel;  // per object, and the total at the end
  modrt_clutter(const modrt::capi::Allocator& a, modrt::DrtOperators d) : alloc(a), drt(std::move(d)) {
    std::uint32_t t = 0;
    for (const modrt::DrtObjectOperators& o : drt.objects) {
      first_texel.push_back(t);
      t += o.texel_count;
    }
    first_texel.push_back(t);
  }
};

namespace modrt::capi {
void retain(modrt_clutter* c);
void release(modrt_clutter* c);

// A whole file in memory from the hook (freed with the image).
struct FileImage {
  const Allocator* alloc = nullptr;
  std::byte* data = nullptr;
  std::size_t size = 0;
  ~FileImage() { alloc->release(data, size); }
};
modrt_status read_whole_file(const char* path, std::uint64_t max_bytes, FileImage& out);
// out non-null, data non-null unless size is 0; `function` starts the message.
modrt_status check_load_args(const char* function, const void* data, size_t size, void* out);

void retain(modrt_dictionary* d);
void release(modrt_dictionary* d);
void retain(modrt_level* l);
void release(modrt_level* l);
}  // namespace modrt::capi
