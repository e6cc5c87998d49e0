#!/usr/bin/env bash
# The cmp corpus: every output a refactor, a move or a speed-up must keep byte-identical.
#
#   bench/corpus.sh VISMAP OUTDIR [quick]     # render with the binary VISMAP into OUTDIR
#   cmp -s / diff -r OLD NEW                  # then compare two such folders
#
# What it renders (one file each, named after the scene and format):
# - the 54 files: the bunny, the teapot, the Cornell box with and without the armadillo,
#   dragon_bunnies and the 21 stiff scenes of data/stiff, each as SVG and as bin;
# - lines and the other writers on the bunny and the Cornell box (lines, fill+lines, --hidden,
#   pdf, eps, png, compact);
# - the bunny under --memory-budget 40M (buckets), the dragon as bin;
# - surfaces: the tea set patches, the Killeroo (Loop), the teapot stadium (made by
#   make_subdivided if bench/scenes lacks it);
# - implicits: the architecture model (3D) and its 2D slice at z = 1.
# "quick" leaves out the dragon, the stadium and the architecture model (the slow ones).
# Each render's stderr goes to OUTDIR/logs/ (not compared: it holds timings). PDF and EPS have
# their CreationDate blanked.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VISMAP="$(realpath "${1:?usage: corpus.sh VISMAP OUTDIR [quick]}")"
OUT="${2:?usage: corpus.sh VISMAP OUTDIR [quick]}"
QUICK="${3:-}"
SHARED="${VISMAP_SHARED_DATA:-$ROOT/../shared/data}"
BUILD="${VISMAP_BUILD_DIR:-$(dirname "$VISMAP")}"
mkdir -p "$OUT/logs"

render() {  # name, ext, then vismap render arguments after the scene
  local name="$1" ext="$2" scene="$3"
  shift 3
  if ! "$VISMAP" render "$scene" -o "$OUT/$name.$ext" "$@" 2> "$OUT/logs/$name.$ext.log"; then
    echo "corpus: $name.$ext failed (exit $?): $(tail -1 "$OUT/logs/$name.$ext.log")" >&2
    echo "failed" > "$OUT/$name.$ext.failed"
  fi
}

# The 54 files.
for pair in bunny:"$ROOT/data/bunny.ply" teapot:"$SHARED/teapot/teapot_c3d.obj" \
            cornell:"$ROOT/data/cornell_box/CornellBox-Original.obj" \
            cornell_armadillo:"$ROOT/data/scenes/cornell_armadillo.json" \
            dragon_bunnies:"$ROOT/data/scenes/dragon_bunnies.json"; do
  render "${pair%%:*}" svg "${pair#*:}"
  render "${pair%%:*}" bin "${pair#*:}"
done
for f in "$ROOT"/data/stiff/*.json; do
  n="stiff_$(basename "$f" .json)"
  render "$n" svg "$f"
  render "$n" bin "$f"
done

# Lines and the other writers.
for pair in bunny:"$ROOT/data/bunny.ply" cornell_armadillo:"$ROOT/data/scenes/cornell_armadillo.json"; do
  n="${pair%%:*}"
  s="${pair#*:}"
  render "${n}_lines" svg "$s" --style lines
  render "${n}_fill_lines" svg "$s" --style fill+lines
  render "${n}_hidden" svg "$s" --style lines --hidden
  render "$n" vmc "$s"
done
render bunny pdf "$ROOT/data/bunny.ply"
render bunny eps "$ROOT/data/bunny.ply"
render bunny png "$ROOT/data/bunny.ply"
render bunny_id svg "$ROOT/data/bunny.ply" --fill id
render bunny_budget40M bin "$ROOT/data/bunny.ply" --memory-budget 40M

# Surfaces.
render teaset_teapot bin "$SHARED/teapot/newell_teapot.patches"
render teaset_teacup svg "$SHARED/teapot/newell_teacup.patches"
render teaset_teaspoon svg "$SHARED/teapot/newell_teaspoon.patches"
render killeroo bin "$SHARED/killeroo/killeroo-simple.pbrt" --tolerance 6  # Loop level 1 (0.2 px is past the plan cap)

if [ "$QUICK" != quick ]; then
  render dragon bin "$ROOT/data/dragon_vrip.ply.gz"
  GEN="$ROOT/bench/scenes"
  if [ ! -f "$GEN/stadium.obj" ] || [ ! -f "$GEN/teapot_loop2.ply" ]; then
    [ -x "$BUILD/bench/make_subdivided" ] || { echo "corpus: no $BUILD/bench/make_subdivided" >&2; exit 1; }
    "$BUILD/bench/make_subdivided" --stadium "$GEN/stadium.obj"
    "$BUILD/bench/make_subdivided" "$SHARED/teapot/teapot_c3d.obj" "$GEN/teapot_loop2.ply" --levels 2 --weld
  fi
  render stadium bin "$GEN/teapot_stadium.json"
  render architecture bin "$ROOT/bench/implicit/architecture.json"
  slice="$OUT/logs/architecture_z1.sexp"
  sed 's/\bz\b/1.0/g' "$SHARED/implicit/mpr_architecture.sexp" > "$slice"
  render architecture_z1 svg "$slice" --bounds -19,-16,19,22
fi
# cairo stamps PDF and EPS with the time of writing (and ignores SOURCE_DATE_EPOCH): blank it.
for f in "$OUT"/*.pdf "$OUT"/*.eps; do
  [ -f "$f" ] && LC_ALL=C sed -i 's/CreationDate.*$/CreationDate (blanked by corpus.sh)/' "$f"
done
echo "corpus: $(find "$OUT" -maxdepth 1 -type f | wc -l) files in $OUT" >&2
