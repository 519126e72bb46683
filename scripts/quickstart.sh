#!/usr/bin/env bash
# Installs, builds and renders the embedded default scene (a procedural cloud lit by a key and
# a fill light) to out/default.exr and out/default.png.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/build.sh
./build/bin/nimbus render --default --explain
