# SPDX-License-Identifier: MIT
# bench_quick: modrt-bench's tiny CI suite (res 6 small bakes, single box, Cornell box,
# maze11, in-prior lights). Fails when MRT's in-prior relative L2 error against the path
# traced ground truth exceeds tests/bench_quick_thresholds.json (measured values + ~30%).
# GLES rows are left out here (their conformance is test_gles_backend's, and Mesa under
# ASan would need that test's leak suppressions).
# Included from tests/CMakeLists.txt inside if(MODRT_BUILD_PRECOMPUTE); needs the demo
# programs (MODRT_BUILD_DEMO).
if(TARGET modrt-bench)
  add_test(NAME bench_quick
           COMMAND modrt-bench --quick --backends cpu --check-thresholds tests/bench_quick_thresholds.json
           WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
  set_tests_properties(bench_quick PROPERTIES
                       ENVIRONMENT "MODRT_CACHE_DIR=${CMAKE_BINARY_DIR}/test-cache"
                       LABELS "bench" TIMEOUT 300)
endif()
