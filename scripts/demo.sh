#!/usr/bin/env bash
# Build modrt (Release, in build/) and run the relighting demo.
#
#   scripts/demo.sh [modrt-relight arguments...]
#
# On first use modrt-relight bakes the default dictionary into ~/.cache/modrt/ (this
# takes a while); later runs reuse it. The program runs from the repository root, so
# its default output lands in out/ there (out/lightmap.png). Same settings as the
# CMake preset "release".
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

scripts/install-deps.sh

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"

exec build/bin/modrt-relight "$@"
