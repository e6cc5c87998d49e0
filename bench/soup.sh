#!/usr/bin/env bash
# Dense penetrating soup (issues 15, 32): N random triangles of size 0.2 in the unit cube
# (tests/support/soup.h), rendered by the CLI at 1024x1024 under --memory-budget. Prints a
# markdown table: whole-process time, peak RSS, peak device memory, buckets, fragments, visible
# fragments, fragments per visible one, what the cull left out, entangled pairs, crossing entries.
# Cost should follow the output (the visible fragments), and memory stay under the budget.
#   bench/soup.sh [--sizes 1000,2000,5000,10000,20000] [--budget 256M] [--res 1024]
#                 [--vismap BIN]... [--plot OUT.svg] [--time-limit S]
# Each --vismap adds a build to compare (default: $BUILD/vismap); sizes are run smallest first,
# the builds alternated per size. --plot writes time against visible fragments (log-log), one
# series per build. VISMAP_BUILD_DIR picks the build folder (default build/, Release expected).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${VISMAP_BUILD_DIR:-$ROOT/build}"
SIZES=1000,2000,5000,10000,20000
BUDGET=256M
RES=1024
PLOT=
LIMIT=600
TOOLS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --sizes) SIZES="$2"; shift 2 ;;
    --budget) BUDGET="$2"; shift 2 ;;
    --res) RES="$2"; shift 2 ;;
    --vismap) TOOLS+=("$(realpath "$2")"); shift 2 ;;
    --plot) PLOT="$2"; shift 2 ;;
    --time-limit) LIMIT="$2"; shift 2 ;;
    *) echo "usage: bench/soup.sh [--sizes N,N,...] [--budget BYTES] [--res PX] [--vismap BIN]... [--plot OUT.svg] [--time-limit S]" >&2; exit 2 ;;
  esac
done
cmake --build "$BUILD" -j"$(nproc)" --target vismap make_soup >/dev/null
[ ${#TOOLS[@]} -gt 0 ] || TOOLS=("$BUILD/vismap")
[ -x /usr/bin/time ] || { echo "bench: /usr/bin/time missing (apt-get install time)" >&2; exit 1; }
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
for t in "${TOOLS[@]}"; do "$t" render "$ROOT/data/bunny.ply" -o "$WORK/warm.svg" 2>/dev/null; done  # kernel caches
echo "| build | triangles | budget | time s | peak RSS MB | device peak MB | buckets | fragments | visible | fragments / visible | culled | dropped | pairs | crossing entries |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
: > "$WORK/rows.tsv"
for n in ${SIZES//,/ }; do
  "$BUILD/bench/make_soup" "$n" "$WORK/soup$n.obj" --size 0.2 --seed 1
  for i in "${!TOOLS[@]}"; do
    if /usr/bin/time -f "TIME %e %M" "${TOOLS[$i]}" render "$WORK/soup$n.obj" -o "$WORK/out.svg" \
        --width "$RES" --height "$RES" --memory-budget "$BUDGET" --time-limit "$LIMIT" --stats \
        2>"$WORK/log"; then
      python3 - "$i" "$n" "$BUDGET" "$WORK/log" "$WORK/rows.tsv" <<'PY'
import re, sys
build, n, budget, log, rows = sys.argv[1], sys.argv[2], sys.argv[3], open(sys.argv[4]).read(), sys.argv[5]
def g(pat, cast=float):
    m = re.search(pat, log)
    return cast(m.group(1)) if m else float("nan")
t = re.search(r"TIME ([\d.]+) (\d+)", log)
num = r"(\d+)"
frags, vis = g("fragments " + num + ", visible", int), g("visible " + num, int)
cols = [build, n, budget, "%.2f" % float(t.group(1)), "%.0f" % (int(t.group(2)) / 1024),
        "%.1f" % g(r"device memory peak ([\d.]+) MB"), g(num + " bucket", int), frags, vis,
        "%.2f" % (frags / vis if vis else float("nan")), g(num + " screen triangles \\(cull\\)", int),
        g(num + " fragments \\(stopped", int), g("entangled pairs " + num, int),
        g("crossing entries " + num, int)]
print("| " + " | ".join(str(c) for c in cols) + " |")
open(rows, "a").write("%s\t%s\t%s\t%s\n" % (build, n, vis, t.group(1)))
PY
    else
      echo "| $i | $n | $BUDGET | failed: $(grep -v '^TIME' "$WORK/log" | tail -1) |"
    fi
  done
done
for i in "${!TOOLS[@]}"; do echo "build $i: ${TOOLS[$i]}"; done
if [ -n "$PLOT" ]; then
  python3 - "$WORK/rows.tsv" "$PLOT" "$ROOT/bench" "${TOOLS[@]}" <<'PY'
import sys
sys.path.insert(0, sys.argv[3])
import svgplot
rows = [l.split("\t") for l in open(sys.argv[1]).read().split("\n") if l]
tools = sys.argv[4:]
series = []
for i, tool in enumerate(tools):
    pts = [(float(r[2]), float(r[3])) for r in rows if r[0] == str(i)]
    series.append(("%s (%s)" % (tool.split("/")[-3] if tool.count("/") >= 2 else tool, i), pts, "line"))
svgplot.line_plot(sys.argv[2], "Dense penetrating soup, 1024^2, --memory-budget: time against output",
                  "visible fragments", "whole process s", series, logx=True, logy=True)
PY
  echo "plot: $PLOT"
fi
