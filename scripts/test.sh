#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Build modrt with warnings as errors and run the test suite.
#
#   scripts/test.sh                 # build-tests/: -O2 -g1, -DMODRT_WERROR=ON
#   scripts/test.sh --asan          # build-asan/:  clang, AddressSanitizer + UBSan, -O1 -g1, WERROR,
#                                   #   no benches; also the libFuzzer harnesses (scripts/fuzz.sh --reuse)
#   scripts/test.sh --scalar-clang  # build-scalar-clang/: clang, -DMODRT_NO_SIMD=ON, WERROR, no programs
#
# Exits non-zero if the configure, the build or any test fails. Same settings as the
# CMake presets "tests", "asan" and "scalar-clang".
set -euo pipefail

usage() {
  sed -n '3,10p' "$0" | sed 's/^# \{0,1\}//'
}

asan=0
scalar_clang=0
for arg in "$@"; do
  case "$arg" in
    --asan) asan=1 ;;
    --scalar-clang) scalar_clang=1 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "test.sh: unknown argument '$arg'" >&2; usage >&2; exit 2 ;;
  esac
done

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

scripts/install-deps.sh

# Debug information is line tables only (-g1): file:line in every backtrace and sanitizer
# report, at a fraction of full -g's compile and link time (CI's budget, .ci/run).
if ((asan)); then
  build_dir=build-asan
  # clang, with the libFuzzer harnesses and their coverage instrumentation in the same tree:
  # CI's fuzz step runs them from here (scripts/fuzz.sh --reuse build-asan) instead of
  # compiling the libraries a second time with the same sanitizers (budget: .ci/run).
  cmake_args=(
    -DCMAKE_BUILD_TYPE=RelWithDebInfo
    "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g1"
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1"
    -DCMAKE_C_COMPILER=clang
    -DCMAKE_CXX_COMPILER=clang++
    -DMODRT_FUZZ=ON
    -DMODRT_ASAN=ON
    -DMODRT_WERROR=ON
    -DMODRT_BUILD_TESTS=ON
    # The benchmark programs are timing tools; their code runs under ASan through bench_quick
    # nowhere else, and eight more sanitized links cost CI minutes (budget: .ci/run).
    -DMODRT_BUILD_BENCH=OFF
  )
  # Exported before the build too: gtest_discover_tests runs the test binaries then.
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
elif ((scalar_clang)); then
  # The second compiler and the scalar twins only: what GCC accepts clang may warn about, and
  # the suite must pass without any SIMD kernel (the scalar path is every SIMD test's reference).
  # The runtime an app compiles (core, cpu, runtime), precompute and their tests, configured
  # without the GLES backend: its tests are labelled gles and run in the other two builds, and
  # this build checks what an app configured with MODRT_BUILD_GLES=OFF gets (the GLES entries
  # refuse by name, test_runtime_without_gles). The demo and benchmark programs are GCC-only
  # here (CI's budget).
  build_dir=build-scalar-clang
  cmake_args=(
    -DCMAKE_BUILD_TYPE=RelWithDebInfo
    "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"
    -DCMAKE_C_COMPILER=clang
    -DCMAKE_CXX_COMPILER=clang++
    -DMODRT_NO_SIMD=ON
    -DMODRT_WERROR=ON
    -DMODRT_BUILD_TESTS=ON
    -DMODRT_BUILD_GLES=OFF
    -DMODRT_BUILD_DEMO=OFF
    -DMODRT_BUILD_BENCH=OFF
  )
else
  build_dir=build-tests
  cmake_args=(
    -DCMAKE_BUILD_TYPE=RelWithDebInfo
    "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"
    -DMODRT_WERROR=ON
    -DMODRT_BUILD_TESTS=ON
  )
fi

