#!/usr/bin/env bash
# Installs everything vismap needs to build and test, from Debian 12 packages only.
# Idempotent: when every package is already there it only checks and returns.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers pocl-opencl-icd clinfo
  libtinygltf-dev libopenmesh-dev libcgal-dev libgmp-dev libmpfr-dev
  libboost-dev nlohmann-json3-dev googletest libgtest-dev zlib1g-dev
  librsvg2-bin libxml2-utils python3
  time
  python3-websockets python3-jsonschema
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
