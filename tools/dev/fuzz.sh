#!/usr/bin/env bash
# Fuzzes the table readers and the spec parser with libFuzzer:
#   tools/dev/fuzz.sh [SECONDS]        (default 60 seconds per target)
# Configures a clang-14 build in build-fuzz (-DBRDF_FUZZ=ON, AddressSanitizer + UBSan, the whole
# project coverage-instrumented), builds fuzz_merl, fuzz_exr, fuzz_fourier, fuzz_spectral_exr,
# fuzz_rgl and fuzz_spec, and runs each for SECONDS on its seed corpus (read only; new inputs go to
# build-fuzz/corpus/NAME): tests/data/fuzz/{merl,exr,fourier,spectral_exr,rgl} for the readers,
# tests/data/specs/good for the spec parser, and for every target the malformed files of
# tests/data/bad (each seed lives in one place only). A crash, hang, leak or sanitizer report stops that target, leaves the
# input in build-fuzz/artifacts/NAME/, and makes the script exit 1 after the others have run.
# Keep each such input in tests/data/fuzz/regressions/ (named NAME-WHAT.ext, NAME in merl, exr,
# fourier, spectral, spec): test_fuzz_regressions replays it in every build once the bug is fixed.
# Needs the Debian packages clang-14 and libclang-rt-14-dev (tools/dev/install-deps.sh --fuzz).
# Environment: JOBS (build parallelism, default 1), BUILD (folder, default build-fuzz),
# CXX (default clang++-14).
set -euo pipefail

seconds="${1:-60}"
[[ "$seconds" =~ ^[0-9]+$ ]] || { echo "usage: $0 [SECONDS]" >&2; exit 2; }
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${BUILD:-$root/build-fuzz}"
cxx="${CXX:-clang++-14}"
command -v "$cxx" >/dev/null || {
  echo "fuzz.sh: $cxx not found; install clang-14 libclang-rt-14-dev (tools/dev/install-deps.sh --fuzz)" >&2
  exit 2
}

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER="$cxx" \
  -DBRDF_FUZZ=ON -DBRDF_SANITIZE=address,undefined -DCMAKE_CXX_FLAGS=-fsanitize=fuzzer-no-link \
  -DBRDF_BUILD_TESTS=OFF -DBRDF_BUILD_BENCH=OFF >/dev/null
cmake --build "$build" -j "${JOBS:-1}" --target fuzz_merl fuzz_exr fuzz_fourier fuzz_spectral_exr fuzz_rgl fuzz_spec

# Leaks are reported (detect_leaks); UBSan findings abort (-fno-sanitize-recover at build time).
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:allocator_may_return_null=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

failed=()
for name in merl exr fourier spectral_exr rgl spec; do
  corpus="$build/corpus/$name"
  artifacts="$build/artifacts/$name"
  mkdir -p "$corpus" "$artifacts"
  args=(-max_total_time="$seconds" -timeout=25 -rss_limit_mb=4096 -print_final_stats=1
        -artifact_prefix="$artifacts/")
  # A valid OpenEXR table is ~35 kB, the RGL seeds up to ~8 kB; the others stay small.
  [ "$name" = exr ] && args+=(-max_len=65536)
  [ "$name" = rgl ] && args+=(-max_len=16384)
  [ "$name" = spectral_exr ] && args+=(-max_len=65536)
  [ "$name" = spec ] && args+=(-dict="$root/tests/fuzz/spec.dict" -max_len=8192)
  echo "== fuzz_$name: $seconds s" >&2
  seeds="$root/tests/data/fuzz/$name"
  [ "$name" = spec ] && seeds="$root/tests/data/specs/good"
  if ! "$build/bin/fuzz_$name" "${args[@]}" "$corpus" "$seeds" "$root/tests/data/bad" \
       > "$build/fuzz_$name.log" 2>&1; then
    failed+=("$name")
    echo "fuzz.sh: fuzz_$name found a problem: see $build/fuzz_$name.log and $artifacts/" >&2
  fi
  tail -n 12 "$build/fuzz_$name.log" | grep -E '^(stat::|#|Done|==)' >&2 || true
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: findings in: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz.sh: no findings" >&2