echo "test.sh: configuring $build_dir"
cmake -S . -B "$build_dir" "${cmake_args[@]}"
echo "test.sh: building $build_dir"
cmake --build "$build_dir" -j"$(nproc)"
echo "test.sh: running tests in $build_dir"
ctest_args=(--output-on-failure -j2 --timeout 900)
# The scalar-only build runs the CPU, core and program tests; the GL tests' CPU side is the
# same scalar reference the other tests check, and they ran in the default build.
((scalar_clang)) && ctest_args+=(--label-exclude gles)
# Under ASan a test that passed could die at exit when LeakSanitizer's stop-the-world tracer
# crashed (signal 11) while llvmpipe's threads shut down; the GL tests now run the leak check
# after their last test instead (tests/gl_sanitizer_options.cpp). The second run stays for
# any other exit-time flake; a real failure fails it too.
((asan)) && ctest_args+=(--repeat until-pass:2)
# Under ASan, the four longest numerical runs are left out (510 of the suite's ~1 500
# sanitized CPU seconds): the rank sweeps of the bake, the 2 000-frame drift run, the
# 1 000-iteration multi-bounce on maze41 and bench_quick repeat code that the shorter tests
# run under the sanitizers too; they check convergence, and run in the default build.
#
# Also left out under ASan, because the sanitizer finds nothing more in them than in their
# siblings that stay (the default build runs them all):
# - the GL tests on OSMesa and EGL device: the
#   same llvmpipe and the same modrt code as on EGL
#   surfaceless, which stays with every target format; only the platform class differs, and
#   its creation and teardown run under ASan in every surfaceless test (748 of the sanitized
#   suite's ~3 070 CPU seconds);
# - the SSE4.1 and AVX2 backends on one thread: their kernels run on two threads, and the
#   one-thread partition runs in the scalar backend (~125 s); the scalar backend on two threads:
#   its kernels run on one, and the two-thread partition with SSE4.1 and AVX2 (~75 s);
# - the accuracy comparisons against ray-traced references (DRT's five against the path tracer,
#   LevelAccuracy's against the one-bounce reference, the imported flat's against the path tracer
#   on its triangles): the tracers, the DRT build, the import and the demo's frame run under
#   ASan in the shorter DRT, path-tracer, level, import and demo tests (~190 s);
# - six numerical checks whose code runs sanitized in a shorter sibling (~480 sanitized CPU
#   seconds, measured by a local .ci/run): the dense spectral radii (the reduced operators'
#   build runs in every other ReducedFeedback test), the incremental DRT rebuild of a moved
#   object (DrtMesh's and DrtPrior's incremental rebuilds stay), exact skipping against the
#   full path (the two SkippingStaysWithinStatedBound tests stay), the quarter-turn symmetry
#   and the zero / non-zero response of a level (the other level tests build levels too),
#   and multi-bounce bounded for any albedo (the MultiBounceStepsMatchLevelMultiBounce tests stay);
# - the mirror-image and energy-bound sweeps of a level (~118 sanitized CPU seconds, CTestCostData
#   of a local .ci/run): they build and evaluate levels many times over, code every other level
#   test runs sanitized; what they check is numerical;
# - two checks whose calls run sanitized elsewhere (~105 sanitized CPU seconds, CTestCostData of a
#   local .ci/run): no allocation per frame (the same CpuLevelRuntime calls, every ISA, storage
#   and thread count, run in ThreadsAreBitIdentical, skipping in the SkippingStaysWithinStatedBound
#   tests; the counter is an operator new replacement, which ASan adds nothing to), and the
#   bilinear seam lookups (maze11's build and evaluation run in the other level tests; the lookups
#   are the test's own arithmetic);
# - the seven long frame sequences of the backend conformance suite (camera flight and camera skip
#   through maze41, skipping unchanged work, the converged solve, camera skip under feedback,
#   multi-bounce steps, converged frames that keep b0) on all but two backends, AVX2 on two
#   threads and GLES with fp16 operators: what these sequences exercise beyond the other
#   conformance tests is the frame pipeline's skip and solve logic, one C++ code for every
#   backend, while each backend's own kernels and passes run sanitized in the suite's other
#   tests (~350 of the sanitized suite's ~2 600 CPU seconds, measured by a local .ci/run).
# - DemoRender.AnimatedLightFollowsItsTrack: LeakSanitizer's tracer crashed in its leak check
#   after the last test ("Tracer caught signal 11"), both runs of a local CI; the animated
#   light's track and the DemoRun it drives run sanitized in the other DemoRender tests
#   (EveryLightLightsTheFrame, CpuDirectLightMatchesTheLdPass) and test_gltf_scene.
# GoogleTest tests are left out through GTEST_FILTER (gtest's glob patterns, '*' any text,
# matched against "Suite.Test" and, for parameterised tests, "Prefix/Suite.Test/param"); the
# tests that are programs (bench_quick, import_accuracy_flat) by ctest's exclude regex.
asan_excluded=(
  'ClosedAndDeadEnd/LowRank.RandomLightsMatchFAndBeatTruncatedSvd/*'
  'Stress.LongAnimatedRunDoesNotDrift'
  'LevelMultiBounce.FortyOneBlockMazeStaysBoundedOverThousandIterations'
  '*/egl_device*'
  '*/osmesa*'
  '*/sse41_1_thread*'
  '*/avx2_1_thread*'
  '*/scalar_2_threads*'
  'Drt.LowersTheError*'
  'Drt.MultiBounceLowersTheError*'
  'DrtMesh.LowersTheError*'
  'Drt.ConvergedGatherAgainstAManyBouncePathTracer'
  'LevelAccuracy.InterfaceTransportMatchesOneBounceReference'
  'DemoRender.AnimatedLightFollowsItsTrack'
  'LevelAccuracy.ResponseIsZeroWithoutAPathAndNonZeroWithOne'
  'ReducedFeedback.SpectralRadiiMatchTheDenseOperators'
  'Drt.IncrementalRebuildOfAMovedObjectEqualsAFullBuild'
  'CpuLevelRuntime.ExactSkippingIsBitIdenticalToFullPath'
  'LevelSymmetry.QuarterTurnGivesTheSameLightmapsUpToPermutation'
  'Stress.MultiBounceStaysBoundedForAnyAlbedo'
  'CpuLevelRuntime.NoAllocationPerFrame'
  'LevelSeams.BilinearLookupsAgreeAcrossEveryEdge'
  'LevelSymmetry.MirrorImageAgreesWithinDiscretisation'
  'LevelEnergy.IndirectNeverExceedsTheClosedBoxBoundAndGrowsWithDmax'
  # Brute-force references over many rays (numerics, no new code path: 30-50 s each under
  # ASan); the default build runs them.
  'LevelProbes.ProbesAroundACornerMatchBruteForceGather'
  'LevelVectorIrradiance.InterfaceResponseMatchesBruteForceOhlsh'
  'ReducedFeedback.IncrementalSolveAppliesFewerBlocksWithinTheBound'
  # GLES render-target formats: bits32 and float16 targets differ from float32 in shader code,
  # which ASan does not see; float32 and float16 operators (host-side packing) stay.
  '*/egl_surfaceless_bits32'
  '*/egl_surfaceless_float16_targets'
)
for sequence in CameraFlightThroughMaze41KeepsVisibleTilesExact CameraSkipKeepsEveryVisibleBlockExact \
  SkippingUnchangedWorkIsExact ConvergedUpdateMatchesLevelConvergedBounce \
  CameraSkipUnderFeedbackAndConvergedSolveIsExact MultiBounceStepsMatchLevelMultiBounce \
  ConvergedFramesRecomputeOnlyTheChangedB0Exactly; do
  for backend in reference scalar_1_thread sse41_2_threads egl_surfaceless_float32 egl_surfaceless_bits32 \
    egl_surfaceless_float16_targets; do
    asan_excluded+=("Backends/BackendConformance.$sequence/$backend")
  done
