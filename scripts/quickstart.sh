#!/usr/bin/env bash
# Installs, builds and renders the embedded default scene (a procedural cumulus under a sun and
# a blue sky, with multiple scattering: wkb) to out/default.exr and out/default.png.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/build.sh
./build/bin/nimbus render --default --explain
