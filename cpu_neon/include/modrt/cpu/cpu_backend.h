// SPDX-License-Identifier: MIT
// modrt::cpu — CpuLevelRuntime behind the Backend interface (modrt/backend.h), so a caller
// switches between the CPU and GLES backends by a flag. It keeps the lightmap, atlas and
// probes in CPU memory; update() fills all three (probes only when the dictionary has them and
// CpuBackendOptions::probes is on).
// read_vector_lightmap() computes the vector irradiance of the last update on request.
#pragma once

#include <memory>

#include "modrt/backend.h"
#include "modrt/cpu/cpu_level_runtime.h"

namespace modrt::cpu {

struct CpuBackendOptions {
  CpuRuntimeOptions runtime;
  bool probes = true;   // compute the volume probes in every evaluation (when the dictionary has them)
  bool timing = false;  // stage_times() from the steady clock (Backend::set_timing)
};

// `level` and `dict` are borrowed and must outlive the backend.
Result<std::unique_ptr<Backend>> create_cpu_backend(const Level& level, const Dictionary& dict,
                                                    const CpuBackendOptions& options);
Result<std::unique_ptr<Backend>> create_cpu_backend(const Level& level, const Dictionary& dict,
                                                    const CpuRuntimeOptions& options = {});

}  // namespace modrt::cpu
