#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Cross-build the embeddable runtime (core, cpu_neon with its NEON kernels) and its tests for
# aarch64 with g++-aarch64-linux-gnu, and run them under qemu-aarch64.
#
#   scripts/test-aarch64.sh        # build-aarch64/: RelWithDebInfo, -DMODRT_WERROR=ON
#
# GoogleTest is built from Debian's sources (/usr/src/googletest) with the cross compiler;
# GLM and Eigen are header-only. Precompute (Embree), GLES and the programs are host-only and
# not built. Exits non-zero if anything fails.
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

scripts/install-deps.sh --cross

build_dir=build-aarch64
toolchain="$repo_root/cmake/toolchains/aarch64-linux-gnu.cmake"
staging="$repo_root/$build_dir/staging"

if [[ ! -f "$staging/lib/cmake/GTest/GTestConfig.cmake" ]]; then
  echo "test-aarch64.sh: building GoogleTest for aarch64"
  cmake -S /usr/src/googletest -B "$build_dir/googletest" -DCMAKE_TOOLCHAIN_FILE="$toolchain" \
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$staging" -DBUILD_GMOCK=OFF
  cmake --build "$build_dir/googletest" -j"$(nproc)"
  cmake --install "$build_dir/googletest"
fi

echo "test-aarch64.sh: configuring $build_dir"
cmake -S . -B "$build_dir/modrt" -DCMAKE_TOOLCHAIN_FILE="$toolchain" \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMODRT_WERROR=ON \
  -DMODRT_BUILD_PRECOMPUTE=OFF -DMODRT_BUILD_GLES=OFF -DMODRT_BUILD_DEMO=OFF -DMODRT_BUILD_BENCH=OFF \
  -DGTest_DIR="$staging/lib/cmake/GTest" -Dglm_DIR="$repo_root/cmake/cross/glm" \
  -DEigen3_DIR=/usr/share/eigen3/cmake
echo "test-aarch64.sh: building"
cmake --build "$build_dir/modrt" -j"$(nproc)"
echo "test-aarch64.sh: running the tests under qemu-aarch64"
ctest --test-dir "$build_dir/modrt" --output-on-failure -j2 --timeout 900
echo "test-aarch64.sh: all aarch64 tests passed"
