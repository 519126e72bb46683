#!/usr/bin/python3
"""What a sequence keeps between frames (issue 16, item 1; docs/sequences.md): N frames rendered
by `nimbus render --frames 1-N` in one process against N separate `nimbus render --frame F`
processes, wall time side by side, rounds interleaved. Two shots:

  static:   the default scene's procedural cloud (no path, no token), the token only in the output
            path: the volume is built once and kept for every later frame.
  sequence: a VDB file per frame (generated here, a 64^3 ball growing with the frame): every
            frame reads its own file, so only what is per process (start-up, OCIO, the volume
            shader, thread pools) is saved.

Prints the section body for docs/benchmarks.md (scripts/bench.sh writes it there):
    bench_sequence.py NIMBUS_BINARY [FRAMES] [ROUNDS]
"""
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import pyopenvdb as vdb


def wall(cmd):
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    return time.perf_counter() - t


def write_ball(path, frame):
    n = 64
    i = np.indices((n, n, n), dtype=np.float32) - (n - 1) / 2.0
    r = np.sqrt((i ** 2).sum(axis=0))
    radius = 16.0 + frame  # voxels
    density = np.clip(1.0 - r / radius, 0.0, None).astype(np.float32)
    grid = vdb.FloatGrid()
    grid.copyFromArray(density, ijk=(-n // 2, -n // 2, -n // 2))
    grid.name = "density"
    grid.transform = vdb.createLinearTransform(voxelSize=2.0 / n)
    vdb.write(path, grids=[grid])


def main():
    nimbus = os.path.abspath(sys.argv[1])
    frames = int(sys.argv[2]) if len(sys.argv) > 2 else 12
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    work = tempfile.mkdtemp(prefix="nimbus-bench-seq-")
    scene = json.loads(subprocess.run([nimbus, "default-scene"], check=True, capture_output=True, text=True).stdout)
    scene["camera"]["resolution"] = [320, 180]
    scene["output"] = {"file": os.path.join(work, "out", "static.$F4.exr")}
    with open(os.path.join(work, "static.json"), "w") as f:
        json.dump(scene, f)
    os.makedirs(os.path.join(work, "cache"))
    for frame in range(1, frames + 1):
        write_ball(os.path.join(work, "cache", f"ball.{frame:04d}.vdb"), frame)
    seq = json.loads(json.dumps(scene))
    seq["volumes"][0]["source"] = {"type": "vdb", "file": "cache/ball.####.vdb"}
    seq["output"] = {"file": os.path.join(work, "out", "seq.$F4.exr")}
    with open(os.path.join(work, "sequence.json"), "w") as f:
        json.dump(seq, f)

    rows = []
    for shot in ("static", "sequence"):
        path = os.path.join(work, shot + ".json")
        one, many = [], []
        for _ in range(rounds):  # interleaved, so load on the machine hits both alike
            one.append(wall([nimbus, "render", path, "-q", "--frames", f"1-{frames}"]))
            many.append(sum(wall([nimbus, "render", path, "-q", "--frame", str(f)]) for f in range(1, frames + 1)))
        rows.append((shot, statistics.median(one), statistics.median(many)))

    print(f"`tests/bench/bench_sequence.py` ({time.strftime('%Y-%m-%d')}, {os.cpu_count()} cores, "
          f"{platform.machine()}): {frames} frames of the default scene at 320x180 (single, 4 spp), medians of "
          f"{rounds} interleaved rounds, wall time of the whole command(s).\n")
    print(f"| shot | `--frames 1-{frames}`, one process | {frames} processes (`--frame F`) | speed-up |")
    print("|---|---|---|---|")
    labels = {"static": "static: procedural cloud, token in the output only (volume kept)",
              "sequence": "sequence: a 64^3 VDB per frame (`cache/ball.####.vdb`)"}
    for shot, one, many in rows:
        print(f"| {labels[shot]} | {one:.2f} s ({one / frames:.2f} s/frame) | {many:.2f} s "
              f"({many / frames:.2f} s/frame) | {many / one:.2f}x |")
    subprocess.run(["rm", "-rf", work])


if __name__ == "__main__":
    main()
