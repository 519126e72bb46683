#!/usr/bin/python3
"""`nimbus farm plan` (issue 16, item 6; docs/farm.md): a shot as an engine-neutral job
description. The plan's shape (tasks, commands, dependencies, outputs, groups), then the plan run
by the smallest possible adapter (each task's command in dependency order, from another
directory) against the same frames rendered by `--frames` in one process: bit for bit for tiles,
to float rounding for the path tracer's sample splits of one seed. Bad plans: exit 2, one line.

Run by ctest with Debian's python3:  test_farm_plan.py NIMBUS_BINARY [-k NAME]
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
    p = subprocess.run([NIMBUS, *args], capture_output=True, text=True, timeout=600, cwd=cwd)
    return p.returncode, p.stdout, p.stderr


def read_exr(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    spec = inp.spec()
    pixels = np.asarray(inp.read_image(oiio.FLOAT))
    inp.close()
    return spec, pixels


def write_ball(path, radius):
    """A small VDB ball of `radius` voxels (0.1 m): each frame of the shot differs."""
    grid = vdb.FloatGrid()
    grid.name = "density"
    grid.transform = vdb.createLinearTransform(voxelSize=0.1)
    acc = grid.getAccessor()
    r = int(radius)
    for i in range(-r, r + 1):
        for j in range(-r, r + 1):
            for k in range(-r, r + 1):
                if i * i + j * j + k * k <= radius * radius:
                    acc.setValueOn((i, j, k), 1.0 - 0.5 * (i * i + j * j + k * k) / (radius * radius))
    vdb.write(path, grids=[grid])


def shot(method, spp):
    return {
        "camera": {"from": [0.4, 0.3, 3], "to": [0, 0, 0], "up": [0, 1, 0], "fov": 30, "resolution": [24, 19]},
        "lights": [{"name": "key", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [2, 2, 2]}],
        "volumes": [{"name": "smoke", "source": {"type": "vdb", "file": "cache/smoke.$F4.vdb"},
                     "medium": {"sigma_s": [4, 4, 4], "sigma_a": [0.1, 0.1, 0.1]}}],
        "render": {"method": method, "spp": spp, "seed": 5},
        "output": {"file": "out/beauty.$F4.exr"},
    }


class FarmPlan(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name
        os.makedirs(self.path("cache"))
        for frame, radius in ((1, 5), (2, 7), (3, 9)):
            write_ball(self.path("cache", f"smoke.{frame:04d}.vdb"), radius)
        os.makedirs(self.path("elsewhere"))

    def tearDown(self):
        self.dir.cleanup()

    def path(self, *parts):
        return os.path.join(self.d, *parts)

    def scene_file(self, scene, name="shot.json"):
        with open(self.path(name), "w") as f:
            json.dump(scene, f)
        return self.path(name)

    def plan(self, *args):
        code, out, err = run("farm", "plan", *args, cwd=self.d)
        self.assertEqual(code, 0, err)
        return json.loads(out)

    def check_shape(self, plan, frames, tiles, splits, method):
        tasks = {t["id"]: t for t in plan["tasks"]}
        self.assertEqual(len(tasks), len(plan["tasks"]), "task ids are unique")
        renders = [t for t in plan["tasks"] if t["kind"] == "render"]
        merges = [t for t in plan["tasks"] if t["kind"] == "merge"]
        self.assertEqual(plan["frames"], frames)
        self.assertEqual(len(renders), len(frames) * tiles * splits)
        self.assertEqual(len(merges), len(frames) if tiles * splits > 1 else 0)
        for t in plan["tasks"]:
            self.assertEqual(t["command"][0], NIMBUS)
            for dep in t["depends_on"]:
                self.assertIn(dep, tasks)
                self.assertEqual(tasks[dep]["kind"], "render")
            for out in t["outputs"]:
                self.assertTrue(os.path.isabs(out), out)
            self.assertEqual(t["resumable"], method == "pathtrace" and t["kind"] == "render")
            if t["resumable"]:
                self.assertIn("--resume", t["command"])
                self.assertIn("--checkpoint", t["command"])
        for m in merges:
            self.assertEqual(sorted(m["inputs"]), sorted(o for d in m["depends_on"] for o in tasks[d]["outputs"]))
            self.assertEqual(m["outputs"], [self.path("out", f"beauty.{m['frame']:04d}.exr")])
            self.assertEqual(m["command"][1:4], ["merge", "-q", m["outputs"][0]])
        groups = {g["name"]: g for g in plan["groups"]}
        self.assertEqual(sorted(groups["render"]["tasks"]), sorted(t["id"] for t in renders))
        if merges:
            self.assertEqual(groups["merge"]["depends_on"], ["render"])
            self.assertEqual(sorted(groups["merge"]["tasks"]), sorted(t["id"] for t in merges))

    def execute(self, plan):
        """The smallest adapter: every task once its dependencies have succeeded, run from a
        directory that is not the plan's (the commands' paths are absolute)."""
        done, pending = set(), list(plan["tasks"])
        while pending:
            ready = [t for t in pending if all(d in done for d in t["depends_on"])]
            self.assertTrue(ready, "the dependencies form a cycle")
            for t in ready:
                p = subprocess.run(t["command"], capture_output=True, text=True, timeout=600,
                                   cwd=self.path("elsewhere"))
                self.assertEqual(p.returncode, 0, f"{t['id']}: {p.stderr}")
                for out in t["outputs"]:
                    self.assertTrue(os.path.exists(out), f"{t['id']} did not write {out}")
                done.add(t["id"])
                pending.remove(t)

    def whole_frames(self, scene_file, frames):
        code, _, err = run("render", scene_file, "-q", "--frames", frames, "-o", self.path("whole", "b.$F4.exr"),
                           cwd=self.d)
        self.assertEqual(code, 0, err)

    def assert_identical(self, a, b):
        sa, pa = read_exr(a)
        sb, pb = read_exr(b)
        self.assertEqual(list(sa.channelnames), list(sb.channelnames))
        for k, name in enumerate(sa.channelnames):
            self.assertTrue(np.array_equal(pa[..., k].view(np.uint32), pb[..., k].view(np.uint32)), f"{b}: {name}")

    def test_wkb_tiles_run_by_the_plan_equal_the_frames(self):
        scene = self.scene_file(shot("wkb", 1))
        plan = self.plan(scene, "--frames", "1-3", "--tiles", "3")
        self.check_shape(plan, [1, 2, 3], 3, 1, "wkb")
        self.execute(plan)
        self.whole_frames(scene, "1-3")
        for f in (1, 2, 3):
            self.assert_identical(self.path("whole", f"b.{f:04d}.exr"), self.path("out", f"beauty.{f:04d}.exr"))

    def test_pathtrace_tiles_and_splits_run_by_the_plan_equal_the_frames(self):
        spp, splits = 40, 3
        scene = self.scene_file(shot("pathtrace", spp))
        plan = self.plan(scene, "--frames", "3,1", "--tiles", "2", "--sample-splits", str(splits),
                         "--checkpoint", "30")
        self.check_shape(plan, [3, 1], 2, splits, "pathtrace")
        samples = sorted({t["samples"] for t in plan["tasks"] if t["kind"] == "render"})
        self.assertEqual(samples, ["0-12", "13-25", "26-39"])  # 40 samples in 3 near-equal runs
        self.execute(plan)
        self.whole_frames(scene, "1,3")
        for f in (1, 3):
            sa, pa = read_exr(self.path("whole", f"b.{f:04d}.exr"))
            sb, pb = read_exr(self.path("out", f"beauty.{f:04d}.exr"))
            self.assertEqual(sb.get_int_attribute("nimbus:spp"), spp)
            self.assertEqual(list(sa.channelnames), list(sb.channelnames))
            # The same samples pooled in double instead of accumulated in float: rounding only
            # (test_merge.py derives the bound).
            for k, name in enumerate(sa.channelnames):
                a, b = pa[..., k], pb[..., k]
                half = sa.channelformat(k) == oiio.HALF
                bound = (2.0 ** -10 if half else 0.0) * np.abs(a) + spp * 2.0 ** -24 * (np.abs(a) + 1.0)
                self.assertLessEqual((np.abs(a - b) - bound).max(), 0.0, f"frame {f}, {name}")

    def test_an_unsplit_plan_renders_each_frame_directly(self):
        scene = self.scene_file(shot("single", 2))
        plan = self.plan(scene, "--frames", "1-2")
        self.check_shape(plan, [1, 2], 1, 1, "single")
        self.assertEqual([t["outputs"] for t in plan["tasks"]],
                         [[self.path("out", "beauty.0001.exr")], [self.path("out", "beauty.0002.exr")]])
        self.execute(plan)
        self.whole_frames(scene, "1-2")
        for f in (1, 2):
            self.assert_identical(self.path("whole", f"b.{f:04d}.exr"), self.path("out", f"beauty.{f:04d}.exr"))

    def test_deep_output_goes_where_the_plan_says(self):
        # output.deep is relative to the plan's directory; the tasks run elsewhere (issue 14, item 5).
        s = shot("single", 2)
        s["output"]["deep"] = "out/deep.$F4.exr"
        plan = self.plan(self.scene_file(s, "deep.json"), "--frames", "1-2")
        self.assertEqual([t["outputs"] for t in plan["tasks"]],
                         [[self.path("out", f"beauty.{f:04d}.exr"), self.path("out", f"deep.{f:04d}.exr")]
                          for f in (1, 2)])
        self.execute(plan)  # checks every output exists

    def test_bad_plans_are_one_line(self):
        wkb = self.scene_file(shot("wkb", 1), "wkb.json")
        noise = shot("pathtrace", 0)
        still = shot("single", 1)
        still["output"]["file"] = "out/still.exr"
        cases = [
            ([wkb, "--sample-splits", "2"], "--sample-splits: only the path tracer"),
            ([self.scene_file(noise, "noise.json"), "--sample-splits", "2"], "render.spp"),
            ([self.scene_file(shot("pathtrace", 4), "four.json"), "--sample-splits", "5"], "--sample-splits"),
            ([wkb, "--tiles", "20"], "--tiles 20"),
            ([self.scene_file(still, "still.json"), "--frames", "1-2"], "output.file"),
            ([wkb, "--frames", "3-1"], "--frames"),
            ([wkb, "--tiles", "0"], "--tiles"),
            ([self.scene_file(dict(shot("wkb", 1), output={"file": "out/b.$F4.exr", "deep": "out/d.$F4.exr"}),
                              "deep.json"), "--tiles", "2"], "output.deep: --tiles 2"),
            ([self.scene_file(dict(shot("wkb", 1), output={"file": "out/b.$F4.exr", "deep": "out/d.exr"}),
                              "deep1.json"), "--frames", "1-2"], "output.deep"),
        ]
        for args, words in cases:
            code, out, err = run("farm", "plan", *args, cwd=self.d)
            self.assertEqual(code, 2, f"{args}: {err}")
            self.assertEqual(out, "")
            self.assertEqual(len(err.strip().splitlines()), 1, err)
            self.assertIn(words, err)


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
