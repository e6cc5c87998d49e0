#!/usr/bin/env bash
# Issue 17: the device run. On the GPU machine, from the repo root, with .gpu/ (made here by
# bench/gpu/pack.sh) carried:   bash .gpu/run.sh   (the pack's copy; or bash bench/gpu/run.sh)
# One call gives every figure: the devices; each scene rendered (--format bin) twice on the GPU
# and compared byte for byte with itself and with the PoCL map made by pack.sh; vismap_bench on
# the GPU (warm medians, stages, the z-buffer floor ratio) at each resolution; then, if that
# machine has PoCL and time is left, the maps on PoCL there (compared with the GPU's) and a
# vismap_bench row per scene on PoCL at 1024.
# A failed or timed-out step is recorded and the run goes on. Writes under $OUT (few files, as
# the device tool returns at most 8): summary.md (printed at the end too), bench.jsonl, maps.tsv,
# steps.tsv, log.txt, and maps_diff.tar.gz holding the GPU maps that differ, if any.
#
# Env: OUT (/tmp/vismap-gpu-out); VISMAP_GPU_DEVICE (NVIDIA) and VISMAP_POCL_DEVICE (Portable
# Computing Language): part of a platform name, made P:D from `vismap devices` (a GPU name that
# matches no platform goes to --device as it is; a PoCL one means no PoCL); VISMAP_GPU_RES
# ("1024 4096"); VISMAP_GPU_RUNS (7); VISMAP_GPU_SCENES (all in .gpu/scenes/scenes.tsv, e.g.
# "bunny teapot"); VISMAP_GPU_BUDGET_S (300: steps past it are skipped, so a call with
# timeout_s 420 ends in time and a second call still fits in the 15 device minutes);
# VISMAP_GPU_STEP_S (120: one step's limit); VISMAP_GPU_POCL_BENCH (1: the PoCL bench rows at
# 1024, when time is left; 0 skips); VISMAP_GPU_FORCE_GLIBC (1: run through the packed glibc
# even when the binaries start: to test that path).
set -u
SECONDS=0
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if [ -x "$HERE/bin/vismap" ]; then PACK="$HERE"; else PACK="${VISMAP_GPU_PACK:-$(cd "$HERE/../.." && pwd)/.gpu}"; fi
OUT="${OUT:-/tmp/vismap-gpu-out}"
GPU="${VISMAP_GPU_DEVICE:-NVIDIA}"
POCL="${VISMAP_POCL_DEVICE:-Portable Computing Language}"
RES="${VISMAP_GPU_RES:-1024 4096}"
RUNS="${VISMAP_GPU_RUNS:-7}"
BUDGET="${VISMAP_GPU_BUDGET_S:-300}"
STEP_S="${VISMAP_GPU_STEP_S:-120}"
POCL_BENCH="${VISMAP_GPU_POCL_BENCH:-1}"
mkdir -p "$OUT"
TMP="$(mktemp -d /tmp/vismap-gpu.XXXXXX)"
LOG="$OUT/log.txt" STEPS="$OUT/steps.tsv" MAPS="$OUT/maps.tsv" BENCH="$OUT/bench.jsonl"
: > "$LOG"
: > "$BENCH"
printf 'step\tstatus\tseconds\tnote\n' > "$STEPS"
printf 'scene\tgpu_bytes\tgpu_sha256\tgpu_repeat\tvs_packed_pocl\tvs_pocl_here\tgpu_render_ms\tgpu2_render_ms\tpocl_render_ms\n' \
  > "$MAPS"
log() { echo "$*" | tee -a "$LOG" >&2; }

