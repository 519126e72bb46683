#!/usr/bin/python3
"""Transform and light motion blur within the shutter (issue 16, item 2; docs/motion-blur.md,
"Transform and light motion"; kernels/shared/motion.h).

1. A volume whose `transform` keys move it by D over the shutter equals the same ball moved by a
   uniform velocity field by D over the shutter (velocity motion blur, issue 16 item 3, tested
   against camera blur in test_velocity_blur.py): both are the density rho(x - D u) at shutter
   fraction u. In single, wkb and pathtrace with test_velocity_blur's strip z-tests (the noise
   from the renders: the spread of the difference for single and wkb, whose renders draw the same
   time per camera sample; the variance AOVs for pathtrace), in vrl with its Welch t over
   independent renders. A power check asserts the blur is far above the noise (against the
   shutter-closed render).

2. A point light whose `position` keys move it over the shutter lights the still ball as the
   average over the shutter of the ball lit by the still light at each time. The target is the
   mean of renders with the light placed (no keys, shutter closed) at the midpoints of K = 16 equal
   parts of the shutter: the composite midpoint rule's error is h^2 / 24 (f'(1) - f'(0)) + O(h^4),
   h = 1/K, for the light received at a point as a function f of the shutter time; the light
   moves 2 m along a line passing 0.45 m from the ball, so f (an inverse square and a smoothly
   varying transmittance) is nearly flat at both ends of its path and that error is about 1e-4
   of the signal, far below the noise the test resolves. Path tracer: exact in expectation, z-tested per strip with the variance AOVs
   (the K renders' variances add with weight 1/K^2). single and wkb place the light at each
   sample's time (direction, distance, spot cone) but read the shadow map built at the shutter's
   centre: their check uses an optically thin ball (optical depth 0.02 across), where that
   approximation is below the noise; docs/motion-blur.md says what it costs in a thick one.
   vrl (one shutter time per iteration, the light placed at it) against the path tracer's blurred
   render: t per strip with the spread of eight vrl renders and the path tracer's variance AOV.

3. A camera whose `fov` keys zoom within the shutter (20 degrees from the open to a key half way,
   then out to 48 at the close: a key inside the shutter, and the centre's fov, 20, far from the
   time-average, 27) equals the average over the shutter of still renders: the mean of K = 16
   renders at the fovs of the midpoints of the shutter's K parts (the key falls on a part's
   boundary; the midpoint rule's error is as in 2). single and wkb: the still renders share the
   blurred render's seed, so each camera sample keeps its filter offset and march and only its
   time differs: the difference is the time-sampling noise alone, zero in expectation and
   independent between pixels, z-tested per ring about the image centre (a zoom's blur is
   radial) with its spread in the ring. pathtrace: independent seeds, z per ring with the
   variance AOVs and the per-pixel mean z^2. vrl: against the path tracer's blurred render as
   in 2, t per ring. Each with a power check against the fov held at the shutter's centre.

Run by ctest with Debian's python3 (pyopenvdb and OpenImageIO's bindings come from Debian):
    test_transform_blur.py NIMBUS_BINARY [-k NAME]
"""
import json
import os
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import test_velocity_blur as vb  # noqa: E402  (the ball, its scene, the strip z-test)

STRIPS, Z_MAX = vb.STRIPS, vb.Z_MAX
LIGHT_FROM, LIGHT_TO = (-1.0, 0.6, 0.6), (1.0, 0.6, 0.6)  # the point light over the shutter [0, 1]
K = 16  # still-light renders at the midpoints of the shutter's K parts


def transform_scene(method, output, seed=1, spp=16):
    """The ball without velocity blur, moved by its transform keys by D over the shutter (frame 1
    to frame 2: the shutter [0, 1] at frame 1)."""
    s = vb.scene(method, output, velocity_blur=False, seed=seed, spp=spp)
    s["volumes"][0]["transform"] = [{"frame": 1, "value": {"translate": [0, 0, 0]}},
                                    {"frame": 2, "value": {"translate": list(vb.DISPLACEMENT)}}]
    return s


