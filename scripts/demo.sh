#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Build modrt (Release, in build/) and run the offscreen demo, modrt-demo.
#
#   scripts/demo.sh [modrt-demo arguments...]      e.g. --backend cpu --frames 96
#
# On first use the demo bakes the default dictionary (res 16, kb 32) into ~/.cache/modrt/
# (this takes a few minutes on two cores); later runs load it from there. The program runs
# from the repository root, so its frames land in out/demo/ there (frame_NNNN.png, tone
# mapped, and frame_NNNN.exr, linear). Same settings as the CMake preset "release".
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

scripts/install-deps.sh

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"

exec build/bin/modrt-demo "$@"
