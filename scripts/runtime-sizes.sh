#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Builds the embeddable runtime library for x86-64 and, cross-compiled, for aarch64 (both
# runtime-only: core + cpu_neon + gles + platform + runtime) and prints the stripped sizes of
# libmodrt_runtime.so and of the static archives an app links, with the shared library's
# NEEDED entries. docs/embedding.md quotes its output.
#
#   scripts/runtime-sizes.sh [BUILD_TYPE]   # default MinSizeRel; build-rt-size/, build-rt-aarch64/
#
# aarch64: g++-aarch64-linux-gnu and qemu-user (scripts/install-deps.sh --cross); the cross-built
# C consumer (tests/consumer) runs under qemu-aarch64 against the cross-built library. Debian's multiarch libEGL
# for arm64 is not installed by the project, so the aarch64 library is built without
# context creation and without the eglGetProcAddress default (MODRT_PLATFORM_CONTEXTS=OFF,
# MODRT_RUNTIME_EGL=OFF): the app passes its GL loader (modrt_context_options.gl_loader), as
# an iOS app must anyway. The GL ES headers are architecture-independent and are exposed to
# the cross compiler through the build's cross-include directory (as glm is,
# cmake/cross/glm).
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"
build_type="${1:-MinSizeRel}"
jobs="$(nproc)"
((jobs > 4)) && jobs=4
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
common=(-DCMAKE_BUILD_TYPE="$build_type" -DMODRT_WERROR=ON -DMODRT_BUILD_PRECOMPUTE=OFF -DMODRT_BUILD_DEMO=OFF
  -DMODRT_BUILD_BENCH=OFF -DMODRT_BUILD_TESTS=OFF)

build() {  # build_dir, extra cmake args...
  local dir="$1"
  shift
  cmake -S . -B "$dir" "${common[@]}" "$@" >/dev/null
  cmake --build "$dir" --target modrt_runtime_shared modrt_runtime -j"$jobs" >/dev/null
}

report() {  # label, build_dir, strip tool, readelf tool
  local label="$1" dir="$2" strip_tool="$3" readelf_tool="$4"
  cp -L "$dir/lib/libmodrt_runtime.so" "$work/$label.so"
  "$strip_tool" --strip-unneeded "$work/$label.so"
  local archives=0 a
  for a in runtime gles platform cpu core; do
    if [[ -f "$dir/lib/libmodrt_$a.a" ]]; then
      cp "$dir/lib/libmodrt_$a.a" "$work/$label-$a.a"
      "$strip_tool" --strip-debug "$work/$label-$a.a"
      archives=$((archives + $(stat -c %s "$work/$label-$a.a")))
    fi
  done
  printf '%-8s %-12s libmodrt_runtime.so stripped %8d bytes (%.0f KiB); static archives (runtime+gles+platform+cpu+core, strip -g) %8d bytes (%.0f KiB)\n' \
    "$label" "$build_type" "$(stat -c %s "$work/$label.so")" "$(echo "$(stat -c %s "$work/$label.so") / 1024" | bc -l)" \
    "$archives" "$(echo "$archives / 1024" | bc -l)"
  echo "         NEEDED: $("$readelf_tool" -d "$work/$label.so" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p' | tr '\n' ' ')"
}

build build-rt-size
report x86-64 build-rt-size strip readelf

cross_dir=build-rt-aarch64
mkdir -p "$cross_dir/cross-include"
for h in GLES2 GLES3 KHR; do
  [[ -e "$cross_dir/cross-include/$h" ]] || ln -s "/usr/include/$h" "$cross_dir/cross-include/$h"
done
build "$cross_dir" -DCMAKE_TOOLCHAIN_FILE="$repo_root/cmake/toolchains/aarch64-linux-gnu.cmake" \
  -Dglm_DIR="$repo_root/cmake/cross/glm" -DMODRT_PLATFORM_CONTEXTS=OFF -DMODRT_RUNTIME_EGL=OFF
report aarch64 "$cross_dir" aarch64-linux-gnu-strip aarch64-linux-gnu-readelf

# The aarch64 library works: the C consumer, cross-built against it, under qemu.
aarch64-linux-gnu-gcc -std=c99 -Wall -Werror tests/consumer/main.c -Iruntime/include -L"$cross_dir/lib" \
  -lmodrt_runtime -lm -o "$work/consumer-aarch64"
QEMU_LD_PREFIX=/usr/aarch64-linux-gnu LD_LIBRARY_PATH="$repo_root/$cross_dir/lib" qemu-aarch64 \
  "$work/consumer-aarch64" tests/fuzz/corpus/dictionary/tiny_interfaces.modrt \
  tests/fuzz/corpus/level_file/maze11.modrtlevel
