// SPDX-License-Identifier: MIT
// The creator table of modrt/backends.h: one entry per BackendKind (bgfx's backend table).
#include <iterator>
#include <string>

#include "modrt/backends.h"
#include "modrt/cpu/cpu_backend.h"
#include "modrt/reference_backend.h"
#if MODRT_RUNTIME_GLES
#include "modrt/gles/gles_level_runtime.h"
#endif

namespace modrt {
namespace {

using Creator = Result<std::unique_ptr<Backend>> (*)(const BackendCreateInfo& info);

Result<std::unique_ptr<Backend>> create_cpu(const BackendCreateInfo& info) {
  cpu::CpuBackendOptions options;
  options.runtime.threads = info.threads;
  options.runtime.skip.enabled = info.skip_unchanged;  // every epsilon 0: exact
  options.probes = info.probes;
  options.timing = info.timing;
  return cpu::create_cpu_backend(*info.level, *info.dict, options);
}

Result<std::unique_ptr<Backend>> create_gles(const BackendCreateInfo& info) {
#if MODRT_RUNTIME_GLES
  if (!info.gl)
    return Status::error(ErrorCode::invalid_argument,
                         "create_backend(gles): BackendCreateInfo::gl is null: pass the current GL context's "
                         "functions (platform::GlContext::gl() or platform::load_gl_functions)");
  gles::GlesRuntimeOptions options;
  options.skip_unchanged = info.skip_unchanged;
  options.probes = info.probes;
  options.vector_irradiance = info.vector_irradiance;
  Result<std::unique_ptr<gles::GlesLevelRuntime>> rt =
      gles::GlesLevelRuntime::create(*info.gl, info.gles_context, *info.level, *info.dict, options);
  if (!rt.ok()) return rt.status();
  rt.value()->set_timing(info.timing);
  return std::unique_ptr<Backend>(std::move(rt).value());
#else
  (void)info;
  return Status::error(
      ErrorCode::invalid_argument,
      "create_backend(gles): this build has no GLES backend (configured with MODRT_BUILD_GLES=OFF)");
#endif
}

Result<std::unique_ptr<Backend>> create_reference(const BackendCreateInfo& info) {
  ReferenceBackendOptions options;
  options.probes = info.probes;
  options.skip_unchanged = info.skip_unchanged;
  return create_reference_backend(*info.level, *info.dict, options);
}

// Indexed by BackendKind.
constexpr Creator kCreators[] = {create_cpu, create_gles, create_reference};
static_assert(std::size(kCreators) == std::size_t(BackendKind::count), "one creator per BackendKind");

}  // namespace

Result<std::unique_ptr<Backend>> create_backend(BackendKind kind, const BackendCreateInfo& info) {
  const int k = int(kind);
  if (k < 0 || k >= int(BackendKind::count))
    return Status::error(ErrorCode::invalid_argument,
                         "create_backend: kind " + std::to_string(k) + " is not a backend");
  if (!info.level || !info.dict)
    return Status::error(
        ErrorCode::invalid_argument,
        std::string("create_backend(") + backend_kind_name(kind) + "): the level or dictionary is null");
  return kCreators[k](info);
}

}  // namespace modrt
