#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The embeddable runtime as an app team gets it: configure a runtime-only build (no precompute,
# no programs), `cmake --install` it into a temporary prefix, then build and run the
# out-of-tree consumer (tests/consumer) against the installed package, through
# find_package(modrt) (shared and static library) and through pkg-config; and check that
# libmodrt_runtime.so needs only libc, libm, libstdc++, libEGL / libGLESv2 (readelf -d) and
# exports only modrt_* symbols.
#
# With --full-build DIR (a configured and built full tree, e.g. build-tests/ after
# scripts/test.sh), also: install it whole and build the consumer with COMPONENTS runtime while
# Embree, Eigen and TBB are made unfindable (-DCMAKE_DISABLE_FIND_PACKAGE_*): the runtime's
# package files must need none of them; and install only `--component runtime` of it and check
# that no precompute library, header or program comes along.
#
#   scripts/test-install.sh                          # build-rt-install/: RelWithDebInfo, WERROR
#   scripts/test-install.sh --full-build build-tests # and the full tree's install
#   scripts/test-install.sh BUILD_DIR                # another runtime-only build directory
#
# The consumer (plain C: its project enables no C++ compiler) runs on a committed tiny
# dictionary and level (the fuzz seeds); its GPU half (tests/consumer/gpu.c) renders ld in its
# own EGL context and samples the GLES context's atlas and probe textures in its own shaders.
# Exits non-zero if anything fails.
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"
build_dir=build-rt-install
full_build=""
while (($#)); do
  case "$1" in
    --full-build) full_build="${2:?--full-build needs a build directory}"; shift 2 ;;
    -h | --help) sed -n '3,23p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "test-install.sh: unknown option '$1'" >&2; exit 2 ;;
    *) build_dir="$1"; shift ;;
  esac
done
if [[ -n $full_build && ! -f $full_build/cmake_install.cmake ]]; then
  echo "test-install.sh: --full-build $full_build: not a configured build directory (run scripts/test.sh)" >&2
  exit 2
fi
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
# Operators of the DRT fuzz seed: valid structure for the tiny dictionary's kb, built for no
# level (the full-build run below also gives the consumer a scene's own clutter).
clutter="$repo_root/tests/fuzz/corpus/drt_file/two_objects.modrtdrt"

echo "test-install.sh: find_package(modrt) consumer"
cmake -S tests/consumer -B "$work/consumer" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release
cmake --build "$work/consumer" -j"$jobs"
"$work/consumer/modrt_consumer" "$dict" "$level" "$clutter"
"$work/consumer/modrt_consumer_static" "$dict" "$level" "$clutter"
# The GPU half: the consumer's own EGL context and ld pass, the GLES context's textures sampled
# in its own shaders, against a CPU context (exit 77: no EGL surfaceless GLES 3 context here).
if [[ -x $work/consumer/modrt_consumer_gpu ]]; then
  rc=0
  "$work/consumer/modrt_consumer_gpu" "$dict" "$level" || rc=$?
  if ((rc == 77)); then
    echo "test-install.sh: modrt_consumer_gpu skipped: no EGL surfaceless GLES 3 context"
  elif ((rc != 0)); then
    exit "$rc"
  fi
else
  echo "test-install.sh: modrt_consumer_gpu not built (pkg-config egl glesv2 not found)" >&2
  exit 1
fi

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

