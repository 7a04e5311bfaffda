// SPDX-License-Identifier: MIT
// LeakSanitizer settings for the test programs that load Mesa.
//
// Suppressions: the sanitizer runtime calls this hook at start-up (options in the environment
// still apply). OSMesa leaks by design: it never frees its per-format framebuffer list
// (OSMesaMakeCurrent) nor a small allocation of OSMesaCreateContextAttribs, even after
// OSMesaDestroyContext. The frame that allocated is in libOSMesa, which the fast unwinder always
// sees. The DRI driver and LLVM are listed for leaks reported while they are loaded. The slow
// unwinder (fast_unwind_on_malloc=0), which would see deeper into Mesa, deadlocks in llvmpipe's
// JIT (malloc inside libgcc's unwinder lock), so it is not used.
//
// When the leak check runs: after the last test, not at exit. At exit LeakSanitizer's
// stop-the-world tracer runs while Mesa's exit handlers are ending llvmpipe's and the shader
// cache's threads, and it crashed there ("Tracer caught signal 11", a fatal error that fails a
// test that passed) in 3 of 174 GL tests in one CI run, twice each. After the last test every
// Mesa thread is parked on its queue, so the check sees a process that holds still; the check
// at exit then does nothing (LeakSanitizer checks once per process).

#include <gtest/gtest.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MODRT_TEST_LSAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) && !defined(MODRT_TEST_LSAN)
#define MODRT_TEST_LSAN 1
#endif

#ifdef MODRT_TEST_LSAN
#include <sanitizer/lsan_interface.h>
#endif

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

namespace {

#ifdef MODRT_TEST_LSAN
// Registered before any test runs; gtest tears environments down after the last test, in the
// reverse order of registration, so this may run before or after the GL context fixture's
// teardown (tests/gl_test_context.h): both are points where Mesa's threads are parked.
class LeakCheckAfterTheTests : public ::testing::Environment {
 public:
  void TearDown() override { __lsan_do_leak_check(); }
};
[[maybe_unused]] ::testing::Environment* const kLeakCheckAfterTheTests =
    ::testing::AddGlobalTestEnvironment(new LeakCheckAfterTheTests);
#endif

}  // namespace
