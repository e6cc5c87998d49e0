#!/usr/bin/env bash
# The streaming bench (docs/STREAMING.md, issue 16): builds what it needs (Release), renders an
# orbit of every scene, measures the vector encodings in process (vismap_stream_bench), rasterizes
# the frames with rsvg-convert, encodes them with ffmpeg (x264, x265) and writes
# bench/results/<date>-stream[-quick]/: results.csv, results.md, raw.jsonl, env.txt,
# plots/bytes_vs_triangles.svg. Frames, rasters and videos go to bench/out/stream/ (ignored).
#   bench/stream/run.sh [--quick] [--scenes cornell,teapot,cornell_armadillo,bunny,dragon]
#                       [--frames N] [--width W --height H] [--device NAME] [--out DIR]
#                       [--frames-dir DIR] [--clean]
# Needs rsvg-convert (librsvg2-bin) and ffmpeg/ffprobe with libx264 and libx265 (Debian's
# ffmpeg). VISMAP_BUILD_DIR picks another build folder.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
BUILD="${VISMAP_BUILD_DIR:-$ROOT/build}"
if [ ! -f "$BUILD/CMakeCache.txt" ]; then
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release
fi
if ! grep -q '^CMAKE_BUILD_TYPE:STRING=Release' "$BUILD/CMakeCache.txt"; then
  echo "stream: warning: $BUILD is not a Release build" >&2
fi
cmake --build "$BUILD" -j"$(nproc)" --target vismap_stream_bench
exec python3 "$ROOT/bench/stream/stream.py" --build "$BUILD" "$@"
