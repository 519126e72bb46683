"""test_references.py: the shipped references are still what the path tracer renders.

    /usr/bin/python3 tests/validation/test_references.py NIMBUS [--reference-scale S] [--keep DIR]

The references of tests/validation/references/ (made by scripts/make-references) would rot
silently if the path tracer changed: this test re-renders three of them with a seed none of them
used, at a small spp (a few seconds each), and tests the new render and the reference as two
unbiased estimates of the same image, each with its own variance AOV (the variance of the pixel
mean of the channel-averaged beauty, docs/pathtracer.md). Per pixel with any variance,

    z = (y_new - y_ref) / sqrt(s^2 (1/n_new + 1/n_ref)),    s^2 = (n_new^2 v_new + n_ref^2 v_ref) / (n_new + n_ref),

y the channel mean of the beauty, n the spp, v the variance AOV (so n v is the per-sample
variance) and s^2 the two renders' pooled per-sample variance: under the hypothesis that both
render the same image their samples have the same variance, and the reference's many samples
estimate it far better than a short render, whose variance is 0 at a thin edge that none of its
samples happened to hit (with v_new + v_ref there, such pixels give z of 8 and more). Pooling needs
one estimator for both: the new render uses the references' (`render.equiangular` off). The checks:

- **per pixel**: sum z^2 over the K pixels is chi-square with K degrees of freedom (the spp is
  large enough for the variances to be known: the finite-spp excess of E[z^2] is ~2/spp); it must
  lie between the distribution's 1e-4 and 1 - 1e-4 quantiles (Wilson-Hilferty), i.e. mean z^2 in
  about 1 +- 3.7 sqrt(2/K). This catches a changed image (a moved light, a wrong phase) anywhere;
- **energy**: sum y_new - sum y_ref within 4 combined standard errors (sqrt of the sum over pixels
  of s^2 (1/n_new + 1/n_ref), pixels independent). This catches a small change of scale the per-pixel test is too weak for;
- **power**: the same two checks must reject the reference scaled by 1.05, so that the test can
  fail on a 5% error at the spp it runs with.

On a failure the new render and the z image are kept (printed path), with the worst pixel and
the command that replays the render. `--reference-scale 1.05` scales the shipped reference by hand
to watch the test fail. Also checked, without rendering: every scene has a reference, a noise.json
entry and a row in tests/validation/README.md, and the whole set is at most 3 MB.
"""

import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import suite_tools as st  # noqa: E402

# (suite, scene, spp): a distant light on a box against the light, a point light on wisps, a
# spot on a chromatic box; a few seconds each on 2 cores.
CASES = [
    ("calibration", "haze_box_against", 2048),
    ("validation", "wisps_point_lit", 1024),
    ("validation", "chromatic_box_spot_lit", 1024),
]
SEED = 7  # the references use seeds 1 and 2, make-references' pilots 1001 and 1002
Z_QUANTILE = 3.719  # standard normal quantile of 1e-4 (one side)
ENERGY_SE = 4.0
MAX_BYTES = 3_000_000

ARGS = None


def chi2_bounds(k, z=Z_QUANTILE):
    """Wilson-Hilferty: chi2_k / k is about (1 - 2/(9k) + x sqrt(2/(9k)))^3, x standard normal."""
    a = 2.0 / (9.0 * k)
    return k * (1 - a - z * math.sqrt(a)) ** 3, k * (1 - a + z * math.sqrt(a)) ** 3


def statistics(new, ref, n_new, n_ref, scale=1.0):
    y_new = new["beauty"][..., :3].mean(-1)
    y_ref = scale * ref["beauty"][..., :3].mean(-1)
    s2 = (n_new ** 2 * new["variance"][..., 0] + n_ref ** 2 * scale * scale * ref["variance"][..., 0]) / (n_new + n_ref)
    v_new, v_ref = s2 / n_new, s2 / n_ref
    v = v_new + v_ref
    mask = v > 0
    z = np.zeros_like(y_new)
    z[mask] = (y_new[mask] - y_ref[mask]) / np.sqrt(v[mask])
    k = int(mask.sum())
    lo, hi = chi2_bounds(k)
    chi2 = float(np.sum(z[mask] ** 2))
    de = float(np.sum(y_new) - np.sum(y_ref))
    se = math.sqrt(float(np.sum(v_new) + np.sum(v_ref)))
    # Pixels without variance saw no volume (background, or light the medium cannot scatter):
    # both estimates are exact there and must agree to the reference's half precision.
    flat = float(np.max(np.abs(y_new[~mask] - y_ref[~mask]) / (np.abs(y_ref[~mask]) + 1e-6), initial=0.0))
    return {"z": z, "k": k, "chi2": chi2, "lo": lo, "hi": hi, "de": de, "se": se, "flat": flat,
            "chi2_ok": lo <= chi2 <= hi, "energy_ok": abs(de) <= ENERGY_SE * se}


