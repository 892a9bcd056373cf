#!/usr/bin/env bash
# Builds the project with AddressSanitizer + UBSan and runs the test suite under them:
#   tools/dev/test-sanitized.sh [CTEST ARGS...]      (default: -LE slow)
# Build folder: build-asan (BUILD to change), RelWithDebInfo, -DBRDF_SANITIZE=address,undefined.
# Tests get LSAN_OPTIONS with tools/dev/lsan.supp (OpenCL/PoCL/LLVM leaks) from CMake
# (cmake/BrdfTesting.cmake); it is exported here as well, so that gtest's test discovery and any
# binary run by hand see the same suppressions. Exits with ctest's status (CI can call it); a test
# that failed only by LeakSanitizer's tracer crashing is rerun once first (lsan-tracer-crashes.py).
# Environment: JOBS (build parallelism, default 1), CTEST_JOBS (default 2), BUILD.
set -euo pipefail

root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${BUILD:-$root/build-asan}"
args=("$@")
[ ${#args[@]} -eq 0 ] && args=(-LE slow)

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DBRDF_SANITIZE=address,undefined -DBRDF_BUILD_BENCH=OFF
cmake --build "$build" -j "${JOBS:-1}"

export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$root/tools/dev/lsan.supp:print_suppressions=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# GCC 12's ASan cannot unmap its alternate signal stack when a thread it did not create exits
# (PoCL's device threads inside brdfd children): "CHECK failed: sanitizer_posix.cpp:61 unable to
# unmap". Not a finding in our code; running without the alternate stack avoids it.
export ASAN_OPTIONS="${ASAN_OPTIONS:-use_sigaltstack=0}"
cd "$build"
status=0
ctest --output-on-failure -j "${CTEST_JOBS:-2}" "${args[@]}" || status=$?
# A test that failed only because LeakSanitizer's own tracer crashed at exit is rerun once (and
# must pass then); any other failure stands (tools/dev/lsan-tracer-crashes.py).
if [ "$status" -ne 0 ] && python3 "$root/tools/dev/lsan-tracer-crashes.py" "$build"; then
  status=0
  ctest --output-on-failure --rerun-failed || status=$?
fi
exit "$status"
