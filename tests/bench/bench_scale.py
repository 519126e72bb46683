"""Scale: time and peak memory against voxels and pixels (issue 18, item 7).

The default scene (sun and sky) with its procedural cumulus (4.5 m across) at voxel sizes giving
128 to 1024 voxels across its largest extent, rendered at 1920x1080 by `single`, `wkb` and
`pathtrace`; then, at 256 voxels across, the same three at 480x270, 960x540 and 1920x1080. Each
scale's cloud is generated once and written to a .vdb file (tests/bench/bench_cloud_vdb), which
the renders read as a production scene would. Per render: the voxels in allocated bricks
(`--explain`: bricks x 512), the time to load the volume (`--explain`'s "volumes" stage: the VDB
read and the bricks), the render's own wall time less that (EXR header nimbus:render_time, which
excludes process start), the process's CPU time (user + system, from wait4), the peak resident
memory the render measured (nimbus:memory_peak_bytes) and the whole process's wall time. Then the
growth exponent of each against voxels and against pixels: the least-squares slope of log(time)
and log(memory) on log(voxels) or log(pixels). Warm-up renders per method and resolution
first (not recorded) compile and cache the path tracer's kernel, so no row pays for it.

The sun is the default scene's (a 0.53 degree disc, `--sun-angle`): from 256 voxels across its
penumbra is wider than a voxel, which until 2026-12-03 sent `single` and `wkb` from the deep
shadow map to shadow rays at every march step (a cost growing with the square of the voxels
across); the map now filters the penumbra (docs/single-scattering.md). `--sun-angle 0` measures a
hard sun.

    /usr/bin/python3 tests/bench/bench_scale.py build/bin/nimbus [--voxels 128,256,512,1024]
        [--pixel-voxels 256] [--spp 1] [--methods single,wkb,pathtrace] [--sun-angle 0.53]
        [--ladders voxels,pixels] [--workdir DIR] [--quick]

--quick: 64 and 128 voxels across at 480x270 (a check that the script runs). Each render uses
spp 1 (`--spp`): the per-sample cost is what grows; the time of a render at spp n is about n
times this one's sample part. Prints a Markdown section for docs/benchmarks.md.
"""
import argparse
import contextlib
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

import OpenImageIO as oiio

EXTENT = 4.5  # metres, the default cloud's largest extent (nimbus info: bounds)


DEFAULT_SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scene", "data", "default.json")


def cloud_scene(tool, across, workdir, sun_angle):
    """The default scene with its cloud at `across` voxels written once to a .vdb file (the
    generator runs once per scale; each render then reads the file as a production scene would).
    Returns the scene path and the seconds the generator and the write took."""
    vdb = os.path.join(workdir, f"cloud{across}.vdb")
    scene = os.path.join(workdir, f"scale{across}.json")
    start = time.monotonic()
    if os.path.exists(vdb):  # kept from an earlier run (--workdir)
        seconds = None
    else:
        subprocess.run([tool, f"{EXTENT / across:.9g}", vdb], check=True)
        seconds = time.monotonic() - start
    with open(DEFAULT_SCENE) as f:
        doc = json.load(f)
    doc["volumes"][0]["source"] = {"type": "vdb", "file": vdb}
    doc["lights"][0]["angle"] = sun_angle
    doc.pop("output", None)
    with open(scene, "w") as f:
        json.dump(doc, f)
    return scene, seconds


def run_render(nimbus, scene, sets, workdir):
    out = os.path.join(workdir, "scale.exr")
    args = [nimbus, "render", scene, "-q", "--explain", "-o", out, "--preview", os.path.join(workdir, "scale.png")]
    for s in sets:
        args += ["--set", s]
    start = time.monotonic()
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    text = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.monotonic() - start
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"bench_scale: {' '.join(args)} exited {os.waitstatus_to_exitcode(status)}:\n{text[-2000:]}")
    bricks = re.search(r"(\d+) bricks", text)
    volumes = re.search(r"stages: volumes ([\d.]+) s", text)
    if not bricks or not volumes:
        raise SystemExit("bench_scale: --explain printed no brick count or volume stage:\n" + text[-2000:])
    spec = oiio.ImageInput.open(out).spec()
    total = float(spec.getattribute("nimbus:render_time"))
    return {
        "voxels": int(bricks.group(1)) * 512,
        "volume_s": float(volumes.group(1)),
        "render_s": total - float(volumes.group(1)),
        "peak_mib": float(spec.getattribute("nimbus:memory_peak_bytes")) / 2**20,
        # The render's own estimate, made before its large allocations (issue 18, item 4).
        "estimate_mib": float(spec.getattribute("nimbus:memory_estimate_bytes")) / 2**20,
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "process_s": wall,
    }


