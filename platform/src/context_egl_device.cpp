// SPDX-License-Identifier: MIT
// egl_device: EGL_EXT_platform_device, a GPU without any display server (NVIDIA's headless
// path, Mesa DRM render nodes). Mesa also lists a software device (EGL_MESA_device_software);
// auto_select skips it so that a real GPU, not llvmpipe, is what "egl-device" means there.
#include <string>
#include <vector>

#include "context_kinds.h"
#include "egl_common.h"

namespace modrt::platform::detail {
namespace {

struct DeviceEntry {
  EGLDeviceEXT device = nullptr;
  int index = 0;
  bool software = false;
  std::string description;
};

std::string describe(PFNEGLQUERYDEVICESTRINGEXTPROC query_string, EGLDeviceEXT device, int index, int count,
                     const char* extensions, bool software) {
  std::string text = "EGL device " + std::to_string(index) + " of " + std::to_string(count);
  if (software) text += ": Mesa software device (EGL_MESA_device_software)";
  if (extension_listed(extensions, "EGL_EXT_device_query_name")) {
    if (const char* renderer = query_string(device, EGL_RENDERER_EXT)) text += std::string(": ") + renderer;
  }
  if (extension_listed(extensions, "EGL_EXT_device_drm")) {
    if (const char* file = query_string(device, EGL_DRM_DEVICE_FILE_EXT))
      text += std::string(" (") + file + ")";
  }
  eglGetError();  // a refused optional query must not leak into a later error message
  return text;
}

}  // namespace

Result<std::unique_ptr<GlContext>> create_egl_device_context(const ContextOptions& options,
                                                             bool hardware_only) {
  const std::string name = context_kind_name(ContextKind::egl_device);
  auto fail = [&](const std::string& why) {
    return Status::error(ErrorCode::internal_error, name + ": " + why);
  };

  const std::string client = egl_client_extensions();
  if (!extension_listed(client.c_str(), "EGL_EXT_device_enumeration") &&
      !extension_listed(client.c_str(), "EGL_EXT_device_base"))
    return fail("EGL client extension EGL_EXT_device_enumeration is missing");
  if (!extension_listed(client.c_str(), "EGL_EXT_platform_device"))
    return fail("EGL client extension EGL_EXT_platform_device is missing");
  auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  auto query_string =
      reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
  if (!query_devices || !query_string) return fail("eglQueryDevicesEXT or eglQueryDeviceStringEXT not found");

  EGLint count = 0;
  if (!query_devices(0, nullptr, &count)) return fail(egl_failure("eglQueryDevicesEXT"));
  std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(count > 0 ? count : 0));
  if (count > 0 && !query_devices(count, devices.data(), &count))
    return fail(egl_failure("eglQueryDevicesEXT"));
  devices.resize(static_cast<std::size_t>(count > 0 ? count : 0));
  if (devices.empty()) return fail("no EGL devices");

  // Hardware devices first, in EGL's order; the software device only as an explicit request's fallback.
  std::vector<DeviceEntry> hardware, software;
  for (int i = 0; i < count; ++i) {
    EGLDeviceEXT device = devices[static_cast<std::size_t>(i)];
    const char* extensions = query_string(device, EGL_EXTENSIONS);
    if (!extensions) eglGetError();
    const bool is_software = extension_listed(extensions, "EGL_MESA_device_software");
    DeviceEntry entry{device, i, is_software,
                      describe(query_string, device, i, count, extensions, is_software)};
    (is_software ? software : hardware).push_back(std::move(entry));
  }
  std::vector<DeviceEntry> order = hardware;
  if (hardware.empty() && hardware_only)
    return fail("no hardware EGL device (only " + std::to_string(software.size()) + " Mesa software device" +
                (software.size() == 1 ? ")" : "s)"));
  if (!hardware_only) order.insert(order.end(), software.begin(), software.end());

  std::string reasons;
  for (const DeviceEntry& entry : order) {
    std::string error;
    EglSetup setup;
    setup.kind = ContextKind::egl_device;
    setup.display = egl_platform_display(EGL_PLATFORM_DEVICE_EXT, entry.device, &error);
    setup.device = entry.description;
    if (entry.software) setup.device += ", fallback: no hardware device worked";
    if (setup.display != EGL_NO_DISPLAY) {
      auto context = create_egl_context(setup, options);
      if (context) return context;
      error = context.status().message();
      if (error.rfind(name + ": ", 0) == 0) error.erase(0, name.size() + 2);
    }
    reasons += (reasons.empty() ? "" : "; ") + entry.description + ": " + error;
  }
  return fail(reasons.empty() ? "no usable EGL device" : reasons);
}

}  // namespace modrt::platform::detail