def light_scene(method, output, position=None, spp=16, seed=1, thin=False):
    """The still ball lit by a point light that moves from LIGHT_FROM to LIGHT_TO over the shutter
    [0, 1], or, with `position`, by a still light there and the shutter closed. No background, so
    beauty is the light scattered by the ball."""
    s = vb.scene(method, output, velocity_blur=False, seed=seed, spp=spp)
    s["background"] = [0, 0, 0]
    if thin:  # optical depth 0.02 across the 0.8 m ball
        s["volumes"][0]["medium"] = {"sigma_s": [0.025, 0.025, 0.025], "phase": {"type": "hg", "g": 0.3}}
    light = {"name": "bulb", "type": "point", "intensity": [2, 2, 2]}
    if position is None:
        light["position"] = [{"frame": 1, "value": list(LIGHT_FROM)}, {"frame": 2, "value": list(LIGHT_TO)}]
    else:
        light["position"] = list(position)
        s["camera"]["shutter"] = [0, 0]
    s["lights"] = [light]
    return s


FOV_KEYS = [(1.0, 20.0), (1.5, 20.0), (2.0, 48.0)]  # (frame, fov): the shutter [0, 1] at frame 1


def fov_at(u):
    """The keys' fov at shutter fraction u (linear in degrees between keys)."""
    return float(np.interp(1.0 + u, [f for f, _ in FOV_KEYS], [v for _, v in FOV_KEYS]))


RINGS = 8  # rings about the image centre, RING_WIDTH pixels wide, and all beyond them
RING_WIDTH = 2.0


def ring_masks(shape):
    """A zoom about the image centre moves the ball's image radially: its blur is a ring, so the
    zoom tests compare ring means (where every pixel's difference has one sign), not strips."""
    h, w = shape
    y, x = np.mgrid[0:h, 0:w]
    r = np.hypot(x + 0.5 - 0.5 * w, y + 0.5 - 0.5 * h)
    k = np.minimum((r / RING_WIDTH).astype(int), RINGS)
    return [k == i for i in range(RINGS + 1)]


def ring_z(diff, var):
    """z of the mean difference in each ring; var: per-pixel variance of diff."""
    return np.array([diff[m].mean() / max(np.sqrt(var[m].sum()) / m.sum(), 1e-12) for m in ring_masks(diff.shape)])


def zoom_scene(method, output, fov=None, spp=16, seed=1):
    """The still ball seen by a camera whose fov zooms within the shutter [0, 1] as FOV_KEYS say,
    or, with `fov`, held at that fov with the shutter closed."""
    s = vb.scene(method, output, velocity_blur=False, seed=seed, spp=spp)
    if fov is None:
        s["camera"]["fov"] = [{"frame": f, "value": v} for f, v in FOV_KEYS]
    else:
        s["camera"]["fov"] = fov
        s["camera"]["shutter"] = [0, 0]
    return s


def light_at(u):
    return [a + (b - a) * u for a, b in zip(LIGHT_FROM, LIGHT_TO)]


