#!/bin/bash
# scripts/fuzz-bundle/make.sh [BUILD_SAN]: packs the sanitized libFuzzer harnesses for
# scripts/fuzz-bundle/run.sh (long fuzzing runs on a borrowed many-core machine; see its header).
# BUILD_SAN defaults to build-san/ in the repository root (scripts/sanitize.sh with all five harnesses,
# e.g. NIMBUS_SANITIZED=all; clang 14 on Debian 12). Writes, in .fuzz/ in the repository root
# (git-ignored): bin.tar.xz (the stripped harnesses), libs.tar.xz (a copy of .gpu's, from
# scripts/gpu-bundle/make_bundle.sh; NB_GPU_LIBS=path to use another), extra-libs.tar.xz (only if the
# harnesses need libraries that .gpu's lacks; the check reads .gpu's libraries unpacked in /opt/nb/lib,
# NB_PREFIX to change) and SOURCE_DIR (the checkout compiled in, which run.sh links on the device).
set -eu
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
F=$REPO/.fuzz
mkdir -p "$F"
B=${1:-$REPO/build-san}
NB=${NB_PREFIX:-/opt/nb}
GPU_LIBS=${NB_GPU_LIBS:-$REPO/.gpu/libs.tar.xz}
ML=/usr/lib/x86_64-linux-gnu
S=$(mktemp -d)
for h in scene vdb mesh depth envmap; do
    [ -x "$B/tests/fuzz/fuzz_$h" ] || { echo "no fuzz_$h in $B"; continue; }
    cp "$B/tests/fuzz/fuzz_$h" "$S/" && strip -s "$S/fuzz_$h"
done
ls -la "$S"
# What the bundled libs do not provide (glibc, libstdc++, libgcc_s come from the device).
missing=$(for b in "$S"/fuzz_*; do LD_LIBRARY_PATH=$NB/lib ldd "$b"; done | awk '/=>/{print $1, $3}' | sort -u |
    grep -v -E '^(libc|libm|libdl|librt|libpthread|libresolv|libstdc\+\+|libgcc_s|linux-vdso|ld-linux)' | grep -v " $NB/lib/" || true)
echo "not in $NB/lib: ${missing:-none}"
rm -f "$F/extra-libs.tar.xz"
if [ -n "$missing" ]; then
    mkdir -p "$S/x/lib"
    while read -r so path; do cp -L "$path" "$S/x/lib/$so"; done <<<"$missing"
    tar -C "$S/x" -cf - lib | xz -9 -T1 >"$F/extra-libs.tar.xz"
fi
tar -C "$S" -cf - $(cd "$S" && ls fuzz_*) | xz -6 -T2 >"$F/bin.tar.xz"
cp -f "$GPU_LIBS" "$F/libs.tar.xz"
sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$B/CMakeCache.txt" >"$F/SOURCE_DIR"
rm -rf "$S"
du -sh "$F" "$F"/*
