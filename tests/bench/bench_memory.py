"""Memory estimate against the measured peak (issue 18, item 4).

For each scene and method: the estimate `nimbus info` prints, the estimate the render made before
its large allocations (EXR header nimbus:memory_estimate_bytes) and the peak resident memory the
render measured (nimbus:memory_peak_bytes, getrusage), then estimate / peak. Prints a Markdown
table for docs/benchmarks.md "Memory".

    /usr/bin/python3 tests/bench/bench_memory.py build/bin/nimbus [--quick]

--quick: the default scene's three methods only. --from N: the cases from the N-th (0-based) on.
"""
import os
import re
import subprocess
import sys
import tempfile

import OpenImageIO as oiio

CASES = [
    ("default scene 640x360", "single", []),
    ("default scene 640x360", "wkb", []),
    ("default scene 640x360", "pathtrace", ["render.spp=16"]),
    ("default scene 1920x1080", "single", ["camera.resolution=[1920,1080]"]),
    ("default scene 1920x1080", "pathtrace", ["camera.resolution=[1920,1080]", "render.spp=2"]),
    ("default scene 320x180, shadow maps up to 2048^2", "single",
     ["camera.resolution=[320,180]", "render.shadow_map_resolution=2048"]),
    ("cloud at voxel 0.02 m (3.8x the bricks) 320x180", "single",
     ["camera.resolution=[320,180]", "volumes[0].source.voxel_size=0.02"]),
    ("cloud at voxel 0.02 m (3.8x the bricks) 320x180", "wkb",
     ["camera.resolution=[320,180]", "volumes[0].source.voxel_size=0.02"]),
]


def mib(b):
    return f"{b / 2**20:.0f}"


def main():
    nimbus = os.path.abspath(sys.argv[1])
    cases = CASES[:3] if "--quick" in sys.argv else CASES
    if "--from" in sys.argv:
        cases = cases[int(sys.argv[sys.argv.index("--from") + 1]):]
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for name, method, sets in cases:
            args = ["--set", f"render.method={method}"]
            for s in sets:
                args += ["--set", s]
            info = subprocess.run([nimbus, "info", "--default", *args], capture_output=True, text=True, check=True)
            m = re.search(r"estimated peak ([\d.]+) MiB", info.stdout)
            info_mib = float(m.group(1)) if m else float("nan")
            out = os.path.join(d, "out.exr")
            subprocess.run([nimbus, "render", "--default", "-q", "-o", out, "--preview", os.path.join(d, "p.png"),
                            *args], check=True)
            spec = oiio.ImageInput.open(out).spec()
            peak = spec.getattribute("nimbus:memory_peak_bytes")
            estimate = spec.getattribute("nimbus:memory_estimate_bytes")
            rows.append((name, method, f"{info_mib:.0f}", mib(estimate), mib(peak), f"{estimate / peak:.2f}"))
            print(" | ".join(rows[-1]), file=sys.stderr)
    print("| scene | method | `nimbus info` estimate, MiB | render's estimate, MiB | measured peak, MiB | estimate / peak |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(r) + " |")


if __name__ == "__main__":
    main()
