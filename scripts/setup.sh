#!/usr/bin/env bash
# Installs what vismap needs, from Debian 12 packages only.
#   scripts/setup.sh           what building and running vismap, vismapd and vismap-client need
#   scripts/setup.sh --tests   that, and what the tests need: GoogleTest, the Python and JS
#                              clients' interpreters and packages, Chromium and playwright-core
#                              (the web viewer's browser test), nginx (the scale-out test), clang
#                              with libFuzzer (the fuzzers' short runs), oclgrind (the OpenCL
#                              device simulator: scripts/oclgrind_check.sh), assimp's test models
#                              (real-world files the loader tests read where installed)
# The bench peers have setup scripts of their own (bench/peers/setup.sh, bench/lines/setup.sh).
# Idempotent: when every package is already there it only checks and returns.
set -euo pipefail

TESTS=0
for arg in "$@"; do
  case "$arg" in
    --tests) TESTS=1 ;;
    *) echo "usage: scripts/setup.sh [--tests]" >&2; exit 2 ;;
  esac
done

PACKAGES=(
  build-essential cmake pkg-config
  ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers pocl-opencl-icd
  libtinygltf-dev libopenmesh-dev libcgal-dev libgmp-dev libmpfr-dev
  libboost-dev nlohmann-json3-dev zlib1g-dev
  libmeshoptimizer-dev libzstd-dev libcairo2-dev
)
TEST_PACKAGES=(
  git clinfo googletest libgtest-dev
  librsvg2-bin libxml2-utils python3
  time
  python3-websockets python3-jsonschema python3-numpy python3-zstandard
  python3-setuptools python3-wheel python3-pip libmeshoptimizer2d
  chromium nodejs nginx
  clang libclang-rt-14-dev
  oclgrind
  assimp-testmodels
)
[ "$TESTS" -eq 1 ] && PACKAGES+=("${TEST_PACKAGES[@]}")

ROOT="$(cd "$(dirname "$0")/.." && pwd)"

# The web viewer's browser test drives Debian's Chromium with playwright-core from the npm
# registry (the library only: it downloads no browser). Installed into the checkout, untracked.
# Debian's nodejs comes without npm (a package of its own); a Node.js from elsewhere (NodeSource,
# as on the CI machines) brings its own npm and conflicts with Debian's: so npm is installed only
# where there is none.
install_playwright() {
  [ -d "$ROOT/node_modules/playwright-core" ] && return 0
  if ! command -v npm >/dev/null 2>&1; then
    echo "setup: installing npm"
    $SUDO apt-get install -y -qq --no-install-recommends npm >/dev/null || true
  fi
  if command -v npm >/dev/null 2>&1; then
    (cd "$ROOT" && npm install --no-save --no-audit --no-fund --no-package-lock playwright-core@1 >/dev/null 2>&1) \
      && echo "setup: playwright-core installed" \
      || echo "setup: playwright-core could not be installed (the web viewer test will be skipped)"
  else
    echo "setup: no npm (the web viewer test will be skipped)"
  fi
}

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  [ "$TESTS" -eq 0 ] || install_playwright
  exit 0
fi

echo "setup: installing ${missing[*]}"
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
[ "$TESTS" -eq 0 ] || install_playwright
echo "setup: done"
