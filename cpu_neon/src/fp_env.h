// SPDX-License-Identifier: MIT
// modrt::cpu — flush-to-zero for the runtime's float work (private to cpu_neon).
//
// Subnormal floats (below FLT_MIN = 1.2e-38) are slow on some SIMD paths: x86 cores without
// full-speed subnormal support take a microcode assist per operation (measured here, AMD EPYC:
// the SSE4.1 frame 1.6x slower with an all-subnormal ld, AVX2 + FMA and the scalar double path
// unaffected; docs/robustness.md). Light that small is physically nothing, so while a
// CpuLevelRuntime computes, subnormal inputs read as 0 and subnormal results are written as 0:
//   x86-64   MXCSR FTZ (bit 15) and DAZ (bit 6), which govern SSE / AVX, the only float units
//            the runtime uses (x87 is never used on x86-64);
//   aarch64  FPCR.FZ (bit 24): flushes inputs and outputs of scalar and Advanced SIMD float.
// The guard saves the thread's control register and restores it on scope exit, writing it only
// when the bits differ, so a host application's own setting survives every call.
#pragma once

#include <cstdint>

#if defined(__x86_64__) || defined(_M_X64)
#include <xmmintrin.h>
#endif

namespace modrt::cpu {

class ScopedFlushDenormals {
 public:
  explicit ScopedFlushDenormals(bool enable) {
    if (!enable) return;
#if defined(__x86_64__) || defined(_M_X64)
    saved_ = _mm_getcsr();
    const std::uint64_t wanted = saved_ | kMxcsrFtzDaz;
    if (wanted != saved_) {
      _mm_setcsr(unsigned(wanted));
      changed_ = true;
    }
#elif defined(__aarch64__)
    std::uint64_t fpcr;
    __asm__ volatile("mrs %0, fpcr" : "=r"(fpcr));
    saved_ = fpcr;
    const std::uint64_t wanted = fpcr | kFpcrFz;
    if (wanted != saved_) {
      __asm__ volatile("msr fpcr, %0" : : "r"(wanted));
      changed_ = true;
    }
#endif
  }
  ~ScopedFlushDenormals() {
    if (!changed_) return;
#if defined(__x86_64__) || defined(_M_X64)
    _mm_setcsr(unsigned(saved_));
#elif defined(__aarch64__)
    __asm__ volatile("msr fpcr, %0" : : "r"(saved_));
#endif
  }
  ScopedFlushDenormals(const ScopedFlushDenormals&) = delete;
  ScopedFlushDenormals& operator=(const ScopedFlushDenormals&) = delete;

 private:
  static constexpr std::uint64_t kMxcsrFtzDaz = (1u << 15) | (1u << 6);
  static constexpr std::uint64_t kFpcrFz = std::uint64_t(1) << 24;
  std::uint64_t saved_ = 0;
  bool changed_ = false;
};

}  // namespace modrt::cpu
