#!/usr/bin/env bash
# Opt-in: what bench/lines/run.sh needs beyond scripts/setup.sh (CI does not run this): Debian's
# Blender (Freestyle and its render_freestyle_svg add-on ship with it) and OpenCASCADE's
# development packages for bench/lines/occt_hlr.cpp. Then configure with -DVISMAP_BENCH_PEERS=ON.
set -euo pipefail
# libtbb-dev: OCCT's CMake targets name libtbb.so.
PACKAGES=(blender libtbb-dev libocct-foundation-dev libocct-modeling-data-dev libocct-modeling-algorithms-dev
          librsvg2-bin imagemagick python3)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && { echo "bench/lines/setup.sh: all present"; exit 0; }
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
