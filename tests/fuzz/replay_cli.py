#!/usr/bin/env python3
"""Runs fuzz inputs through the nimbus binary itself: the regression test of every fuzz finding
(issue 18, item 5; tests/fuzz/CMakeLists.txt).

    replay_cli.py NIMBUS HARNESS DIR...

Each file in the DIRs (the saved findings, tests/fuzz/regressions/HARNESS, and the seeds,
tests/fuzz/corpus/HARNESS) is given to nimbus the way the harness gives it to the loader, and
nimbus must exit 0, or 2 with one line on stderr ("nimbus: error: ...", naming the file but for
scene inputs), within 60 s:

    scene   the document as a scene file (empty: --default) and the NUL-separated rest as --set
            assignments; `nimbus info` (parse, validate, plan: the volumes load too)
    vdb     the default scene with its volume's source replaced by the file; a render
    nvdb    the same with the file written as .nvdb (NanoVDB's reader); both under a
            render.memory_limit of 512 MiB
    mesh    the default scene with the file as a mesh (.ply if it starts with "ply", else .obj)
    depth   the default scene at 16x16 with the file (.exr) as camera.holdout_depth
    envmap  the default scene lit by the file (.hdr if it starts with "#?", else .exr) as an
            environment map

The renders are 16x16 at 1 spp with `single`, to a temporary folder.
"""
import json
import os
import subprocess
import sys
import tempfile

TIMEOUT = 60


def command(nimbus, harness, data, work):
    render = [nimbus, "render", "--default", "-q", "-o", os.path.join(work, "out.exr"), "--preview", "",
              "--method", "single", "--set", "camera.resolution=[16,16]", "--set", "render.spp=1"]

    def put(suffix):
        path = os.path.join(work, "input" + suffix)
        with open(path, "wb") as f:
            f.write(data)
        return path

    if harness == "scene":
        document, _, rest = data.partition(b"\0")
        sets = [s.decode("utf-8", "surrogateescape") for s in rest.split(b"\0")] if _ else []
        args = [nimbus, "info"]
        if document:
            args.append(put(".json"))
        else:
            args.append("--default")
        for s in sets:
            args += ["--set", s]
        return args
    if harness in ("vdb", "nvdb"):
        # Under a render.memory_limit of 512 MiB (the harness loads under 64 MiB, fuzz_vdb.cpp; a
        # render here needs ~200 MiB resident), so that a file asking for gigabytes is refused
        # here as there, not loaded for a minute.
        source = {"type": "vdb", "file": put("." + harness)}
        return render + ["--set", "volumes[0].source=" + json.dumps(source), "--set", "render.memory_limit=536870912"]
    if harness == "mesh":
        path = put(".ply" if data.startswith(b"ply") else ".obj")
        return render + ["--set", "geometry=" + json.dumps([{"type": "mesh", "file": path}])]
    if harness == "depth":
        return render + ["--set", "camera.holdout_depth=" + json.dumps({"file": put(".exr")})]
    if harness == "envmap":
        path = put(".hdr" if data.startswith(b"#?") else ".exr")
        return render + ["--set", "lights=" + json.dumps([{"type": "environment", "map": path}])]
    sys.exit("replay_cli.py: unknown harness " + harness)


def main():
    nimbus, harness, dirs = sys.argv[1], sys.argv[2], sys.argv[3:]
    files = sorted(os.path.join(d, f) for d in dirs if os.path.isdir(d) for f in os.listdir(d))
    files = [f for f in files if os.path.isfile(f) and not os.path.basename(f).startswith(".")]
    if not files:
        sys.exit("replay_cli.py: no inputs in " + " ".join(dirs))
    failures = []
    for path in files:
        with open(path, "rb") as f:
            data = f.read()
        with tempfile.TemporaryDirectory(prefix="nimbus-replay-") as work:
            args = command(nimbus, harness, data, work)
            try:
                r = subprocess.run(args, cwd=work, capture_output=True, timeout=TIMEOUT)
            except subprocess.TimeoutExpired:
                failures.append("%s: no answer within %d s" % (path, TIMEOUT))
                continue
        err = r.stderr.decode("utf-8", "replace")
        lines = [l for l in err.splitlines() if l.startswith("nimbus: error: ")]
        ok = r.returncode == 0 or (r.returncode == 2 and len(lines) == 1)
        # A refused file is named in its error line (every harness but scene's gives a file),
        # unless the render it makes is refused by its memory estimate (a valid file of a volume
        # 10^7 m wide asks for terabytes of shadow marches: render.memory_limit is the key then).
        named = "input." in lines[0] if lines else False
        over_limit = lines[0].startswith("nimbus: error: render.memory_limit: ") if lines else False
        if ok and r.returncode == 2 and harness != "scene" and not (named or over_limit):
            ok = False
        print("%s: exit %d%s" % (os.path.relpath(path), r.returncode, (": " + lines[0]) if lines else ""))
        if not ok:
            failures.append("%s: exit %d, stderr:\n%s" % (path, r.returncode, err[-2000:]))
    if failures:
        print("\nFAILED (%d of %d):\n%s" % (len(failures), len(files), "\n".join(failures)))
        sys.exit(1)
    print("all %d inputs: exit 0 or 2 with one line" % len(files))


if __name__ == "__main__":
    main()
