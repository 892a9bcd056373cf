#!/usr/bin/env bash
# Speed against error of every BRDF method (docs/speed-vs-error.md): builds bench/speed_vs_error, runs it
# on the analytic media and the example catalogue (spectrum "rgb"), then bench/speed_vs_error.py adds
# DISORT rows (pip install pydisort), draws bench/results/speed_vs_error.png and writes
# docs/speed-vs-error.md. About 15 minutes on 2 cores.
#   tools/dev/speed-vs-error.sh [BUILD_DIR]      (default: build-bench; JOBS=N for the build)
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build-bench}"
cd "$root"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$build" -j"${JOBS:-1}" --target speed_vs_error
mkdir -p bench/results
"$build/bin/speed_vs_error" --csv bench/results/speed_vs_error.csv \
    --reference-json bench/results/speed_vs_error_reference.json
python3 bench/speed_vs_error.py --csv bench/results/speed_vs_error.csv \
    --reference bench/results/speed_vs_error_reference.json \
    --png bench/results/speed_vs_error.png --doc docs/speed-vs-error.md
