// SPDX-License-Identifier: MIT
// LeakSanitizer suppressions for the test programs that load Mesa; the sanitizer runtime
// calls this hook at start-up (options in the environment still apply). OSMesa leaks by
// design: it never frees its per-format framebuffer list (OSMesaMakeCurrent) nor a small
// allocation of OSMesaCreateContextAttribs, even after OSMesaDestroyContext. The frame that
// allocated is in libOSMesa, which the fast unwinder always sees. The DRI driver and LLVM are
// listed for leaks reported while they are loaded. The slow unwinder
// (fast_unwind_on_malloc=0), which would see deeper into Mesa, deadlocks in llvmpipe's JIT
// (malloc inside libgcc's unwinder lock), so it is not used.

extern "C" {

__attribute__((used)) const char* __lsan_default_suppressions() {
  return "leak:libOSMesa.so\n"
         "leak:libEGL_mesa.so\n"
         "leak:swrast_dri.so\n"
         "leak:libgallium\n"
         "leak:libLLVM\n"
         "leak:libglapi.so\n";
}

}  // extern "C"
