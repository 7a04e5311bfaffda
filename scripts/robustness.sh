#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The robustness table of issue 9 (docs/robustness.md) in one command: builds the stress
# suite, runs `ctest -L stress` and turns the rows its tests print,
#   ROBUSTNESS|case|stage|value|bound|result
# into a markdown table on stdout (case, stage, measured value, bound asserted, result; rows
# with bound "report" are logged quantities such as an SVD's conditioning). The ctest log is
# kept in <build>/robustness.log. Exits non-zero when a stress test fails.
#
# Usage: scripts/robustness.sh [build-dir]
#   build-dir  an existing build tree, or a new one configured here (default: build-robustness,
#              RelWithDebInfo, without GLES, demo and benchmarks)
#   MODRT_JOBS parallel build jobs (default: nproc); MODRT_STRESS_FRAMES=100000 runs the
#              issue's full-length animated run (default 20 000 frames)
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-robustness}
jobs=${MODRT_JOBS:-$(nproc)}

if [[ ! -f "$build/CMakeCache.txt" ]]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMODRT_BUILD_GLES=OFF \
    -DMODRT_BUILD_DEMO=OFF -DMODRT_BUILD_BENCH=OFF >&2
fi
cmake --build "$build" --target test_stress test_stress_bake -j"$jobs" >&2

log="$build/robustness.log"
status=0
ctest --test-dir "$build" -L stress -V >"$log" 2>&1 || status=$?

echo "| case | stage | value | bound | result |"
echo "|---|---|---|---|---|"
# ctest -V prefixes each line of a test's output with "<test number>: ".
sed -n 's/^[0-9]*: ROBUSTNESS|\(.*\)$/\1/p' "$log" |
  awk -F'|' 'NF == 5 { printf "| %s | %s | %s | %s | %s |\n", $1, $2, $3, $4, $5 }'

rows=$(grep -c 'ROBUSTNESS|' "$log" || true)
failed=$(grep -c 'ROBUSTNESS|.*|FAIL$' "$log" || true)
summary=$(grep -E '^[0-9]+% tests passed' "$log" || true)
echo
echo "$rows rows, $failed failed; ctest: ${summary:-no summary (see $log)}"
exit "$status"
