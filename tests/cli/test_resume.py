#!/usr/bin/python3
"""Preemption (issue 16, item 5; docs/farm.md): a path-tracer render killed with kill -9 at any
moment resumes from its last checkpoint with `--resume` and reaches its target samples.

The target, pinned by the design: a checkpoint holds the running estimate itself (float state
AOVs) and its sample count, and each pixel's samples come from (seed, pixel, sample index) and
enter the running means one by one, so the resumed render is the uninterrupted one bit for bit,
wherever the kills fell (during start-up, a launch, a checkpoint's write or the final write).
Beyond that, the statistical check the issue asks for: the resumed frame against an
uninterrupted render of another seed, per pixel z = (a - b) / sqrt(var_a + var_b) from the
files' variance AOVs, mean z^2 within 5 standard errors of 1.

Kill moments are random; the seed is printed and NIMBUS_RESUME_SEED replays it.
Run by ctest with Debian's python3:  test_resume.py NIMBUS_BINARY [-k NAME]
"""
import json
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np
import OpenImageIO as oiio

NIMBUS = None
SPP = 2400
TRIALS = 6


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


def cloud_scene(spp, seed=3):
    return {
        "camera": {"from": [1.2, 0.8, 6], "to": [0.1, 0, 0], "up": [0, 1, 0], "fov": 30, "resolution": [32, 24]},
        "lights": [{"name": "key", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [2, 2, 2]}],
        "volumes": [{"name": "cloud", "source": {"type": "procedural", "generator": "cloud", "radius": 1.2,
                                                 "octaves": 3, "seed": 7, "voxel_size": 0.08},
                     "medium": {"sigma_s": [3, 3, 3], "sigma_a": [0.1, 0.1, 0.1]}}],
        "render": {"method": "pathtrace", "spp": spp, "seed": seed},
    }


