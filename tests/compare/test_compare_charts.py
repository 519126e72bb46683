"""The charts of `nimbus compare` (src/compare/compare_charts.py) on a small synthetic output
directory: a compare.csv with every kind of row nimbus compare writes (the path tracer's time
ladder over two seeds, its equal-time run, WKB's four source x kernel runs and its quality
ladder, single) and 16x12 panels. Checks that both PNGs are written at the sizes the script
fixes, and, from the script's --describe (read back from the matplotlib objects), the chart's
title, axis labels, log scales and legend entries, the sheet's panel titles and its colour bar's
label and symmetric range. Then the errors: a missing CSV and missing panels are one line each,
exit status 1.

    test_compare_charts.py SCRIPT
"""

import csv
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

SCRIPT = sys.argv[1]
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAIL:", what)


HEADER = ["method", "label", "source", "kernel", "seed", "seconds", "spp"]
for aov in ("beauty", "L1", "L2plus"):
    HEADER += [f"{aov}_relmse", f"{aov}_meanrel", f"{aov}_energyrel"]
HEADER.append("pt_seconds_to_equal_beauty_relmse")


def row(method, label, source, kernel, seed, seconds, relmse):
    r = dict.fromkeys(HEADER, "0")
    r.update(method=method, label=label, source=source, kernel=kernel, seed=str(seed), seconds=f"{seconds:.4f}",
             beauty_relmse=f"{relmse:.6g}", pt_seconds_to_equal_beauty_relmse="")
    return r


