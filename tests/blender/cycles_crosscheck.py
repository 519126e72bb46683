"""Cross-check of the Blender add-on's parameter mapping: the test scene of blender_scene.py (a
VDB volume with a Principled Volume material, lit by a sun) rendered by Cycles and by nimbus
pathtrace from the add-on's export. Not a ctest (Cycles takes minutes on 2 cores); run it after
changing the mapping and record the result in docs/embedding.md:

    /usr/bin/python3 tests/blender/cycles_crosscheck.py BLENDER BUILD_DIR SOURCE_DIR OUT_DIR

Both renderers are unbiased estimators of the same image once the mapping is right, so the test
is statistical: four independent seeds each give the spread of each image mean, and the
difference of the means is reported in standard errors (z). Cycles' heterogeneous volumes are
ray-marched (step rate 0.25 of a voxel), which is biased, so a small systematic difference is
possible and is what z shows. Writes OUT_DIR/cycles-crosscheck.png: Cycles | nimbus | |difference|
x 10, for all scattering orders (top) and single scattering (bottom)."""
import os
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_blender_addon_lib import read_layers, smoke_vdb  # noqa: E402

blender, build_dir, source_dir, out_dir = sys.argv[1:5]
os.makedirs(out_dir, exist_ok=True)
env = dict(os.environ, BLENDER=blender, BLENDER_USER_SCRIPTS=os.path.join(out_dir, "scripts"),
           BLENDER_USER_CONFIG=os.path.join(out_dir, "config"))
smoke = os.path.join(out_dir, "smoke.vdb")
smoke_vdb(smoke)
subprocess.run(["bash", os.path.join(source_dir, "scripts", "install-blender-addon.sh"), build_dir], env=env,
               check=True, capture_output=True)
subprocess.run([blender, "-b", "--factory-startup", "--python",
                os.path.join(source_dir, "tests", "blender", "blender_scene.py"), "--", out_dir, smoke, "crosscheck"],
               env=env, check=True, capture_output=True)

seeds = range(4)
cycles_all = np.stack([read_layers(os.path.join(out_dir, "cycles_all_%d.exr" % s))["ViewLayer.Combined"][..., :3]
                       for s in seeds])
cycles_single = np.stack([read_layers(os.path.join(out_dir, "cycles_single_%d.exr" % s))["ViewLayer.Combined"][..., :3]
                          for s in seeds])
nimbus = [read_layers(os.path.join(out_dir, "nimbus_%d.exr" % s)) for s in seeds]
nimbus_all = np.stack([n["ViewLayer.Combined"][..., :3] for n in nimbus])
nimbus_single = np.stack([n["ViewLayer.L0"] + n["ViewLayer.L1"] for n in nimbus])


def compare(label, cycles, ours):
    """Image means per channel over the seeds, their ratio and the z of their difference; and
    per pixel, the RMS difference of the 4-seed averages against the RMS that noise alone gives
    (from the scatter between seeds of each renderer): 1 when the images differ by noise only."""
    k = len(seeds)
    mc, mn = cycles.mean(axis=(1, 2)), ours.mean(axis=(1, 2))  # (seed, channel)
    c, n = mc.mean(0), mn.mean(0)
    z = (c - n) / np.sqrt(mc.var(0, ddof=1) / k + mn.var(0, ddof=1) / k)
    noise = np.sqrt(cycles.var(0, ddof=1).mean() / k + ours.var(0, ddof=1).mean() / k)
    rms = np.sqrt(np.mean((cycles.mean(0) - ours.mean(0)) ** 2))
    shifted = np.sqrt(np.mean((cycles.mean(0) - ours.mean(0) * (c / n)) ** 2))  # the mean ratio taken out
    print("| %s | %s | %s | %s | %s | %.2f | %.2f |" % (
        label, " ".join("%.5f" % v for v in c), " ".join("%.5f" % v for v in n),
        " ".join("%.3f" % v for v in c / n), " ".join("%+.1f" % v for v in z), rms / noise, shifted / noise))
    return cycles.mean(0), ours.mean(0)


print("| orders | Cycles mean RGB | nimbus mean RGB | Cycles / nimbus | z | pixel RMS / noise | same, ratio removed |")
print("|---|---|---|---|---|---|---|")
rows = [compare("all (L0 + L1 + L2+)", cycles_all, nimbus_all), compare("single (L0 + L1)", cycles_single, nimbus_single)]

peak = max(float(np.percentile(np.concatenate([r[0].ravel() for r in rows]), 99.5)), 1e-6)
tiles = []
for c, n in rows:
    tiles.append(np.concatenate([c, n, np.abs(c - n) * 10.0], axis=1))
image = np.clip(np.concatenate(tiles, axis=0) / peak, 0.0, 1.0) ** (1.0 / 2.2)
image = np.repeat(np.repeat(image, 3, axis=0), 3, axis=1)  # 3x: readable in a document
png = os.path.join(out_dir, "cycles-crosscheck.png")
out = oiio.ImageOutput.create(png)
out.open(png, oiio.ImageSpec(image.shape[1], image.shape[0], 3, oiio.UINT8))
out.write_image((image * 255.0 + 0.5).astype(np.uint8))
out.close()
print("wrote", png)
