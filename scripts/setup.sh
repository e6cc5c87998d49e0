#!/usr/bin/env bash
# Installs everything vismap needs to build and test, from Debian 12 packages only.
# Idempotent: when every package is already there it only checks and returns.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers pocl-opencl-icd clinfo
  libtinygltf-dev libopenmesh-dev libcgal-dev libgmp-dev libmpfr-dev
  libboost-dev nlohmann-json3-dev googletest libgtest-dev zlib1g-dev
  libmeshoptimizer-dev libzstd-dev libcairo2-dev
  librsvg2-bin libxml2-utils python3
  time
  python3-websockets python3-jsonschema python3-numpy python3-zstandard
  python3-setuptools python3-wheel python3-pip libmeshoptimizer2d
  chromium nodejs nginx
)

ROOT="$(cd "$(dirname "$0")/.." && pwd)"

# The web viewer's browser test drives Debian's Chromium with playwright-core from the npm
# registry (the library only: it downloads no browser). Installed into the checkout, untracked.
install_playwright() {
  [ -d "$ROOT/node_modules/playwright-core" ] && return 0
  if command -v npm >/dev/null 2>&1; then
    (cd "$ROOT" && npm install --no-save --no-audit --no-fund --no-package-lock playwright-core@1 >/dev/null 2>&1) \
      && echo "setup: playwright-core installed" \
      || echo "setup: playwright-core could not be installed (the web viewer test will be skipped)"
  else
    echo "setup: no npm (the web viewer test will be skipped)"
  fi
}

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  install_playwright
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
install_playwright
echo "setup: done"