def write_dir(d, panels=True, vrl=False):
    rows = []
    if vrl:  # virtual ray lights at the path tracer's ladder and at WKB's time (issue 15)
        for t in (0.5, 1, 2, 4, 8):
            for k in range(2):
                rows.append(row("vrl", f"t={t:g}s", "", "", 1000 + k, t * 1.02, 0.02 / t * (1 + 0.1 * k)))
        rows.append(row("vrl", "equal-time", "", "", 2000, 0.46, 0.05))
    for t in (0.5, 1, 2, 4, 8):
        for k in range(2):
            rows.append(row("pathtrace", f"t={t:g}s", "", "", 1000 + k, t * 1.01, 0.05 / t * (1 + 0.1 * k)))
    for i, (s, k) in enumerate([("straight", "gaussian"), ("straight", "exact"), ("random_walk", "gaussian"),
                                ("random_walk", "exact")]):
        rows.append(row("wkb", "base", s, k, 1, 0.3 + 0.05 * i, 0.02 + 0.01 * i))
    for label, t, e in (("coarse", 0.1, 0.08), ("fast", 0.2, 0.04), ("fine", 1.5, 0.015)):
        rows.append(row("wkb", label, "random_walk", "exact", 1, t, e))
    rows.append(row("single", "base", "", "", 1, 0.05, 0.3))
    rows.append(row("pathtrace", "equal-time", "", "", 2000, 0.45, 0.12))
    with open(os.path.join(d, "compare.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=HEADER)
        w.writeheader()
        w.writerows(rows)
    if not panels:
        return
    os.makedirs(os.path.join(d, "panels"))
    h, w = 12, 16
    ramp = np.linspace(0, 1, w * h * 3, dtype=np.float32).reshape(h, w, 3)
    for name in ("reference", "wkb", "pathtrace") + (("vrl",) if vrl else ()):
        out = oiio.ImageOutput.create("png")
        check(out.open(os.path.join(d, "panels", name + ".png"), oiio.ImageSpec(w, h, 3, oiio.UINT8)), "open png")
        out.write_image(ramp)
        out.close()
    diff = np.linspace(-0.25, 0.5, w * h, dtype=np.float32).reshape(h, w, 1)
    spec = oiio.ImageSpec(w, h, 1, oiio.FLOAT)
    spec.channelnames = ("Y",)
    out = oiio.ImageOutput.create("exr")
    check(out.open(os.path.join(d, "panels", "difference.exr"), spec), "open exr")
    out.write_image(diff)
    out.close()


def run(d, *extra):
    return subprocess.run(["/usr/bin/python3", SCRIPT, d, *extra], capture_output=True, text=True, timeout=60)


with tempfile.TemporaryDirectory() as d:
    write_dir(d)
    p = run(d, "--title", "slab_thin.json", "--reference-noise", "0.0004", "--wkb", "random_walk/exact", "--describe")
    check(p.returncode == 0, f"the script failed: {p.stderr.strip()}")
    if p.returncode == 0:
        desc = json.loads(p.stdout)
        c, s = desc["error_vs_time"], desc["sheet"]
        for name, size in (("error_vs_time.png", c["size"]), ("sheet.png", s["size"])):
            check(os.path.getsize(os.path.join(d, name)) > 10000, f"{name} is nearly empty")
        # The chart's figure is 9.6 x 5.6 in at 100 dpi; the sheet four panels of 3.2 in (aspect 4:3).
        check(c["size"] == [960, 560], f"error_vs_time.png is {c['size']}, not 960x560")
        check(1300 <= s["size"][0] <= 1500 and 300 <= s["size"][1] <= 450, f"sheet.png is {s['size']}")
        check(c["title"] == "slab_thin.json: beauty error against render time", f"chart title {c['title']!r}")
        check(c["xlabel"] == "time (s)" and c["ylabel"] == "beauty relMSE", f"axis labels {c['xlabel']!r}, {c['ylabel']!r}")
        check(c["xscale"] == "log" and c["yscale"] == "log", "the chart is not log-log")
        want = ["path tracer, each seed", "path tracer, mean of 2 seeds", "path tracer at WKB's time",
                "WKB straight/gaussian", "WKB straight/exact", "WKB random_walk/gaussian", "WKB random_walk/exact",
                "WKB random_walk/exact quality ladder", "single (L0 + L1 only)", "reference noise floor (0.0004)"]
        check(c["legend"] == want, f"legend {c['legend']}")
        check(len(s["panels"]) == 4, f"{len(s['panels'])} panels")
        check(s["panels"][0].startswith("reference"), f"panel 1 {s['panels'][0]!r}")
        check(s["panels"][1] == "WKB random_walk/exact\n0.45 s, beauty relMSE 0.05", f"panel 2 {s['panels'][1]!r}")
        check(s["panels"][2] == "path tracer at WKB's time\n0.45 s, beauty relMSE 0.12", f"panel 3 {s['panels'][2]!r}")
        check(s["panels"][3].startswith("WKB \u2212 reference, luminance"), f"panel 4 {s['panels'][3]!r}")
        check("W/(m\u00b2 sr)" in s["colorbar"] and "\u0394Y" in s["colorbar"], f"colour bar {s['colorbar']!r}")
        check(abs(s["difference_peak"] - 0.5) < 1e-6 and s["colorbar_range"] == [-0.5, 0.5],
              f"colour bar range {s['colorbar_range']} (peak {s['difference_peak']})")
    # Without --reference-noise the floor is left out, and a rerun replaces the files.
    p = run(d, "--describe")
    check(p.returncode == 0 and not any("noise" in t for t in json.loads(p.stdout or "{}")
                                        .get("error_vs_time", {}).get("legend", ["noise"])), "noise floor without a value")
    check(not any(n.startswith(".") for n in os.listdir(d)), f"temporary files left: {os.listdir(d)}")

with tempfile.TemporaryDirectory() as d:
    p = run(d)
    lines = p.stderr.strip().splitlines()
    check(p.returncode == 1 and len(lines) == 1 and "compare.csv" in lines[0], f"missing CSV: {p.returncode} {p.stderr!r}")
    write_dir(d, panels=False)
    p = run(d)
    lines = p.stderr.strip().splitlines()
    check(p.returncode == 1 and len(lines) == 1 and "reference.png" in lines[0], f"missing panels: {p.stderr!r}")

# With vrl's rows and panel: its ladder and equal-time point in the chart, a fifth sheet panel.
with tempfile.TemporaryDirectory() as d:
    write_dir(d, vrl=True)
    p = run(d, "--wkb", "random_walk/exact", "--describe")
    check(p.returncode == 0, f"the script failed with vrl rows: {p.stderr.strip()}")
    if p.returncode == 0:
        desc = json.loads(p.stdout)
        c, s = desc["error_vs_time"], desc["sheet"]
        check("virtual ray lights, mean of 2 seeds" in c["legend"] and "virtual ray lights at WKB's time" in c["legend"],
              f"legend with vrl {c['legend']}")
        check(len(s["panels"]) == 5, f"{len(s['panels'])} panels with vrl")
        check(s["panels"][3] == "virtual ray lights at WKB's time\n0.46 s, beauty relMSE 0.05", f"vrl panel {s['panels'][3]!r}")
        check(s["panels"][4].startswith("WKB \u2212 reference, luminance"), f"panel 5 {s['panels'][4]!r}")

print("test_compare_charts: " + ("%d failures" % len(failures) if failures else "all checks passed"))
sys.exit(1 if failures else 0)
