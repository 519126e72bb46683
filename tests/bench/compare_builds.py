#!/usr/bin/env python3
"""compare_builds.py: two or more nimbus binaries timed side by side on the same scenes, rounds
interleaved (A B C, A B C, ...) so that machine load falls on all alike; medians of each stage
that `--explain` reports, and each build's ratio to the first.

Usage: compare_builds.py [--rounds N] [--set key=value ...] NAME=BINARY NAME=BINARY [...]
Scenes: the default scene with single and wkb (640x360, 4 spp), and pathtrace at 160x90 with
16 spp and max_depth 64 (so builds with other defaults trace the same paths).
"""
import argparse
import re
import statistics
import subprocess
import sys
import tempfile

import OpenImageIO as oiio

CASES = [
    ("single", ["--method", "single"]),
    ("wkb", ["--method", "wkb"]),
    ("pathtrace", ["--method", "pathtrace", "--set", "camera.resolution=[160,90]", "--set", "render.spp=16",
                   "--set", "render.max_depth=64"]),
]


def stages(binary, args, extra, out):
    cmd = [binary, "render", "--default", "-o", out, "--explain", "-q"] + args + extra
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"compare_builds: {' '.join(cmd)} failed: {p.stderr.strip()}")
    line = [l for l in p.stdout.splitlines() if l.strip().startswith("stages:")][-1]
    out_stages = {k.strip(): float(v) for k, v in re.findall(r"([a-z0-9 +]+?) ([0-9.]+) s;", line.split(":", 1)[1])}
    # The whole render() as the EXR records it (stages plus what no stage names).
    spec = oiio.ImageInput.open(out).spec()
    out_stages["render_time (all)"] = float(spec.get_string_attribute("nimbus:render_time", "0"))
    return out_stages


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("builds", nargs="+")
    a = ap.parse_args()
    builds = [b.split("=", 1) for b in a.builds]
    extra = sum((["--set", s] for s in a.set), [])
    with tempfile.TemporaryDirectory() as tmp:
        for case, args in CASES:
            times = {name: {} for name, _ in builds}
            for _ in range(a.rounds):
                for name, binary in builds:
                    for k, v in stages(binary, args, extra, f"{tmp}/{name}.exr").items():
                        times[name].setdefault(k, []).append(v)
            keys = [k for k in times[builds[0][0]] if all(k in times[n] for n, _ in builds)]
            print(f"\n{case} ({a.rounds} rounds, medians, seconds; ratio to {builds[0][0]})")
            print("| stage | " + " | ".join(n for n, _ in builds) + " |")
            print("|---|" + "---|" * len(builds))
            for k in keys:
                base = statistics.median(times[builds[0][0]][k])
                cells = []
                for n, _ in builds:
                    m = statistics.median(times[n][k])
                    cells.append(f"{m:.3f}" + ("" if n == builds[0][0] else f" ({m / base:.2f}x)" if base > 0 else ""))
                print(f"| {k} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
