// SPDX-License-Identifier: MIT
// Ends the scope of simd_config.h (included last in a .cpp).
#undef MODRT_CPU_X86
#undef MODRT_CPU_NEON
#undef MODRT_TARGET_AVX2
#undef MODRT_TARGET_AVX2_F16C
#undef MODRT_TARGET_SSE41
