#!/usr/bin/env bash
# Installs the dependencies (Debian 12 packages) and builds nimbus (Release) into build/.
# Usage: scripts/build.sh [extra cmake arguments]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

bash scripts/install-deps.sh

# ccache keeps rebuilds cheap: its default per-user directory is shared by every checkout on
# the machine, and CCACHE_BASEDIR makes paths relative so a fresh clone hits the same entries.
export CCACHE_BASEDIR=$root
export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-5G}

jobs=${NIMBUS_JOBS:-$(nproc)}
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build build -j "$jobs"
