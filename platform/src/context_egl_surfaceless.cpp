// SPDX-License-Identifier: MIT
// egl_surfaceless: Mesa's EGL_MESA_platform_surfaceless. Needs no display server and no
// device node: a DRM render node when Mesa finds one, else llvmpipe (the CI case).
#include "context_kinds.h"
#include "egl_common.h"

namespace modrt::platform::detail {

Result<std::unique_ptr<GlContext>> create_egl_surfaceless_context(const ContextOptions& options) {
  const std::string name = context_kind_name(ContextKind::egl_surfaceless);
  if (!extension_listed(egl_client_extensions().c_str(), "EGL_MESA_platform_surfaceless"))
    return Status::error(
        ErrorCode::internal_error,
        name + ": EGL client extension EGL_MESA_platform_surfaceless is missing (not Mesa's EGL?)");
  std::string error;
  EglSetup setup;
  setup.kind = ContextKind::egl_surfaceless;
  setup.display = egl_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, &error);
  if (setup.display == EGL_NO_DISPLAY) return Status::error(ErrorCode::internal_error, name + ": " + error);
  setup.surface = EglSurfaceMode::surfaceless_if_possible;
  setup.device = "surfaceless platform";
  return create_egl_context(setup, options);
}

}  // namespace modrt::platform::detail