done
# hostile (114 s serial under ASan) and the embed host's scene check (89 s) run in the default
# build; the fuzz step runs every parser under ASan.
asan_excluded_programs='^(bench_quick|import_accuracy_flat|hostile|embed_host_scene_matches_demo)$'
if ((asan)); then
  # Each pattern must still name a test: a renamed test would otherwise come back under ASan
  # unnoticed, and a mistyped pattern leave nothing out.
  all_tests=$(for binary in "$build_dir"/bin/test_*; do
    "$binary" --gtest_list_tests | awk '/^[^ ]/ {suite = $1} /^  / {print suite $1}'
  done)
  excluded_count=0
  for pattern in "${asan_excluded[@]}"; do
    matches=0
    while IFS= read -r name; do
      # shellcheck disable=SC2053 # the pattern is a glob on purpose
      [[ $name == $pattern ]] && matches=$((matches + 1))
    done <<<"$all_tests"
    if ((matches == 0)); then
      echo "test.sh: the ASan exclusion '$pattern' matches no test" >&2
      exit 1
    fi
    excluded_count=$((excluded_count + matches))
  done
  echo "test.sh: left out under ASan: $excluded_count GoogleTest tests (some counted twice) and $asan_excluded_programs"
  GTEST_FILTER="-$(IFS=':'; echo "${asan_excluded[*]}")"
  export GTEST_FILTER
  ctest_args+=(--exclude-regex "$asan_excluded_programs")
fi
ctest --test-dir "$build_dir" "${ctest_args[@]}"
echo "test.sh: all tests passed ($build_dir)"