class TransformBlur(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name
        vb.write_smoke(self.path("smoke.vdb"))

    def tearDown(self):
        self.dir.cleanup()

    def path(self, *parts):
        return os.path.join(self.d, *parts)

    def render(self, name, s):
        f = self.path(name + ".json")
        with open(f, "w") as out:
            json.dump(s, out)
        code, _, err = vb.run("render", f)
        self.assertEqual(code, 0, err)
        self.assertNotIn("not motion-blurred", err)  # lights and volume transforms are blurred
        return vb.read_exr(s["output"]["file"])

    def beauty(self, names, pixels):
        return vb.channel(names, pixels, "beauty.R", "beauty.G", "beauty.B").mean(axis=-1)

    def variance(self, names, pixels):
        return vb.channel(names, pixels, "variance.Y")[:, :, 0]

    # ---- 1. a moving transform equals the same motion by velocity ---------------------------

    def check_march_method(self, method, spp):
        def kernel_orders3(s):
            # wkb: orders 3+ by the kernel in all three. A volume moved by its transform gets them
            # from the kernel anyway (the traced cache, the default, is not planned there:
            # docs/motion-blur.md), so the velocity render must too for the two to be the same
            # model; with the cache in both this check failed (2026-12-03, strip z -7.8 to +7.2,
            # one side bright and the other dark: the cache's placement of a transform-moved
            # volume, not followed up).
            if method == "wkb":
                s["render"]["wkb_orders3"] = "kernel"
            return s
        vel = self.beauty(*self.render(method + "_vel", kernel_orders3(vb.scene(method, self.path(method + "_vel.exr"),
                                                                                spp=spp))))
        xf = self.beauty(*self.render(method + "_xf", kernel_orders3(
            transform_scene(method, self.path(method + "_xf.exr"), spp=spp))))
        still = self.beauty(*self.render(method + "_still", kernel_orders3(
            vb.scene(method, self.path(method + "_still.exr"), velocity_blur=False, shutter=(0.0, 0.0), spp=spp))))
        diff = xf - vel
        var = np.zeros_like(diff)
        for cols in np.array_split(np.arange(diff.shape[1]), STRIPS):
            var[:, cols] = diff[:, cols].var()
        z = vb.strip_z(diff, var)
        print(f"{method} transform vs velocity: strip z = {np.round(z, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(z) < Z_MAX), f"{method}: transform blur vs velocity blur, strip z = {z}")
        zStill = vb.strip_z(xf - still, var)
        self.assertGreater(np.abs(zStill).max(), 2 * Z_MAX, f"{method}: the blur is not visible, z = {zStill}")
        self.assertLess(abs(xf.mean() - vel.mean()), 0.02 * vel.mean())

    def test_single_transform_equals_velocity_blur(self):
        self.check_march_method("single", 16)

    def test_wkb_transform_equals_velocity_blur(self):
        self.check_march_method("wkb", 8)

    def test_pathtrace_transform_equals_velocity_blur(self):
        spp = 96
        nx, px = self.render("pt_xf", transform_scene("pathtrace", self.path("pt_xf.exr"), spp=spp))
        nv, pv = self.render("pt_vel", vb.scene("pathtrace", self.path("pt_vel.exr"), spp=spp))
        ns, ps = self.render("pt_still", vb.scene("pathtrace", self.path("pt_still.exr"), velocity_blur=False,
                                                  shutter=(0.0, 0.0), spp=spp))
        xf, vel, still = self.beauty(nx, px), self.beauty(nv, pv), self.beauty(ns, ps)
        var = self.variance(nx, px) + self.variance(nv, pv)
        z = vb.strip_z(xf - vel, var)
        print(f"pathtrace transform vs velocity: strip z = {np.round(z, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(z) < Z_MAX), f"pathtrace: transform blur vs velocity blur, strip z = {z}")
        ok = var > 0
        chi = ((xf - vel)[ok] ** 2 / var[ok]).mean()
        self.assertLess(abs(chi - 1.0), 0.35, f"pathtrace: mean z^2 per pixel {chi}")
        zStill = vb.strip_z(xf - still, self.variance(nx, px) + self.variance(ns, ps))
        self.assertGreater(np.abs(zStill).max(), 2 * Z_MAX, f"pathtrace: the blur is not visible, z = {zStill}")

    def test_vrl_transform_equals_velocity_blur(self):
        """One shutter time per iteration for the VRLs and the camera paths, as for velocity blur:
        Welch's t per strip and term over independent renders (test_velocity_blur's reasoning)."""
        renders, spp, terms = 8, 48, ("L0", "L1", "L2plus")

        def strips(name, seed, make):
            s = make(seed)
            s["render"]["vrl_paths"] = 16
            names, pixels = self.render(f"{name}_{seed}", s)
            out = []
            for term in terms:
                b = vb.channel(names, pixels, term + ".R", term + ".G", term + ".B").mean(axis=-1)
                out += [b[:, cols].mean() for cols in np.array_split(np.arange(b.shape[1]), STRIPS)]
            return out

        xf = np.array([strips("vrl_xf", k + 1, lambda sd: transform_scene(
            "vrl", self.path(f"vrl_xf_{sd}.exr"), seed=sd, spp=spp)) for k in range(renders)])
        vel = np.array([strips("vrl_vel", k + 101, lambda sd: vb.scene(
            "vrl", self.path(f"vrl_vel_{sd}.exr"), seed=sd, spp=spp)) for k in range(renders)])
        still = np.array([strips("vrl_still", k + 201, lambda sd: vb.scene(
            "vrl", self.path(f"vrl_still_{sd}.exr"), velocity_blur=False, shutter=(0.0, 0.0), seed=sd, spp=spp))
            for k in range(renders)])

        def welch_t(a, b):
            se = np.sqrt(a.var(axis=0, ddof=1) / len(a) + b.var(axis=0, ddof=1) / len(b))
            return (a.mean(axis=0) - b.mean(axis=0)) / np.maximum(se, 1e-12)

        t = welch_t(xf, vel).reshape(len(terms), STRIPS)
        print(f"vrl transform vs velocity: strip t per term =\n{np.round(t, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(t) < 6.0), f"vrl: transform blur vs velocity blur, strip t per term =\n{t}")
        tStill = welch_t(xf, still).reshape(len(terms), STRIPS)
        self.assertGreater(np.abs(tStill[0]).max(), 12.0, f"vrl: the blur is not visible in L0, t = {tStill[0]}")

    # ---- 2. a moving light equals the average of the still light over the shutter -----------

    def still_light_average(self, method, spp, thin=False):
        """The mean of K renders with the light still at the midpoints of the shutter's K parts,
        and the variance of that mean (path tracer: from the variance AOVs)."""
        mean, var = None, None
        for k in range(K):
            s = light_scene(method, self.path(f"{method}_at{k}.exr"), position=light_at((k + 0.5) / K), spp=spp,
                            seed=1000 + k, thin=thin)
            names, pixels = self.render(f"{method}_at{k}", s)
            b = self.beauty(names, pixels) / K
            mean = b if mean is None else mean + b
            if method == "pathtrace":
                v = self.variance(names, pixels) / K ** 2
                var = v if var is None else var + v
        return mean, var

    def test_pathtrace_moving_light_equals_the_still_lights_average(self):
        names, pixels = self.render("pt_light", light_scene("pathtrace", self.path("pt_light.exr"), spp=256))
        blurred, varBlurred = self.beauty(names, pixels), self.variance(names, pixels)
        mean, varMean = self.still_light_average("pathtrace", 16)
        var = varBlurred + varMean
        z = vb.strip_z(blurred - mean, var)
        print(f"pathtrace moving light vs still lights' mean: strip z = {np.round(z, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(z) < Z_MAX), f"pathtrace: moving light vs still lights' mean, strip z = {z}")
        ok = var > 0
        chi = ((blurred - mean)[ok] ** 2 / var[ok]).mean()
        self.assertLess(abs(chi - 1.0), 0.35, f"pathtrace: mean z^2 per pixel {chi}")
        # Power: against the light held at the shutter's centre, the lit side moves far beyond
        # that noise (a light read at the centre would fail the comparison above).
        nc, pc = self.render("pt_centre", light_scene("pathtrace", self.path("pt_centre.exr"), position=light_at(0.5),
                                                      spp=256, seed=7))
        zCentre = vb.strip_z(blurred - self.beauty(nc, pc), varBlurred + self.variance(nc, pc))
        self.assertGreater(np.abs(zCentre).max(), 2 * Z_MAX, f"pathtrace: the light's motion is not visible, {zCentre}")

    def test_vrl_moving_light_equals_the_path_tracers(self):
        """vrl places the moving light at each iteration's time for its light pass and its camera
        paths. Its errors are correlated across the pixels an iteration's VRLs light, so its strip
        means' noise comes from eight independent renders; the target is the path tracer's
        blurred render (checked against the still lights' mean above), whose strip means' noise
        comes from its variance AOV: t per strip with both noises."""
        names, pixels = self.render("vpt_light", light_scene("pathtrace", self.path("vpt_light.exr"), spp=256))
        pt, ptVar = self.beauty(names, pixels), self.variance(names, pixels)
        nc, pc = self.render("vpt_centre", light_scene("pathtrace", self.path("vpt_centre.exr"), position=light_at(0.5),
                                                       spp=256, seed=7))
        centre, centreVar = self.beauty(nc, pc), self.variance(nc, pc)
        cols = np.array_split(np.arange(pt.shape[1]), STRIPS)

        def strips(image):
            return np.array([image[:, c].mean() for c in cols])

        def strip_var(var):
            return np.array([var[:, c].sum() / var[:, c].size ** 2 for c in cols])

        vrl = []
        for k in range(8):
            s = light_scene("vrl", self.path(f"vrl_light_{k}.exr"), spp=48, seed=k + 1)
            s["render"]["vrl_paths"] = 16
            vrl.append(strips(self.beauty(*self.render(f"vrl_light_{k}", s))))
        vrl = np.array(vrl)
        se2 = vrl.var(axis=0, ddof=1) / len(vrl)
        t = (vrl.mean(axis=0) - strips(pt)) / np.maximum(np.sqrt(se2 + strip_var(ptVar)), 1e-12)
        print(f"vrl moving light vs pathtrace: strip t = {np.round(t, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(t) < 6.0), f"vrl: moving light vs the path tracer's, strip t = {t}")
        tCentre = (vrl.mean(axis=0) - strips(centre)) / np.maximum(np.sqrt(se2 + strip_var(centreVar)), 1e-12)
        self.assertGreater(np.abs(tCentre).max(), 12.0, f"vrl: the light's motion is not visible, t = {tCentre}")

    def check_march_light(self, method, spp):
        """single, wkb in a thin ball: the blurred render and the mean of the still lights differ
        by the time sampling (per camera sample against 16 fixed times) and the march; the noise
        is the spread of the difference within each strip."""
        names, pixels = self.render(method + "_light", light_scene(method, self.path(method + "_light.exr"), spp=spp,
                                                                   thin=True))
        blurred = self.beauty(names, pixels)
        mean, _ = self.still_light_average(method, spp, thin=True)
        diff = blurred - mean
        var = np.zeros_like(diff)
        for cols in np.array_split(np.arange(diff.shape[1]), STRIPS):
            var[:, cols] = diff[:, cols].var()
        z = vb.strip_z(diff, var)
        print(f"{method} moving light vs still lights' mean: strip z = {np.round(z, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(z) < Z_MAX), f"{method}: moving light vs still lights' mean, strip z = {z}")
        nc, pc = self.render(method + "_centre", light_scene(method, self.path(method + "_centre.exr"),
                                                             position=light_at(0.5), spp=spp, thin=True))
        zCentre = vb.strip_z(blurred - self.beauty(nc, pc), var)
        self.assertGreater(np.abs(zCentre).max(), 2 * Z_MAX, f"{method}: the light's motion is not visible, {zCentre}")
        self.assertLess(abs(blurred.mean() - mean.mean()), 0.02 * mean.mean())

    def test_single_moving_light_equals_the_still_lights_average(self):
        self.check_march_light("single", 16)

    def test_wkb_moving_light_equals_the_still_lights_average(self):
        self.check_march_light("wkb", 8)

    # ---- 3. a zoom equals the average of the still fovs over the shutter ----------------------

    def still_fov_average(self, method, spp, seed=None):
        """The mean of K renders with the fov still at the midpoints of the shutter's K parts, and
        the variance of that mean (path tracer: from the variance AOVs). seed None: 1000 + k."""
        mean, var = None, None
        for k in range(K):
            s = zoom_scene(method, self.path(f"{method}_fov{k}.exr"), fov=fov_at((k + 0.5) / K), spp=spp,
                           seed=1000 + k if seed is None else seed)
            names, pixels = self.render(f"{method}_fov{k}", s)
            b = self.beauty(names, pixels) / K
            mean = b if mean is None else mean + b
            if method == "pathtrace":
                v = self.variance(names, pixels) / K ** 2
                var = v if var is None else var + v
        return mean, var

    def check_march_zoom(self, method, spp):
        names, pixels = self.render(method + "_zoom", zoom_scene(method, self.path(method + "_zoom.exr"), spp=spp))
        blurred = self.beauty(names, pixels)
        mean, _ = self.still_fov_average(method, spp, seed=1)
        diff = blurred - mean
        var = np.zeros_like(diff)
        for m in ring_masks(diff.shape):
            var[m] = diff[m].var()
        z = ring_z(diff, var)
        print(f"{method} zoom vs still fovs' mean: ring z = {np.round(z, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(z) < Z_MAX), f"{method}: zoom vs still fovs' mean, ring z = {z}")
        # Power: the fov held at the shutter's centre (what nimbus did before) is far off.
        nc, pc = self.render(method + "_fovc", zoom_scene(method, self.path(method + "_fovc.exr"), fov=fov_at(0.5),
                                                         spp=spp))
        zCentre = ring_z(blurred - self.beauty(nc, pc), var)
        print(f"{method} zoom vs the centre's fov: ring z = {np.round(zCentre, 2)}", file=sys.stderr)
        self.assertGreater(np.abs(zCentre).max(), 2 * Z_MAX, f"{method}: the zoom is not visible, {zCentre}")
        self.assertLess(abs(blurred.mean() - mean.mean()), 0.02 * mean.mean())

    def test_single_zoom_equals_the_still_fovs_average(self):
        self.check_march_zoom("single", 16)

    def test_wkb_zoom_equals_the_still_fovs_average(self):
        self.check_march_zoom("wkb", 8)

    def test_pathtrace_zoom_equals_the_still_fovs_average(self):
        names, pixels = self.render("pt_zoom", zoom_scene("pathtrace", self.path("pt_zoom.exr"), spp=256))
        blurred, varBlurred = self.beauty(names, pixels), self.variance(names, pixels)
        mean, varMean = self.still_fov_average("pathtrace", 16)
        var = varBlurred + varMean
        z = ring_z(blurred - mean, var)
        print(f"pathtrace zoom vs still fovs' mean: ring z = {np.round(z, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(z) < Z_MAX), f"pathtrace: zoom vs still fovs' mean, ring z = {z}")
        ok = var > 0
        chi = ((blurred - mean)[ok] ** 2 / var[ok]).mean()
        self.assertLess(abs(chi - 1.0), 0.35, f"pathtrace: mean z^2 per pixel {chi}")
        nc, pc = self.render("pt_fovc", zoom_scene("pathtrace", self.path("pt_fovc.exr"), fov=fov_at(0.5), spp=256,
                                                   seed=7))
        zCentre = ring_z(blurred - self.beauty(nc, pc), varBlurred + self.variance(nc, pc))
        print(f"pathtrace zoom vs the centre's fov: ring z = {np.round(zCentre, 2)}", file=sys.stderr)
        self.assertGreater(np.abs(zCentre).max(), 2 * Z_MAX, f"pathtrace: the zoom is not visible, {zCentre}")

    def test_vrl_zoom_equals_the_path_tracers(self):
        """vrl's camera paths draw their own times (nothing else moves): against the path tracer's
        zoom (checked against the still fovs' mean above), t per strip with the spread of eight
        vrl renders and the path tracer's variance AOV, as for the moving light."""
        names, pixels = self.render("vpt_zoom", zoom_scene("pathtrace", self.path("vpt_zoom.exr"), spp=256))
        pt, ptVar = self.beauty(names, pixels), self.variance(names, pixels)
        nc, pc = self.render("vpt_fovc", zoom_scene("pathtrace", self.path("vpt_fovc.exr"), fov=fov_at(0.5), spp=256,
                                                    seed=7))
        centre, centreVar = self.beauty(nc, pc), self.variance(nc, pc)
        masks = ring_masks(pt.shape)

        def rings(image):
            return np.array([image[m].mean() for m in masks])

        def ring_var(var):
            return np.array([var[m].sum() / m.sum() ** 2 for m in masks])

        vrl = []
        for k in range(8):
            s = zoom_scene("vrl", self.path(f"vrl_zoom_{k}.exr"), spp=48, seed=k + 1)
            s["render"]["vrl_paths"] = 16
            vrl.append(rings(self.beauty(*self.render(f"vrl_zoom_{k}", s))))
        vrl = np.array(vrl)
        se2 = vrl.var(axis=0, ddof=1) / len(vrl)
        t = (vrl.mean(axis=0) - rings(pt)) / np.maximum(np.sqrt(se2 + ring_var(ptVar)), 1e-12)
        print(f"vrl zoom vs pathtrace: ring t = {np.round(t, 2)}", file=sys.stderr)
        self.assertTrue(np.all(np.abs(t) < 6.0), f"vrl: zoom vs the path tracer's, ring t = {t}")
        tCentre = (vrl.mean(axis=0) - rings(centre)) / np.maximum(np.sqrt(se2 + ring_var(centreVar)), 1e-12)
        print(f"vrl zoom vs the centre's fov: ring t = {np.round(tCentre, 2)}", file=sys.stderr)
        # Power: the fov held at the centre fails the test the zoom passes (|t| < 6). vrl's noise,
        # correlated across the pixels an iteration's VRLs light, leaves t of about 10 here, short
        # of the 2x margin the other power checks keep; the path tracer's check above has it.
        self.assertGreater(np.abs(tCentre).max(), 6.0, f"vrl: the zoom is not visible, t = {tCentre}")

    def test_info_shows_the_zoom(self):
        s = zoom_scene("single", self.path("zinfo.exr"))
        f = self.path("zinfo.json")
        with open(f, "w") as out:
            json.dump(s, out)
        code, out, err = vb.run("info", f)
        self.assertEqual(code, 0, err)
        # Shutter [0, 1] at frame 1: the open, the key at 1.5 and the close.
        self.assertIn("fov moves within the shutter (3 knots, 20 to 48 deg)", out)

    def test_more_fov_keys_in_a_shutter_than_the_kernel_holds_is_one_line(self):
        s = zoom_scene("single", self.path("dense.exr"))
        s["camera"]["fov"] = [{"frame": 1.0 + 0.1 * j, "value": 30 + j} for j in range(11)]  # 9 inside
        f = self.path("dense.json")
        with open(f, "w") as out:
            json.dump(s, out)
        code, _, err = vb.run("render", f)
        self.assertEqual(code, 2, err)
        lines = err.strip().splitlines()
        self.assertEqual(len(lines), 1, err)
        self.assertIn("dense.json", lines[0])
        self.assertIn("camera.fov: 9 keys within the shutter", lines[0])
        self.assertFalse(os.path.exists(self.path("dense.exr")))

    # ---- what stays at the shutter's centre ---------------------------------------------------

    def test_geometry_keys_still_warn_and_fov_keys_do_not(self):
        s = transform_scene("single", self.path("geo.exr"), spp=1)
        s["geometry"] = [{"type": "sphere", "radius": 0.1, "holdout": False,
                          "transform": [{"frame": 1, "value": {"translate": [1, 0, 0]}},
                                        {"frame": 2, "value": {"translate": [1, 0.2, 0]}}]}]
        f = self.path("geo.json")
        with open(f, "w") as out:
            json.dump(s, out)
        code, _, err = vb.run("render", f)
        self.assertEqual(code, 0, err)
        warnings = [l for l in err.splitlines() if "not motion-blurred" in l]
        self.assertEqual(len(warnings), 1, err)
        self.assertIn("geometry[0].transform moves during the shutter but is not motion-blurred", warnings[0])
        # It names only what is not blurred: the moving volume, and a zoom, are not in it.
        self.assertNotIn("volumes[0]", warnings[0])
        s["camera"]["fov"] = [{"frame": f, "value": v} for f, v in FOV_KEYS]
        with open(f, "w") as out:
            json.dump(s, out)
        code, _, err = vb.run("render", f)
        self.assertEqual(code, 0, err)
        warnings = [l for l in err.splitlines() if "not motion-blurred" in l]
        self.assertEqual(len(warnings), 1, err)
        self.assertNotIn("fov", warnings[0])
        self.assertNotIn("camera", warnings[0])

    def test_info_shows_what_moves_within_the_shutter(self):
        s = transform_scene("single", self.path("info.exr"))
        s["lights"] = light_scene("single", self.path("info.exr"))["lights"]
        f = self.path("info.json")
        with open(f, "w") as out:
            json.dump(s, out)
        code, out, err = vb.run("info", f)
        self.assertEqual(code, 0, err)
        # Shutter [0, 1] at frame 1, keys at frames 1 and 2: the knots are open and close.
        self.assertIn("transform moves within the shutter (2 knots)", out)
        self.assertIn("moves within the shutter (2 knots); shadow map at the shutter's centre", out)
        s["camera"]["shutter"] = [0, 0]
        with open(f, "w") as out:
            json.dump(s, out)
        code, out, err = vb.run("info", f)
        self.assertEqual(code, 0, err)
        self.assertNotIn("within the shutter", out)


if __name__ == "__main__":
    vb.NIMBUS = sys.argv.pop(1)
    unittest.main()
