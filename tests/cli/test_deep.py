#!/usr/bin/python3
"""Deep EXR output (issue 14, item 5; docs/output.md "Deep output"): `output.deep` from single and
wkb. Flattening the deep image, by `oiiotool --flatten` and by our own reader through
OpenImageIO's DeepData, gives the flat beauty and alpha; a deep holdout at a depth gives the render
held out at that depth by `camera.holdout_depth`; pathtrace, --tile and bad keys are refused with
one line and exit 2.

The deep channels are float and flattening telescopes (src/render/DeepFilm.h), so deep and flat
agree to float rounding; the flat beauty's colour channels are half (docs/output.md), so they are
compared within half's rounding, 2^-11 relative. A holdout cut at a sample's edge is exact; inside
a sample, OpenEXR's split (uniform density across the sample) errs by at most that sample's alpha
seen through what lies in front.

Run by ctest with Debian's python3:
    test_deep.py NIMBUS_BINARY [-k NAME]
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import OpenImageIO as oiio

NIMBUS = None
W, H = 40, 28
HALF_REL = 2.0 ** -11  # half's relative rounding (11 significant bits)
MERGE_ALPHA = 0.001  # kDeepMergeAlpha (src/render/DeepFilm.h): the most opaque a merged sample is


def run(*args):
    p = subprocess.run([NIMBUS, *args], capture_output=True, text=True, timeout=600)
    return p.returncode, p.stdout, p.stderr


def scene(method="single", background=(0, 0, 0), generator="cloud", **render):
    r = {"method": method, "spp": 3, "seed": 5}
    r.update(render)
    source = {"type": "procedural", "generator": generator, "voxel_size": 0.06}
    if generator == "sphere":
        source["radius"] = 1.0
    return {
        "camera": {"from": [0.4, 0.6, 5.5], "to": [0, 0, 0], "up": [0, 1, 0], "fov": 38, "resolution": [W, H]},
        "lights": [{"name": "key", "type": "distant", "direction": [0.3, -1, -0.4], "irradiance": [3, 3, 3]}],
        "volumes": [{"name": "cloud", "source": source,
                     "medium": {"sigma_s": [2.5, 2.2, 2.0], "sigma_a": [0.1, 0.1, 0.1]}}],
        "background": list(background),
        "render": r,
    }


def read_flat(path):
    """Beauty RGB (half, read as float) and alpha (float) of a flat EXR: (h, w, 3), (h, w)."""
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    spec = inp.spec()
    px = np.asarray(inp.read_image(oiio.FLOAT), dtype=np.float64)
    inp.close()
    names = list(spec.channelnames)
    rgb = px[..., [names.index(c) for c in ("R", "G", "B")]]
    alpha = px[..., names.index("alpha.A")] if "alpha.A" in names else px[..., names.index("A")]
    return rgb, alpha


def read_deep(path):
    """{(x, y): [(z, zback, r, g, b, a), ...]} by OpenImageIO's DeepData, and the spec."""
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    spec = inp.spec()
    assert spec.deep, path + " is not deep"
    dd = inp.read_native_deep_image()
    inp.close()
    names = list(spec.channelnames)
    idx = [names.index(c) for c in ("Z", "ZBack", "R", "G", "B", "A")]
    pixels = {}
    for y in range(spec.height):
        for x in range(spec.width):
            p = y * spec.width + x
            pixels[(spec.x + x, spec.y + y)] = [tuple(dd.deep_value(p, c, s) for c in idx)
                                                for s in range(dd.samples(p))]
    return pixels, spec


