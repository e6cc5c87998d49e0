#!/usr/bin/env bash
# Line drawings against other tools (docs/LINES.md, "Against other tools"; issue 20 part 5):
# vismap, OpenCASCADE's HLRBRep_PolyAlgo in both forms (bench/lines/occt_hlr.cpp) and Blender
# Freestyle's SVG exporter (bench/lines/freestyle.py), same camera, each scored by
# `vismap check --lines --lines-from`, one run.
#
#   bench/lines/setup.sh                        # blender, libocct-*-dev (opt-in)
#   cmake -S . -B build -DVISMAP_BENCH_PEERS=ON && cmake --build build --target vismap vismap_lines_prep vismap_occt_hlr
#   bench/lines/run.sh [RESULTS_DIR]            # default bench/results/2026-12-05-lines
#
# Times: the whole process, wall clock (GNU time), the median of 3 when the first run takes
# under 60 s, else that one run. A tool past TIME_LIMIT seconds (default 300) is DNF.
set -uo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$ROOT"
BUILD="${BUILD:-$ROOT/build}"
RES="${1:-$ROOT/bench/results/2026-12-05-lines}"
WORK="$ROOT/bench/out/lines"
SIZE="${SIZE:-1024}"
LIMIT="${TIME_LIMIT:-300}"
MEM_KB="${MEM_KB:-8000000}"   # address-space cap per peer process (this machine is shared)
mkdir -p "$RES" "$WORK"
SCENES=(
  "bunny=data/bunny.ply"
  "fandisk=../shared/data/cgal/fandisk.off"
  "mech-holes-shark=../shared/data/cgal/mech-holes-shark.off"
  "cornell_armadillo=data/scenes/cornell_armadillo.json"
  "dragon=data/dragon_vrip.ply.gz"
)
[ -n "${ONLY:-}" ] && SCENES=($(printf '%s\n' "${SCENES[@]}" | grep -E "^(${ONLY})="))
CSV="$RES/results.csv"
echo "scene,tool,status,wall_s,runs,svg_bytes,chains,recall,precision,line_px" > "$CSV"

# timed NAME CMD...: runs it (up to 3 times), sets STATUS and WALL.
timed() {
  local name=$1; shift
  local times=() t rc
  for i in 1 2 3; do
    ( ulimit -v "$MEM_KB"; /usr/bin/time -f "%e" -o "$WORK/$name.time" timeout "$LIMIT" "$@" ) \
      > "$WORK/$name.log" 2>&1
    rc=$?
    if [ $rc -ne 0 ]; then
      STATUS=$([ $rc -eq 124 ] && echo DNF || echo "failed($rc)"); WALL=""
      [ $rc -eq 124 ] && WALL="$LIMIT"
      return
    fi
    t=$(tail -1 "$WORK/$name.time"); times+=("$t")
    awk -v t="$t" 'BEGIN{exit !(t >= 60)}' && break
  done
  STATUS=ok
  WALL=$(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END{print a[int((NR+1)/2)]}')
  RUNS=${#times[@]}
}

{
  echo "date: $(date -u +%FT%TZ)"; echo "commit: $(git rev-parse --short HEAD)"
  echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2) x $(nproc)"
  echo "load: $(cut -d' ' -f1-3 /proc/loadavg) (shared machine)"
  echo "blender: $(blender --version 2>/dev/null | head -1)"
  echo "occt: $(dpkg-query -W -f='${Version}' libocct-foundation-dev 2>/dev/null)"
  echo "vismap device: $("$BUILD/vismap" devices 2>/dev/null | head -1)"
  echo "size: ${SIZE}x${SIZE}, time limit ${LIMIT} s, address space cap ${MEM_KB} KB"
} > "$RES/env.txt"

for entry in "${SCENES[@]}"; do
  name=${entry%%=*}; scene=${entry#*=}
  CAM=$("$BUILD/bench/vismap_lines_prep" "$scene" --width "$SIZE" --height "$SIZE" --obj "$WORK/$name.obj")
  echo "$name: $CAM" >> "$RES/env.txt"
  for tool in ${TOOLS:-vismap vismap_all occt_outline occt_faces freestyle}; do
    svg="$WORK/$name.$tool.svg"; rm -f "$svg"; RUNS=0
    case $tool in
      vismap) timed "$name.$tool" "$BUILD/vismap" render "$scene" -o "$svg" --style lines $CAM ;;
      # Everything the classification places, no selection (docs/LINES.md "Selection").
      vismap_all) timed "$name.$tool" "$BUILD/vismap" render "$scene" -o "$svg" --style lines $CAM \
                    --self-folds --crease-smooth off ;;
      occt_outline) timed "$name.$tool" "$BUILD/bench/vismap_occt_hlr" "$scene" $CAM --form outline -o "$svg" ;;
      occt_faces) timed "$name.$tool" "$BUILD/bench/vismap_occt_hlr" "$scene" $CAM --form faces -o "$svg" ;;
      freestyle) timed "$name.$tool" blender -b --factory-startup --python bench/lines/freestyle.py -- \
                   "$WORK/$name.obj" "$svg" $CAM ;;
    esac
    row="$name,$tool,$STATUS,$WALL,$RUNS"
    if [ "$STATUS" = ok ] && [ -s "$svg" ]; then
      "$BUILD/vismap" check "$scene" --no-reference --lines --lines-from "$svg" $CAM \
        > "$WORK/$name.$tool.check.json" 2> "$WORK/$name.$tool.check.log"
      row="$row,$(stat -c %s "$svg"),$(/usr/bin/python3 -c '
import json,sys; l=json.load(open(sys.argv[1]))["lines"]
print(",".join(str(l[k]) for k in ("chains","recall","precision","line_px")))' \
        "$WORK/$name.$tool.check.json")"
      rsvg-convert -b white -w 512 -h 512 "$svg" -o "$WORK/$name.$tool.png" 2>/dev/null || true
    else
      row="$row,,,,,"
    fi
    echo "$row" | tee -a "$CSV"
  done
done
/usr/bin/python3 "$ROOT/bench/lines/summarize.py" "$CSV" "$WORK" "$RES"
