#!/bin/bash
# scripts/gpu-bundle/make_bundle.sh [BUNDLE_DIR]: packs nimbus's OpenCL path tracer for a borrowed GPU
# machine (issue 13: the path tracer "on any OpenCL GPU where present"; when a task is lent a GPU,
# its kernels are timed there with scripts/gpu-bundle/run.sh). The device tool sends the repository's
# working tree plus a few carried ignored paths, no Debian packages: so this copies the binaries
# and their libraries into BUNDLE_DIR (default .gpu/ in the repository root, git-ignored), from the
# build in $BUILD (default build/ in the repository root; from a worktree without its own build,
# e.g. BUILD=/work/main/build). Run from the repository root after building nimbus_cli,
# bench_pathtrace and test_pathtracer on Debian 12:
#   bash scripts/gpu-bundle/make_bundle.sh          # ~45 MB in .gpu/ (the carry limit is 64 MiB); minutes (xz -9)
# It writes bin/ (stripped nimbus, bench_pathtrace, test_pathtracer), libs.tar.xz, closure.txt
# (what went in) and SOURCE_DIR (the checkout compiled into the binaries, which run.sh links there).
# libs.tar.xz unpacks to lib/ (the binaries' shared-library closure less glibc, libstdc++ and
# libgcc_s, which the device's own newer ones provide) and data/ (PNanoVDB.h, read at run time
# from a compiled-in Debian path). Libraries the binaries load but the path tracer never calls
# into, whose dependency trees would not fit the carry (OIIO's ffmpeg, OpenCV, DICOM, HEIF
# and LibRaw readers; OpenVDB AX and its LLVM 14, 130 MB), are replaced by stand-ins from
# mkstub.py: same soname, versions and symbols, no code (AX shaders do not work from the bundle).
# libexpat too (OpenColorIO's CLF/CTF LUT reader; nimbus's OCIO config has no file transforms):
# Debian's needs glibc 2.36 (arc4random_buf), the rest of the bundle 2.35, which Ubuntu 22.04 has.
set -eu
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
G=${1:-$REPO/.gpu}
B=${BUILD:-$REPO/build}
[ -x "$B/bin/nimbus" ] || { echo "no $B/bin/nimbus: build first, or set BUILD"; exit 1; }
ML=/usr/lib/x86_64-linux-gnu
BINS="$B/bin/nimbus $(find $B -type f -name bench_pathtrace -perm -u+x | head -1) $(find $B -type f -name test_pathtracer -perm -u+x | head -1)"
STUBS="libopencv_core.so.406 libopencv_imgproc.so.406 libopencv_videoio.so.406 libdcmimage.so.17 libdcmimgle.so.17
libdcmdata.so.17 liboflog.so.17 libofstd.so.17 libavcodec.so.59 libavformat.so.59 libavutil.so.57 libswscale.so.6
libheif.so.1 libraw_r.so.20 libopenvdb_ax.so.10.0 libLLVM-14.so.1 libexpat.so.1"
mkdir -p "$G/bin"
# Stripped copies (the symbol tables only: 6 MB of the carry).
for b in $BINS; do cp -f "$b" "$G/bin/" && strip -s "$G/bin/$(basename "$b")"; done
S=$(mktemp -d)
mkdir -p "$S/lib" "$S/data"
python3 "$HERE/closure.py" $BINS --stub $STUBS >"$S/closure.txt"
if grep -q NOTFOUND "$S/closure.txt"; then grep NOTFOUND "$S/closure.txt"; exit 1; fi
# Real libraries under their soname (the file the symlink names), stand-ins for the stubbed ones.
while read -r soname path; do
    if [ "$path" = STUB ]; then
        python3 "$HERE/mkstub.py" "$(readlink -f $ML/$soname)" "$S/lib" >/dev/null
        echo "$soname" >>"$S/STUBS"
    else
        cp -L "$path" "$S/lib/$soname"
    fi
done <"$S/closure.txt"
# The ICD loader is in the closure through libOpenCL.so.1; make sure.
[ -f "$S/lib/libOpenCL.so.1" ] || cp -L $ML/libOpenCL.so.1 "$S/lib/"
# (compiled in as NIMBUS_PNANOVDB_HEADER, src/CMakeLists.txt; the compiler folds it into code, so not in `strings`)
PN=$(grep -m1 -o 'NIMBUS_PNANOVDB_HEADER=[^ ]*' "$B/build.ninja" | sed 's/.*=\\"//; s/\\"$//')
[ -f "$PN" ] || { echo "no PNanoVDB.h at '$PN'"; exit 1; }
cp "$PN" "$S/data/PNanoVDB.h"
echo "$PN" >"$S/data/PNANOVDB_PATH"
# What the device's glibc and libstdc++ must provide.
for f in "$G"/bin/* "$S"/lib/*; do objdump -T "$f" 2>/dev/null; done | grep -oE 'GLIBC_[0-9.]+' | sort -uV | tail -1 >"$S/GLIBC_MAX"
for f in "$G"/bin/* "$S"/lib/*; do objdump -T "$f" 2>/dev/null; done | grep -oE 'GLIBCXX_[0-9.]+' | sort -uV | tail -1 >"$S/GLIBCXX_MAX"
cp "$S/closure.txt" "$G/closure.txt"
# The source tree the binaries have compiled in (kernels, shaders, test data): run.sh links it.
sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$B/CMakeCache.txt" >"$G/SOURCE_DIR"
tar -C "$S" -cf - lib data STUBS GLIBC_MAX GLIBCXX_MAX | nice -n 10 xz -9 -T1 >"$G/libs.tar.xz"
rm -rf "$S"
du -sh "$G" "$G/libs.tar.xz" "$G"/bin/*
