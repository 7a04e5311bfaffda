// SPDX-License-Identifier: MIT
// create_context and the kind names; the kinds themselves live in context_*.cpp.
#include "modrt/platform/gl_context.h"

#include <utility>

#include "context_kinds.h"

namespace modrt::platform {
namespace {

// selection_report is known only here, after the kind's factory returned; GlContext keeps
// info_ protected, and a member pointer named through a derived class reaches it without
// widening the public header.
struct SelectionReport : GlContext {
  static void set(GlContext& context, std::string report) {
    (context.*(&SelectionReport::info_)).selection_report = std::move(report);
  }
};

Result<std::unique_ptr<GlContext>> create_kind(ContextKind kind, const ContextOptions& options,
                                               bool auto_select) {
  switch (kind) {
    case ContextKind::egl_device:
      return detail::create_egl_device_context(options, /*hardware_only=*/auto_select);
    case ContextKind::egl_surfaceless: return detail::create_egl_surfaceless_context(options);
    case ContextKind::egl_pbuffer: return detail::create_egl_pbuffer_context(options);
    case ContextKind::osmesa: return detail::create_osmesa_context(options);
  }
  return Status::error(ErrorCode::invalid_argument, "unknown context kind");
}

}  // namespace

const char* context_kind_name(ContextKind kind) {
  switch (kind) {
    case ContextKind::egl_device: return "egl-device";
    case ContextKind::egl_surfaceless: return "egl-surfaceless";
    case ContextKind::egl_pbuffer: return "egl-pbuffer";
    case ContextKind::osmesa: return "osmesa";
  }
  return "unknown";
}

const char* context_request_name(ContextRequest request) {
  switch (request) {
    case ContextRequest::auto_select: return "auto";
    case ContextRequest::egl_device: return context_kind_name(ContextKind::egl_device);
    case ContextRequest::egl_surfaceless: return context_kind_name(ContextKind::egl_surfaceless);
    case ContextRequest::egl_pbuffer: return context_kind_name(ContextKind::egl_pbuffer);
    case ContextRequest::osmesa: return context_kind_name(ContextKind::osmesa);
  }
  return "unknown";
}

bool parse_context_request(const std::string& name, ContextRequest* out) {
  static constexpr ContextRequest kAll[] = {ContextRequest::auto_select, ContextRequest::egl_device,
                                            ContextRequest::egl_surfaceless, ContextRequest::egl_pbuffer,
                                            ContextRequest::osmesa};
  ContextRequest found = ContextRequest::auto_select;
  bool ok = name == "egl";
  if (ok) found = ContextRequest::egl_surfaceless;
  for (ContextRequest request : kAll) {
    if (!ok && name == context_request_name(request)) {
      found = request;
      ok = true;
    }
  }
  if (ok && out) *out = found;
  return ok;
}

Result<std::unique_ptr<GlContext>> create_context(ContextRequest request, const ContextOptions& options) {
  static constexpr ContextKind kAutoOrder[] = {ContextKind::egl_device, ContextKind::egl_surfaceless,
                                               ContextKind::egl_pbuffer, ContextKind::osmesa};
  if (request != ContextRequest::auto_select) {
    // ContextRequest lists the kinds in ContextKind's order after auto_select.
    const auto kind = static_cast<ContextKind>(static_cast<int>(request) - 1);
    auto context = create_kind(kind, options, /*auto_select=*/false);
    if (context) SelectionReport::set(*context.value(), std::string(context_kind_name(kind)) + ": chosen");
    return context;
  }
  std::string report;
  for (ContextKind kind : kAutoOrder) {
    auto context = create_kind(kind, options, /*auto_select=*/true);
    if (context) {
      SelectionReport::set(*context.value(), report + context_kind_name(kind) + ": chosen");
      return context;
    }
    report += context.status().message() + "\n";
  }
  return Status::error(ErrorCode::internal_error,
                       "no OpenGL ES 3 capable context could be created:\n" + report);
}

namespace detail {

void read_gl_strings(const GlFunctions& gl, ContextInfo* info) {
  auto text = [&](GLenum name) {
    const auto* s = reinterpret_cast<const char*>(gl.glGetString(name));
    return std::string(s ? s : "");
  };
  info->version = text(GL_VERSION);
  info->glsl_version = text(GL_SHADING_LANGUAGE_VERSION);
  info->renderer = text(GL_RENDERER);
  info->vendor = text(GL_VENDOR);
}

}  // namespace detail
}  // namespace modrt::platform
