#!/usr/bin/env bash
# Installs the nimbus Blender add-on into Blender's user add-ons and enables it.
#
#   bash scripts/install-blender-addon.sh [BUILD_DIR]      (default: build)
#
# Copies plugins/blender/nimbus_blender, records where this build's Python module and CLI are
# (nimbus_blender/paths.json), enables the add-on and saves Blender's preferences. Honours
# $BLENDER (the executable) and Blender's own $BLENDER_USER_SCRIPTS / $BLENDER_USER_CONFIG.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
blender=${BLENDER:-blender}

command -v "$blender" >/dev/null || { echo "install-blender-addon: '$blender' not found (apt-get install blender)" >&2; exit 1; }
module=$(ls "$build"/python/nimbus*.so 2>/dev/null | head -n 1 || true)
[ -n "$module" ] || echo "install-blender-addon: warning: no nimbus module in $build/python (build target nimbus_python); the add-on will use the CLI" >&2
[ -x "$build/bin/nimbus" ] || echo "install-blender-addon: warning: no $build/bin/nimbus (build target nimbus_cli)" >&2

addons=$("$blender" -b --factory-startup --python-expr \
  "import bpy, sys; sys.stdout.write('NIMBUS_ADDONS=' + bpy.utils.user_resource('SCRIPTS', path='addons', create=True) + '\n')" \
  2>/dev/null | sed -n 's/^NIMBUS_ADDONS=//p')
[ -n "$addons" ] || { echo "install-blender-addon: cannot ask $blender for its add-on directory" >&2; exit 1; }

rm -rf "$addons/nimbus_blender"
cp -r "$root/plugins/blender/nimbus_blender" "$addons/nimbus_blender"
rm -rf "$addons/nimbus_blender/__pycache__"
printf '{"python": "%s", "cli": "%s"}\n' "$build/python" "$build/bin/nimbus" > "$addons/nimbus_blender/paths.json"

"$blender" -b --python-expr "
import addon_utils, bpy, sys
if addon_utils.enable('nimbus_blender', default_set=True, persistent=True) is None:
    sys.exit('install-blender-addon: Blender could not enable nimbus_blender')
bpy.ops.wm.save_userpref()
" >/dev/null
echo "install-blender-addon: installed and enabled in $addons/nimbus_blender (render engine 'nimbus')"
