#!/usr/bin/python3
"""Every numeric scene key across its range (issue 18, item 2): the property test.

For each numeric key of the scene format (docs/scene-format.md's tables, the procedural
generators' parameters in docs/volumes.md) the sweep renders a tiny scene with the key set, by
`--set`, to each end of its documented range, just outside each end, 0, -0, denormals (1e-310,
1e-45), huge values (1e30, 1e300, and their negatives) and the NaN / infinity spellings JSON has
no number for (as text they must be refused). Each case must either

  - exit 0 with an EXR whose every pixel value is finite, or
  - exit 2 with exactly one stderr line, naming the key,

within a limit per case (a hang is a failure): 20 s of CPU time (RLIMIT_CPU, so that a loaded
machine does not fail a case that is merely slow; a render spinning without progress is stopped
by it) and 120 s of wall-clock time (a render blocked without using the CPU). Exit 1, a signal, a timeout, a NaN pixel or
an error that does not name its key fails, naming the key, the value and the method.

Cases run with `single` and, when single accepts the value, with `wkb` too (a value single
refuses is refused by the shared validation before any method runs); the path tracer's own keys
run with `pathtrace` at one sample per pixel. The renders are 8x8 pixels of a 4^3-voxel box, so
the whole sweep costs a few CPU minutes.

The key list is written out here (each key needs a scene that reads it: a spot light for
`cone_angle`, a sphere for `geometry.radius`), and `test_every_documented_numeric_key_is_swept`
fails when the docs' tables or `nimbus default-scene` gain a numeric key this list lacks.

Keys with no upper end whose value is an amount of work (`render.spp`, `render.light_samples`,
`render.adaptive_max_spp`)
are swept up to 4096, not to 2^31: there a huge value is a long render, not a wrong one; its
memory is item 5's estimate. So is `render.wkb_orders3_paths`, swept to 2^20 light paths (a few
CPU seconds here) of its documented 2^26 (minutes: the traced orders-3+ cache's light pass).

    test_input_sweep.py NIMBUS_BINARY [-k NAME]     (NIMBUS_SWEEP_JOBS: parallel cases, default 2)
"""
import concurrent.futures
import copy
import json
import math
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import OpenImageIO as oiio

NIMBUS = None
HERE = os.path.dirname(os.path.abspath(__file__))
DOCS = os.path.join(HERE, "..", "..", "docs")
CASE_CPU_S = 20  # CPU seconds (all threads) per case
CASE_WALL_S = 120  # wall seconds per case


def limit_cpu():
    resource.setrlimit(resource.RLIMIT_CPU, (CASE_CPU_S, CASE_CPU_S + 1))
FLOAT_MAX = 3.4028234663852886e38

BASE_SCENE = {
    "camera": {"from": [0, 0, 3], "to": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "resolution": [8, 8]},
    "lights": [{"type": "distant", "direction": [0.3, -1, -0.2], "irradiance": 2}],
    "volumes": [{"source": {"type": "procedural", "generator": "box", "size": 1, "voxel_size": 0.25},
                 "medium": {"sigma_s": 2, "sigma_a": 0.1}}],
    "render": {"spp": 1, "threads": 1, "shadow_map_resolution": 16, "light_volume_resolution": 8,
               "wkb_order2_samples": 1, "emission_samples": 1, "time_limit": 5},
}

LIGHT_TYPES = ["distant", "point", "spot", "rect", "sphere", "environment"]


class Key:
    """One numeric key: `name` is its canonical name (what the coverage check compares), `path`
    the --set path, `kind` how a swept number becomes the key's value, [lo, hi] its documented
    range (open ends flagged; None: unbounded), `setup` the scene changes it needs."""

    def __init__(self, name, path, kind, lo, hi, lo_open=False, hi_open=False, setup=None, methods=("single", "wkb"),
                 integer=False):
        self.name, self.path, self.kind = name, path, kind
        self.lo, self.hi, self.lo_open, self.hi_open = lo, hi, lo_open, hi_open
        self.setup, self.methods, self.integer = setup, methods, integer

    def value(self, x, scene):
        """The JSON value that puts number x into this key of `scene` (other components kept)."""
        if self.kind == "scalar":
            return x
        if self.kind.startswith("component"):  # component<i> of a list: the others as in the scene
            i = int(self.kind[len("component"):])
            current = list(lookup(scene, self.path))
            current[i] = x
            return current
        raise AssertionError(self.kind)


