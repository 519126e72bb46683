#!/bin/bash
# .gpu/make_bundle.sh: builds .gpu/bin and .gpu/libs.tar.xz from /work/main/build on Debian 12.
# libs.tar.xz unpacks to lib/ (the binaries' shared-library closure less glibc, libstdc++ and
# libgcc_s, which the device's own newer ones provide) and data/ (PNanoVDB.h, read at run time
# from a compiled-in Debian path). Libraries the binaries load but the path tracer never calls
# into, whose dependency trees would not fit the 50 MiB carry (OIIO's ffmpeg, OpenCV, DICOM, HEIF
# and LibRaw readers; OpenVDB AX and its LLVM 14, 130 MB), are replaced by stand-ins from
# mkstub.py: same soname, versions and symbols, no code (AX shaders do not work from the bundle).
# libexpat too (OpenColorIO's CLF/CTF LUT reader; nimbus's OCIO config has no file transforms):
# Debian's needs glibc 2.36 (arc4random_buf), the rest of the bundle 2.35, which Ubuntu 22.04 has.
set -eu
G=$(cd "$(dirname "$0")" && pwd)
B=${BUILD:-/work/main/build}
ML=/usr/lib/x86_64-linux-gnu
BINS="$B/bin/nimbus $(find $B -type f -name bench_pathtrace -perm -u+x | head -1) $(find $B -type f -name test_pathtracer -perm -u+x | head -1)"
STUBS="libopencv_core.so.406 libopencv_imgproc.so.406 libopencv_videoio.so.406 libdcmimage.so.17 libdcmimgle.so.17
libdcmdata.so.17 liboflog.so.17 libofstd.so.17 libavcodec.so.59 libavformat.so.59 libavutil.so.57 libswscale.so.6
libheif.so.1 libraw_r.so.20 libopenvdb_ax.so.10.0 libLLVM-14.so.1 libexpat.so.1"
mkdir -p "$G/bin"
# Stripped copies (the symbol tables only: 6 MB of the 50 MiB carry).
for b in $BINS; do cp -f "$b" "$G/bin/" && strip -s "$G/bin/$(basename "$b")"; done
S=$(mktemp -d)
mkdir -p "$S/lib" "$S/data"
python3 "$G/closure.py" $BINS --stub $STUBS >"$S/closure.txt"
if grep -q NOTFOUND "$S/closure.txt"; then grep NOTFOUND "$S/closure.txt"; exit 1; fi
# Real libraries under their soname (the file the symlink names), stand-ins for the stubbed ones.
while read -r soname path; do
    if [ "$path" = STUB ]; then
        python3 "$G/mkstub.py" "$(readlink -f $ML/$soname)" "$S/lib" >/dev/null
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
tar -C "$S" -cf - lib data STUBS GLIBC_MAX GLIBCXX_MAX | nice -n 10 xz -9 -T1 >"$G/libs.tar.xz"
rm -rf "$S"
du -sh "$G" "$G/libs.tar.xz" "$G"/bin/*
