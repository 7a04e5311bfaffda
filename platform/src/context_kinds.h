// SPDX-License-Identifier: MIT
// Private: one factory per context kind (each in its own file) and what they share.
#pragma once

#include <memory>

#include "modrt/platform/gl_context.h"

namespace modrt::platform::detail {

// Each returns a current context with its GL table and ContextInfo filled (except
// selection_report), or an error whose message starts with the kind's name.
// hardware_only: skip Mesa's software EGL device (what auto_select wants).
Result<std::unique_ptr<GlContext>> create_egl_device_context(const ContextOptions& options,
                                                             bool hardware_only);
Result<std::unique_ptr<GlContext>> create_egl_surfaceless_context(const ContextOptions& options);
Result<std::unique_ptr<GlContext>> create_egl_pbuffer_context(const ContextOptions& options);
Result<std::unique_ptr<GlContext>> create_osmesa_context(const ContextOptions& options);

// Reads GL_VERSION, GL_SHADING_LANGUAGE_VERSION, GL_RENDERER and GL_VENDOR of the current context.
void read_gl_strings(const GlFunctions& gl, ContextInfo* info);

}  // namespace modrt::platform::detail
