#!/usr/bin/python3
"""Splitting a frame (issue 16, item 4; docs/farm.md): `--tile I/N`, the path tracer's
`--samples A-B` and seed splits, and `nimbus merge OUT.exr PARTS...`.

- Tiles merged are the frame rendered whole, bit for bit (every channel, the windows), for
  single, wkb and pathtrace, for N that do and do not divide the height, and inside a crop.
- K sample splits of one seed merged are one render of K times the samples: the same samples,
  pooled in double instead of accumulated in float, so equal to float rounding (1e-5 relative),
  the variance AOV included.
- K seed splits merged against one render of K times the samples from another seed: per pixel
  z = (a - b) / sqrt(var_a + var_b) from the files' own variance AOVs, mean z^2 within 5 standard
  errors of 1 (chi-square with one degree of freedom per pixel); the merged variance AOV against
  the single run's by a paired t-test over the pixels.
- Mismatched parts (scene, frame, overlapping tiles or samples, a missing tile, a checkpoint)
  are refused: exit 2, one line naming the part, no output.

Run by ctest with Debian's python3:  test_merge.py NIMBUS_BINARY [-k NAME]
"""
import json
import os
import random
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import OpenImageIO as oiio

NIMBUS = None


def run(*args):
    p = subprocess.run([NIMBUS, *args], capture_output=True, text=True, timeout=600)
    return p.returncode, p.stdout, p.stderr


