#!/usr/bin/python3
"""The command line's contract (issue 2): exit codes, one-line errors naming the file and the
key path, earlier outputs left untouched, tolerated inputs rendering finite non-negative images.

Run by ctest with Debian's python3 (pyopenvdb and OpenImageIO's bindings come from Debian):
    test_cli.py NIMBUS_BINARY [-k NAME]
"""
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import OpenImageIO as oiio
import pyopenvdb as vdb

NIMBUS = None


def run(*args, cwd=None):
    p = subprocess.run([NIMBUS, *args], capture_output=True, text=True, cwd=cwd, timeout=600)
    return p.returncode, p.stdout, p.stderr


def small_scene(**overrides):
    scene = {
        "camera": {"from": [0, 0, 6], "to": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "resolution": [32, 24]},
        "lights": [{"name": "key", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [2, 2, 2]}],
        "volumes": [{"name": "ball", "source": {"type": "procedural", "generator": "sphere", "radius": 1.0,
                                                "voxel_size": 0.1},
                     "medium": {"sigma_s": [2, 2, 2], "sigma_a": [0.1, 0.1, 0.1]}}],
        "render": {"method": "single", "spp": 1},
        "output": {"file": "out.exr"},
    }
    scene.update(overrides)
    return scene


def read_exr(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    spec = inp.spec()
    pixels = inp.read_image(oiio.FLOAT)
    names = list(spec.channelnames)
    meta = {a.name: a.value for a in spec.extra_attribs}
    inp.close()
    return names, np.asarray(pixels), meta


def write_vdb(path, values, name="density", voxel=0.1):
    grid = vdb.FloatGrid()
    grid.name = name
    grid.transform = vdb.createLinearTransform(voxelSize=voxel)
    acc = grid.getAccessor()
    for ijk, v in values:
        acc.setValueOn(ijk, v)
    vdb.write(path, grids=[grid])


class Cli(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name
        # An earlier render at the output path: bad input must leave it byte for byte.
        self.out = os.path.join(self.d, "out.exr")
        with open(self.out, "wb") as f:
            f.write(b"earlier render")

    def tearDown(self):
        self.dir.cleanup()

    def scene_file(self, scene, name="scene.json"):
        path = os.path.join(self.d, name)
        if isinstance(scene, str):
            text = scene
        else:
            scene.setdefault("output", {})["file"] = self.out
            text = json.dumps(scene)
        with open(path, "w") as f:
            f.write(text)
        return path

    def expect_bad_input(self, args, *fragments):
        code, out, err = run(*args)
        self.assertEqual(code, 2, f"exit code for {args}: {code}\n{err}")
        lines = [l for l in err.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, f"one error line expected, got:\n{err}")
        for frag in fragments:
            self.assertIn(frag, lines[0])
        with open(self.out, "rb") as f:
            self.assertEqual(f.read(), b"earlier render", "the earlier output was touched")
        return lines[0]

    # Bad input: one line, exit 2, earlier output untouched.
    def test_missing_scene_file(self):
        path = os.path.join(self.d, "nope.json")
        self.expect_bad_input(["render", path, "-o", self.out], "nope.json")

    def test_bad_json(self):
        path = self.scene_file('{"camera": {"fov": 40,, }')
        self.expect_bad_input(["render", path, "-o", self.out], "scene.json", "line 1")

    def test_unknown_key(self):
        s = small_scene()
        s["render"]["bogus"] = 1
        self.expect_bad_input(["render", self.scene_file(s)], "scene.json", "render.bogus")

    def test_wrong_type(self):
        s = small_scene()
        s["volumes"][0]["medium"]["sigma_s"] = "lots"
        self.expect_bad_input(["render", self.scene_file(s)], "scene.json", "volumes[0].medium.sigma_s")

    def test_zero_fov(self):
        s = small_scene()
        s["camera"]["fov"] = 0
        self.expect_bad_input(["render", self.scene_file(s)], "scene.json", "camera.fov")

    def test_negative_resolution(self):
        s = small_scene()
        s["camera"]["resolution"] = [-32, 24]
        self.expect_bad_input(["render", self.scene_file(s)], "scene.json", "camera.resolution")

    def test_camera_looking_at_itself(self):
        s = small_scene()
        s["camera"]["to"] = s["camera"]["from"]
        self.expect_bad_input(["render", self.scene_file(s)], "scene.json", "camera")

    def test_missing_vdb_file(self):
        s = small_scene()
        s["volumes"][0]["source"] = {"type": "vdb", "file": "missing.vdb"}
        self.expect_bad_input(["render", self.scene_file(s)], "scene.json", "volumes[0].source.file", "missing.vdb")

    def test_missing_grid(self):
        vdb_path = os.path.join(self.d, "cloud.vdb")
        write_vdb(vdb_path, [((0, 0, 0), 1.0)], name="smoke")
        s = small_scene()
        s["volumes"][0]["source"] = {"type": "vdb", "file": vdb_path, "grids": {"density": "density"}}
        self.expect_bad_input(["render", self.scene_file(s)], "scene.json", "volumes[0].source.grids.density", "density")

    def test_bad_override(self):
        self.expect_bad_input(["render", self.scene_file(small_scene()), "--set", "camera.fov=-3"], "camera.fov")

    def test_unknown_flag(self):
        code, _, err = run("render", self.scene_file(small_scene()), "--frobnicate")
        self.assertEqual(code, 2, err)

    def test_unwritable_output_fails_before_rendering(self):
        blocker = os.path.join(self.d, "file")
        open(blocker, "w").close()
        self.expect_bad_input(["render", self.scene_file(small_scene()), "-o", os.path.join(blocker, "x.exr")],
                              "output.file")

    def test_unknown_aov(self):
        s = small_scene()
        s["output"] = {"aovs": ["beauty", "L2plus"]}  # single has no L2plus
        self.expect_bad_input(["render", self.scene_file(s)], "output.aovs")

    # Tolerated input: the render succeeds with a finite, non-negative image.
    def assert_clean_render(self, scene):
        code, out, err = run("render", self.scene_file(scene), "-q")
        self.assertEqual(code, 0, err)
        names, px, meta = read_exr(self.out)
        self.assertTrue(np.all(np.isfinite(px)), "non-finite pixels")
        self.assertTrue(np.all(px >= 0), "negative pixels")
        return names, px, meta

    def test_bad_voxels_clamped_with_one_warning(self):
        vdb_path = os.path.join(self.d, "bad.vdb")
        vals = [((i, j, k), 1.0) for i in range(-4, 4) for j in range(-4, 4) for k in range(-4, 4)]
        vals[0] = ((-4, -4, -4), float("nan"))
        vals[1] = ((-4, -4, -3), -5.0)
        vals[2] = ((-4, -4, -2), float("inf"))
        vals[3] = ((-4, -4, -1), float("-inf"))
        write_vdb(vdb_path, vals, voxel=0.2)
        s = small_scene()
        s["volumes"][0]["source"] = {"type": "vdb", "file": vdb_path}
        code, _, err = run("render", self.scene_file(s))
        self.assertEqual(code, 0, err)
        warnings = [l for l in err.splitlines() if "warning" in l]
        self.assertEqual(len(warnings), 1, err)
        self.assertIn("4", warnings[0])
        names, px, _ = read_exr(self.out)
        self.assertTrue(np.all(np.isfinite(px)) and np.all(px >= 0))

    def test_empty_grid(self):
        vdb_path = os.path.join(self.d, "empty.vdb")
        write_vdb(vdb_path, [])
        s = small_scene()
        s["volumes"][0]["source"] = {"type": "vdb", "file": vdb_path}
        self.assert_clean_render(s)

    def test_camera_and_light_inside_volume(self):
        s = small_scene()
        s["camera"]["from"] = [0.1, 0.05, 0.2]
        s["lights"].append({"name": "bulb", "type": "point", "position": [0, 0.2, -0.2], "intensity": [3, 3, 3]})
        self.assert_clean_render(s)

    def test_emission_from_temperature_renders_in_L0(self):
        vdb_path = os.path.join(self.d, "fire.vdb")
        density, temperature = vdb.FloatGrid(), vdb.FloatGrid()
        density.name, temperature.name = "density", "temperature"
        for g in (density, temperature):
            g.transform = vdb.createLinearTransform(voxelSize=0.1)
        da, ta = density.getAccessor(), temperature.getAccessor()
        for i in range(-5, 5):
            for j in range(-5, 5):
                for k in range(-5, 5):
                    da.setValueOn((i, j, k), 0.5)
                    ta.setValueOn((i, j, k), 1800.0)  # kelvin
        vdb.write(vdb_path, grids=[density, temperature])
        s = small_scene(lights=[])
        s["volumes"][0]["source"] = {"type": "vdb", "file": vdb_path,
                                     "grids": {"density": "density", "temperature": "temperature"}}
        names, px, _ = self.assert_clean_render(s)
        L0 = px[..., [names.index(f"L0.{c}") for c in "RGB"]]
        L1 = px[..., [names.index(f"L1.{c}") for c in "RGB"]]
        self.assertGreater(float(L0.max()), 0.0, "the hot volume should glow in L0")
        self.assertGreater(float(L0[..., 0].max()), float(L0[..., 2].max()), "1800 K glows red, not blue")
        self.assertEqual(float(L1.max()), 0.0, "no lights, no single scattering")

    def test_several_volumes_each_lit(self):
        s = small_scene()
        ball = s["volumes"][0]
        left = json.loads(json.dumps(ball))
        right = json.loads(json.dumps(ball))
        left["name"], right["name"] = "left", "right"
        left["transform"] = {"translate": [-1.5, 0, 0], "scale": 0.5}
        right["transform"] = {"translate": [1.5, 0, 0], "scale": 0.5}
        right["medium"]["sigma_s"] = [0.5, 2, 0.5]
        s["volumes"] = [left, right]
        s["camera"]["resolution"] = [48, 16]
        names, px, _ = self.assert_clean_render(s)
        beauty = px[..., names.index("beauty.G")]
        self.assertGreater(float(beauty[:, :22].max()), 0.0, "left volume lit")
        self.assertGreater(float(beauty[:, 26:].max()), 0.0, "right volume lit")
        self.assertEqual(float(beauty[:, 22:26].max()), 0.0, "nothing between them")

    # The EXR's shape: layers, channel types, metadata.
    def test_exr_layers_and_metadata(self):
        s = small_scene()
        names, px, meta = self.assert_clean_render(s)
        for aov in ["beauty", "L0", "L1", "alpha", "depth", "light_key"]:
            for c in "RGB":
                self.assertIn(f"{aov}.{c}", names)
        for key in ["nimbus:version", "nimbus:method", "nimbus:seed", "nimbus:render_time", "nimbus:settings"]:
            self.assertIn(key, meta)
        self.assertEqual(meta["nimbus:method"], "single")
        lit = px[..., names.index("beauty.R")]
        self.assertGreater(float(lit.max()), 0.0, "the sphere should be lit")

    def test_method_flag_and_set(self):
        s = small_scene()
        code, _, err = run("render", self.scene_file(s), "-q", "--set", "render.seed=7", "--set",
                           "camera.resolution=[16,12]")
        self.assertEqual(code, 0, err)
        names, px, meta = read_exr(self.out)
        self.assertEqual(px.shape[:2], (12, 16))
        self.assertEqual(meta["nimbus:seed"], "7")

    def test_info_prints_plan(self):
        s = small_scene()
        s["lights"].append({"name": "dark", "type": "point", "position": [0, 3, 0], "intensity": [0, 0, 0]})
        code, out, err = run("info", self.scene_file(s))
        self.assertEqual(code, 0, err)
        self.assertIn("render plan", out)
        self.assertIn("deep shadow map", out)
        self.assertIn("skipped: zero power", out)

    def test_default_scene_renders(self):
        code, _, err = run("render", "--default", "-q", "-o", self.out, "--set", "camera.resolution=[48,27]",
                           "--set", "render.spp=1", "--preview", os.path.join(self.d, "p.png"))
        self.assertEqual(code, 0, err)
        self.assertTrue(os.path.getsize(os.path.join(self.d, "p.png")) > 0)


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
