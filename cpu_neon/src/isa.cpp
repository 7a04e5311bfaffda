// SPDX-License-Identifier: MIT
// ISA detection, done once (function-local statics) and forced by set_isa().
#include "modrt/cpu/isa.h"

#include "simd_config.h"

#if MODRT_CPU_X86
#include <cpuid.h>
#endif

namespace modrt::cpu {
namespace {

std::vector<Isa> detect() {
  std::vector<Isa> isas{Isa::scalar};
#if MODRT_CPU_X86
  __builtin_cpu_init();
  if (__builtin_cpu_supports("sse4.1")) isas.push_back(Isa::sse41);
  // GCC and Clang check the OS's XSAVE support (XGETBV) for AVX features here.
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) isas.push_back(Isa::avx2);
#endif
#if MODRT_CPU_NEON
  isas.push_back(Isa::neon);
#endif
  return isas;
}

const std::vector<Isa>& isas() {
  static const std::vector<Isa> list = detect();
  return list;
}

bool detect_f16c() {
#if MODRT_CPU_X86
  // CPUID leaf 1, ECX bit 29: clang 14 has no "f16c" for __builtin_cpu_supports (the fuzz
  // build of the C API failed on it). F16C is VEX-encoded, so the OS must enable AVX state too.
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  __builtin_cpu_init();
  return __get_cpuid(1, &eax, &ebx, &ecx, &edx) && (ecx & bit_F16C) != 0 && __builtin_cpu_supports("avx");
#else
  return false;
#endif
}

Isa& active() {
  static Isa isa = isas().back();
  return isa;
}

}  // namespace

const char* isa_name(Isa isa) {
  switch (isa) {
    case Isa::scalar: return "scalar";
    case Isa::sse41: return "sse41";
    case Isa::avx2: return "avx2";
    case Isa::neon: return "neon";
  }
  return "unknown";
}

std::vector<Isa> supported_isas() { return isas(); }

bool isa_supported(Isa isa) {
  for (Isa i : isas())
    if (i == isa) return true;
  return false;
}

Isa best_isa() { return isas().back(); }

Isa active_isa() { return active(); }

bool f16c_supported() {
  static const bool has = detect_f16c();
  return has;
}

namespace {
bool& f16c_use() {
  static bool use = f16c_supported();
  return use;
}
}  // namespace

bool f16c_active() { return f16c_use(); }

bool set_f16c(bool enabled) {
  if (enabled && !f16c_supported()) return false;
  f16c_use() = enabled;
  return true;
}

bool set_isa(Isa isa) {
  if (!isa_supported(isa)) return false;
  active() = isa;
  return true;
}

}  // namespace modrt::cpu

#include "simd_config_end.h"
