#!/usr/bin/python3
"""bench_wkb_orders3.py: WKB's time over single's, with the lights' orders 3+ traced (render.wkb_orders3
"traced") and by the kernel, on the validation suite at its own 64x64 and on the default scene.

    tests/bench/bench_wkb_orders3.py [--nimbus build/bin/nimbus] [--before OTHER_NIMBUS]
                                     [--suite validation] [--repeat 1] [--default-size 320x180]

Per scene: single, wkb (kernel) and wkb traced with --nimbus and, with --before, wkb traced with
that other build, rendered one after another (interleaved, so a loaded machine weighs on all of
them alike); the renderer's own seconds (nimbus:render_time: volumes, plan, shadow maps, the
orders-3+ cache and the march), the least of --repeat runs. Prints a Markdown table of the ratios to
single's time (issue 13: WKB's at most 2x single's). Images go to a temporary folder.
"""

import argparse
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "validation"))
import suite_tools as st  # noqa: E402


def render_seconds(nimbus, scene, out, method, sets):
    cmd = [nimbus, "render"] + (["--default"] if scene == "default" else [scene])
    cmd += ["-q", "--method", method, "-o", out, "--set", "output.preview=", "--set", 'output.aovs=["beauty"]']
    for s in sets:
        cmd += ["--set", s]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        raise RuntimeError("%s failed (%d): %s" % (" ".join(cmd), r.returncode, r.stdout.strip()))
    _, meta = st.read_layers(out)
    return float(meta["nimbus:render_time"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nimbus", default=st.default_nimbus())
    ap.add_argument("--before", help="another nimbus build: its wkb traced time beside --nimbus's")
    ap.add_argument("--suite", choices=st.SUITES, default="validation")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--default-size", default="320x180", help="the default scene's resolution, WxH")
    args = ap.parse_args()
    w, h = (int(v) for v in args.default_size.split("x"))

    traced = ['render.wkb_orders3="traced"']
    runs = [("single", args.nimbus, "single", []), ("kernel", args.nimbus, "wkb", ['render.wkb_orders3="kernel"']),
            ("traced", args.nimbus, "wkb", traced)]
    if args.before:
        runs.append(("traced before", args.before, "wkb", traced))
    scenes = [(n, st.scene_path(args.suite, n), []) for n in st.scene_names(args.suite)]
    scenes.append(("default (%dx%d)" % (w, h), "default", ["camera.resolution=[%d,%d]" % (w, h)]))

    print("| scene | single s | wkb kernel / single | wkb traced / single |%s" %
          (" traced before / single |" if args.before else ""))
    print("|---|---|---|---|%s" % ("---|" if args.before else ""))
    ratios = {label: [] for label, _, _, _ in runs}
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "bench.exr")
        for name, path, sets in scenes:
            best = {label: float("inf") for label, _, _, _ in runs}
            for _ in range(args.repeat):
                for label, nimbus, method, extra in runs:
                    best[label] = min(best[label], render_seconds(nimbus, path, out, method, sets + extra))
            row = "| %s | %.3f |" % (name, best["single"])
            for label, _, _, _ in runs[1:]:
                r = best[label] / max(best["single"], 1e-9)
                ratios[label].append(r)
                row += " %.2f |" % r
            print(row, flush=True)
    row = "| median | |"
    for label, _, _, _ in runs[1:]:
        v = sorted(ratios[label])
        row += " %.2f |" % v[len(v) // 2]
    print(row)


if __name__ == "__main__":
    main()
