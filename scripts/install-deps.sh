#!/usr/bin/env bash
# Installs everything nimbus needs to build, test and benchmark, from Debian 12 packages.
# Safe to run again: apt-get skips what is already installed.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config
  libopenvdb-dev libopenvdb-ax-dev libopenvdb-tools python3-openvdb
  # .nvdb volume sources and the PNanoVDB kernel variant (NanoVDB.h, PNanoVDB.h; header-only).
  libnanovdb-dev
  libopenimageio-dev openimageio-tools python3-openimageio
  libopencolorio-dev
  libembree-dev libtbb-dev
  # Scene geometry: OBJ and PLY meshes (src/geometry/MeshFile.cpp).
  libassimp-dev
  ocl-icd-opencl-dev opencl-headers pocl-opencl-icd clinfo
  libboost-math-dev libboost-dev
  nlohmann-json3-dev libcli11-dev
  libgtest-dev libgmock-dev
  pybind11-dev python3-dev python3-numpy
  # nimbus compare's charts (src/compare/compare_charts.py), run with /usr/bin/python3.
  python3-matplotlib
  # The sanitized build (scripts/sanitize.sh): clang with libFuzzer and the ASan/UBSan runtimes
  # (libclang-rt-14-dev is only recommended by clang, and recommends are not installed).
  clang libclang-rt-14-dev
  # The Blender add-on's end-to-end test (tests/blender): ~30 s to install, ~15 s to run.
  blender
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
