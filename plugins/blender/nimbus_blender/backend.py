"""Running nimbus from Blender: the Python module in-process, or the command line.

Debian's Blender 3.4 embeds Debian's Python 3.11, the Python the `nimbus` module is built for,
so the module loads inside Blender and renders without leaving the process (the GIL is released
while it renders). The command line is the fallback, and what a farm runs on the exported JSON.

Where they are found, first hit wins: the add-on preferences, then paths.json beside this file
(written by scripts/install-blender-addon.sh), then $NIMBUS_PYTHONPATH / $NIMBUS_CLI, then an
importable `nimbus` / `nimbus` on $PATH.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np


class RenderError(Exception):
    """nimbus refused the scene or failed; the message is nimbus's one line."""


def _installed():
    path = os.path.join(os.path.dirname(__file__), "paths.json")
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return {}


def _preferences():
    try:
        import bpy

        return bpy.context.preferences.addons[__package__].preferences
    except Exception:  # noqa: BLE001 - outside Blender, or the add-on not enabled by name
        return None


def _candidates(pref_attr, installed_key, env):
    prefs = _preferences()
    out = [getattr(prefs, pref_attr, "") if prefs else "", _installed().get(installed_key, ""),
           os.environ.get(env, "")]
    return [p for p in out if p]


def load_module():
    """The nimbus Python module, or None."""
    # The path tracer loads OpenCL drivers with RTLD_DEEPBIND to keep PoCL's LLVM 15 off the
    # LLVM 14 that OpenVDB AX puts in a nimbus *executable's* global scope (docs/pathtracer.md).
    # Inside Blender that isolation is not needed (Python loads the module and its LLVM 14
    # RTLD_LOCAL, Blender links no LLVM) and is harmful: a deep-bound PoCL calls glibc's malloc
    # while Blender runs on jemalloc, and the first path-traced render aborts in free(). So the
    # add-on turns it off before the module can load a driver.
    os.environ.setdefault("NIMBUS_OPENCL_NO_DEEPBIND", "1")
    for directory in _candidates("python_path", "python", "NIMBUS_PYTHONPATH"):
        directory = os.path.abspath(os.path.expanduser(directory))
        if directory not in sys.path:
            sys.path.insert(0, directory)
    try:
        import nimbus

        return nimbus
    except ImportError:
        return None


def cli_path():
    for path in _candidates("cli_path", "cli", "NIMBUS_CLI"):
        path = os.path.abspath(os.path.expanduser(path))
        if os.access(path, os.X_OK):
            return path
    return shutil.which("nimbus")


def describe():
    module = load_module()
    return "module %s, command line %s" % (module.__file__ if module else "not found", cli_path() or "not found")


def render(document, backend="AUTO", progress=None, test_break=None):
    """Renders a scene document. Returns {aov name: float32 array (height, width, channels),
    rows from the top}, or None if test_break() asked to stop."""
    progress = progress or (lambda fraction: None)
    test_break = test_break or (lambda: False)
    module = load_module() if backend in ("AUTO", "MODULE") else None
    if backend == "MODULE" and module is None:
        raise RenderError("the nimbus Python module is not found (" + describe() + ")")
    if module is not None:
        return _render_module(module, document, progress, test_break)
    cli = cli_path()
    if cli is None:
        raise RenderError("neither the nimbus Python module nor the nimbus executable is found; "
                          "run scripts/install-blender-addon.sh or set the add-on preferences")
    return _render_cli(cli, document, progress, test_break)


def _render_module(nimbus, document, progress, test_break):
    try:
        scene = nimbus.load_dict(document)
        session = nimbus.Session(scene)
        session.start()
        # Blender's own calls (progress, test_break) stay on Blender's render thread: poll.
        while not session.wait(0.1):
            progress(session.state[1])
            if test_break():
                session.cancel()
        frame = session.frame
    except nimbus.Cancelled:
        return None
    except nimbus.Error as e:
        raise RenderError(str(e)) from None
    return {name: frame[name] for name in frame.keys()}


def _render_cli(cli, document, progress, test_break):
    with tempfile.TemporaryDirectory(prefix="nimbus-blender-") as tmp:
        scene_path, exr = os.path.join(tmp, "scene.json"), os.path.join(tmp, "render.exr")
        with open(scene_path, "w") as f:
            json.dump(document, f)
        proc = subprocess.Popen([cli, "render", scene_path, "-o", exr], stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, text=True)
        lines = []

        def read():
            for line in proc.stderr:
                lines.append(line.rstrip("\n"))
                if line.startswith("render: ") and "%" in line:
                    try:
                        progress(float(line.split()[1].rstrip("%")) / 100.0)
                    except ValueError:
                        pass

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        while proc.poll() is None:
            if test_break():
                proc.terminate()
                proc.wait()
                return None
            time.sleep(0.1)
        reader.join(5)
        if proc.returncode != 0:
            errors = [l for l in lines if l.startswith("nimbus: error")]
            raise RenderError((errors or lines or ["nimbus exited with %d" % proc.returncode])[-1])
        return read_exr(exr)


def read_exr(path):
    """The AOV layers of a nimbus EXR (docs/output.md) as {name: (height, width, channels)}."""
    import OpenImageIO as oiio

    image = oiio.ImageInput.open(path)
    if image is None:
        raise RenderError("cannot read %s: %s" % (path, oiio.geterror()))
    spec = image.spec()
    pixels = image.read_image(oiio.FLOAT)
    image.close()
    full = np.zeros((spec.full_height, spec.full_width, spec.nchannels), dtype=np.float32)
    full[spec.y - spec.full_y:spec.y - spec.full_y + spec.height,
         spec.x - spec.full_x:spec.x - spec.full_x + spec.width] = pixels
    layers = {}
    for index, name in enumerate(spec.channelnames):
        if "." in name:
            layer, channel = name.rsplit(".", 1)
            layers.setdefault(layer, []).append((channel, index))
    out = {}
    order = {"R": 0, "G": 1, "B": 2, "A": 3}
    for layer, channels in layers.items():
        indices = [i for _, i in sorted(channels, key=lambda c: order.get(c[0], 4))]
        data = full[..., indices]
        if layer in ("alpha", "depth", "variance"):
            data = data[..., :1]  # one channel (alpha.A, depth.Z, variance.Y); older files repeat it in R, G, B
        out[layer] = np.ascontiguousarray(data[..., 0] if data.shape[-1] == 1 else data)
    return out
