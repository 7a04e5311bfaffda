// SPDX-License-Identifier: MIT
// Which SIMD code paths this translation unit compiles (meshoptimizer-style detection block;
// simd_config_end.h undefines the macros again). MODRT_NO_SIMD builds the scalar twins only.
#pragma once

#if !defined(MODRT_NO_SIMD) && defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define MODRT_CPU_X86 1
// Per-function ISA: the file itself is compiled for the x86-64 baseline.
#define MODRT_TARGET_AVX2 __attribute__((target("avx2,fma")))
// The AVX2 GEMV reading binary16 matrices (run only when F16C is detected too).
#define MODRT_TARGET_AVX2_F16C __attribute__((target("avx2,fma,f16c")))
#define MODRT_TARGET_SSE41 __attribute__((target("sse4.1")))
#else
#define MODRT_CPU_X86 0
#endif

#if !defined(MODRT_NO_SIMD) && defined(__aarch64__)
#define MODRT_CPU_NEON 1  // Advanced SIMD is baseline on aarch64: no detection needed
#else
#define MODRT_CPU_NEON 0
#endif
