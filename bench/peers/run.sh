#!/bin/bash
# Whole-process times of `vismap render SCENE -o OUT.svg` against GL2PS on the same view
# (vismap_gl2ps_peer: its simple sort with occlusion culling, the simple sort alone, and the
# simple sort with OpenGL's back-face culling, GL2PS's fastest SVG), alternated in one run
# (issue 17 part 5, issue 32), at 1024^2.
#   bench/peers/run.sh [SCENE] [RUNS] [VISMAP] [VISMAP_B]
#   (defaults: data/bunny.ply, 5, build/vismap; VISMAP_B: a second build for an A/B)
# Needs build/bench/vismap_gl2ps_peer (bench/peers/setup.sh, then cmake -S . -B build again and
# build). Prints one line per run and the medians, in ms.
set -euo pipefail
cd "$(dirname "$0")/../.."
SCENE=${1:-data/bunny.ply}
RUNS=${2:-5}
TOOLS=("${3:-build/vismap}")
[ -n "${4:-}" ] && TOOLS+=("$4")
PEER=build/bench/vismap_gl2ps_peer
[ -x "$PEER" ] || { echo "no $PEER: run bench/peers/setup.sh, then cmake -S . -B build and build" >&2; exit 1; }
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
ms() { local t0 t1; t0=$(date +%s%N); "$@" > /dev/null; t1=$(date +%s%N); echo $(((t1 - t0) / 1000000)); }
median() { sort -n | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }
for t in "${TOOLS[@]}"; do "$t" render "$SCENE" -o "$TMP/warm.svg" > /dev/null; done  # kernel caches
names=(); for i in "${!TOOLS[@]}"; do names+=("vismap$i"); done; names+=(gl2ps_cull gl2ps_simple gl2ps_backface)
for n in "${names[@]}"; do : > "$TMP/$n"; done
for r in $(seq "$RUNS"); do
  line="run $r:"
  for i in "${!TOOLS[@]}"; do
    a=$(ms "${TOOLS[$i]}" render "$SCENE" -o "$TMP/vismap.svg"); echo "$a" >> "$TMP/vismap$i"
    line+=" ${TOOLS[$i]} $a ms,"
  done
  b=$(ms "$PEER" "$SCENE" "$TMP/gl2ps.svg"); echo "$b" >> "$TMP/gl2ps_cull"
  c=$(ms "$PEER" "$SCENE" "$TMP/gl2ps.svg" --no-cull); echo "$c" >> "$TMP/gl2ps_simple"
  d=$(ms "$PEER" "$SCENE" "$TMP/gl2ps.svg" --no-cull --back-faces); echo "$d" >> "$TMP/gl2ps_backface"
  echo "$line gl2ps simple+cull $b ms, gl2ps simple $c ms, gl2ps simple+back-face culling $d ms"
done
line="median ($SCENE):"
for i in "${!TOOLS[@]}"; do line+=" ${TOOLS[$i]} $(median < "$TMP/vismap$i") ms,"; done
echo "$line gl2ps simple+cull $(median < "$TMP/gl2ps_cull") ms, gl2ps simple $(median < "$TMP/gl2ps_simple") ms, gl2ps simple+back-face culling $(median < "$TMP/gl2ps_backface") ms"
