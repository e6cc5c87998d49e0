#!/usr/bin/env bash
# Dense penetrating soup (issue 15): N random triangles of size 0.2 in the unit cube
# (tests/support/soup.h), rendered by the CLI at 1024x1024 under --memory-budget. Prints a
# markdown table: whole-process time, peak RSS, peak device memory, buckets, fragments, visible
# fragments, entangled pairs, crossing entries. Cost should grow with the output, and memory stay
# under the budget.
#   bench/soup.sh [--sizes 1000,2000,5000,20000] [--budget 256M] [--res 1024]
# VISMAP_BUILD_DIR picks the build folder (default build/, Release expected).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${VISMAP_BUILD_DIR:-$ROOT/build}"
SIZES=1000,2000,5000,20000
BUDGET=256M
RES=1024
while [ $# -gt 0 ]; do
  case "$1" in
    --sizes) SIZES="$2"; shift 2 ;;
    --budget) BUDGET="$2"; shift 2 ;;
    --res) RES="$2"; shift 2 ;;
    *) echo "usage: bench/soup.sh [--sizes N,N,...] [--budget BYTES] [--res PX]" >&2; exit 2 ;;
  esac
done
cmake --build "$BUILD" -j"$(nproc)" --target vismap make_soup >/dev/null
[ -x /usr/bin/time ] || { echo "bench: /usr/bin/time missing (apt-get install time)" >&2; exit 1; }
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
echo "| triangles | budget | time s | peak RSS MB | device peak MB | buckets | fragments | visible | pairs | crossing entries | output triangles |"
echo "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for n in ${SIZES//,/ }; do
  "$BUILD/bench/make_soup" "$n" "$WORK/soup$n.obj" --size 0.2 --seed 1
  if /usr/bin/time -f "TIME %e %M" "$BUILD/vismap" render "$WORK/soup$n.obj" -o "$WORK/out.svg" \
      --width "$RES" --height "$RES" --memory-budget "$BUDGET" --stats 2>"$WORK/log"; then
    python3 - "$n" "$BUDGET" "$WORK/log" <<'PY'
import re, sys
n, budget, log = sys.argv[1], sys.argv[2], open(sys.argv[3]).read()
def g(pat, cast=float):
    m = re.search(pat, log)
    return cast(m.group(1)) if m else float("nan")
t = re.search(r"TIME ([\d.]+) (\d+)", log)
num = r"(\d+)"
cols = [n, budget, "%.2f" % float(t.group(1)), "%.0f" % (int(t.group(2)) / 1024),
        "%.1f" % g(r"device memory peak ([\d.]+) MB"), g(num + " bucket", int),
        g("fragments " + num + ", visible", int), g("visible " + num, int),
        g("entangled pairs " + num, int), g("crossing entries " + num, int),
        g("output: " + num + " triangles", int)]
print("| " + " | ".join(str(c) for c in cols) + " |")
PY
  else
    echo "| $n | $BUDGET | failed: $(grep -v '^TIME' "$WORK/log" | tail -1) |"
  fi
done
