#!/bin/sh
# The GL2PS peer's packages (Debian 12, as root): GL2PS and Mesa's off-screen OpenGL.
set -e
apt-get install -y --no-install-recommends libgl2ps-dev libosmesa6-dev