class Resume(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory()
        cls.d = cls.dir.name
        cls.seed = int(os.environ.get("NIMBUS_RESUME_SEED", str(int(time.time()) % 100000)))
        print(f"kill moments from seed {cls.seed} (NIMBUS_RESUME_SEED={cls.seed} replays them)", file=sys.stderr)
        cls.scene = os.path.join(cls.d, "scene.json")
        with open(cls.scene, "w") as f:
            json.dump(cloud_scene(SPP), f)
        # The uninterrupted render (the kernel is built and cached by it), timed.
        cls.reference = os.path.join(cls.d, "reference.exr")
        start = time.time()
        code, _, err = run("render", cls.scene, "-q", "-o", cls.reference)
        assert code == 0, err
        code, _, err = run("render", cls.scene, "-q", "-o", cls.reference)
        assert code == 0, err
        cls.seconds = max(0.5, (time.time() - start) / 2.0)

    @classmethod
    def tearDownClass(cls):
        cls.dir.cleanup()

    def path(self, name):
        return os.path.join(self.d, name)

    def start(self, out, *flags):
        return subprocess.Popen([NIMBUS, "render", self.scene, "-o", out, "--checkpoint", "0.05", "--resume", *flags],
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)

    def preempted(self, out, rng, kills, *flags):
        """Renders `out` through `kills` kill -9 at random moments, then to the end. Returns the
        samples per pixel each resumed run started from."""
        resumed_from = []
        for _ in range(kills + 1):
            proc = self.start(out, *flags)
            killed = False
            if kills > 0:
                try:
                    proc.wait(timeout=rng.uniform(0.0, self.seconds))
                except subprocess.TimeoutExpired:
                    proc.send_signal(signal.SIGKILL)
                    killed = True
                kills -= 1
            _, err = proc.communicate(timeout=600)
            m = re.search(r"resuming from .* at (\d+) samples per pixel", err)
            if m:
                resumed_from.append(int(m.group(1)))
            if killed and proc.returncode == 0:
                # The render finished between the wait's timeout and the signal (Popen.send_signal
                # does not signal a process it has seen exit): a run that was never killed.
                killed = False
            if not killed:
                self.assertEqual(proc.returncode, 0, err)
                return resumed_from
            self.assertEqual(proc.returncode, -signal.SIGKILL)
        self.fail("unreachable")

    def assert_identical(self, a, b):
        sa, pa = read_exr(a)
        sb, pb = read_exr(b)
        self.assertEqual(list(sa.channelnames), list(sb.channelnames))
        for k, name in enumerate(sa.channelnames):
            diff = np.argwhere(pa[..., k].view(np.uint32) != pb[..., k].view(np.uint32))
            self.assertEqual(len(diff), 0, f"{name}: {len(diff)} pixels differ from the uninterrupted render, "
                                           f"first at (row, col) {diff[:1]}")

    def test_killed_renders_resume_to_the_uninterrupted_image(self):
        rng = random.Random(self.seed)
        resumes = []
        for trial in range(TRIALS):
            out = self.path(f"trial{trial}.exr")
            with self.subTest(trial=trial, seed=self.seed):
                resumed_from = self.preempted(out, rng, rng.randint(1, 3))
                resumes += resumed_from
                spec, _ = read_exr(out)
                self.assertEqual(spec.get_int_attribute("nimbus:complete"), 1)
                self.assertEqual(spec.get_int_attribute("nimbus:spp"), SPP)
                self.assertFalse(os.path.exists(self.path(f"trial{trial}.partial.exr")), "a stale checkpoint stayed")
                self.assert_identical(self.reference, out)
        # The kills must have hit renders in flight: some runs resumed from a checkpoint part way.
        midway = [k for k in resumes if 0 < k < SPP]
        print(f"{TRIALS} trials: resumed from {resumes} samples per pixel (of {SPP})", file=sys.stderr)
        self.assertGreaterEqual(len(midway), 2, f"resumed from {resumes} (seed {self.seed})")

        # Statistically the same as an uninterrupted render of another seed.
        other = self.path("other.exr")
        with open(self.path("other.json"), "w") as f:
            json.dump(cloud_scene(SPP, seed=99), f)
        code, _, err = run("render", self.path("other.json"), "-q", "-o", other)
        self.assertEqual(code, 0, err)
        sa, pa = read_exr(self.path("trial0.exr"))
        sb, pb = read_exr(other)
        ya = sum(channel(sa, pa, "beauty." + c) for c in "RGB") / 3.0
        yb = sum(channel(sb, pb, "beauty." + c) for c in "RGB") / 3.0
        va, vb = channel(sa, pa, "variance.Y"), channel(sb, pb, "variance.Y")
        lit = (va > 0) & (vb > 0)
        z2 = (ya - yb)[lit] ** 2 / (va + vb)[lit]
        self.assertGreater(lit.sum(), 100)
        self.assertLess(abs(z2.mean() - 1.0), 5 * np.sqrt(2.0 / lit.sum()), f"mean z^2 {z2.mean()}")

    def test_a_killed_sample_split_resumes_exactly(self):
        rng = random.Random(self.seed + 1)
        whole = self.path("split_whole.exr")
        code, _, err = run("render", self.scene, "-q", "-o", whole, "--samples", "400-1999")
        self.assertEqual(code, 0, err)
        out = self.path("split.exr")
        self.preempted(out, rng, 2, "--samples", "400-1999")
        self.assert_identical(whole, out)  # the running estimate (state AOVs) included

    def wait_for_checkpoint(self, out, partial, *flags):
        proc = self.start(out, *flags)
        deadline = time.time() + 300
        while not os.path.exists(partial) and proc.poll() is None and time.time() < deadline:
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
        proc.communicate()
        self.assertTrue(os.path.exists(partial), "no checkpoint appeared")

    def test_more_samples_continue_and_another_scene_is_refused(self):
        out, partial = self.path("more.exr"), self.path("more.partial.exr")
        self.wait_for_checkpoint(out, partial)
        spec, _ = read_exr(partial)
        self.assertEqual(spec.get_int_attribute("nimbus:complete"), 0)
        # Another scene: one line naming the checkpoint and the key, exit 2, the checkpoint kept.
        code, _, err = run("render", self.scene, "-o", out, "--resume", "--set", "volumes[0].medium.sigma_s=[2,2,2]")
        self.assertEqual(code, 2, err)
        self.assertEqual(len(err.strip().splitlines()), 1, err)
        self.assertIn("more.partial.exr", err)
        self.assertIn("/volumes/0/medium/sigma_s", err)
        self.assertTrue(os.path.exists(partial))
        self.assertFalse(os.path.exists(out))
        code, _, err = run("render", self.scene, "-o", out, "--resume", "--samples", "0-99")
        self.assertEqual(code, 2, err)
        self.assertIn("samples from", err)
        # A larger spp continues the same sample sequence: the render of that many samples.
        code, _, err = run("render", self.scene, "-q", "-o", out, "--resume", "--set", f"render.spp={SPP + 300}")
        self.assertEqual(code, 0, err)
        longer = self.path("longer.exr")
        code, _, err = run("render", self.scene, "-q", "-o", longer, "--set", f"render.spp={SPP + 300}")
        self.assertEqual(code, 0, err)
        self.assert_identical(longer, out)
        # --resume with no checkpoint renders from the start; other methods have no checkpoints.
        code, _, err = run("render", self.scene, "-o", self.path("fresh.exr"), "--resume")
        self.assertEqual(code, 0, err)
        self.assertIn("rendering from the start", err)
        code, _, err = run("render", self.scene, "-o", self.path("s.exr"), "--resume", "--method", "single")
        self.assertEqual(code, 2, err)
        self.assertIn("--resume", err)


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
