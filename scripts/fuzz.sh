#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Build the libFuzzer harnesses with clang (build-fuzz/) and run each for a bounded time on
# a copy of its seed corpus (tests/fuzz/corpus/<name>), printing libFuzzer's execution count.
# A crash, leak or sanitizer report fails the script; the reproducer is left in
# build-fuzz/artifacts/ (turn it into a regression test).
#
#   scripts/fuzz.sh [seconds per fuzzer, default 60]
#   scripts/fuzz.sh --reuse build-asan [seconds]   # the harnesses of scripts/test.sh --asan's
#                                                  # tree (clang, MODRT_FUZZ=ON), no second build
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

build=build-fuzz
reuse=0
if [[ ${1:-} == --reuse ]]; then
  build="${2:?fuzz.sh: --reuse needs a build directory}"
  reuse=1
  shift 2
fi
seconds="${1:-60}"
harnesses=(fuzz_dictionary fuzz_level_file fuzz_drt_file fuzz_drt_state fuzz_level_json fuzz_gltf fuzz_scene_import fuzz_settings fuzz_c_api)

scripts/install-deps.sh
if ((reuse)); then
  if ! grep -q '^MODRT_FUZZ:BOOL=ON' "$build/CMakeCache.txt" 2>/dev/null; then
    echo "fuzz.sh: $build is not a MODRT_FUZZ=ON build (scripts/test.sh --asan makes one)" >&2
    exit 2
  fi
else
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DMODRT_FUZZ=ON -DMODRT_BUILD_GLES=OFF -DMODRT_BUILD_TESTS=OFF -DMODRT_BUILD_DEMO=OFF -DMODRT_BUILD_BENCH=OFF
fi
cmake --build "$build" -j"$(nproc)" --target "${harnesses[@]}"
mkdir -p "$build/artifacts"
for name in dictionary level_file drt_file drt_state level_json gltf scene_import settings c_api; do
  corpus_name="$name"
  [[ $name == level_json ]] && corpus_name=level
  work="$build/corpus-$name"
  rm -rf "$work"
  mkdir -p "$work"
  if [[ -d "tests/fuzz/corpus/$corpus_name" ]]; then cp "tests/fuzz/corpus/$corpus_name"/* "$work"/; fi
  # Reproducers of earlier findings are replayed first (tests/data/fuzz_regressions/fuzz_<name>_*).
  for f in tests/data/fuzz_regressions/fuzz_"$name"_*; do [[ -e $f ]] && cp "$f" "$work"/; done
  echo "=== fuzz_$name: ${seconds} s"
  # rss_limit/malloc_limit: a parser must refuse a huge size before allocating it.
  log="$build/fuzz_$name.log"
  status=0
  ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    "$build/bin/fuzz_$name" -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -timeout=10 -print_final_stats=1 -artifact_prefix="$build/artifacts/$name-" "$work" >"$log" 2>&1 ||
    status=$?
  grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb|^INFO: seed corpus|^Done" "$log" || true
  if [[ $status -ne 0 ]]; then
    tail -60 "$log" >&2
    echo "=== fuzz_$name: FAILED (exit $status), artifacts in $build/artifacts/" >&2
    exit 1
  fi
done
echo "=== fuzz: all harnesses ran ${seconds} s without a finding"