def lookup(scene, path):
    node = scene
    for part in re.findall(r"[^.\[\]]+|\[\d+\]", path):
        node = node[int(part[1:-1])] if part.startswith("[") else node[part]
    return node


def light_setup(light):
    return lambda s: s.__setitem__("lights", [light])


def source_setup(source):
    return lambda s: s["volumes"][0].__setitem__("source", source)


def geometry_setup(g):
    return lambda s: s.__setitem__("geometry", [g])


def keys():
    k = []
    # Top level.
    k.append(Key("background", "background", "scalar", 0, None))
    k.append(Key("version", "version", "scalar", 1, 1, integer=True))
    # camera.
    for name in ("from", "to"):
        k.append(Key(f"camera.{name}", f"camera.{name}", "component0", None, None))
    k.append(Key("camera.up", "camera.up", "component0", None, None))
    k.append(Key("camera.fov", "camera.fov", "scalar", 1e-30, 180, hi_open=True))
    k.append(Key("camera.resolution", "camera.resolution", "component0", 1, 65536, integer=True))
    k.append(Key("camera.crop", "camera.crop", "component1", 0, 1))
    k.append(Key("camera.shutter", "camera.shutter", "component1", 0, None,
                 setup=lambda s: s["camera"].update(shutter=[0, 1], motion={"from": [0.1, 0, 3]})))
    k.append(Key("camera.motion.from", "camera.motion.from", "component0", None, None,
                 setup=lambda s: s["camera"].update(shutter=[0, 1], motion={"from": [0.1, 0, 3]})))
    # lights, one type at a time.
    distant = {"type": "distant", "direction": [0.3, -1, -0.2], "irradiance": 2, "angle": 0}
    point = {"type": "point", "position": [0, 2, 0], "intensity": 5}
    spot = {"type": "spot", "position": [0, 2, 0], "direction": [0, -1, 0], "intensity": 5, "cone_angle": 40,
            "cone_softness": 5}
    rect = {"type": "rect", "center": [0, 2, 0], "normal": [0, -1, 0], "up": [0, 0, 1], "size": [1, 1],
            "radiance": 2}
    sphere = {"type": "sphere", "position": [0, 2, 0], "radius": 0.5, "radiance": 2}
    env = {"type": "environment", "radiance": 0.5}
    for light, rows in ((distant, [("direction", "component0", None, None, False, False),
                                   ("irradiance", "scalar", 0, None, False, False),
                                   ("angle", "scalar", 0, 180, False, True)]),
                        (point, [("position", "component0", None, None, False, False),
                                 ("intensity", "scalar", 0, None, False, False)]),
                        (spot, [("position", "component1", None, None, False, False),
                                ("direction", "component0", None, None, False, False),
                                ("intensity", "scalar", 0, None, False, False),
                                ("cone_angle", "scalar", 0, 180, True, True),
                                ("cone_softness", "scalar", 0, 40, False, False)]),
                        (rect, [("center", "component1", None, None, False, False),
                                ("normal", "component0", None, None, False, False),
                                ("up", "component0", None, None, False, False),
                                ("size", "component0", 0, None, True, False),
                                ("radiance", "scalar", 0, None, False, False)]),
                        (sphere, [("position", "component1", None, None, False, False),
                                  ("radius", "scalar", 0, None, True, False),
                                  ("radiance", "scalar", 0, None, False, False)]),
                        (env, [("radiance", "scalar", 0, None, False, False),
                               ("rotate", "scalar", None, None, False, False),
                               ("intensity", "scalar", 0, None, False, False)])):
        for key, kind, lo, hi, lo_open, hi_open in rows:
            k.append(Key(f"lights.{light['type']}.{key}", f"lights[0].{key}", kind, lo, hi, lo_open, hi_open,
                         setup=light_setup(dict(light))))
    # volumes: medium and phase.
    m = "volumes[0].medium."
    for key in ("sigma_s", "sigma_a", "density_scale", "emission_scale"):
        k.append(Key(f"volumes.medium.{key}", m + key, "scalar", 0, None))
    # Any finite value; non-zero on this procedural source is refused naming the key (no vel grid).
    k.append(Key("volumes.medium.velocity_scale", m + "velocity_scale", "scalar", None, None))
    for key in ("g", "g2"):
        k.append(Key(f"volumes.medium.phase.{key}", m + "phase." + key, "scalar", -0.999, 0.999,
                     setup=lambda s: s["volumes"][0]["medium"].update(phase={"type": "hg2", "g": 0.3, "g2": -0.2,
                                                                            "blend": 0.3})))
    k.append(Key("volumes.medium.phase.blend", m + "phase.blend", "scalar", 0, 1,
                 setup=lambda s: s["volumes"][0]["medium"].update(phase={"type": "hg2", "g": 0.3, "g2": -0.2})))
    # volumes: transform, as an object and as the matrix.
    t = "volumes[0].transform"
    k.append(Key("volumes.transform.scale", t + ".scale", "scalar", 0, None, lo_open=True))
    k.append(Key("volumes.transform.rotate", t + ".rotate", "component0", None, None,
                 setup=lambda s: s["volumes"][0].update(transform={"rotate": [30, 0, 1, 0]})))
    k.append(Key("volumes.transform.translate", t + ".translate", "component0", None, None))
    k.append(Key("volumes.transform", t, "component3", None, None,
                 setup=lambda s: s["volumes"][0].update(transform=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])))
    # volumes: procedural parameters. voxel_size is kept coarse by setting the size keys against it.
    box = {"type": "procedural", "generator": "box", "size": 1, "voxel_size": 0.25}
    sph = {"type": "procedural", "generator": "sphere", "radius": 1, "voxel_size": 0.25}
    cloud = {"type": "procedural", "generator": "cloud", "radius": 1, "voxel_size": 0.25, "octaves": 1, "puffs": 0}
    for source, rows in ((box, [("size", 1e-4, 1e30, False, False), ("size_x", 1e-4, 1e30, False, False),
                                ("size_y", 1e-4, 1e30, False, False), ("size_z", 1e-4, 1e30, False, False),
                                ("voxel_size", 1e-4, 1e30, False, False), ("density", 0, 1e30, False, False)]),
                         (sph, [("radius", 1e-4, 1e30, False, False), ("voxel_size", 1e-4, 1e30, False, False),
                                ("density", 0, 1e30, False, False), ("falloff", 0, 1e30, False, False)]),
                         (cloud, [("radius", 1e-4, 1e30, False, False), ("voxel_size", 1e-4, 1e30, False, False),
                                  ("density", 0, 1e30, False, False), ("seed", 0, 2147483647, False, False),
                                  ("octaves", 1, 12, False, False), ("frequency", 0, None, True, False),
                                  ("detail", 0, 2, False, False), ("softness", 0, None, True, False),
                                  ("puffs", 0, 64, False, False), ("base", -10, 1, False, False)])):
        for key, lo, hi, lo_open, hi_open in rows:
            k.append(Key(f"volumes.source.{source['generator']}.{key}", f"volumes[0].source.{key}", "scalar", lo, hi,
                         lo_open, hi_open, setup=source_setup(dict(source)),
                         integer=key in ("seed", "octaves", "puffs")))
    # geometry.
    k.append(Key("geometry.radius", "geometry[0].radius", "scalar", 0, None, lo_open=True,
                 setup=geometry_setup({"type": "sphere", "radius": 0.3, "transform": {"translate": [0.5, 0, 1]}})))
    k.append(Key("geometry.size", "geometry[0].size", "component0", 0, None, lo_open=True,
                 setup=geometry_setup({"type": "plane", "size": [1, 1], "transform": {"translate": [0, -0.4, 0]}})))
    k.append(Key("geometry.transform", "geometry[0].transform", "component3", None, None,
                 setup=geometry_setup({"type": "sphere", "radius": 0.3,
                                       "transform": [1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1]})))
    # render.
    r = "render."
    rows = [("seed", 0, 4294967295, False, False, True), ("threads", 0, None, False, False, True),
            ("spp", 0, 4096, False, False, True), ("adaptive_threshold", 0, 1, False, False, False),
            ("adaptive_max_spp", 0, 4096, False, False, True), ("filter_width", 0, 16, True, False, False),
            ("step", 0.001, 100, False, False, False), ("shadow_map_resolution", 8, 16384, False, False, True),
            ("tolerance", 0, 0.5, True, False, False), ("shadow_step", 0, 100, True, False, False),
            ("light_samples", 1, 4096, False, False, True), ("emission_samples", 1, 1024, False, False, True),
            ("wkb_order2_samples", 1, 1024, False, False, True), ("wkb_blur_k", 0, 1000, True, False, False),
            ("wkb_orders3_paths", 0, 1 << 20, False, False, True), ("wkb_orders3_grid", 2, 512, False, False, True),
            ("wkb_l_step", 0, 10, True, False, False), ("wkb_order_max", 0, 4096, False, False, True),
            ("wkb_sh_order_max", 0, 8, False, False, True), ("light_volume_resolution", 4, 4096, False, False, True),
            ("wkb_memory_budget", 0, 100, True, False, False), ("memory_limit", 0, None, False, False, False),
            ("frame", -2147483648, 2147483647, False, False, True), ("fps", 0, None, True, False, False)]
    for key, lo, hi, lo_open, hi_open, integer in rows:
        methods = ("wkb",) if key.startswith("wkb_") or key == "light_volume_resolution" else ("single", "wkb")
        if key == "spp":
            methods = ("single", "wkb", "pathtrace")
        k.append(Key(f"render.{key}", r + key, "scalar", lo, hi, lo_open, hi_open, methods=methods, integer=integer))
    # The path tracer's own keys, rendered by it (one sample per pixel, a short time limit).
    for key, lo, hi, integer in (("max_depth", 0, None, True), ("time_limit", 0, None, False),
                                 ("noise_target", 0, 1, False)):
        k.append(Key(f"render.{key}", r + key, "scalar", lo, hi, methods=("pathtrace",), integer=integer))
    # Virtual ray lights' own key, rendered by vrl (docs/vrl.md).
    k.append(Key("render.vrl_paths", r + "vrl_paths", "scalar", 1, 4096, methods=("vrl",), integer=True))
    k.append(Key("output.exposure", "output.exposure", "scalar", -64, 64,
                 setup=lambda s: s["output"].update(preview="PREVIEW")))
    # Deep output's slice count, with a deep file to write (single and wkb; pathtrace refuses it).
    k.append(Key("output.deep_samples", "output.deep_samples", "scalar", 1, 1024, integer=True,
                 setup=lambda s: s["output"].update(deep="DEEP")))
    return k


