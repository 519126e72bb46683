"""Scale: time and peak memory against voxels and pixels (issue 18, item 7).

The default scene's procedural cumulus (4.5 m across) at voxel sizes giving 128 to 1024 voxels
across its largest extent, rendered at 1920x1080 by `single`, `wkb` and `pathtrace`; then, at 256
voxels across, the same three at 480x270, 960x540 and 1920x1080. Per render: the voxels in
allocated bricks (`--explain`: bricks x 512), the time to build the volume (the procedural
generator; `--explain`'s "volumes" stage), the render's own wall time less that (EXR header
nimbus:render_time, which excludes process start), the process's CPU time (user + system, from
wait4), the peak resident memory the render measured (nimbus:memory_peak_bytes) and the whole
process's wall time (loading and building the volume included). Then the growth exponent of each
against voxels and against pixels: the least-squares slope of log(time) and log(memory) on
log(voxels) or log(pixels). One warm-up render per method first (not recorded) compiles and
caches the path tracer's kernel, so no row pays for it.

    /usr/bin/python3 tests/bench/bench_scale.py build/bin/nimbus [--voxels 128,256,512,1024]
        [--pixel-voxels 256] [--spp 1] [--methods single,wkb,pathtrace] [--quick]

--quick: 64 and 128 voxels across at 480x270 (a check that the script runs). Each render uses
spp 1 (`--spp`): the per-sample cost is what grows; the time of a render at spp n is about n
times this one's sample part. Prints a Markdown section for docs/benchmarks.md.
"""
import argparse
import math
import os
import re
import subprocess
import sys
import tempfile
import time

import OpenImageIO as oiio

EXTENT = 4.5  # metres, the default cloud's largest extent (nimbus info: bounds)


def run_render(nimbus, sets, workdir):
    out = os.path.join(workdir, "scale.exr")
    args = [nimbus, "render", "--default", "-q", "--explain", "-o", out, "--preview", os.path.join(workdir, "scale.png")]
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

    def sets_for(method, across, res):
        return [f"render.method={method}", f"render.spp={a.spp}", f"camera.resolution=[{res[0]},{res[1]}]",
                f"volumes[0].source.voxel_size={EXTENT / across:.9g}"]

    rows = []  # (ladder, method, across, res, voxels, result)
    with tempfile.TemporaryDirectory() as d:
        # Warm-up, not recorded: compiles and caches the path tracer's kernel for this scene.
        for method in methods:
            run_render(nimbus, sets_for(method, voxels[0], (64, 36)), d)
        for ladder, cases in (("voxels", [(n, full_res) for n in voxels]),
                              ("pixels", [(pixel_voxels, r) for r in resolutions])):
            for method in methods:
                for across, res in cases:
                    sets = sets_for(method, across, res)
                    r = run_render(nimbus, sets, d)
                    nvox = r["voxels"]
                    rows.append((ladder, method, across, res, nvox, r))
                    print(f"{ladder} {method} {across} {res[0]}x{res[1]} voxels {nvox} volume {r['volume_s']:.2f} s render {r['render_s']:.2f} s "
                          f"cpu {r['cpu_s']:.2f} s process {r['process_s']:.2f} s peak {r['peak_mib']:.0f} MiB",
                          file=sys.stderr, flush=True)

    load = os.getloadavg()
    print(f"Default cloud, spp {a.spp}, {os.cpu_count()} cores, load average at the end "
          f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}.\n")
    print("| ladder | method | voxels across | pixels | voxels in bricks | volume build s | render s | process CPU s "
          "| process wall s | peak MiB |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for ladder, method, across, res, nvox, r in rows:
        print(f"| {ladder} | {method} | {across} | {res[0]}x{res[1]} | {nvox:.3g} | {r['volume_s']:.2f} | {r['render_s']:.2f} | "
              f"{r['cpu_s']:.1f} | {r['process_s']:.1f} | {r['peak_mib']:.0f} |")
    print("\nGrowth exponents (least-squares slope in log-log; time = the render's own time less the volume build):\n")
    print("| method | render time vs voxels | peak memory vs voxels | render time vs pixels | peak memory vs pixels |")
    print("|---|---|---|---|---|")
    for method in methods:
        v = [(nv, r) for lad, m, _, _, nv, r in rows if lad == "voxels" and m == method]
        p = [(res[0] * res[1], r) for lad, m, _, res, _, r in rows if lad == "pixels" and m == method]
        cells = []
        for pts in (v, p):
            xs = [x for x, _ in pts]
            cells.append(f"{slope(xs, [r['render_s'] for _, r in pts]):.2f}")
            cells.append(f"{slope(xs, [r['peak_mib'] for _, r in pts]):.2f}")
        print(f"| {method} | {cells[0]} | {cells[1]} | {cells[2]} | {cells[3]} |")


if __name__ == "__main__":
    main()