def read_exr(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    spec = inp.spec()
    pixels = np.asarray(inp.read_image(oiio.FLOAT))
    inp.close()
    return spec, pixels


def channel(spec, pixels, name):
    return pixels[..., list(spec.channelnames).index(name)]


def cloud_scene(method, spp, resolution=(37, 29), crop=None):
    camera = {"from": [1.2, 0.8, 6], "to": [0.1, 0, 0], "up": [0, 1, 0], "fov": 30, "resolution": list(resolution)}
    if crop:
        camera["crop"] = crop
    return {
        "camera": camera,
        "lights": [{"name": "key", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [2, 2, 2]},
                   {"name": "fill", "type": "point", "position": [-3, 1, 2], "intensity": [4, 3, 2]}],
        "volumes": [{"name": "cloud", "source": {"type": "procedural", "generator": "cloud", "radius": 1.2,
                                                 "octaves": 3, "seed": 7, "voxel_size": 0.08},
                     "medium": {"sigma_s": [3, 3, 3], "sigma_a": [0.1, 0.1, 0.1]}}],
        "render": {"method": method, "spp": spp, "seed": 3},
    }


class Merge(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name

    def tearDown(self):
        self.dir.cleanup()

    def path(self, name):
        return os.path.join(self.d, name)

    def scene_file(self, scene, name="scene.json"):
        with open(self.path(name), "w") as f:
            json.dump(scene, f)
        return self.path(name)

    def render(self, scene_file, out, *flags):
        code, _, err = run("render", scene_file, "-q", "-o", self.path(out), *flags)
        self.assertEqual(code, 0, err)
        return self.path(out)

    def merge(self, out, parts):
        code, _, err = run("merge", "-q", self.path(out), *parts)
        self.assertEqual(code, 0, err)
        return self.path(out)

    def assert_same_image(self, a, b):
        sa, pa = read_exr(a)
        sb, pb = read_exr(b)
        self.assertEqual(list(sa.channelnames), list(sb.channelnames))
        self.assertEqual((sa.x, sa.y, sa.width, sa.height, sa.full_width, sa.full_height),
                         (sb.x, sb.y, sb.width, sb.height, sb.full_width, sb.full_height))
        for k, name in enumerate(sa.channelnames):
            diff = np.argwhere(pa[..., k].view(np.uint32) != pb[..., k].view(np.uint32))
            self.assertEqual(len(diff), 0, f"{name}: {len(diff)} pixels differ, first at (row, col) {diff[:1]}")

    def tiles_equal_full_frame(self, method, spp, counts, crop=None):
        scene = self.scene_file(cloud_scene(method, spp, crop=crop), f"{method}.json")
        full = self.render(scene, f"{method}_full.exr")
        for n in counts:
            parts = [self.render(scene, f"{method}_t{i}of{n}.exr", "--tile", f"{i}/{n}") for i in range(1, n + 1)]
            spec, _ = read_exr(parts[0])
            self.assertEqual(spec.get_string_attribute("nimbus:tile"), f"1/{n}")
            random.Random(n).shuffle(parts)  # merge takes the parts in any order
            merged = self.merge(f"{method}_merged{n}.exr", parts)
            with self.subTest(method=method, tiles=n):
                self.assert_same_image(full, merged)

    # 29 rows: 2, 3 and 7 tiles do not divide it; 29 tiles is one row each.
    def test_single_tiles_equal_the_full_frame(self):
        self.tiles_equal_full_frame("single", 2, (2, 3, 7))

    def test_wkb_tiles_equal_the_full_frame(self):
        self.tiles_equal_full_frame("wkb", 1, (3, 4))

    def test_single_tiles_of_a_crop_equal_the_cropped_frame(self):
        self.tiles_equal_full_frame("single", 1, (3,), crop=[0.1, 0.85, 0.2, 0.7])

    def test_pathtrace_tiles_equal_the_full_frame(self):
        self.tiles_equal_full_frame("pathtrace", 16, (3,))

    def test_one_row_per_tile(self):
        scene = self.scene_file(cloud_scene("single", 1, resolution=(20, 6)))
        full = self.render(scene, "full.exr")
        parts = [self.render(scene, f"t{i}.exr", "--tile", f"{i}/6") for i in range(1, 7)]
        self.assert_same_image(full, self.merge("merged.exr", parts))
        code, _, err = run("render", scene, "-q", "-o", self.path("t7.exr"), "--tile", "1/7")
        self.assertEqual(code, 2, err)
        self.assertIn("--tile", err)

    def test_sample_splits_of_one_seed_equal_one_long_render(self):
        k, n = 4, 32
        scene = self.scene_file(cloud_scene("pathtrace", k * n))
        whole = self.render(scene, "whole.exr")
        parts = [self.render(scene, f"s{i}.exr", "--samples", f"{i * n}-{i * n + n - 1}") for i in range(k)]
        spec, _ = read_exr(parts[1])
        self.assertEqual(spec.get_int_attribute("nimbus:sample_start"), n)
        self.assertEqual(spec.get_int_attribute("nimbus:spp"), n)
        merged = self.merge("merged.exr", parts[::-1])
        sw, pw = read_exr(whole)
        sm, pm = read_exr(merged)
        self.assertEqual(sm.get_int_attribute("nimbus:spp"), k * n)
        self.assertEqual(list(sw.channelnames), list(sm.channelnames))
        for name in sw.channelnames:
            a, b = channel(sw, pw, name), channel(sm, pm, name)
            # Rounding only: a running mean of k n float terms carries up to k n float epsilons
            # (2^-24) of error relative to its terms, which are of order |a| or, for alpha = 1 - T,
            # of the transmittance's 1; half channels add one half ulp (2^-10 relative).
            half = sw.channelformat(list(sw.channelnames).index(name)) == oiio.HALF
            bound = (2.0 ** -10 if half else 0.0) * np.abs(a) + k * n * 2.0 ** -24 * (np.abs(a) + 1.0)
            excess = np.abs(a - b) - bound
            self.assertLessEqual(excess.max(), 0.0, f"{name}: the merged splits differ from one render: "
                                 f"{np.abs(a - b).max()} at most")

    def test_seed_splits_match_one_render_within_noise(self):
        k, n = 4, 48
        single = self.render(self.scene_file(cloud_scene("pathtrace", k * n)), "single.exr")
        parts = []
        for i in range(k):
            s = cloud_scene("pathtrace", n)
            s["render"]["seed"] = 100 + i
            # Sample splits keep their running estimate (--samples), which merge pools.
            parts.append(self.render(self.scene_file(s, f"seed{i}.json"), f"seed{i}.exr", "--samples", f"0-{n - 1}"))
        merged = self.merge("merged.exr", parts)
        ss, ps = read_exr(single)
        sm, pm = read_exr(merged)
        self.assertEqual(sm.get_int_attribute("nimbus:spp"), k * n)
        ya = channel(ss, ps, "beauty.R") + channel(ss, ps, "beauty.G") + channel(ss, ps, "beauty.B")
        yb = channel(sm, pm, "beauty.R") + channel(sm, pm, "beauty.G") + channel(sm, pm, "beauty.B")
        va, vb = channel(ss, ps, "variance.Y"), channel(sm, pm, "variance.Y")
        lit = (va > 0) & (vb > 0)
        self.assertGreater(lit.sum(), 200)
        z2 = ((ya - yb)[lit] / 3.0) ** 2 / (va + vb)[lit]  # y is the channel average
        p = lit.sum()
        self.assertLess(abs(z2.mean() - 1.0), 5 * np.sqrt(2.0 / p), f"mean z^2 {z2.mean()} over {p} pixels")
        # The variance of the mean: the merged one against the single run's, paired over pixels.
        d = (vb - va)[lit]
        t = d.mean() / (d.std(ddof=1) / np.sqrt(p))
        self.assertLess(abs(t), 5.0, f"merged variance {vb[lit].mean()} vs single {va[lit].mean()}, t = {t}")
        self.assertLess(abs(vb[lit].mean() / va[lit].mean() - 1.0), 0.2)

    # Refusals: exit 2, one line naming the part, nothing written.
    def expect_refused(self, parts, *words):
        out = self.path("refused.exr")
        code, _, err = run("merge", out, *parts)
        self.assertEqual(code, 2, err)
        lines = err.strip().splitlines()
        self.assertEqual(len(lines), 1, err)
        for w in words:
            self.assertIn(w, lines[0])
        self.assertFalse(os.path.exists(out))

    def test_mismatched_parts_are_refused(self):
        scene = self.scene_file(cloud_scene("single", 1))
        t1 = self.render(scene, "t1.exr", "--tile", "1/2")
        t2 = self.render(scene, "t2.exr", "--tile", "2/2")
        other = cloud_scene("single", 1)
        other["lights"][0]["irradiance"] = [3, 3, 3]
        o2 = self.render(self.scene_file(other, "other.json"), "o2.exr", "--tile", "2/2")
        self.expect_refused([t1, o2], "o2.exr", "another scene", "/lights/0/irradiance")
        f2 = self.render(scene, "f2.exr", "--tile", "2/2", "--frame", "2")
        self.expect_refused([t1, f2], "f2.exr", "frame 2", "frame 1")
        self.expect_refused([t1, t2, self.render(scene, "t2b.exr", "--tile", "2/2")], "t2b.exr", "overlap")
        self.expect_refused([t1], "tile 2/2 is missing")
        t13 = self.render(scene, "t13.exr", "--tile", "1/3")
        self.expect_refused([t13, t2], "t2.exr", "tilings differ")
        self.expect_refused([t1, t1], "given twice")
        wkb = self.render(self.scene_file(cloud_scene("wkb", 1), "wkb.json"), "w2.exr", "--tile", "2/2")
        self.expect_refused([t1, wkb], "w2.exr", "method wkb")
        with open(self.path("junk.exr"), "w") as f:
            f.write("not an image")
        self.expect_refused([t1, self.path("junk.exr")], "junk.exr")

    def test_output_that_is_a_part_is_refused(self):  # issue 18: merge replaced its own input, exit 0
        scene = self.scene_file(cloud_scene("single", 1))
        t1 = self.render(scene, "t1.exr", "--tile", "1/2")
        t2 = self.render(scene, "t2.exr", "--tile", "2/2")
        os.symlink(t2, self.path("link.exr"))
        os.link(t1, self.path("hard.exr"))
        before = {p: open(p, "rb").read() for p in (t1, t2)}
        for out in (t1, os.path.join(self.d, ".", "t2.exr"), self.path("link.exr"), self.path("hard.exr")):
            code, _, err = run("merge", out, t1, t2)
            self.assertEqual(code, 2, err)
            lines = err.strip().splitlines()
            self.assertEqual(len(lines), 1, err)
            self.assertIn("writing it would destroy it", lines[0])
        for p, data in before.items():
            self.assertEqual(open(p, "rb").read(), data, f"{p} was touched")
        self.assertTrue(os.path.islink(self.path("link.exr")))
        self.merge("ok.exr", [t1, t2])

    def test_overlapping_or_unfinished_sample_splits_are_refused(self):
        scene = self.scene_file(cloud_scene("pathtrace", 16))
        a = self.render(scene, "a.exr", "--samples", "0-15")
        b = self.render(scene, "b.exr", "--samples", "8-23")
        self.expect_refused([a, b], "b.exr", "overlap", "samples 8-23 of seed 3", "samples 0-15")
        whole = self.render(scene, "whole.exr")
        self.expect_refused([a, whole], "overlap")
        c = self.render(scene, "c.exr", "--samples", "16-31")
        ct = self.render(scene, "ct.exr", "--samples", "0-15", "--tile", "1/2")
        self.expect_refused([a, c, ct], "tilings differ")
        # A tile whose samples differ from the other tile's.
        t1 = self.render(scene, "t1.exr", "--samples", "0-15", "--tile", "1/2")
        t2 = self.render(scene, "t2.exr", "--samples", "0-7", "--tile", "2/2")
        self.expect_refused([t1, t2], "other samples")
        # Tiles and splits together merge.
        t2b = self.render(scene, "t2b.exr", "--samples", "0-15", "--tile", "2/2")
        self.merge("ok.exr", [t1, t2b])
        self.assert_same_image(self.render(scene, "full16.exr"), self.path("ok.exr"))

    def test_bad_split_flags_are_one_line(self):
        scene = self.scene_file(cloud_scene("single", 1))
        for tile in ("0/3", "4/3", "3", "a/b", "1/0", "-1/2"):
            code, _, err = run("render", scene, "-q", "--tile", tile)
            self.assertEqual(code, 2, err)
            self.assertEqual(len(err.strip().splitlines()), 1, err)
            self.assertIn("--tile", err)
        code, _, err = run("render", scene, "-q", "--samples", "0-15")
        self.assertEqual(code, 2, err)
        self.assertIn("--samples: only the path tracer", err)
        pt = self.scene_file(cloud_scene("pathtrace", 4), "pt.json")
        for samples in ("5-2", "x", "3", "-1-4", "0-99999999999"):
            code, _, err = run("render", pt, "-q", "--samples", samples)
            self.assertEqual(code, 2, err)
            self.assertIn("--samples", err)
        self.assertFalse(os.path.exists(self.path("frame.exr")))


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
