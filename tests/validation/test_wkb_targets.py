"""test_wkb_targets.py: issue 13's accuracy targets, asserted for WKB at its defaults.

    /usr/bin/python3 tests/validation/test_wkb_targets.py NIMBUS

Renders validation scenes with `wkb` at their own settings (the defaults: random_walk + exact,
order 2 auto, i.e. from the cache except under a spot light (2026-12-07; traced before), orders 3+
traced) and asserts issue 13's per-scene targets against the shipped
path-tracer references (tests/validation/references/): beauty relMSE <= 0.01 and L2plus energy
within +-5% (the metrics of `nimbus compare`, suite_tools.py). The targets are the issue's, not a
measured value plus a margin; the scenes are the validation scenes that meet them today
(2026-12-03, orders 3+ traced the default; the table in docs/validation.md: `box_twolobe_env`
0.0026 / -1.3%, `chromatic_box_spot_lit` 0.0068 / -0.9%, `chromatic_cloud_side` 0.0080 / -1.2%,
`sphere_forward_against` 0.0054 / -3.5%, `thin_cloud_spot_against` 0.0080 / -0.7%; with orders
3+ by the kernel, the default before, only the last two; and since the cache's skin cells,
2026-12-04, `slab_iso_a08` 0.0041 / -1.7%; since the cache's paths are aimed at the view, the same
day, `slab_g07_side` 0.0045 / -3.2%, and since point lights aim at the volumes, `wisps_point_lit`
0.0035 / +1.5%; since adaptive pixel sampling and the cache's paths from the image, the night of
2026-12-04, `core_spot_side` 0.0090 / -1.3% and `cumulus_against` 0.0065 / -1.5%; since the cache's paths
follow its measured noise, 2026-12-05, `cumulus_side_sky` 0.0068 / +2.3%, and since a quiet cache is
left unblurred, `sphere_backscatter_point` 0.0031 / -3.9%; since the cache's cells follow the densest
medium's transport length and its path cap rose, 2026-12-06, `sphere_thick_against` 0.0070 / +1.8%), so a change that makes WKB worse on them fails here. `scripts/validate-suite
--targets` runs the same check on every scene (every validation scene since 2026-12-06).
"""

import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import suite_tools as st  # noqa: E402

BEAUTY_TARGET = 0.01
L2PLUS_ENERGY_TARGET = 0.05
SCENES = ["box_twolobe_env", "chromatic_box_spot_lit", "chromatic_cloud_side", "core_spot_side", "cumulus_against",
          "cumulus_side_sky", "slab_g07_side", "slab_iso_a08", "sphere_backscatter_point", "sphere_forward_against",
          "sphere_thick_against", "thin_cloud_spot_against", "wisps_point_lit"]
NIMBUS = None


class WkbTargets(unittest.TestCase):
    def test_scenes_meet_the_targets(self):
        with tempfile.TemporaryDirectory() as tmp:
            for name in SCENES:
                with self.subTest(scene=name):
                    ref, _ = st.read_layers(st.reference_path("validation", name))
                    x, _ = st.render(NIMBUS, st.scene_path("validation", name), os.path.join(tmp, name + ".exr"),
                                     "wkb", (), aovs=("beauty", "L1", "L2plus"))
                    beauty = st.rel_mse(x["beauty"], ref["beauty"])
                    energy = st.energy_error(x["L2plus"], ref["L2plus"])
                    print("%s: beauty relMSE %.4f (target %g), L2plus energy %+.3f (target +-%g)"
                          % (name, beauty, BEAUTY_TARGET, energy, L2PLUS_ENERGY_TARGET))
                    self.assertLessEqual(beauty, BEAUTY_TARGET)
                    self.assertLessEqual(abs(energy), L2PLUS_ENERGY_TARGET)


if __name__ == "__main__":
    NIMBUS = sys.argv.pop(1)
    unittest.main()
