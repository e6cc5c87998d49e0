#!/usr/bin/env bash
# Issue 17: makes .gpu/, everything a device run needs, here (Debian 12, with the project's
# packages), for bench/gpu/run.sh to use on the GPU machine, which has g++, cmake, the OpenCL
# headers, the ICD loader and NVIDIA's OpenCL library but no registry and none of our
# dependencies. See bench/gpu/README.md.
#
#   bench/gpu/pack.sh            # build (Release, ccache), gather, reference maps on PoCL
#
# .gpu/ (gitignored; carried with `run`, carry [".gpu"]):
#   bin/       vismap, vismap_bench (stripped)
#   lib/       the shared libraries ldd names that a bare machine lacks (see below)
#   lib/glibc/ Debian's loader, libc, libm, libstdc++, libgcc_s: used by run.sh only when the
#              binaries do not start there (a glibc older than 2.35 or a libstdc++ without
#              GLIBCXX_3.4.29, the newest versions they need)
#   lib/icd/   Debian's ICD loader libOpenCL.so.1: used by run.sh only when the machine has none
#   scenes/    the scenes, scenes.tsv (name, file)
#   refs/      the maps rendered here on PoCL: refs.tsv (name, bytes, sha256), small ones whole
#   run.sh, summarize.py, MANIFEST.txt
#
# Env: VISMAP_BUILD_DIR (build/), VISMAP_GPU_PACK (.gpu), VISMAP_SHARED_DATA (../shared/data),
# VISMAP_REF_DEVICE (the PoCL device, "Portable Computing Language"), VISMAP_GPU_PACK_MAX_MB
# (40: the whole tree that travels is limited to 64 MiB and the tracked files are ~14 MB).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
BUILD="${VISMAP_BUILD_DIR:-$ROOT/build}"
PACK="${VISMAP_GPU_PACK:-$ROOT/.gpu}"
SHARED="${VISMAP_SHARED_DATA:-$ROOT/../shared/data}"
REF_DEVICE="${VISMAP_REF_DEVICE:-Portable Computing Language}"
MAX_MB="${VISMAP_GPU_PACK_MAX_MB:-40}"
REF_WHOLE_MAX=$((8 * 1024 * 1024))  # reference maps up to this size travel whole (cmp offsets)
say() { echo "pack: $*" >&2; }

# 1. Build.
if [ ! -f "$BUILD/CMakeCache.txt" ]; then
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DVISMAP_BUILD_TESTS=OFF "${launcher[@]}"
fi
grep -q '^CMAKE_BUILD_TYPE:STRING=Release' "$BUILD/CMakeCache.txt" || say "warning: $BUILD is not a Release build"
CCACHE_BASEDIR="${CCACHE_BASEDIR:-$(dirname "$ROOT")}" cmake --build "$BUILD" -j"$(nproc)" \
  --target vismap vismap_bench make_subdivided

# 2. Generated scenes, as bench/bench.py makes them (bench/scenes/ is gitignored).
GEN="$ROOT/bench/scenes"
[ -f "$GEN/stadium.obj" ] || "$BUILD/bench/make_subdivided" --stadium "$GEN/stadium.obj"
[ -f "$GEN/teapot_loop2.ply" ] ||
  "$BUILD/bench/make_subdivided" "$SHARED/teapot/teapot_c3d.obj" "$GEN/teapot_loop2.ply" --levels 2 --weld

rm -rf "$PACK"
mkdir -p "$PACK"/{bin,lib/glibc,lib/icd,scenes,refs}

# 3. Binaries and libraries. Not carried in lib/: the ICD loader (the machine has one; it must
# be the one that reads /etc/OpenCL/vendors there), and glibc/libstdc++/libgcc_s, which every
# machine with g++ has: the binaries need GLIBC_2.35 and GLIBCXX_3.4.29 at most (checked below),
# which Ubuntu 22.04 and 24.04 (CUDA 13's; the image's OS is not recorded) meet; a copy of ours
# would shadow a newer libstdc++ that the machine's own libraries may need. Those five go to
# lib/glibc/ as a fallback only.
for b in vismap bench/vismap_bench; do
  cp "$BUILD/$b" "$PACK/bin/"
  strip --strip-unneeded "$PACK/bin/$(basename "$b")"
