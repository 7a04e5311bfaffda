// SPDX-License-Identifier: MIT
// egl_pbuffer: the default EGL display with a 1x1 pbuffer, for EGL implementations that have
// neither the device nor the surfaceless platform (older vendor drivers, some Android-like stacks).
#include "context_kinds.h"
#include "egl_common.h"

namespace modrt::platform::detail {

Result<std::unique_ptr<GlContext>> create_egl_pbuffer_context(const ContextOptions& options) {
  EglSetup setup;
  setup.kind = ContextKind::egl_pbuffer;
  setup.display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (setup.display == EGL_NO_DISPLAY)
    return Status::error(ErrorCode::internal_error, std::string(context_kind_name(ContextKind::egl_pbuffer)) +
                                                        ": " +
                                                        egl_failure("eglGetDisplay(EGL_DEFAULT_DISPLAY)"));
  setup.surface = EglSurfaceMode::pbuffer;
  setup.device = "default EGL display";
  return create_egl_context(setup, options);
}

}  // namespace modrt::platform::detail