def sweep_values(key):
    """The numbers tried for one key: its ends, just outside them, and the edge cases of floats."""
    values = [0.0, -0.0, 1e-310, 1e-45, 1e30, -1e30, 1e300]
    for end, outward in ((key.lo, -1), (key.hi, +1)):
        if end is None:
            continue
        values.append(float(end))
        step = 1 if key.integer else max(abs(end) * 1e-6, 1e-6)
        values.append(float(end) + outward * step)
    if key.integer:
        values += [2147483648.0]
    seen, unique = set(), []
    for v in values:
        tag = (v, math.copysign(1, v))
        if tag not in seen:
            seen.add(tag)
            unique.append(v)
    return unique


def number_text(v):
    if v == 0:
        return "-0.0" if math.copysign(1, v) < 0 else "0"
    if v == int(v) and abs(v) < 1e16:
        return str(int(v))
    return repr(v)


# Spellings JSON has no number for: --set takes them as text, a string where a number belongs.
# One per key (the path is the same for every key), all of them for camera.fov.
NON_NUMBERS = ["nan", "NaN", "inf", "-inf", "Infinity", "-Infinity", "1e", "0x10"]


def read_pixels(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    pixels = []
    for sub in range(64):
        if not inp.seek_subimage(sub, 0):
            break
        pixels.append(np.asarray(inp.read_image(oiio.FLOAT)))
    inp.close()
    return pixels


def run_case(case):
    """Render one (key, value text, method); returns None when it kept the contract, else why not."""
    key, text, method, workdir = case
    scene = copy.deepcopy(BASE_SCENE)
    scene["output"] = {"file": "out.exr"}
    if key.setup:
        key.setup(scene)
    d = tempfile.mkdtemp(dir=workdir)
    if scene["output"].get("preview") == "PREVIEW":
        scene["output"]["preview"] = os.path.join(d, "out.png")
    if scene["output"].get("deep") == "DEEP":
        scene["output"]["deep"] = os.path.join(d, "deep.exr")
    scene["output"]["file"] = os.path.join(d, "out.exr")
    scene["render"]["method"] = method
    if method in ("pathtrace", "vrl"):
        scene["render"]["spp"] = scene["render"].get("spp", 1) or 1
    path = os.path.join(d, "scene.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    args = [NIMBUS, "render", path, "-q", "--set", f"{key.path}={text}"]
    where = f"{key.path}={text} ({method})"
    try:
        p = subprocess.run(args, capture_output=True, text=True, timeout=CASE_WALL_S, preexec_fn=limit_cpu)
    except subprocess.TimeoutExpired:
        return f"{where}: no answer within {CASE_WALL_S} s of wall time"
    if p.returncode in (-signal.SIGXCPU, -signal.SIGKILL):
        return f"{where}: no answer within {CASE_CPU_S} s of CPU time"
    err_lines = [l for l in p.stderr.splitlines() if l.strip()]
    if p.returncode == 2:
        if len(err_lines) != 1:
            return f"{where}: exit 2 with {len(err_lines)} stderr lines:\n{p.stderr}"
        # The key as written: its last name (size[0] and crop count as size and crop).
        leaf = re.sub(r"\[\d+\]", "", key.path.split(".")[-1])
        if leaf not in err_lines[0]:
            return f"{where}: the error line does not name '{leaf}': {err_lines[0]}"
        if os.path.exists(scene["output"]["file"]):
            return f"{where}: exit 2 but an output was written"
        return None
    if p.returncode != 0:
        return f"{where}: exit {p.returncode}:\n{p.stderr[-2000:]}"
    try:
        for image in read_pixels(scene["output"]["file"]):
            bad = np.count_nonzero(~np.isfinite(image))
            if bad:
                return f"{where}: exit 0 with {bad} non-finite pixel values"
    except Exception as e:  # an unreadable EXR after exit 0 is a failure too
        return f"{where}: exit 0 but the EXR does not read: {e}"
    return ("ok", key, text, method)


def cases_for(key, workdir):
    texts = [number_text(v) for v in sweep_values(key)] + (NON_NUMBERS if key.name == "camera.fov" else ["nan"])
    return [(key, text, method, workdir) for text in texts for method in key.methods]


# ---- coverage: the docs' numeric keys and default-scene's ------------------------------------

NUMERIC_TYPE = re.compile(r"^(float|int|RGB|vec3|number|16 numbers|\[)")


def table_rows(lines):
    for line in lines:
        if line.startswith("|") and not line.startswith("|---"):
            yield [c.strip() for c in line.strip().strip("|").split("|")]


def strip_code(cell):
    return cell.replace("`", "").strip()


def documented_numeric_keys():
    """Canonical names of the numeric keys in docs/scene-format.md's tables and the generators'
    parameters in docs/volumes.md."""
    names = set()
    section, sub, light_type = "", "", ""
    with open(os.path.join(DOCS, "scene-format.md")) as f:
        lines = f.read().splitlines()
    prefixes = {"Top level": "", "camera": "camera.", "medium": "volumes.medium.", "transform": "volumes.transform.",
                "geometry": "geometry.", "render": "render.", "output": "output.", "sources": "volumes.source."}
    for line in lines:
        if line.startswith("#"):
            section = line.lstrip("#").strip()
            sub, light_type = "", ""
            continue
        if line.strip() == "`phase`:":
            sub = "phase."
            continue
        if not line.startswith("|") or line.startswith("|---"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells[0] in ("Key", "Type"):
            continue
        if section == "lights" and len(cells) >= 3 and cells[1].startswith("`") and len(cells) == 6:
            light_type = strip_code(cells[0]) or light_type
            key, typ = strip_code(cells[1]), cells[2]
            prefix = f"lights.{light_type}."
        else:
            key, typ = strip_code(cells[0]), cells[1] if len(cells) > 1 else ""
            if section not in prefixes:
                continue
            prefix = prefixes[section] + sub
        if key == "any other key" and section == "sources":
            # "(cloud: `radius`, `voxel_size`, ...; sphere: ...; box: ...)": every generator's list.
            for generator, params in re.findall(r"(\w+): ((?:`\w+`(?:, )?)+)", cells[-1]):
                names |= {f"volumes.source.{generator}.{p}" for p in re.findall(r"`(\w+)`", params)}
            continue
        if re.fullmatch(r"[a-z_0-9]+", key) and NUMERIC_TYPE.match(typ):
            names.add(prefix + key)
    with open(os.path.join(DOCS, "volumes.md")) as f:
        in_table, generator = False, ""
        for cells in table_rows(l for l in f.read().splitlines()):
            if cells[:2] == ["generator", "parameter"]:
                in_table = True
                continue
            if in_table and len(cells) == 4:
                generator = cells[0] or generator
                names.add(f"volumes.source.{generator}.{strip_code(cells[1])}")
    return names


def default_scene_numeric_keys(doc, prefix=""):
    """Canonical names of the numeric leaves of a scene document (lists of numbers count once)."""
    names = set()
    if isinstance(doc, dict):
        for k, v in doc.items():
            names |= default_scene_numeric_keys(v, f"{prefix}{k}.")
    elif isinstance(doc, list):
        if doc and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in doc):
            names.add(prefix[:-1])
        for item in doc:
            if isinstance(item, dict):
                p = prefix
                if prefix == "lights.":
                    p = f"lights.{item['type']}."
                names |= default_scene_numeric_keys(item, p)
    elif isinstance(doc, (int, float)) and not isinstance(doc, bool):
        names.add(prefix[:-1])
    return names


class InputSweep(unittest.TestCase):
    def test_every_documented_numeric_key_is_swept(self):
        swept = {k.name for k in keys()}
        documented = documented_numeric_keys()
        self.assertGreater(len(documented), 50, f"the docs' tables did not parse: {sorted(documented)}")
        p = subprocess.run([NIMBUS, "default-scene"], capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 0, p.stderr)
        in_code = default_scene_numeric_keys(json.loads(p.stdout))
        self.assertGreater(len(in_code), 20)
        missing = sorted((documented | in_code) - swept)
        self.assertEqual(missing, [], "numeric scene keys the sweep does not cover; add them to keys()")
        not_documented = sorted(swept - documented - in_code - {"camera.motion.from"})
        self.assertEqual(not_documented, [], "swept keys no table documents")

    def test_every_numeric_key_renders_finite_or_is_refused_in_one_line(self):
        only = os.environ.get("NIMBUS_SWEEP_KEYS")  # a regex, to rerun some keys
        chosen = [k for k in keys() if not only or re.search(only, k.name)]
        jobs = int(os.environ.get("NIMBUS_SWEEP_JOBS", "2"))
        with tempfile.TemporaryDirectory() as workdir:
            cases = [c for k in chosen for c in cases_for(k, workdir)]
            # single first; wkb and pathtrace only for values that single did not refuse, since
            # a refusal comes from the validation every method shares.
            failures, refused = [], set()
            first = [c for c in cases if c[2] == chosen_first(c[0])]
            rest = [c for c in cases if c[2] != chosen_first(c[0])]
            ran = 0
            with concurrent.futures.ThreadPoolExecutor(jobs) as pool:
                for case, result in zip(first, pool.map(run_case, first)):
                    ran += 1
                    if result is None:
                        refused.add((case[0].name, case[1]))
                    elif isinstance(result, str):
                        print("FAIL", result, file=sys.stderr, flush=True)
                        failures.append(result)
                rest = [c for c in rest if (c[0].name, c[1]) not in refused]
                for case, result in zip(rest, pool.map(run_case, rest)):
                    ran += 1
                    if isinstance(result, str):
                        print("FAIL", result, file=sys.stderr, flush=True)
                        failures.append(result)
        print(f"{len(chosen)} keys, {ran} cases, {len(failures)} failures", file=sys.stderr)
        self.assertEqual(failures, [], "\n" + "\n".join(failures))


def chosen_first(key):
    return key.methods[0]


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
