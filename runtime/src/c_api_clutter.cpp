// SPDX-License-Identifier: MIT
// modrt_clutter: DRT clutter operators loaded from a .modrtdrt file or buffer (core's drt_io),
// their sizes and the texels' geometry. Setting one on a context: c_api_context.cpp.
#include <string>

#include "c_api_internal.h"
#include "modrt/drt_io.h"

namespace modrt::capi {

void retain(modrt_clutter* c) { c->refs.fetch_add(1, std::memory_order_relaxed); }
void release(modrt_clutter* c) {
  if (c->refs.fetch_sub(1, std::memory_order_acq_rel) == 1) destroy_handle(c);
}

namespace {

modrt_status make_clutter(std::span<const std::byte> bytes, const std::string& what, const Allocator& a,
                          modrt_clutter** out) {
  Result<DrtOperators> d = parse_drt(bytes, what);
  if (!d.ok()) return fail(d.status());
  *out = make_handle<modrt_clutter>(a, std::move(d).value());
  return MODRT_OK;
}

bool has_texel_geometry(const DrtOperators& drt) {
  for (const DrtObjectOperators& o : drt.objects)
    if (o.texel_count > 0 && o.texel_position.empty()) return false;
  return true;
}

bool has_texel_cells(const DrtOperators& drt) {
  for (const DrtObjectOperators& o : drt.objects)
    if (o.texel_count > 0 && o.texel_cell.empty()) return false;
  return true;
}

// The checks of a per-texel query: clutter and out given, one record per texel.
modrt_status check_texel_records(const char* fn, const modrt_clutter* clutter, const void* out,
                                 size_t count) {
  if (!clutter) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": clutter is null");
  if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out is null");
  const std::size_t texels = clutter->first_texel.back();
  if (count != texels)
    return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out has " + std::to_string(count) +
                                                  " records, the clutter has " + std::to_string(texels) +
                                                  " texels");
  return MODRT_OK;
}

}  // namespace
}  // namespace modrt::capi

using namespace modrt;
using namespace modrt::capi;

extern "C" {

modrt_status modrt_clutter_load_memory(const void* data, size_t size, const char* name,
                                       const modrt_allocator* allocator, modrt_clutter** out) {
  return guarded("modrt_clutter_load_memory", [&] {
    constexpr const char* fn = "modrt_clutter_load_memory";
    if (modrt_status s = check_load_args(fn, data, size, out); s != MODRT_OK) return s;
    *out = nullptr;
    Allocator a;
    if (modrt_status s = Allocator::from(fn, allocator, &a); s != MODRT_OK) return s;
    return make_clutter({static_cast<const std::byte*>(data), size}, name ? name : "clutter", a, out);
  });
}

modrt_status modrt_clutter_load_file(const char* path, const modrt_allocator* allocator,
                                     modrt_clutter** out) {
  return guarded("modrt_clutter_load_file", [&] {
    constexpr const char* fn = "modrt_clutter_load_file";
    if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out is null");
    *out = nullptr;
    if (!path) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": path is null");
    Allocator a;
    if (modrt_status s = Allocator::from(fn, allocator, &a); s != MODRT_OK) return s;
    FileImage image{&a};
    if (modrt_status s = read_whole_file(path, kMaxDrtFileBytes, image); s != MODRT_OK) return s;
    return make_clutter({image.data, image.size}, path, a, out);
  });
}

void modrt_clutter_destroy(modrt_clutter* clutter) {
  if (clutter) release(clutter);
}

modrt_status modrt_clutter_get_info(const modrt_clutter* clutter, modrt_clutter_info* out) {
  constexpr const char* fn = "modrt_clutter_get_info";
  return guarded(fn, [&] {
    if (!clutter) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": clutter is null");
    if (!out) return fail(MODRT_ERROR_INVALID_ARGUMENT, std::string(fn) + ": out is null");
    if (modrt_status s = check_struct_size(fn, "out", *out, "modrt_clutter_info"); s != MODRT_OK) return s;
    modrt_clutter_info info{};
    info.struct_size = sizeof info;
    info.object_count = std::uint32_t(clutter->drt.objects.size());
    info.texel_count = clutter->first_texel.back();
    info.has_texel_geometry = has_texel_geometry(clutter->drt) ? 1 : 0;
    *out = info;
    return MODRT_OK;
  });
}

modrt_status modrt_clutter_get_texels(const modrt_clutter* clutter, modrt_clutter_texel* out, size_t count) {
  constexpr const char* fn = "modrt_clutter_get_texels";
  return guarded(fn, [&] {
    if (modrt_status st = check_texel_records(fn, clutter, out, count); st != MODRT_OK) return st;
    if (!has_texel_geometry(clutter->drt))
      return fail(MODRT_ERROR_UNSUPPORTED, std::string(fn) +
                                               ": the clutter file records no texel positions: rebuild it "
                                               "(modrt-demo --save-clutter)");
    for (std::size_t k = 0; k < clutter->drt.objects.size(); ++k) {
      const DrtObjectOperators& o = clutter->drt.objects[k];
      for (std::uint32_t t = 0; t < o.texel_count; ++t) {
        modrt_clutter_texel& x = out[clutter->first_texel[k] + t];
        for (int a = 0; a < 3; ++a) {
          x.position[a] = o.texel_position[3 * std::size_t(t) + std::size_t(a)];
          x.normal[a] = o.texel_normal[3 * std::size_t(t) + std::size_t(a)];
        }
        x.object = std::uint32_t(k);
      }
    }
    return MODRT_OK;
  });
}

modrt_status modrt_clutter_get_texel_cells(const modrt_clutter* clutter, modrt_clutter_cell* out,
                                           size_t count) {
  constexpr const char* fn = "modrt_clutter_get_texel_cells";
  return guarded(fn, [&] {
    if (modrt_status st = check_texel_records(fn, clutter, out, count); st != MODRT_OK) return st;
    if (!has_texel_cells(clutter->drt))
      return fail(MODRT_ERROR_UNSUPPORTED, std::string(fn) +
                                               ": the clutter operators record no texel cells: rebuild them "
                                               "(modrt-demo --save-clutter)");
    for (std::size_t k = 0; k < clutter->drt.objects.size(); ++k) {
      const DrtObjectOperators& o = clutter->drt.objects[k];
      for (std::uint32_t t = 0; t < o.texel_count; ++t) {
        modrt_clutter_cell& x = out[clutter->first_texel[k] + t];
        x.object = std::uint32_t(k);
        x.face = o.texel_cell[3 * std::size_t(t)];
        x.u = o.texel_cell[3 * std::size_t(t) + 1];
        x.v = o.texel_cell[3 * std::size_t(t) + 2];
        x.res = o.cell_res;
      }
    }
    return MODRT_OK;
  });
}

}  // extern "C"
