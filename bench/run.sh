#!/usr/bin/env bash
# The benchmark (docs/PERFORMANCE.md): builds what it needs (Release), generates the synthetic
# scenes into bench/scenes/, runs every scene and writes bench/results/<date>[-quick]/
# results.csv, sweep.csv, results.md, plots/*.svg.
#   bench/run.sh [--quick] [--scenes bunny,dragon] [--res 1024] [--runs N] [--no-cli] [--no-check]
# Needs /usr/bin/time (Debian package `time`). VISMAP_BUILD_DIR picks another build folder.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${VISMAP_BUILD_DIR:-$ROOT/build}"
if [ ! -f "$BUILD/CMakeCache.txt" ]; then
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release
fi
if ! grep -q '^CMAKE_BUILD_TYPE:STRING=Release' "$BUILD/CMakeCache.txt"; then
  echo "bench: warning: $BUILD is not a Release build" >&2
fi
cmake --build "$BUILD" -j"$(nproc)" --target vismap vismap_bench make_subdivided
[ -x /usr/bin/time ] || { echo "bench: /usr/bin/time missing (apt-get install time)" >&2; exit 1; }
exec python3 "$ROOT/bench/bench.py" --build "$BUILD" "$@"
