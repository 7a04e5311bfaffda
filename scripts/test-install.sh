#!/usr/bin/env bash
# The embeddable runtime as an app team gets it: configure a runtime-only build (no precompute,
# no programs), `cmake --install` it into a temporary prefix, then build and run the
# out-of-tree consumer (tests/consumer) against the installed package, through
# find_package(modrt) (shared and static library) and through pkg-config; and check that
# libmodrt_runtime.so needs only libc, libm, libstdc++, libEGL / libGLESv2 (readelf -d) and
# exports only modrt_* symbols.
#
#   scripts/test-install.sh            # build-rt-install/: RelWithDebInfo, -DMODRT_WERROR=ON
#   scripts/test-install.sh BUILD_DIR  # another build directory
#
# The consumer runs on a committed tiny dictionary and level (the fuzz seeds). Exits non-zero
# if anything fails.
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"
build_dir="${1:-build-rt-install}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
prefix="$work/prefix"
jobs="$(nproc)"
((jobs > 4)) && jobs=4

echo "test-install.sh: configuring the runtime-only build in $build_dir"
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMODRT_WERROR=ON \
  -DMODRT_BUILD_PRECOMPUTE=OFF -DMODRT_BUILD_DEMO=OFF -DMODRT_BUILD_BENCH=OFF -DMODRT_BUILD_TESTS=OFF
cmake --build "$build_dir" -j"$jobs"
echo "test-install.sh: installing into $prefix"
cmake --install "$build_dir" --prefix "$prefix"

dict="$repo_root/tests/fuzz/corpus/dictionary/tiny_interfaces.modrt"
level="$repo_root/tests/fuzz/corpus/level_file/maze11.modrtlevel"

echo "test-install.sh: find_package(modrt) consumer"
cmake -S tests/consumer -B "$work/consumer" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release
cmake --build "$work/consumer" -j"$jobs"
"$work/consumer/modrt_consumer" "$dict" "$level"
"$work/consumer/modrt_consumer_static" "$dict" "$level"

echo "test-install.sh: pkg-config consumer"
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig${PKG_CONFIG_PATH:+:$PKG_CONFIG_PATH}"
flags="$(pkg-config --cflags --libs modrt-runtime)"
echo "pkg-config --cflags --libs modrt-runtime: $flags"
# shellcheck disable=SC2086  # the flags are a word list
cc -std=c99 -Wall -Werror tests/consumer/main.c $flags -lm -o "$work/consumer_pc"
LD_LIBRARY_PATH="$prefix/lib" "$work/consumer_pc" "$dict" "$level"

echo "test-install.sh: dependencies of libmodrt_runtime.so"
lib="$prefix/lib/libmodrt_runtime.so"
needed="$(readelf -d "$lib" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')"
echo "$needed" | sed 's/^/  NEEDED /'
bad=0
while read -r so; do
  case "$so" in
    libc.so.* | libm.so.* | libstdc++.so.* | libEGL.so.* | libGLESv2.so.* | ld-linux-*.so.*) ;;
    *) echo "test-install.sh: libmodrt_runtime.so needs $so, which is not allowed" >&2; bad=1 ;;
  esac
done <<<"$needed"
exported="$(nm -D --defined-only "$lib" | awk '{print $3}')"
if grep -v '^modrt_' <<<"$exported"; then
  echo "test-install.sh: the symbols above are exported besides the modrt_* C API" >&2
  bad=1
fi
echo "  $(wc -l <<<"$exported") exported symbols, all modrt_*"
((bad == 0))

cp -L "$lib" "$work/stripped.so"
strip --strip-unneeded "$work/stripped.so"
echo "test-install.sh: libmodrt_runtime.so $(stat -L -c %s "$lib") bytes, stripped $(stat -c %s "$work/stripped.so") bytes"
echo "test-install.sh: all checks passed"
