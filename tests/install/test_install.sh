#!/usr/bin/env bash
# The installable SDK (issue 17 item 7): cmake --install into a fresh prefix, then, using only
# that prefix: a CMake project (find_package(nimbus)) and a pkg-config build of a small C host
# program and a volume procedural, rendered with; the installed CLI renders the default scene
# from another directory; a copy of the prefix elsewhere still works (relocatable) and reads its
# own share/nimbus (a broken OCIO config there breaks its preview).
#   test_install.sh BUILD_DIR
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
build=$(cd "$1" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix

cmake --install "$build" --prefix "$prefix" >/dev/null
for f in bin/nimbus include/nimbus/nimbus.h include/nimbus/nimbus.hpp include/nimbus/nimbus_volume_plugin.h \
         lib/cmake/nimbus/nimbusConfig.cmake lib/pkgconfig/nimbus.pc share/nimbus/kernels/pathtrace.cl \
         share/nimbus/shaders/default.ax share/nimbus/ocio/config.ocio \
         share/nimbus/compare/compare_charts.py; do
  [ -e "$prefix/$f" ] || { echo "test_install: $f is not installed"; exit 1; }
done
ls "$prefix"/lib*/libnimbus_c.so* >/dev/null || { echo "test_install: libnimbus_c.so is not installed"; exit 1; }

# 1. CMake: find_package(nimbus).
cmake -S "$here/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$prefix" -DTORUS_SOURCE="$root/plugins/procedurals/torus.c" \
      -DCMAKE_BUILD_RPATH="$prefix/lib" >/dev/null
cmake --build "$work/consumer" >/dev/null
(cd "$work" && "$work/consumer/render_ring" "$work/consumer/libring.so" "$work/ring_cmake.exr")
[ -s "$work/ring_cmake.exr" ] || { echo "test_install: the CMake-built host wrote no EXR"; exit 1; }

# 2. pkg-config.
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig"
cc -std=c99 -Wall -Werror -o "$work/render_ring_pc" "$here/consumer/render_ring.c" $(pkg-config --cflags --libs nimbus) \
   -Wl,-rpath,"$(pkg-config --variable=libdir nimbus)"
cc -std=c99 -shared -fPIC -fvisibility=hidden -o "$work/libring_pc.so" "$root/plugins/procedurals/torus.c" \
   $(pkg-config --cflags nimbus) -lm
"$work/render_ring_pc" "$work/libring_pc.so" "$work/ring_pc.exr"

# 3. The installed CLI, from another directory, with none of the build's environment.
mkdir "$work/elsewhere"
(cd "$work/elsewhere" && env -u NIMBUS_KERNEL_DIR -u NIMBUS_SHADER_PATH -u OCIO -u NIMBUS_OCIO_CONFIG \
   "$prefix/bin/nimbus" render --default --set camera.resolution=[64,36] -o d.exr --preview d.png -q)
[ -s "$work/elsewhere/d.exr" ] && [ -s "$work/elsewhere/d.png" ] || { echo "test_install: the CLI wrote nothing"; exit 1; }

# 4. Relocated and run from $PATH (argv[0] a bare name): a copy of the prefix reads its own
#    share/nimbus, not the source tree's.
cp -a "$prefix" "$work/moved"
echo "this is not an OCIO config" > "$work/moved/share/nimbus/ocio/config.ocio"
if (cd "$work/elsewhere" && env -u OCIO -u NIMBUS_OCIO_CONFIG PATH="$work/moved/bin:$PATH" nimbus render --default \
      --set camera.resolution=[32,18] -o m.exr --preview m.png -q 2>"$work/moved.err"); then
  echo "test_install: the moved CLI rendered a preview through a broken config: it does not read its own share/"; exit 1
fi
grep -q "moved/share/nimbus/ocio/config.ocio" "$work/moved.err" || { echo "test_install: unexpected error:"; cat "$work/moved.err"; exit 1; }
echo "test_install: 4 checks passed"