def describe(s, rel_energy):
    iy, ix = np.unravel_index(int(np.argmax(np.abs(s["z"]))), s["z"].shape)
    return ("K %d pixels, mean z^2 %.4f (bounds %.4f-%.4f), energy difference %+.3g = %+.2f SE (%+.3f%%), "
            "worst pixel (x %d, y %d) z %+.2f" % (s["k"], s["chi2"] / s["k"], s["lo"] / s["k"], s["hi"] / s["k"],
                                                  s["de"], s["de"] / s["se"], 100 * rel_energy, ix, iy,
                                                  s["z"][iy, ix]))


class References(unittest.TestCase):
    def test_every_scene_has_its_reference(self):
        noise = st.load_noise().get("scenes", {})
        readme = open(os.path.join(st.HERE, "README.md")).read()
        total = 0
        for suite in st.SUITES:
            names = st.scene_names(suite)
            self.assertGreaterEqual(len(names), 8 if suite == "calibration" else 12, suite)
            for name in names:
                path = st.reference_path(suite, name)
                self.assertTrue(os.path.exists(path), "%s: no reference (run scripts/make-references)" % path)
                self.assertIn("%s/%s" % (suite, name), noise, "noise.json has no entry for %s/%s" % (suite, name))
                self.assertIn("| %s |" % name, readme, "README.md's tables lack %s" % name)
                layers, _ = st.read_layers(path)
                for aov in st.REFERENCE_AOVS:
                    self.assertIn(aov, layers, "%s lacks %s" % (path, aov))
                self.assertEqual(layers["beauty"].shape[:2], (64, 64), path)
                total += os.path.getsize(path)
        self.assertEqual(set(st.scene_names("calibration")) & set(st.scene_names("validation")), set())
        self.assertLessEqual(total, MAX_BYTES, "the references take %.2f MB" % (total / 1e6))

    def test_references_match_a_new_render(self):
        keep = ARGS.keep or tempfile.mkdtemp(prefix="nimbus-refcheck-")
        os.makedirs(keep, exist_ok=True)
        failures = []
        for suite, name, spp in CASES:
            with self.subTest(scene=name):
                scene = st.scene_path(suite, name)
                out = os.path.join(keep, "%s_seed%d.exr" % (name, SEED))
                # The references were made by distance sampling alone; the pooled variance assumes
                # both renders draw their samples from one estimator, so this render turns
                # equi-angular sampling off too (same expectation, a different variance: with it on,
                # thin wisps near the point light get ~1e-7 where the reference's samples never
                # scattered, 0 with variance 0, and z of 20+ on dozens of such pixels).
                sets = ["render.spp=%d" % spp, "render.time_limit=0", "render.seed=%d" % SEED,
                        "render.equiangular=false"]
                new, new_meta = st.render(ARGS.nimbus, scene, out, "pathtrace", sets)
                ref, ref_meta = st.read_layers(st.reference_path(suite, name))
                n = (int(new_meta["nimbus:pathtrace_spp"]), int(ref_meta["nimbus:pathtrace_spp"]))
                s = statistics(new, ref, *n, scale=ARGS.reference_scale)
                rel = s["de"] / float(np.sum(ARGS.reference_scale * ref["beauty"][..., :3].mean(-1)))
                print("%s/%s at %d spp: %s" % (suite, name, spp, describe(s, rel)), file=sys.stderr)
                power = statistics(new, ref, *n, scale=1.05 * ARGS.reference_scale)
                problems = []
                if not s["chi2_ok"]:
                    problems.append("sum z^2 %.1f outside the chi-square bounds [%.1f, %.1f] of %d pixels" % (
                        s["chi2"], s["lo"], s["hi"], s["k"]))
                if not s["energy_ok"]:
                    problems.append("energy differs by %+.2f standard errors (limit %g)" % (s["de"] / s["se"], ENERGY_SE))
                if s["flat"] > 1e-3:
                    problems.append("pixels without variance differ by %.3g (relative)" % s["flat"])
                if power["chi2_ok"] and power["energy_ok"]:
                    problems.append("too weak: the reference x 1.05 would pass (%s)" % describe(power, 0.05))
                if problems:
                    zpath = os.path.join(keep, "%s_z.exr" % name)
                    st.write_layers(zpath, {"beauty": np.dstack([s["z"]] * 3 + [np.ones_like(s["z"])]),
                                            "z": np.dstack([s["z"]] * 3)}, {})
                    failures.append("%s/%s: %s; the new render is %s, z in %s; replay: %s render %s --method "
                                    "pathtrace %s" % (suite, name, "; ".join(problems), out, zpath, ARGS.nimbus, scene,
                                                      " ".join("--set " + x for x in sets)))
        if failures:
            self.fail("\n".join(failures))
        if not ARGS.keep:
            shutil.rmtree(keep, ignore_errors=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("nimbus")
    ap.add_argument("--reference-scale", type=float, default=1.0, help="scale the references (to see the test fail)")
    ap.add_argument("--keep", help="keep the renders in this directory")
    ARGS, rest = ap.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest)
