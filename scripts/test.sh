#!/usr/bin/env bash
# Installs, builds and runs the whole test suite through ctest.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/build.sh
cd build
ctest --output-on-failure -j "${NIMBUS_JOBS:-$(nproc)}" --timeout 900