if [[ -n $full_build ]]; then
  echo "test-install.sh: the full tree $full_build, installed whole"
  full_prefix="$work/full-prefix"
  cmake --install "$full_build" --prefix "$full_prefix" >/dev/null
  for f in lib/libmodrt_precompute.a lib/cmake/modrt/modrtPrecomputeTargets.cmake bin/modrt-bake bin/modrt-demo \
    bin/modrt-embed-host lib/modrt/libmodrt_image_io.so; do
    [[ -e $full_prefix/$f ]] || { echo "test-install.sh: the full install lacks $f" >&2; exit 1; }
  done
  echo "test-install.sh: COMPONENTS runtime with Embree, Eigen and TBB unfindable"
  cmake -S tests/consumer -B "$work/consumer-full" -DCMAKE_PREFIX_PATH="$full_prefix" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_DISABLE_FIND_PACKAGE_embree=ON -DCMAKE_DISABLE_FIND_PACKAGE_Eigen3=ON -DCMAKE_DISABLE_FIND_PACKAGE_TBB=ON
  cmake --build "$work/consumer-full" -j"$jobs"
  "$work/consumer-full/modrt_consumer" "$dict" "$level"
  "$work/consumer-full/modrt_consumer_static" "$dict" "$level"
  # The consumer on one scene's own assets, made by the installed tools as an app's asset
  # pipeline makes them (the fuzz seed above fits the tiny level's layout but was built for no
  # level): a small dictionary (embed_host_scene.sh's settings), host_room's level, and the DRT
  # operators modrt-demo builds for host_room's clutter (--save-clutter).
  echo "test-install.sh: the consumer on host_room's own level and clutter, made by the installed tools"
  assets="$work/host_room"
  mkdir -p "$assets"
  "$full_prefix/bin/modrt-bake" -o "$assets/dict.modrt" --res 8 --rays 1024 --sh-rays 256 --probe-grid 2 \
    --lightfield-spatial 6 --lightfield-directional 12 --response-rays 1024 >"$assets/bake.log"
  "$full_prefix/bin/modrt-level" --level data/scenes/host_room.level.json --dictionary "$assets/dict.modrt" \
    --save "$assets/host_room.modrtlevel" --out "$assets/level_out" >"$assets/level.log"
  "$full_prefix/bin/modrt-demo" --scene data/scenes/host_room.gltf --dictionary "$assets/dict.modrt" \
    --size 64x36 --frames 1 --drt-rays 64 --save-clutter "$assets/host_room.modrtdrt" --no-exr \
    --out "$assets/demo" >"$assets/demo.log" 2>&1 || { cat "$assets/demo.log"; exit 1; }
  [[ -s $assets/demo/frame_0000.png ]] || { echo "test-install.sh: the installed modrt-demo wrote no PNG" >&2; exit 1; }
  "$work/consumer-full/modrt_consumer" "$assets/dict.modrt" "$assets/host_room.modrtlevel" \
    "$assets/host_room.modrtdrt"
  # Its GPU half with the clutter: the clutter lightmap texture sampled at the texels' coordinates.
  rc=0
  "$work/consumer-full/modrt_consumer_gpu" "$assets/dict.modrt" "$assets/host_room.modrtlevel" \
    "$assets/host_room.modrtdrt" || rc=$?
  ((rc == 0 || rc == 77)) || exit "$rc"
  # The installed example host finds the shared runtime next to it (RPATH $ORIGIN/../lib).
  # (ldd's output kept first: grep -q stopping early would make a pipe fail under pipefail.)
  embed_host_libs="$(ldd "$full_prefix/bin/modrt-embed-host")"
  if grep -q "libmodrt_runtime.so.* => $full_prefix/" <<<"$embed_host_libs"; then
    echo "  modrt-embed-host loads $full_prefix/lib/libmodrt_runtime.so"
  else
    grep modrt <<<"$embed_host_libs" >&2
    echo "test-install.sh: the installed modrt-embed-host does not load the installed runtime" >&2
    exit 1
  fi

  echo "test-install.sh: the full tree $full_build, --component runtime only"
  rt_prefix="$work/runtime-prefix"
  cmake --install "$full_build" --prefix "$rt_prefix" --component runtime >/dev/null
  extra="$(cd "$rt_prefix" && find . \( -path ./bin -o -name '*precompute*' -o -path '*/modrt/precompute' \) -print)"
  if [[ -n $extra ]]; then
    echo "$extra" >&2
    echo "test-install.sh: --component runtime installed the files above" >&2
    exit 1
  fi
  cmake -S tests/consumer -B "$work/consumer-rt" -DCMAKE_PREFIX_PATH="$rt_prefix" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_DISABLE_FIND_PACKAGE_embree=ON -DCMAKE_DISABLE_FIND_PACKAGE_Eigen3=ON -DCMAKE_DISABLE_FIND_PACKAGE_TBB=ON
  cmake --build "$work/consumer-rt" -j"$jobs"
  "$work/consumer-rt/modrt_consumer_static" "$dict" "$level"
fi

cp -L "$lib" "$work/stripped.so"
strip --strip-unneeded "$work/stripped.so"
echo "test-install.sh: libmodrt_runtime.so $(stat -L -c %s "$lib") bytes, stripped $(stat -c %s "$work/stripped.so") bytes"
echo "test-install.sh: all checks passed"