# step NAME LIMIT_S CMD...: runs CMD under timeout, output in $TMP/NAME.out (and the log);
# records status and seconds in steps.tsv; returns CMD's status (99: skipped, out of budget).
step() {
  local name="$1" limit="$2" left rc t0 secs status
  shift 2
  left=$((BUDGET - SECONDS))
  if [ "$left" -lt 15 ]; then
    printf '%s\tskipped\t0\t%ss of the %ss budget left\n' "$name" "$left" "$BUDGET" >> "$STEPS"
    log "== $name: skipped (budget)"
    return 99
  fi
  [ "$limit" -gt "$left" ] && limit="$left"
  log "== $name (limit ${limit}s): $*"
  t0=$(date +%s%N)
  timeout -k 5 "$limit" "$@" > "$TMP/$name.out" 2>&1
  rc=$?
  t0=$((($(date +%s%N) - t0) / 1000000))
  secs="$((t0 / 1000)).$(printf '%03d' $((t0 % 1000)))"
  cat "$TMP/$name.out" >> "$LOG"
  case $rc in 0) status=ok ;; 124 | 137) status=timeout ;; *) status="failed rc=$rc" ;; esac
  printf '%s\t%s\t%s\t%s\n' "$name" "$status" "$secs" \
    "$([ $rc -ne 0 ] && tail -n 2 "$TMP/$name.out" | tr '\t\n' '  ' | cut -c1-200)" >> "$STEPS"
  log "-- $name: $status (${secs}s)"
  return $rc
}

# Tools a bare image might lack: nvidia-smi off the PATH, cmp (diffutils).
[ -d /usr/local/nvidia/bin ] && PATH="$PATH:/usr/local/nvidia/bin"
command -v cmp > /dev/null || cmp() {
  [ "$(sha256sum < "$1")" = "$(sha256sum < "$2")" ] || { echo "$1 $2 differ (sha256; no cmp here)"; return 1; }
}

