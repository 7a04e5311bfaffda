// SPDX-License-Identifier: MIT
// modrt::cpu — instruction-set selection for the SIMD CPU backend (architecture.md §1, STYLE 3–5).
//
// Every kernel exists as a scalar twin that is always compiled, plus SSE4.1 and AVX2+FMA
// versions on x86-64 (per-function target attributes, no global -mavx2) and a NEON version
// on aarch64 (baseline there). Building with MODRT_NO_SIMD compiles the scalar twins only.
// The ISA is detected once, on first use, and can be forced for tests and comparisons.
#pragma once

#include <vector>

namespace modrt::cpu {

enum class Isa {
  scalar,  // plain C++; accumulates in double like the core reference
  sse41,   // x86-64 SSE4.1, 4 lanes, no FMA
  avx2,    // x86-64 AVX2 + FMA, 8 lanes
  neon,    // aarch64 Advanced SIMD, 4 lanes, FMA
};

// "scalar", "sse41", "avx2", "neon".
const char* isa_name(Isa isa);

// The ISAs this build was compiled with AND this CPU can run, scalar first, best last.
// With MODRT_NO_SIMD this is {Isa::scalar}.
std::vector<Isa> supported_isas();

// True when `isa` is in supported_isas().
bool isa_supported(Isa isa);

// The best supported ISA (the last entry of supported_isas()), detected once.
Isa best_isa();

// The ISA used by default (by CpuLevelRuntime when its options name none). Starts as
// best_isa(). Not synchronised: set it before starting threads that use the backend.
Isa active_isa();

// x86-64: whether this CPU (and build) has F16C, the half <-> float conversions that the AVX2
// float16 GEMV kernels use; detected once. Isa::avx2 does not imply it: without it those
// kernels run their SSE4.1 variant. False on other architectures and with MODRT_NO_SIMD.
bool f16c_supported();

// Whether the AVX2 float16 kernels use F16C now: starts as f16c_supported(). set_f16c(false)
// makes them run their SSE4.1 variant, as on a CPU without F16C (tests cover that path here);
// set_f16c(true) returns false, changing nothing, where F16C is not supported. Not
// synchronised, like set_isa().
bool f16c_active();
bool set_f16c(bool enabled);

// Forces the default ISA. Returns false (and changes nothing) when `isa` is not supported.
bool set_isa(Isa isa);

}  // namespace modrt::cpu