done
system_lib='^(linux-vdso|ld-linux-x86-64|libc|libm|libstdc\+\+|libgcc_s|libpthread|libdl|librt|libOpenCL)\.so'
for b in "$PACK"/bin/*; do ldd "$b"; done | awk '$2 == "=>" && $3 ~ /^\// {print $1, $3}' | sort -u |
  while read -r name path; do
    if [[ "$name" =~ $system_lib ]]; then continue; fi
    cp -L "$path" "$PACK/lib/$name"
  done
if ldd "$PACK"/bin/* | grep -q 'not found'; then say "error: ldd: not found"; exit 1; fi
for f in /lib64/ld-linux-x86-64.so.2 /lib/x86_64-linux-gnu/{libc.so.6,libm.so.6,libstdc++.so.6,libgcc_s.so.1}; do
  cp -L "$f" "$PACK/lib/glibc/"
done
cp -L /lib/x86_64-linux-gnu/libOpenCL.so.1 "$PACK/lib/icd/"
need="$(objdump -T "$PACK"/bin/* "$PACK"/lib/*.so* | grep -o '\(GLIBC\|GLIBCXX\|CXXABI\)_[0-9][0-9.]*' |
  sort -u | sort -t_ -k1,1 -k2V | awk -F_ '{m[$1]=$0} END {for (k in m) printf "%s ", m[k]}')"

# 4. Scenes. The stadium is a scene file naming its two meshes next to it.
printf 'name\tfile\n' > "$PACK/scenes/scenes.tsv"
add_scene() {  # name, source file(s): the first is the one rendered
  local name="$1"
  shift
  for f in "$@"; do
    [ -f "$f" ] || { say "scene $name: $f missing, left out"; return; }
  done
  for f in "$@"; do cp "$f" "$PACK/scenes/"; done
  printf '%s\t%s\n' "$name" "$(basename "$1")" >> "$PACK/scenes/scenes.tsv"
}
add_scene bunny "$ROOT/data/bunny.ply"
add_scene teapot "$SHARED/teapot/teapot_c3d.obj"
add_scene stadium "$GEN/teapot_stadium.json" "$GEN/stadium.obj" "$GEN/teapot_loop2.ply"
add_scene dragon "$ROOT/data/dragon_vrip.ply.gz"

# 5. Reference maps on PoCL, with the same command run.sh uses (the CLI's default camera, or
# the scene file's). ~/.cache/vismap is shared with other builds: its key includes platform,
# device, options and source, so that is safe and saves the PoCL program build.
printf 'name\tbytes\tsha256\twhole\n' > "$PACK/refs/refs.tsv"
tail -n +2 "$PACK/scenes/scenes.tsv" | while IFS=$'\t' read -r name file; do
  out="$PACK/refs/$name.bin"
  say "reference $name on '$REF_DEVICE'"
  "$PACK/bin/vismap" render "$PACK/scenes/$file" -o "$out" --format bin --device "$REF_DEVICE" --stats \
    2> "$PACK/refs/$name.log"
  bytes=$(stat -c %s "$out")
  sum=$(sha256sum "$out" | cut -d' ' -f1)
  whole=yes
  if [ "$bytes" -gt "$REF_WHOLE_MAX" ]; then rm "$out"; whole=no; fi
  printf '%s\t%s\t%s\t%s\n' "$name" "$bytes" "$sum" "$whole" >> "$PACK/refs/refs.tsv"
done

# 6. Scripts and manifest.
cp "$ROOT/bench/gpu/run.sh" "$ROOT/bench/gpu/summarize.py" "$PACK/"
{
  echo "packed: $(date -u +%FT%TZ) on $(hostname)"
  echo "commit: $(git -C "$ROOT" rev-parse --short HEAD)$(git -C "$ROOT" status --porcelain -uno | grep -q . && echo ' (dirty)')"
  echo "build: $BUILD ($(grep '^CMAKE_BUILD_TYPE:' "$BUILD/CMakeCache.txt" | cut -d= -f2))"
  echo "os: $(. /etc/os-release && echo "$PRETTY_NAME"); $(ldd --version | head -1)"
  echo "pocl: $(dpkg-query -W -f='${Version}' pocl-opencl-icd 2>/dev/null)"
  echo "reference device: $("$PACK/bin/vismap" devices | grep -i -m1 -- "$REF_DEVICE" || true)"
  echo "newest symbol versions needed: $need"
  echo "ldd:"
  for b in "$PACK"/bin/*; do echo "  $(basename "$b"):"; ldd "$b" | sed 's/^/    /'; done
  echo "files:"
  (cd "$PACK" && find . -type f -printf '  %10s %p\n' | sort -k2)
} > "$PACK/MANIFEST.txt"

mb=$(du -sm "$PACK" | cut -f1)
if [ "$mb" -gt "$MAX_MB" ]; then
  say "error: $PACK is $mb MB, over $MAX_MB: drop a scene (VISMAP_GPU_PACK_MAX_MB to override)"
  exit 1
fi
say "$PACK: $mb MB; needs $need"
