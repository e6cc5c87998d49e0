#!/usr/bin/env bash
# Seed corpus for fuzz_load: small real files of every format, each prefixed with its format byte
# (the index in fuzz_load.cpp's names[]). Usage: fuzz/make_seeds.sh OUT_DIR
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$1"
mkdir -p "$out"
seed() {  # seed FORMAT_BYTE FILE
  [ -f "$2" ] || return 0
  { printf "\\x$(printf %02x "$1")"; head -c 65536 "$2"; } > "$out/$(basename "$2").$1"
}
seed 0 "$root/../shared/data/stanford/bun_zipper_res4.ply"
seed 2 "$root/data/scenes/quad.obj"
seed 2 "$root/data/stiff/t_junctions.obj"
seed 3 "$root/data/stiff/penetrating_tetra_triangle.off"
seed 5 "$root/data/scenes/triangle_camera.gltf"
seed 6 "$root/data/scenes/strip_fan.glb"
seed 7 "$root/data/scenes/two_quads.json"
printf '\x01' > "$out/empty_gz.1"
printf '\x04solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n' > "$out/ascii.stl.4"