# 1. NVIDIA's OpenCL driver: the image has the library but no ICD file naming it.
NV=/usr/local/nvidia/lib64/libnvidia-opencl.so.1
if [ -e "$NV" ]; then
  if ! { mkdir -p /etc/OpenCL/vendors && echo "$NV" > /etc/OpenCL/vendors/nvidia.icd; } 2>/dev/null; then
    mkdir -p "$TMP/icd" && cp /etc/OpenCL/vendors/*.icd "$TMP/icd/" 2>/dev/null
    echo "$NV" > "$TMP/icd/nvidia.icd" && export OCL_ICD_VENDORS="$TMP/icd"
    log "note: /etc/OpenCL/vendors not writable, OCL_ICD_VENDORS=$OCL_ICD_VENDORS"
  fi
fi

# 2. Libraries: ours first; the driver's folder for what libnvidia-opencl loads (libcuda).
LP="$PACK/lib"
[ -d /usr/local/nvidia/lib64 ] && LP="$LP:/usr/local/nvidia/lib64"
if LD_LIBRARY_PATH="$LP${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" ldd "$PACK/bin/vismap" 2>&1 |
  grep -q 'libOpenCL\.so\.1 => not found'; then
  LP="$LP:$PACK/lib/icd"
  log "note: the machine has no ICD loader (libOpenCL.so.1): using the packed one (lib/icd)"
fi
export LD_LIBRARY_PATH="$LP${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-${HOME:+$HOME/.cache}}"
[ -n "$XDG_CACHE_HOME" ] || export XDG_CACHE_HOME=/tmp/vismap-cache
VM=("$PACK/bin/vismap")
VB=("$PACK/bin/vismap_bench")

{
  echo "date: $(date -u +%FT%TZ)"
  echo "host: $(uname -srm); $(. /etc/os-release 2>/dev/null && echo "$PRETTY_NAME"); $(ldd --version 2>/dev/null | head -1)"
  echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores"
  command -v nvidia-smi > /dev/null &&
    echo "gpu: $(nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm,temperature.gpu \
      --format=csv,noheader 2>&1 | head -1)"
  echo "icd: $(ls /etc/OpenCL/vendors/ 2>/dev/null | tr '\n' ' ')${OCL_ICD_VENDORS:+ (OCL_ICD_VENDORS=$OCL_ICD_VENDORS)}"
  echo "LD_LIBRARY_PATH: $LD_LIBRARY_PATH"
  echo "gpu device: $GPU; pocl device: $POCL (as asked; resolved in the log); res: $RES; runs: $RUNS; budget: ${BUDGET}s"
  sed -n '1,3p;/newest symbol/p' "$PACK/MANIFEST.txt" 2>/dev/null | sed 's/^/pack /'
} > "$TMP/env.txt"
cat "$TMP/env.txt" >> "$LOG"

# 3. Do the binaries start? If not (an older glibc or libstdc++ there), use the packed loader.
step ldd 20 ldd "${VM[@]}" "${VB[@]}"
grep -q 'not found' "$TMP/ldd.out" && log "note: ldd: $(grep 'not found' "$TMP/ldd.out" | sort -u | tr -s ' \t\n' ' ')"
step devices 60 "${VM[@]}" devices
if [ "${VISMAP_GPU_FORCE_GLIBC:-0}" = 1 ] || grep -q 'GLIBC_\|GLIBCXX_\|CXXABI_\|error while loading' "$TMP/devices.out"; then
  L="$PACK/lib/glibc/ld-linux-x86-64.so.2"
  VM=("$L" --library-path "$PACK/lib/glibc:$LD_LIBRARY_PATH" "$PACK/bin/vismap")
  VB=("$L" --library-path "$PACK/lib/glibc:$LD_LIBRARY_PATH" "$PACK/bin/vismap_bench")
  log "note: running through the packed glibc (lib/glibc)"
  step devices_glibc 60 "${VM[@]}" devices
fi
cat "$TMP"/devices*.out > "$TMP/devices.txt" 2>/dev/null
# A name to P:D by the platform first (`--device` matches device names too, first come first
# served: a PoCL CUDA device named "NVIDIA ..." must not stand in for NVIDIA's own driver).
resolve() {
  awk -v s="$1" 'BEGIN { s = tolower(s) }
    $1 ~ /^[0-9]+:[0-9]+$/ { line = $0; sub(/^[^ ]+ +[^ ]+ +/, "", line); split(line, pd, " / ");
      if (index(tolower(pd[1]), s)) { print $1; exit } }' "$TMP/devices.txt"
}
for v in GPU POCL; do
  id="$(resolve "${!v}")"
  [ -n "$id" ] && log "device: $v '${!v}' is $id" && printf -v "$v" '%s' "$id"
done
have_pocl=0
[[ "$POCL" =~ ^[0-9]+:[0-9]+$ ]] && have_pocl=1
command -v clinfo > /dev/null && step clinfo 30 clinfo -l

# 4. Scenes.
declare -a NAMES FILES
while IFS=$'\t' read -r n f; do
  [ "$n" = name ] && continue
  if [ -n "${VISMAP_GPU_SCENES:-}" ] && ! [[ " $VISMAP_GPU_SCENES " == *" $n "* ]]; then continue; fi
  NAMES+=("$n")
  FILES+=("$PACK/scenes/$f")
done < "$PACK/scenes/scenes.tsv"
ref_field() { awk -F'\t' -v n="$1" -v c="$2" '$1 == n {print $c}' "$PACK/refs/refs.tsv"; }
render_ms() { grep -o 'render [0-9.]* ms' "$TMP/$1.out" 2>/dev/null | head -1 | cut -d' ' -f2; }

# 5. Warm-up: the first render on the GPU builds the program for it (then cached).
step warmup "$STEP_S" "${VM[@]}" render "${FILES[0]}" -o "$TMP/warmup.bin" --format bin --device "$GPU" --stats

# 6. Maps on the GPU: twice (two processes), against each other and the packed PoCL map.
declare -A BYTES SUM REPEAT PACKED HERE
diffs=()
same() { cmp "$1" "$2" > "$TMP/cmp.txt" 2>&1 && echo same ||
  echo "DIFFERS: $(head -c 120 "$TMP/cmp.txt" | sed "s|$TMP/||g; s|$PACK/||g")"; }
for i in "${!NAMES[@]}"; do
  n="${NAMES[$i]}" f="${FILES[$i]}" a="$TMP/${NAMES[$i]}.gpu.bin"
  BYTES[$n]=- SUM[$n]=- REPEAT[$n]=- PACKED[$n]=- HERE[$n]=-
  step "render_${n}_gpu" "$STEP_S" "${VM[@]}" render "$f" -o "$a" --format bin --device "$GPU" --stats || continue
  BYTES[$n]=$(stat -c %s "$a")
  SUM[$n]=$(sha256sum "$a" | cut -d' ' -f1)
  step "render_${n}_gpu2" "$STEP_S" "${VM[@]}" render "$f" -o "$TMP/$n.gpu2.bin" --format bin --device "$GPU" \
    --stats && REPEAT[$n]=$(same "$a" "$TMP/$n.gpu2.bin")
  if [ -f "$PACK/refs/$n.bin" ]; then
    PACKED[$n]=$(same "$a" "$PACK/refs/$n.bin")
  elif [ -n "$(ref_field "$n" 3)" ]; then
    [ "${SUM[$n]}" = "$(ref_field "$n" 3)" ] && PACKED[$n]="same (sha256)" ||
      PACKED[$n]="DIFFERS (sha256; ${BYTES[$n]} vs $(ref_field "$n" 2) bytes)"
  fi
  case "${REPEAT[$n]} ${PACKED[$n]}" in *DIFFERS*) diffs+=("$n.gpu.bin") ;; esac
done

# 7. vismap_bench on the GPU: warm medians, stages, the z-buffer floor (same device).
bench() {  # label, device, res, scene index, runs
  local name="bench_${1}_${3}_${NAMES[$4]}"
  if step "$name" "$STEP_S" "${VB[@]}" "${FILES[$4]}" --device "$2" --runs "$5" --camera auto \
    --width "$3" --height "$3" --budget-s 30; then
    grep '^{' "$TMP/$name.out" | sed "s|^{|{\"run\":\"$1\",\"scene_name\":\"${NAMES[$4]}\",|" >> "$BENCH"
  fi
}
for r in $RES; do
  for i in "${!NAMES[@]}"; do bench gpu "$GPU" "$r" "$i" "$RUNS"; done
done

# 8. PoCL there, if it has PoCL (after the GPU figures: lower priority): maps, then a CPU row.
if [ $have_pocl = 1 ]; then
  for i in "${!NAMES[@]}"; do
    n="${NAMES[$i]}" p="$TMP/${NAMES[$i]}.pocl.bin"
    step "render_${n}_pocl" "$STEP_S" "${VM[@]}" render "${FILES[$i]}" -o "$p" --format bin --device "$POCL" \
      --stats || continue
    [ -f "$TMP/$n.gpu.bin" ] || continue
    HERE[$n]=$(same "$TMP/$n.gpu.bin" "$p")
    case "${HERE[$n]}" in DIFFERS*) diffs+=("$n.gpu.bin" "$n.pocl.bin") ;; esac
  done
  if [ "$POCL_BENCH" = 1 ]; then
    for i in "${!NAMES[@]}"; do bench pocl "$POCL" 1024 "$i" 3; done
  fi
fi
for n in "${NAMES[@]}"; do
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$n" "${BYTES[$n]}" "${SUM[$n]}" "${REPEAT[$n]}" "${PACKED[$n]}" \
    "${HERE[$n]}" "$(render_ms "render_${n}_gpu")" "$(render_ms "render_${n}_gpu2")" \
    "$(render_ms "render_${n}_pocl")" >> "$MAPS"
done
if [ ${#diffs[@]} -gt 0 ]; then  # for a later session to look at here (16 MiB a file comes back)
  (cd "$TMP" && tar czf "$OUT/maps_diff.tar.gz" $(printf '%s\n' "${diffs[@]}" | sort -u))
  [ "$(stat -c %s "$OUT/maps_diff.tar.gz")" -gt 16000000 ] && rm "$OUT/maps_diff.tar.gz" &&
    log "note: the differing maps are over 16 MB packed: not returned"
fi

# 9. Summary.
cp "$TMP/env.txt" "$TMP/devices.txt" "$OUT/" 2>/dev/null
if command -v python3 > /dev/null; then
  python3 "$PACK/summarize.py" "$OUT" > "$OUT/summary.md" 2>> "$LOG" || log "summarize.py failed"
else
  { echo "# GPU run (no python3: raw tables)"; cat "$OUT/env.txt" "$OUT/devices.txt" "$STEPS" "$MAPS"; } > "$OUT/summary.md"
fi
rm -f "$OUT/env.txt" "$OUT/devices.txt"  # inside summary.md; keeps the files returned few
log "total ${SECONDS}s"
echo "Run took ${SECONDS} s (budget ${BUDGET} s)." >> "$OUT/summary.md"
rm -rf "$TMP"
cat "$OUT/summary.md"
