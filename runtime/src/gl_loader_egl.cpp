// SPDX-License-Identifier: MIT
// The default GL loader for GLES contexts: eglGetProcAddress, when the library is built with
// EGL (MODRT_RUNTIME_EGL). Without it the app passes its own (e.g. dlsym on iOS).
#if MODRT_RUNTIME_EGL
#include <EGL/egl.h>
#endif

namespace modrt::capi {

#if MODRT_RUNTIME_EGL
void* default_gl_loader(const char* name, void*) { return reinterpret_cast<void*>(eglGetProcAddress(name)); }
bool has_default_gl_loader() { return true; }
#else
void* default_gl_loader(const char*, void*) { return nullptr; }
bool has_default_gl_loader() { return false; }
#endif

}  // namespace modrt::capi