def slope(xs, ys):
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    den = sum((a - mx) ** 2 for a in lx)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / den if den > 0 else float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("nimbus")
    ap.add_argument("--voxels", default="128,256,512,1024")
    ap.add_argument("--pixel-voxels", type=int, default=256)
    ap.add_argument("--resolutions", default="480x270,960x540,1920x1080")
    ap.add_argument("--spp", type=int, default=1)
    ap.add_argument("--methods", default="single,wkb,pathtrace")
    ap.add_argument("--sun-angle", type=float, default=0.53, help="the sun's apparent diameter, degrees")
    ap.add_argument("--ladders", default="voxels,pixels", help="which ladders to run")
    ap.add_argument("--workdir", help="keep the clouds' .vdb files here and reuse them (default: a temporary folder)")
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    nimbus = os.path.abspath(a.nimbus)
    voxels = [int(v) for v in a.voxels.split(",")]
    full_res = (1920, 1080)
    resolutions = [tuple(int(x) for x in r.split("x")) for r in a.resolutions.split(",")]
    pixel_voxels = a.pixel_voxels
    if a.quick:
        voxels, full_res, resolutions, pixel_voxels = [64, 128], (480, 270), [(240, 135), (480, 270)], 64
    methods = a.methods.split(",")

    tool = os.path.join(os.path.dirname(nimbus), "..", "tests", "bench", "bench_cloud_vdb")

    def sets_for(method, res):
        return [f"render.method={method}", f"render.spp={a.spp}", f"camera.resolution=[{res[0]},{res[1]}]"]

    rows = []  # (ladder, method, across, res, voxels, result)
    if a.workdir:
        os.makedirs(a.workdir, exist_ok=True)
    with (contextlib.nullcontext(a.workdir) if a.workdir else tempfile.TemporaryDirectory()) as d:
        scenes, generated = {}, {}
        # Warm-up renders (not recorded) compile and cache the path tracer's kernel first.
        for across in sorted(set(voxels + [pixel_voxels])):
            scenes[across], generated[across] = cloud_scene(tool, across, d, a.sun_angle)
            made = "reused" if generated[across] is None else f"generated and written in {generated[across]:.1f} s"
            print(f"cloud at {across} voxels across: {made}, "
                  f"{os.path.getsize(os.path.join(d, f'cloud{across}.vdb')) / 2**20:.0f} MiB", file=sys.stderr, flush=True)
        # At every resolution used: the path tracer's kernel cache keys on the launch size too.
        for method in methods:
            for res in sorted(set(resolutions + [full_res])):
                run_render(nimbus, scenes[min(scenes)], sets_for(method, res), d)
        ladders = [(name, cases) for name, cases in (("voxels", [(n, full_res) for n in voxels]),
                                                      ("pixels", [(pixel_voxels, r) for r in resolutions]))
                   if name in a.ladders.split(",")]
        for ladder, cases in ladders:
            for method in methods:
                for across, res in cases:
                    r = run_render(nimbus, scenes[across], sets_for(method, res), d)
                    nvox = r["voxels"]
                    rows.append((ladder, method, across, res, nvox, r))
                    print(f"{ladder} {method} {across} {res[0]}x{res[1]} voxels {nvox} volume {r['volume_s']:.2f} s render {r['render_s']:.2f} s "
                          f"cpu {r['cpu_s']:.2f} s process {r['process_s']:.2f} s peak {r['peak_mib']:.0f} MiB",
                          file=sys.stderr, flush=True)

    load = os.getloadavg()
    print(f"Default scene (sun of angle {a.sun_angle:g} deg and sky), its cloud as a .vdb file per scale, spp {a.spp}, {os.cpu_count()} cores, "
          f"load average at the end {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}. Generating and writing each "
          "cloud: " + ", ".join(f"{n} across " + ("reused from --workdir" if t is None else f"{t:.0f} s")
                                     for n, t in sorted(generated.items())) + ".\n")
    print("| ladder | method | voxels across | pixels | voxels in bricks | volume load s | render s | process CPU s "
          "| process wall s | peak MiB | estimate MiB | estimate / peak |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for ladder, method, across, res, nvox, r in rows:
        print(f"| {ladder} | {method} | {across} | {res[0]}x{res[1]} | {nvox:.3g} | {r['volume_s']:.2f} | {r['render_s']:.2f} | "
              f"{r['cpu_s']:.1f} | {r['process_s']:.1f} | {r['peak_mib']:.0f} | {r['estimate_mib']:.0f} | "
              f"{r['estimate_mib'] / r['peak_mib']:.2f} |")
    print("\nGrowth exponents (least-squares slope in log-log; render time = the render's own time less the volume "
          "load; CPU = the process's user + system time, which a loaded machine inflates less than wall time):\n")
    print("| method | render time vs voxels | CPU vs voxels | peak memory vs voxels | render time vs pixels "
          "| CPU vs pixels | peak memory vs pixels |")
    print("|---|---|---|---|---|---|---|")
    for method in methods:
        v = [(nv, r) for lad, m, _, _, nv, r in rows if lad == "voxels" and m == method]
        p = [(res[0] * res[1], r) for lad, m, _, res, _, r in rows if lad == "pixels" and m == method]
        cells = []
        for pts in (v, p):
            xs = [x for x, _ in pts]
            for key in ("render_s", "cpu_s", "peak_mib"):
                cells.append(f"{slope(xs, [r[key] for _, r in pts]):.2f}" if len(pts) >= 2 else "-")
        print(f"| {method} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
