#!/usr/bin/python3
"""Velocity motion blur (issue 16, item 3; docs/motion-blur.md): the `vel` grid moves the density
over the shutter, rho(x - v (t - t0)), in single, wkb, pathtrace and vrl.

The check of the blur itself is a Galilean one. A smoke ball in a uniform velocity field v, lit by
a distant light against a uniform background, seen by a still camera, is the same picture as the
still ball seen by a camera moving by -v: a distant light and a uniform background do not change
under a translation of everything. Camera motion blur (camera.motion, Tessendorf sec. 7) is
independent, older code, so the velocity-blurred render must equal the camera-blurred render of
the still ball in expectation, for every integrator: the strips of the image are compared with
z-tests whose noise comes from the renders themselves (the per-pixel spread for single and wkb,
the variance AOV for the path tracer). The shutter is [0, 1], not centred, so a sign error in the
displacement would show. A power check makes sure the blur is large against that noise: a render that ignored the
velocity would fail the comparison.

Also: zero velocity renders exactly as no velocity blur; `nimbus info` prints the largest
displacement in voxels; input errors (no vel grid, a vel grid of the wrong type, a procedural
source, a bad fps) are one line and exit code 2.

Run by ctest with Debian's python3 (pyopenvdb and OpenImageIO's bindings come from Debian):
    test_velocity_blur.py NIMBUS_BINARY [-k NAME]
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

VOXEL = 0.05  # m
RADIUS = 8  # voxels: a ball 0.8 m across
FPS = 24.0
VELOCITY = (4.8, 0.0, 0.0)  # m/s in the file
VELOCITY_SCALE = 2.0  # so the flow is 9.6 m/s: 0.4 m = 8 voxels per frame
SHUTTER = (0.0, 1.0)  # frames after the frame rendered
DISPLACEMENT = [VELOCITY_SCALE * v * (SHUTTER[1] - SHUTTER[0]) / FPS for v in VELOCITY]  # m over the shutter
FROM, TO = (0.0, 0.2, 3.0), (0.0, 0.0, 0.0)
STRIPS = 8  # vertical strips of the image, each z-tested
Z_MAX = 4.5  # per strip; with 8 strips a false alarm has odds of about 5e-5


def run(*args, cwd=None):
    p = subprocess.run([NIMBUS, *args], capture_output=True, text=True, cwd=cwd, timeout=900)
    return p.returncode, p.stdout, p.stderr


def read_exr(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    names = list(inp.spec().channelnames)
    pixels = np.asarray(inp.read_image(oiio.FLOAT))
    inp.close()
    return names, pixels


def channel(names, pixels, *wanted):
    return np.stack([pixels[:, :, names.index(w)] for w in wanted], axis=-1)


def write_smoke(path, velocity=VELOCITY, vel="vec3"):
    """A ball of density 1 and, unless vel is None, a vel grid of one velocity over a box that
    holds the ball and everything it sweeps over the shutter (VDB convention: a vel grid's
    inactive voxels read 0, so a simulation's vel reaches beyond its smoke)."""
    density = vdb.FloatGrid()
    density.name = "density"
    density.transform = vdb.createLinearTransform(voxelSize=VOXEL)
    acc = density.getAccessor()
    for i in range(-RADIUS, RADIUS + 1):
        for j in range(-RADIUS, RADIUS + 1):
            for k in range(-RADIUS, RADIUS + 1):
                if i * i + j * j + k * k <= RADIUS * RADIUS:
                    acc.setValueOn((i, j, k), 1.0)
    grids = [density]
    reach = RADIUS + 2 + int(np.ceil(max(abs(d) for d in DISPLACEMENT) / VOXEL))
    if vel == "vec3":
        v = vdb.Vec3SGrid()
        v.fill((-reach, -reach, -reach), (reach, reach, reach), velocity, True)
        grids.append(v)
    elif vel == "float":
        v = vdb.FloatGrid()
        v.fill((-reach, -reach, -reach), (reach, reach, reach), 1.0, True)
        grids.append(v)
    if vel is not None:
        v.name = "vel"
        v.transform = vdb.createLinearTransform(voxelSize=VOXEL)
    vdb.write(path, grids=grids)


def scene(method, output, velocity_blur=True, camera_motion=False, seed=1, spp=16, shutter=SHUTTER, render_extra=None):
    camera = {"from": list(FROM), "to": list(TO), "up": [0, 1, 0], "fov": 36, "resolution": [48, 32],
              "shutter": list(shutter)}
    if camera_motion:
        # The still ball seen from a camera that moves by minus the ball's displacement.
        camera["motion"] = {"from": [f - d for f, d in zip(FROM, DISPLACEMENT)],
                            "to": [t - d for t, d in zip(TO, DISPLACEMENT)]}
    medium = {"sigma_s": [4, 4, 4], "sigma_a": [0.4, 0.4, 0.4], "phase": {"type": "hg", "g": 0.3}}
    if velocity_blur:
        medium["velocity_scale"] = VELOCITY_SCALE
    render = {"method": method, "seed": seed, "spp": spp, "fps": FPS}
    render.update(render_extra or {})
    if method == "pathtrace":
        render["noise_target"] = 0
    return {
        "camera": camera,
        "background": [0.1, 0.1, 0.1],
        "lights": [{"name": "key", "type": "distant", "direction": [0.4, -1, -0.3], "irradiance": [3, 3, 3]}],
        "volumes": [{"name": "smoke", "source": {"type": "vdb", "file": "smoke.vdb"}, "medium": medium}],
        "render": render,
        "output": {"file": output},
    }


def strip_z(diff, var):
    """z of the mean difference in each vertical strip; var: per-pixel variance of diff."""
    zs = []
    for cols in np.array_split(np.arange(diff.shape[1]), STRIPS):
        d, v = diff[:, cols].ravel(), var[:, cols].ravel()
        n = d.size
        zs.append(d.mean() / max(np.sqrt(v.sum()) / n, 1e-12))
    return np.array(zs)


class VelocityBlur(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name
        write_smoke(self.path("smoke.vdb"))

    def tearDown(self):
        self.dir.cleanup()

    def path(self, *parts):
        return os.path.join(self.d, *parts)

    def render(self, name, s):
        f = self.path(name + ".json")
        with open(f, "w") as out:
            json.dump(s, out)
        code, _, err = run("render", f)
        self.assertEqual(code, 0, err)
        return read_exr(s["output"]["file"])

    def beauty(self, names, pixels):
        return channel(names, pixels, "beauty.R", "beauty.G", "beauty.B").mean(axis=-1)

    def expect_bad_input(self, s, *fragments):
        f = self.path("bad.json")
        with open(f, "w") as out:
            json.dump(s, out)
        code, _, err = run("render", f)
        self.assertEqual(code, 2, f"exit code {code}\n{err}")
        lines = [l for l in err.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, f"one error line expected, got:\n{err}")
        for frag in fragments:
            self.assertIn(frag, lines[0])
        self.assertFalse(os.path.exists(s["output"]["file"]), "no output on an input error")

    # ---- the blur equals the equivalent camera motion blur -----------------------------------

    def check_march_method(self, method, spp, render_extra=None):
        """single, wkb: the same seed draws the same time per camera sample in both renders, so
        their difference is only the march lattice's; its per-pixel spread is the noise."""
        x = render_extra
        vel = self.beauty(*self.render(method + "_vel", scene(method, self.path(method + "_vel.exr"), spp=spp,
                                                              render_extra=x)))
        cam = self.beauty(*self.render(method + "_cam", scene(method, self.path(method + "_cam.exr"),
                                                              velocity_blur=False, camera_motion=True, spp=spp,
                                                              render_extra=x)))
        still = self.beauty(*self.render(method + "_still", scene(method, self.path(method + "_still.exr"),
                                                                  shutter=(0.0, 0.0), spp=spp, render_extra=x)))
        diff = vel - cam
        # The per-pixel variance of the difference, estimated from its spread within each strip.
        var = np.zeros_like(diff)
        for cols in np.array_split(np.arange(diff.shape[1]), STRIPS):
            var[:, cols] = diff[:, cols].var()
        z = strip_z(diff, var)
        self.assertTrue(np.all(np.abs(z) < Z_MAX), f"{method}: velocity blur vs camera blur, strip z = {z}")
        # Power: the blur moves light between strips far beyond that noise (a render that ignored
        # the velocity would fail the comparison above).
        zStill = strip_z(vel - still, var)
        self.assertGreater(np.abs(zStill).max(), 2 * Z_MAX, f"{method}: the blur is not visible, z = {zStill}")
        # And the mean radiance is comparable (a moving ball is the same ball).
        self.assertLess(abs(vel.mean() - cam.mean()), 0.02 * cam.mean())

    def test_single_equals_camera_blur(self):
        self.check_march_method("single", 16)

    def test_wkb_equals_camera_blur(self):
        # Orders 3+ by the kernel: with the traced cache the two renders differ in one strip by
        # more than the lattice's noise once the cache has enough paths (strip z 4.6 at the
        # default's 113000 here, 5.4 at 2^20, orders 3 and 5 of the harmonics alike; within 4.5 at
        # 65536): an open finding of docs/motion-blur.md, not a tolerance to widen.
        self.check_march_method("wkb", 8, {"wkb_orders3": "kernel"})

    def test_pathtrace_equals_camera_blur(self):
        """The path tracer: independent estimates (the grown majorants change the collisions), so
        the noise is the sum of both renders' variance AOVs."""
        spp = 96
        nv, pv = self.render("pt_vel", scene("pathtrace", self.path("pt_vel.exr"), spp=spp))
        nc, pc = self.render("pt_cam", scene("pathtrace", self.path("pt_cam.exr"), velocity_blur=False,
                                             camera_motion=True, spp=spp))
        ns, ps = self.render("pt_still", scene("pathtrace", self.path("pt_still.exr"), shutter=(0.0, 0.0),
                                               spp=spp))
        vel, cam, still = self.beauty(nv, pv), self.beauty(nc, pc), self.beauty(ns, ps)
        var = channel(nv, pv, "variance.Y")[:, :, 0] + channel(nc, pc, "variance.Y")[:, :, 0]
        z = strip_z(vel - cam, var)
        self.assertTrue(np.all(np.abs(z) < Z_MAX), f"pathtrace: velocity blur vs camera blur, strip z = {z}")
        # Per pixel too: the normalised squared differences average about 1 (chi-square).
        ok = var > 0
        chi = ((vel - cam)[ok] ** 2 / var[ok]).mean()
        self.assertLess(abs(chi - 1.0), 0.35, f"pathtrace: mean z^2 per pixel {chi}")
        varStill = var + channel(ns, ps, "variance.Y")[:, :, 0]
        zStill = strip_z(vel - still, varStill)
        self.assertGreater(np.abs(zStill).max(), 2 * Z_MAX, f"pathtrace: the blur is not visible, z = {zStill}")

    def test_vrl_equals_camera_blur(self):
        """VRLs read the medium at one shutter time per iteration (light and camera paths alike),
        stratified over iterations; the camera-blurred render draws a time per camera sample.
        An iteration's VRLs light every pixel, so its errors are correlated across a strip and
        the variance AOV (per pixel) does not give a strip mean's noise: that comes from the
        spread of the strip means over independent renders (seeds), with Welch's t per strip,
        for each of L0, L1 and L2plus."""
        renders, spp, terms = 8, 48, ("L0", "L1", "L2plus")

        def strips(name, seed, **kw):
            s = scene("vrl", self.path(f"{name}_{seed}.exr"), seed=seed, spp=spp, **kw)
            s["render"]["vrl_paths"] = 16
            names, pixels = self.render(f"{name}_{seed}", s)
            out = []
            for term in terms:
                b = channel(names, pixels, term + ".R", term + ".G", term + ".B").mean(axis=-1)
                out += [b[:, cols].mean() for cols in np.array_split(np.arange(b.shape[1]), STRIPS)]
            return out

        vel = np.array([strips("vrl_vel", k + 1) for k in range(renders)])
        cam = np.array([strips("vrl_cam", k + 101, velocity_blur=False, camera_motion=True)
                        for k in range(renders)])
        still = np.array([strips("vrl_still", k + 201, shutter=(0.0, 0.0)) for k in range(renders)])

        def welch_t(a, b):
            se = np.sqrt(a.var(axis=0, ddof=1) / len(a) + b.var(axis=0, ddof=1) / len(b))
            return (a.mean(axis=0) - b.mean(axis=0)) / np.maximum(se, 1e-12)

        # t with about 14 degrees of freedom: |t| > 6 has odds of about 3e-5 per strip and term.
        t = welch_t(vel, cam).reshape(len(terms), STRIPS)
        self.assertTrue(np.all(np.abs(t) < 6.0), f"vrl: velocity blur vs camera blur, strip t per term =\n{t}")
        # Power: the transmitted background (L0) shows the blur far beyond that noise.
        tStill = welch_t(vel, still).reshape(len(terms), STRIPS)
        self.assertGreater(np.abs(tStill[0]).max(), 12.0, f"vrl: the blur is not visible in L0, t = {tStill[0]}")

    # ---- zero velocity, info, errors ---------------------------------------------------------

    def test_zero_velocity_is_no_blur_exactly(self):
        write_smoke(self.path("still.vdb"), velocity=(0.0, 0.0, 0.0))
        for method, spp in (("single", 2), ("wkb", 1), ("pathtrace", 4), ("vrl", 2)):
            a = scene(method, self.path(method + "_zero.exr"), spp=spp)
            a["volumes"][0]["source"]["file"] = "still.vdb"
            b = scene(method, self.path(method + "_none.exr"), velocity_blur=False, spp=spp)
            na, pa = self.render(method + "_zero", a)
            nb, pb = self.render(method + "_none", b)
            self.assertEqual(na, nb)
            self.assertTrue(np.array_equal(pa, pb), f"{method}: zero velocity changed the image")

    def test_info_shows_the_largest_displacement(self):
        f = self.path("info.json")
        with open(f, "w") as out:
            json.dump(scene("single", self.path("info.exr")), out)
        code, out, err = run("info", f)
        self.assertEqual(code, 0, err)
        expected = VELOCITY_SCALE * VELOCITY[0] / FPS / VOXEL  # one frame of shutter, in voxels
        self.assertIn(f"largest displacement {expected:.3g} voxels", out)
        code, out, err = run("info", f, "--set", "render.fps=48")
        self.assertEqual(code, 0, err)
        self.assertIn(f"largest displacement {expected / 2:.3g} voxels", out)

    def test_missing_vel_grid_is_an_input_error(self):
        write_smoke(self.path("novel.vdb"), vel=None)
        s = scene("single", self.path("bad.exr"))
        s["volumes"][0]["source"]["file"] = "novel.vdb"
        self.expect_bad_input(s, "volumes[0].source.grids.vel", "'vel' not found")
        s["volumes"][0]["source"]["grids"] = {"vel": "v"}  # a named grid that is not there either
        self.expect_bad_input(s, "volumes[0].source.grids.vel", "'v' not found")

    def test_vel_grid_of_the_wrong_type_is_an_input_error(self):
        write_smoke(self.path("floatvel.vdb"), vel="float")
        s = scene("pathtrace", self.path("bad.exr"))
        s["volumes"][0]["source"]["file"] = "floatvel.vdb"
        self.expect_bad_input(s, "volumes[0].source.grids.vel", "has type float", "vec3s")

    def test_procedural_source_has_no_vel_grid(self):
        s = scene("wkb", self.path("bad.exr"))
        s["volumes"][0]["source"] = {"type": "procedural", "generator": "sphere"}
        self.expect_bad_input(s, "volumes[0].medium.velocity_scale", "procedural")

    def test_bad_fps_and_velocity_scale(self):
        s = scene("single", self.path("bad.exr"))
        s["render"]["fps"] = 0
        self.expect_bad_input(s, "render.fps")
        s = scene("single", self.path("bad.exr"))
        s["volumes"][0]["medium"]["velocity_scale"] = "fast"
        self.expect_bad_input(s, "volumes[0].medium.velocity_scale")


if __name__ == "__main__":
    NIMBUS = sys.argv.pop(1)
    unittest.main()