def composite(samples, z_cut=None):
    """Front-to-back `over` of a pixel's samples, sorted by Z; with z_cut, only what lies in front
    of it, a straddling sample split by OpenEXR's rule (uniform density across [Z, ZBack]).
    Returns rgb, alpha and the largest share any one split sample could move (its alpha seen through
    the front)."""
    rgb, a, split_bound = np.zeros(3), 0.0, 0.0
    for z, zb, r, g, b, sa in sorted(samples):
        c = np.array([r, g, b])
        if z_cut is not None and zb > z_cut:
            if z >= z_cut:
                break
            f = (z_cut - z) / (zb - z)
            if sa < 1.0:
                part = 1.0 - (1.0 - sa) ** f
                c = c * (part / sa if sa > 0 else f)
            else:
                part = 1.0
            split_bound = max(split_bound, (1.0 - a) * sa)
            sa = part
        rgb += (1.0 - a) * c
        a += (1.0 - a) * sa
    return rgb, a, split_bound


class DeepTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="nimbus_deep_")

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.dir, name)

    def render(self, sc, name, deep=True, extra=()):
        sc = json.loads(json.dumps(sc))
        sc["output"] = {"file": self.path(name + ".exr"), "aovs": ["beauty", "alpha"]}
        if deep:
            sc["output"]["deep"] = self.path(name + "_deep.exr")
        f = self.path(name + ".json")
        with open(f, "w") as fh:
            json.dump(sc, fh)
        code, out, err = run("render", f, "-q", *extra)
        self.assertEqual(code, 0, err)
        return self.path(name + ".exr"), (self.path(name + "_deep.exr") if deep else None)

    def check_flatten(self, sc, name, max_samples=32):
        flat, deep = self.render(sc, name)
        rgb, alpha = read_flat(flat)
        pixels, spec = read_deep(deep)
        self.assertEqual((spec.width, spec.height, spec.full_width, spec.full_height), (W, H, W, H))
        self.assertEqual(spec.get_int_attribute("nimbus:deep_samples"), max_samples)
        self.assertIn("nimbus:scene", [a.name for a in spec.extra_attribs])
        counts = [len(s) for s in pixels.values()]
        self.assertLessEqual(max(counts), max_samples)
        self.assertGreater(max(counts), 1, "the volume should be cut into several samples")
        for (x, y), samples in pixels.items():
            for z, zb, r, g, b, a in samples:
                self.assertLessEqual(z, zb)
                self.assertGreaterEqual(min(r, g, b, a), 0.0, (x, y))
                self.assertLessEqual(a, 1.0)
            zs = sorted(samples)
            for s0, s1 in zip(zs, zs[1:]):
                self.assertLessEqual(s0[1], s1[0], "samples overlap at %s" % ((x, y),))
        # Written atomically: no temporary file is left beside the outputs.
        self.assertEqual([f for f in os.listdir(self.dir) if f.startswith(".")], [])
        # Our own reader: composite and compare with the flat beauty and alpha.
        mine = np.zeros((H, W, 4))
        for (x, y), samples in pixels.items():
            c, a, _ = composite(samples)
            mine[y, x, :3], mine[y, x, 3] = c, a
        self.assertGreater(alpha.max(), 0.3)
        np.testing.assert_allclose(mine[..., 3], alpha, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(mine[..., :3], rgb, rtol=HALF_REL, atol=1e-6)
        # oiiotool's flatten.
        out = self.path(name + "_flat.exr")
        p = subprocess.run(["oiiotool", deep, "--flatten", "-d", "float", "-o", out], capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        inp = oiio.ImageInput.open(out)
        fspec = inp.spec()
        fpx = np.asarray(inp.read_image(oiio.FLOAT), dtype=np.float64)
        inp.close()
        names = list(fspec.channelnames)
        np.testing.assert_allclose(fpx[..., names.index("A")], alpha, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(fpx[..., [names.index(c) for c in "RGB"]], rgb, rtol=HALF_REL, atol=1e-6)
        return pixels

    def test_single_flattens_to_the_beauty(self):
        self.check_flatten(scene("single"), "single")

    def test_geometry_holdout_cuts_the_deep_samples(self):
        # A holdout sphere inside the cloud: camera rays stop at it, so do the deep samples (nothing
        # behind the hit), and flattening is still the beauty (alpha 0 where the sphere is in front).
        sc = scene("single", background=(0.1, 0.1, 0.1))
        sc["geometry"] = [{"name": "ball", "type": "sphere", "radius": 0.35}]  # at the cloud's centre
        pixels = self.check_flatten(sc, "sphere")
        # The camera looks at the sphere's centre: the centre pixel's rays stop about |from| - r
        # away, so its samples all start in front of that, and it has no background sample.
        hit = float(np.linalg.norm(sc["camera"]["from"])) - 0.35
        centre = pixels[(W // 2, H // 2)]
        self.assertTrue(centre, "the cloud in front of the sphere is seen")
        self.assertTrue(all(s[0] < 1e38 for s in centre), "a held-out pixel has no background sample")
        self.assertTrue(all(s[0] < hit for s in centre), "no deep sample starts behind the holdout: %s" % centre)

    def test_crop_is_the_data_window(self):
        sc = scene("single")
        sc["camera"]["crop"] = [0.25, 0.75, 0.0, 0.5]  # x [10, 30), y [0, 14) of 40 x 28
        flat, deep = self.render(sc, "crop")
        pixels, spec = read_deep(deep)
        self.assertEqual((spec.x, spec.y, spec.width, spec.height), (10, 0, 20, 14))
        self.assertEqual((spec.full_width, spec.full_height), (W, H))
        inp = oiio.ImageInput.open(flat)
        fspec = inp.spec()
        inp.close()
        self.assertEqual((fspec.x, fspec.y, fspec.width, fspec.height), (10, 0, 20, 14))
        rgb, alpha = read_flat(flat)
        for (x, y), samples in pixels.items():
            c, a, _ = composite(samples)
            self.assertAlmostEqual(a, alpha[y, x - 10], delta=1e-5)
            np.testing.assert_allclose(c, rgb[y, x - 10], rtol=HALF_REL, atol=1e-6)

    def test_background_is_a_sample_behind_everything(self):
        pixels = self.check_flatten(scene("single", background=(0.2, 0.3, 0.4), generator="sphere"), "bg")
        corner = pixels[(0, 0)]  # sees only the background
        self.assertEqual(len(corner), 1)
        z, zb, r, g, b, a = corner[0]
        self.assertEqual(a, 0.0)
        self.assertGreater(z, 1e38)
        np.testing.assert_allclose([r, g, b], [0.2, 0.3, 0.4], rtol=1e-6)

    def test_wkb_flattens_to_the_beauty(self):
        self.check_flatten(scene("wkb"), "wkb")

    def test_deep_samples_caps_the_count(self):
        sc = scene("single", generator="sphere")
        sc["output"] = {"file": self.path("cap.exr"), "deep": self.path("cap_deep.exr"), "deep_samples": 6,
                        "aovs": ["beauty", "alpha"]}
        f = self.path("cap.json")
        with open(f, "w") as fh:
            json.dump(sc, fh)
        code, _, err = run("render", f, "-q")
        self.assertEqual(code, 0, err)
        pixels, spec = read_deep(self.path("cap_deep.exr"))
        self.assertEqual(spec.get_int_attribute("nimbus:deep_samples"), 6)
        self.assertLessEqual(max(len(s) for s in pixels.values()), 6)
        rgb, alpha = read_flat(self.path("cap.exr"))
        for (x, y), samples in pixels.items():
            c, a, _ = composite(samples)
            self.assertAlmostEqual(a, alpha[y, x], delta=1e-5)
            np.testing.assert_allclose(c, rgb[y, x], rtol=HALF_REL, atol=1e-6)

    def holdout_at(self, sc, name, z):
        """The scene rendered held out at camera-space depth z everywhere (camera.holdout_depth)."""
        zfile = self.path(name + "_z.exr")
        out = oiio.ImageOutput.create(zfile)
        spec = oiio.ImageSpec(W, H, 1, oiio.FLOAT)
        spec.channelnames = ("Z",)
        out.open(zfile, spec)
        out.write_image(np.full((H, W, 1), z, dtype=np.float32))
        out.close()
        sc = json.loads(json.dumps(sc))
        sc["camera"]["holdout_depth"] = {"file": zfile, "channel": "Z"}
        flat, _ = self.render(sc, name, deep=False)
        return read_flat(flat)

    def test_deep_holdout_equals_the_rendered_holdout(self):
        sc = scene("single")
        # Compared sample for sample: adaptive sampling off, since a holdout changes what each
        # pixel's samples see and so how many it takes.
        sc["render"]["adaptive_threshold"] = 0
        pixels = self.check_flatten(sc, "full")
        # The slice edges are the same in every pixel: the samples' fronts. One near the middle
        # of the cloud's depth (a cut between samples, exact) and one inside a sample.
        edges = sorted({s[0] for samples in pixels.values() for s in samples if s[0] < 1e38})
        self.assertGreater(len(edges), 8)
        for label, z in (("edge", edges[len(edges) // 2]), ("inside", 0.5 * (edges[len(edges) // 3] +
                                                                              edges[len(edges) // 3 + 1]))):
            rgb, alpha = self.holdout_at(sc, "held_" + label, z)
            self.assertGreater(alpha.max(), 0.05, "the holdout should leave some cloud in front")
            worst = 0.0
            for (x, y), samples in pixels.items():
                c, a, bound = composite(samples, z)
                if label == "edge":  # only a merged sample (at most 0.001 opaque) spans a slice edge
                    self.assertLessEqual(bound, MERGE_ALPHA * (1 + 1e-5),
                                         "a sample straddles the slice edge %g at %s" % (z, (x, y)))
                tol_a = 1e-5 + bound
                self.assertLessEqual(abs(a - alpha[y, x]), tol_a, "%s holdout at z=%g, pixel %s" % (label, z, (x, y)))
                # Colour: half's rounding of the rendered one, plus the split's share of the sample's
                # light (at most its colour seen through the front).
                sample_c = max((max(s[2:5]) for s in samples if s[0] < z < s[1]), default=0.0)
                tol_c = HALF_REL * np.abs(rgb[y, x]) + 1e-6 + sample_c
                self.assertTrue(np.all(np.abs(c - rgb[y, x]) <= tol_c), "%s holdout at z=%g, pixel %s: %s vs %s"
                                % (label, z, (x, y), c, rgb[y, x]))
                worst = max(worst, abs(a - alpha[y, x]))
            print("deep holdout (%s, z=%.4f): largest alpha difference %.2e" % (label, z, worst))

    def test_refusals(self):
        base = scene("pathtrace")
        base["render"]["spp"] = 4
        base["output"] = {"file": self.path("pt.exr"), "deep": self.path("pt_deep.exr")}
        f = self.path("pt.json")
        with open(f, "w") as fh:
            json.dump(base, fh)
        code, _, err = run("render", f, "-q")
        self.assertEqual(code, 2, err)
        self.assertEqual(len(err.strip().splitlines()), 1, err)
        self.assertIn("output.deep", err)
        self.assertIn(f, err)
        self.assertFalse(os.path.exists(self.path("pt.exr")) or os.path.exists(self.path("pt_deep.exr")))

        sc = scene("single")
        for key, value, words in (("deep_samples", 0, "output.deep_samples"),
                                  ("deep", self.path("same.exr"), "output.deep")):
            sc["output"] = {"file": self.path("same.exr"), key: value}
            with open(f, "w") as fh:
                json.dump(sc, fh)
            code, _, err = run("render", f, "-q")
            self.assertEqual(code, 2, err)
            self.assertEqual(len(err.strip().splitlines()), 1, err)
            self.assertIn(words, err)
        sc["output"] = {"file": self.path("t.exr"), "deep": self.path("t_deep.exr")}
        with open(f, "w") as fh:
            json.dump(sc, fh)
        code, _, err = run("render", f, "-q", "--tile", "1/2")
        self.assertEqual(code, 2, err)
        self.assertIn("output.deep", err)
        self.assertEqual(os.listdir(self.dir), ["pt.json"])


if __name__ == "__main__":
    NIMBUS = sys.argv.pop(1)
    unittest.main()
