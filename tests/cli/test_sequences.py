#!/usr/bin/python3
"""Sequences (issue 16, item 1; docs/sequences.md): frame tokens in scene paths, `render.frame`,
`--frame N`, `--frames SPEC` in one process, missing frame files and `--skip-missing`.

Run by ctest with Debian's python3 (pyopenvdb and OpenImageIO's bindings come from Debian):
    test_sequences.py NIMBUS_BINARY [-k NAME]
"""
import json
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


def read_exr(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    spec = inp.spec()
    pixels = np.asarray(inp.read_image(oiio.FLOAT))
    meta = {a.name: a.value for a in spec.extra_attribs}
    inp.close()
    return pixels, meta


def write_ball(path, radius):
    """A tiny VDB: a ball of density 1 of `radius` voxels (0.1 m each): each frame differs."""
    grid = vdb.FloatGrid()
    grid.name = "density"
    grid.transform = vdb.createLinearTransform(voxelSize=0.1)
    acc = grid.getAccessor()
    r = int(radius)
    for i in range(-r, r + 1):
        for j in range(-r, r + 1):
            for k in range(-r, r + 1):
                if i * i + j * j + k * k <= radius * radius:
                    acc.setValueOn((i, j, k), 1.0)
    vdb.write(path, grids=[grid])


def scene(source, output):
    return {
        "camera": {"from": [0, 0, 6], "to": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "resolution": [32, 24]},
        "lights": [{"name": "key", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [2, 2, 2]}],
        "volumes": [{"name": "smoke", "source": source,
                     "medium": {"sigma_s": [2, 2, 2], "sigma_a": [0.1, 0.1, 0.1]}}],
        "render": {"method": "single", "spp": 1},
        "output": {"file": output},
    }


class Sequences(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name
        os.makedirs(os.path.join(self.d, "cache"))
        for frame, radius in ((1, 4), (2, 6), (3, 8)):
            write_ball(os.path.join(self.d, "cache", f"smoke.{frame:04d}.vdb"), radius)

    def tearDown(self):
        self.dir.cleanup()

    def path(self, *parts):
        return os.path.join(self.d, *parts)

    def scene_file(self, s, name="shot.json"):
        with open(self.path(name), "w") as f:
            json.dump(s, f)
        return self.path(name)

    def vdb_shot(self, output="out/beauty.$F4.exr"):
        # Relative to the scene file, in the spelling '####'; the output in '$F4'.
        return self.scene_file(scene({"type": "vdb", "file": "cache/smoke.####.vdb"}, self.path(output)))

    def outputs(self, folder="out"):
        return sorted(os.listdir(self.path(folder))) if os.path.isdir(self.path(folder)) else []

    def expect_bad_input(self, args, *fragments):
        code, _, err = run(*args)
        self.assertEqual(code, 2, f"exit code for {args}: {code}\n{err}")
        lines = [l for l in err.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, f"one error line expected, got:\n{err}")
        for frag in fragments:
            self.assertIn(frag, lines[0])
        return lines[0]

    def test_vdb_sequence_renders_each_frame_from_its_file(self):
        code, _, err = run("render", self.vdb_shot(), "--frames", "1-3")
        self.assertEqual(code, 0, err)
        self.assertEqual(self.outputs(), ["beauty.0001.exr", "beauty.0002.exr", "beauty.0003.exr"])
        alphas = []
        for frame in (1, 2, 3):
            pixels, meta = read_exr(self.path("out", f"beauty.{frame:04d}.exr"))
            self.assertEqual(meta["nimbus:frame"], frame)
            self.assertIn(f"frame {frame}: wrote", err)  # the per-frame time line
            alphas.append(float(pixels[..., 3].sum()))
        # Each frame read its own file: the ball grows with the frame, so does its coverage.
        self.assertLess(alphas[0], alphas[1])
        self.assertLess(alphas[1], alphas[2])
        self.assertIn("3 frame(s) rendered", err)

    def test_frame_two_of_a_sequence_equals_frame_two_alone(self):
        shot = self.vdb_shot()
        code, _, err = run("render", shot, "--frames", "1-3", "-q")
        self.assertEqual(code, 0, err)
        code, _, err = run("render", shot, "--frame", "2", "-q", "-o", self.path("alone", "beauty.$F4.exr"))
        self.assertEqual(code, 0, err)
        self.assertEqual(self.outputs("alone"), ["beauty.0002.exr"])
        in_sequence, _ = read_exr(self.path("out", "beauty.0002.exr"))
        alone, _ = read_exr(self.path("alone", "beauty.0002.exr"))
        self.assertEqual(in_sequence.tobytes(), alone.tobytes())

    def test_static_volume_is_kept_between_frames_and_changes_nothing(self):
        # A procedural volume: no path, no token; the frames differ only in their output name.
        s = scene({"type": "procedural", "generator": "cloud", "radius": 1.0, "voxel_size": 0.08},
                  self.path("out", "cloud.####.exr"))
        shot = self.scene_file(s)
        code, _, err = run("render", shot, "--frames", "1-3")
        self.assertEqual(code, 0, err)
        self.assertIn("frame 1: wrote", err)
        self.assertIn("volumes: 0 reused, 1 built; shadow maps: 0 reused, 1 built", err)  # frame 1
        # frames 2 and 3: the volume and the key light's deep shadow map (ShadowMapCache.h)
        self.assertEqual(err.count("volumes: 1 reused, 0 built; shadow maps: 1 reused, 0 built"), 2, err)
        code, _, err = run("render", shot, "--frame", "3", "-q", "-o", self.path("alone", "cloud.$F.exr"))
        self.assertEqual(code, 0, err)
        reused, _ = read_exr(self.path("out", "cloud.0003.exr"))
        built, _ = read_exr(self.path("alone", "cloud.3.exr"))
        self.assertEqual(reused.tobytes(), built.tobytes())
        # wkb reads the kept maps too (its light volumes' E): still the frame rendered alone.
        code, _, err = run("render", shot, "--frames", "1-2", "-q", "--method", "wkb", "-o",
                           self.path("wkb", "cloud.$F.exr"))
        self.assertEqual(code, 0, err)
        code, _, err = run("render", shot, "--frame", "2", "-q", "--method", "wkb", "-o",
                           self.path("wkbalone", "cloud.$F.exr"))
        self.assertEqual(code, 0, err)
        reused, _ = read_exr(self.path("wkb", "cloud.2.exr"))
        built, _ = read_exr(self.path("wkbalone", "cloud.2.exr"))
        self.assertEqual(reused.tobytes(), built.tobytes())

    def test_static_sky_grid_is_kept_between_frames_and_changes_nothing(self):
        # An environment light (uniform, then a map) over a static volume: frames 2 and 3 take the
        # sky grid of the frame before (ShadowMapCache.h), bit-identical to a frame rendered alone.
        s = scene({"type": "procedural", "generator": "cloud", "radius": 1.0, "voxel_size": 0.08},
                  self.path("out", "sky.####.exr"))
        s["lights"].append({"name": "sky", "type": "environment", "radiance": [0.1, 0.2, 0.4]})
        shot = self.scene_file(s)
        for method in ("single", "wkb"):
            with self.subTest(method=method):
                code, _, err = run("render", shot, "--frames", "1-3", "--method", method, "-o",
                                   self.path(method, "sky.$F.exr"))
                self.assertEqual(code, 0, err)
                self.assertEqual(err.count("sky grids: 0 reused, 1 built"), 1, err)  # frame 1
                self.assertEqual(err.count("sky grids: 1 reused, 0 built"), 2, err)  # frames 2 and 3
                code, _, err = run("render", shot, "--frame", "3", "-q", "--method", method, "-o",
                                   self.path(method + "alone", "sky.$F.exr"))
                self.assertEqual(code, 0, err)
                reused, _ = read_exr(self.path(method, "sky.3.exr"))
                built, _ = read_exr(self.path(method + "alone", "sky.3.exr"))
                self.assertEqual(reused.tobytes(), built.tobytes())
        # A map: kept while the file is the same, built again where the frame names another file.
        write_sky = ("import OpenImageIO as oiio, numpy as np, sys\n"
                     "o = oiio.ImageOutput.create(sys.argv[1]); o.open(sys.argv[1], oiio.ImageSpec(8, 4, 3, 'float'))\n"
                     "o.write_image(np.full((4, 8, 3), float(sys.argv[2]), np.float32)); o.close()\n")
        for name, value in (("sky.exr", "0.3"), ("sky.1.exr", "0.3"), ("sky.2.exr", "0.6")):
            subprocess.run([sys.executable, "-c", write_sky, self.path(name), value], check=True)
        for map_name, reused in (("sky.exr", 1), ("sky.$F.exr", 0)):
            with self.subTest(map=map_name):
                s["lights"][1] = {"name": "sky", "type": "environment", "map": self.path(map_name)}
                shot = self.scene_file(s, "mapped.json")
                code, _, err = run("render", shot, "--frames", "1-2", "-o", self.path("map", "sky.$F.exr"))
                self.assertEqual(code, 0, err)
                self.assertEqual(err.count("sky grids: 1 reused, 0 built"), reused, err)
                self.assertEqual(err.count("sky grids: 0 reused, 1 built"), 2 - reused, err)

    def test_render_frame_key_and_frame_flag(self):
        s = scene({"type": "vdb", "file": "cache/smoke.$F4.vdb"}, self.path("out", "b.$F.exr"))
        s["render"]["frame"] = 3
        shot = self.scene_file(s)
        code, _, err = run("render", shot, "-q")
        self.assertEqual(code, 0, err)
        self.assertEqual(self.outputs(), ["b.3.exr"])
        code, _, err = run("render", shot, "-q", "--frame", "1")  # the flag wins over the key
        self.assertEqual(code, 0, err)
        self.assertEqual(self.outputs(), ["b.1.exr", "b.3.exr"])
        _, meta = read_exr(self.path("out", "b.1.exr"))
        self.assertEqual(meta["nimbus:frame"], 1)

    def test_stepped_and_listed_frames_and_tokens_in_directories(self):
        shot = self.vdb_shot(output="frames/f$F/beauty.exr")
        code, _, err = run("render", shot, "--frames", "1-3x2", "-q")
        self.assertEqual(code, 0, err)
        self.assertEqual(self.outputs("frames"), ["f1", "f3"])
        self.assertTrue(os.path.isfile(self.path("frames", "f3", "beauty.exr")))
        code, _, err = run("render", shot, "--frames", "2,1", "-q")
        self.assertEqual(code, 0, err)
        self.assertEqual(self.outputs("frames"), ["f1", "f2", "f3"])

    def test_missing_frame_file_is_bad_input_naming_it(self):
        os.remove(self.path("cache", "smoke.0002.vdb"))
        shot = self.vdb_shot()
        self.expect_bad_input(["render", shot, "--frames", "1-3"], "shot.json", "volumes[0].source.file",
                              "smoke.0002.vdb", "no such file")
        self.assertEqual(self.outputs(), [], "no frame is written when one is missing")
        self.expect_bad_input(["render", shot, "--frame", "2"], "volumes[0].source.file", "smoke.0002.vdb")

    def test_skip_missing_renders_the_others(self):
        os.remove(self.path("cache", "smoke.0002.vdb"))
        code, _, err = run("render", self.vdb_shot(), "--frames", "1-3", "--skip-missing")
        self.assertEqual(code, 0, err)
        self.assertEqual(self.outputs(), ["beauty.0001.exr", "beauty.0003.exr"])
        warnings = [l for l in err.splitlines() if "warning" in l]
        self.assertEqual(len(warnings), 1, err)
        self.assertIn("frame 2 skipped", warnings[0])
        self.assertIn("smoke.0002.vdb", warnings[0])
        self.assertIn("2 frame(s) rendered in", err)
        self.assertIn("1 skipped", err)

    def test_bad_frames_spec_is_one_line_naming_the_flag(self):
        shot = self.vdb_shot()
        for spec in ("3-1", "1-", "a", "1-3x0", "1,,2", "1,1", ""):
            line = self.expect_bad_input(["render", shot, "--frames", spec], "--frames")
            self.assertIn("bad frame list", line)
        self.expect_bad_input(["render", shot, "--frame", "x"], "--frame")
        self.expect_bad_input(["render", shot, "--frame", "2", "--frames", "1-3"], "--frame")
        self.assertEqual(self.outputs(), [])

    def test_output_without_token_is_refused_for_several_frames(self):
        shot = self.scene_file(scene({"type": "vdb", "file": "cache/smoke.####.vdb"}, self.path("out", "b.exr")))
        self.expect_bad_input(["render", shot, "--frames", "1-3"], "shot.json", "output.file", "b.exr",
                              "overwrite each other")
        self.expect_bad_input(["render", shot, "--frames", "1-3", "-o", self.path("out", "b.$F.exr"),
                               "--preview", self.path("out", "p.png")], "output.preview", "p.png")
        self.assertEqual(self.outputs(), [])
        # One frame needs no token.
        code, _, err = run("render", shot, "--frames", "2", "-q")
        self.assertEqual(code, 0, err)
        self.assertEqual(self.outputs(), ["b.exr"])

    # ---- animation keys (issue 16, item 2; docs/scene-format.md "Animation") ----

    def animated_shot(self, output):
        s = scene({"type": "procedural", "generator": "cloud", "radius": 1.0, "voxel_size": 0.08}, output)
        s["camera"]["from"] = [{"frame": 1, "value": [0, 0, 6]}, {"frame": 5, "value": [4, 1, 6]}]
        s["lights"][0]["direction"] = [{"frame": 1, "value": [0.3, -1, -0.2]}, {"frame": 5, "value": [-0.5, -1, 0.1]}]
        s["volumes"][0]["transform"] = [{"frame": 1, "value": {"translate": [0, 0, 0]}},
                                        {"frame": 5, "value": {"rotate": [60, 0, 1, 0], "translate": [0.4, 0, 0]}}]
        return s

    def test_animated_frames_equal_the_static_scenes_of_their_values(self):
        s = self.animated_shot(self.path("out", "anim.$F.exr"))
        shot = self.scene_file(s)
        code, _, err = run("render", shot, "--frames", "1-3", "-q")
        self.assertEqual(code, 0, err)
        # Frame 3 is halfway: the same scene written with the halfway values renders the same bits.
        static = scene({"type": "procedural", "generator": "cloud", "radius": 1.0, "voxel_size": 0.08},
                       self.path("static", "s.exr"))
        static["camera"]["from"] = [2, 0.5, 6]
        static["lights"][0]["direction"] = [-0.1, -1, -0.05]
        static["volumes"][0]["transform"] = {"rotate": [30, 0, 1, 0], "translate": [0.2, 0, 0]}
        code, _, err = run("render", self.scene_file(static, "static.json"), "-q")
        self.assertEqual(code, 0, err)
        frame3, meta = read_exr(self.path("out", "anim.3.exr"))
        reference, _ = read_exr(self.path("static", "s.exr"))
        np.testing.assert_allclose(frame3, reference, rtol=0, atol=1e-6)
        # The header's scene is the frame's: plain values, no keys.
        header = json.loads(meta["nimbus:scene"])
        self.assertEqual(len(header["camera"]["from"]), 3)
        self.assertTrue(all(isinstance(v, (int, float)) for v in header["camera"]["from"]))
        # Frames differ (the camera moved), and the moving volume was not taken from the cache.
        frame1, _ = read_exr(self.path("out", "anim.1.exr"))
        self.assertGreater(float(np.abs(frame1 - frame3).max()), 1e-3)

    def test_camera_keys_blur_over_the_shutter_as_motion_does(self):
        s = scene({"type": "procedural", "generator": "cloud", "radius": 1.0, "voxel_size": 0.08},
                  self.path("out", "keys.exr"))
        s["camera"]["from"] = [{"frame": 1, "value": [0, 0, 6]}, {"frame": 3, "value": [2, 0, 6]}]
        s["camera"]["shutter"] = [0, 0.5]
        s["render"]["frame"] = 2
        code, _, err = run("render", self.scene_file(s), "-q")
        self.assertEqual(code, 0, err)
        m = scene({"type": "procedural", "generator": "cloud", "radius": 1.0, "voxel_size": 0.08},
                  self.path("out", "motion.exr"))
        m["camera"]["from"] = [1, 0, 6]
        m["camera"]["shutter"] = [0, 0.5]
        m["camera"]["motion"] = {"from": [1.5, 0, 6]}
        m["render"]["frame"] = 2
        code, _, err = run("render", self.scene_file(m, "motion.json"), "-q")
        self.assertEqual(code, 0, err)
        keys, _ = read_exr(self.path("out", "keys.exr"))
        motion, _ = read_exr(self.path("out", "motion.exr"))
        np.testing.assert_allclose(keys, motion, rtol=0, atol=1e-6)

    def test_what_moves_in_the_shutter_warns_only_where_not_blurred_and_bad_keys_are_one_line(self):
        # Lights, volume transforms and the fov are blurred within the shutter
        # (docs/motion-blur.md): no warning; geometry is not: one warning naming it.
        s = self.animated_shot(self.path("out", "w.exr"))
        s["camera"]["shutter"] = [0, 0.5]
        s["render"]["frame"] = 2
        code, _, err = run("render", self.scene_file(s), "-q")
        self.assertEqual(code, 0, err)
        self.assertNotIn("lights[0].direction", err)
        self.assertNotIn("volumes[0].transform", err)
        s["camera"]["fov"] = [{"frame": 1, "value": 40}, {"frame": 5, "value": 30}]
        code, _, err = run("render", self.scene_file(s), "-q")
        self.assertEqual(code, 0, err)
        self.assertNotIn("not motion-blurred", err)
        self.assertNotIn("camera.fov", err)
        s["geometry"] = [{"type": "sphere", "radius": 0.1, "holdout": False,
                          "transform": [{"frame": 1, "value": {"translate": [1, 0, 0]}},
                                        {"frame": 5, "value": {"translate": [1, 1, 0]}}]}]
        code, _, err = run("render", self.scene_file(s), "-q")
        self.assertEqual(code, 0, err)
        self.assertIn("geometry[0].transform moves during the shutter but is not motion-blurred", err)
        self.assertNotIn("camera.fov", err)
        self.assertNotIn("lights[0].direction", err)
        del s["geometry"]
        s["camera"]["from"] = [{"frame": 1, "value": [0, 0, 6]}, {"frame": 1, "value": [1, 0, 6]}]
        self.expect_bad_input(["render", self.scene_file(s, "bad.json")], "bad.json", "camera.from[1]",
                              "second key at frame 1")


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
