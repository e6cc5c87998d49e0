#!/usr/bin/env bash
# Seed corpora for the fuzzers. Usage: fuzz/make_seeds.sh OUT_DIR [load|compact|delta]
#   load (default): fuzz_load's, small real files of every format, each prefixed with its format
#     byte (the index in fuzz_load.cpp's names[]), written here so that every reader has seeds
#     without ../shared/data;
#   compact: fuzz_compact's, the test vectors and the decoder's regressions;
#   delta: fuzz_delta's, the vectors' delta frames (each applied after their keyframe).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$1"
kind="${2:-load}"
mkdir -p "$out"
vectors="$root/proto/vectors"
if [ "$kind" = compact ]; then
  cp "$vectors"/*.vmc "$out/"
  # Issue 35, case 8 (stream.Compact.CountsAreCheckedAgainstTheBytesBeforeAllocating): a header
  # that claims 2^28 triangles (the word at byte 28) or 2^24 meshes (byte 32) over small sections.
  word() {  # word FILE OFFSET BYTES (little-endian, as printf escapes)
    printf "$3" | dd of="$1" bs=1 seek="$2" conv=notrunc status=none
  }
  cp "$vectors/compact_cornell.vmc" "$out/claims_2e28_triangles.vmc"
  word "$out/claims_2e28_triangles.vmc" 28 '\x00\x00\x00\x10'
  cp "$vectors/compact_cornell.vmc" "$out/claims_2e24_meshes.vmc"
  word "$out/claims_2e24_meshes.vmc" 32 '\x00\x00\x00\x01'
  exit 0
fi
if [ "$kind" = delta ]; then
  cp "$vectors/delta_cornell_1.vmd" "$vectors/delta_cornell_2.vmd" "$vectors/delta2_torus_3.vmd" \
     "$vectors/delta2_torus_4.vmd" "$out/"
  exit 0
fi
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
seed 9 "$root/../shared/data/teapot/teapot.bpt"
seed 10 "$root/../shared/data/teapot/newell_teaspoon.patches"
printf '\x01' > "$out/empty_gz.1"
printf '\x04solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n' > "$out/ascii.stl.4"
# Regressions of issue 15 (tests/test_load_errors.cpp has each as a named test):
# PropertylessElementWithHugeCountHang: an element of 2^63-1 items without properties.
printf '\x00ply\nformat ascii 1.0\nelement junk 9223372036854775807\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' > "$out/propertyless_huge_count.ply.0"
# ListCountTimesSizeWrapsReadPastBuffer: a binary list count of 2^62 (double) times 4 bytes wraps.
verts='\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x00'
printf '\x00ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list double int vertex_indices\nend_header\n'"$verts"'\x00\x00\x00\x00\x00\x00\xd0\x43' > "$out/list_count_wraps.ply.0"
printf '\x00ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n1000000000 0 1 2\n' > "$out/ascii_list_huge.ply.0"
# GltfAccessorCountWraps: 2^62 VEC3 floats with a 12-byte stride wrap the bounds check.
printf '\x05{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"accessors":[{"bufferView":0,"componentType":5126,"count":4611686018427387904,"type":"VEC3"}],"bufferViews":[{"buffer":0,"byteLength":36,"byteStride":12}],"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]}' > "$out/gltf_count_wraps.gltf.5"
# GzipBombStopsAtMaxBytes, small: 32 MiB + 100 bytes of zeros in ~32 KB (fuzz_load's max_bytes
# is 16 MiB, so this is refused as TooLarge before the buffer passes it).
{ printf '\x01'; { printf 'ply\nformat ascii 1.0\ncomment '; head -c 33554432 /dev/zero; } | gzip -9; } > "$out/gzip_bomb.ply.gz.1"
# GltfNodeHierarchyBlowupAndDepth: 64 levels of nodes, each listing the next one twice.
nodes=''
for i in $(seq 1 64); do nodes="$nodes{\"children\":[$i,$i]},"; done
printf '\x05{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[%s{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],"bufferViews":[{"buffer":0,"byteLength":36}],"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]}' "$nodes" > "$out/gltf_shared_children.gltf.5"
# Every reader without ../shared/data: a one-patch .bpt (9) and .patches (10), a pbrt scene with a
# camera, a trianglemesh, a transform and the directives it ignores (8).
{ printf '\x09''1\n3 3\n'; for i in 0 1 2 3; do for j in 0 1 2 3; do echo "$j $i $(( (i * j) % 3 ))"; done; done; } > "$out/one_patch.bpt.9"
{ printf '\x0a''1\n1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16\n16\n'; for i in 0 1 2 3; do for j in 0 1 2 3; do echo "$j,$i,$(( (i + j) % 2 ))"; done; done; } > "$out/one_patch.patches.10"
printf '\x08LookAt 0 0 5 0 0 0 0 1 0\nCamera "perspective" "float fov" [45]\nFilm "image" "integer xresolution" [64] "integer yresolution" [48]\nWorldBegin\nAttributeBegin\nMaterial "matte" "rgb Kd" [0.5 0.2 0.1]\nTranslate 0 0 1\nRotate 30 0 1 0\nShape "trianglemesh" "point P" [0 0 0 1 0 0 0 1 0 1 1 0] "integer indices" [0 1 2 2 1 3]\nAttributeEnd\nWorldEnd\n' > "$out/camera_mesh.pbrt.8"
# Issue 35: the .sexp reader (format byte 11) and the scene-file and pbrt cases it fixed.
printf '\x0b(- (+ (square x) (square y) (square z)) 1)' > "$out/sphere.sexp.11"
printf '\x0b(max (- (abs x) 1) (- (abs y) 1) (- (abs z) 1) (- 0.5 (sqrt (+ (square x) (square y)))))' > "$out/box_hole.sexp.11"
printf '\x0b(+ x (- (/ 1 0) (/ 1 0)))' > "$out/folds_to_nan.sexp.11"
printf '\x07{"meshes":[{"expression":"(- (+ (square x) (square y) (square z)) 1)","bounds":[-2,-2,-2,2,2,2],"matrix":[1,0,0,0,0,1,0,0,0,0,1,0.5,0,0,0,1]}]}' > "$out/projective_matrix.json.7"
printf '\x07{"meshes":[{"expression":"(- (square x) 1)","bounds":[0,0,0,1e-300,1,1]}]}' > "$out/thin_bounds.json.7"
printf '\x08WorldBegin\nScale 0 0 0\nShape "trianglemesh" "point P" [0 0 0 1 0 0 0 1 0] "integer indices" [0 1 2]\nWorldEnd\n' > "$out/scale_zero.pbrt.8"
printf '\x08LookAt 0 0 5 0 0 0 0 1 0\nCamera "perspective" "float fov" [45]\nWorldBegin\nAttributeBegin\nTranslate 0 0 1\nShape "loopsubdiv" "point P" [1 0 0 -1 0 0 0 1 0 0 -1 0 0 0 1 0 0 -1] "integer indices" [0 2 4 2 1 4 1 3 4 3 0 4 2 0 5 1 2 5 3 1 5 0 3 5]\nAttributeEnd\nWorldEnd\n' > "$out/loop_octahedron.pbrt.8"
# Issue 35, case 1: a sphere under 2,000 nested (+ ... 0), which no box of the bounds search shortens.
{ printf '\x0b'; for i in $(seq 2000); do printf '(+ '; done; printf '(- (+ (square x) (square y) (square z)) 1)'; for i in $(seq 2000); do printf ' 0)'; done; } > "$out/nested_sum.sexp.11"
