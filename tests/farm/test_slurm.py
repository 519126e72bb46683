#!/usr/bin/python3
"""End to end on a real Slurm (issue 16, item 7; docs/farm.md, "Tested on a real Slurm").

Installs Debian's slurm-wlm and munge when missing, starts a single-host cluster on loopback
(scripts/slurm-local.sh: munged, slurmctld, slurmd), and submits with `nimbus farm submit
--engine slurm` a 6-frame shot of a procedural cloud that turns and drifts while the camera moves
(animation keys), in 2 tiles per frame (wkb): a 12-task render array and a 6-task merge array
(afterok). While it runs, the nimbus process of one render task is killed with SIGKILL once its
log shows it mid-render (a progress line under 100%). Then:

- every array task ends COMPLETED (the merges ran, so every render succeeded);
- the killed task's log shows the kill and the retry ("attempt 1 of 3 killed by signal 9:
  retrying", "done on attempt 2");
- every merged frame is bit for bit the frame `nimbus render --frames 1-6` writes in one process,
  and the frames differ (the shot is animated).

Then a preemption: a path-tracer frame in 2 sample splits with a checkpoint every second
(`--sample-splits 2 --checkpoint 1`); once one render task's log shows a checkpoint written and
its render still running, `scontrol requeue` puts that array task back in the queue as Slurm's
preemption (PreemptMode=REQUEUE) does: its processes are signalled and it runs again. Then:

- every task of that job ends COMPLETED;
- the requeued task's log shows its second run (`Slurm restart 1`) resuming from its checkpoint
  at more than 0 samples per pixel (`resuming from ... at N samples per pixel`), not rendering
  from the start, and finishing;
- its part is bit for bit the same task run uninterrupted by hand (the same command, another
  output), the other part too, and the merged frame is bit for bit the merge of those two.

Skipped (exit 77, one line saying why) only when not root or when apt cannot install Slurm. The
daemons this test starts are stopped at its end, also when it fails, and by a watchdog process if
the test itself is killed; a cluster that was already running is used and left running. Tests on
one machine take a lock, so two suites never share the cluster at once.

Run by ctest:  test_slurm.py NIMBUS_BINARY
"""
import fcntl
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import OpenImageIO as oiio

SKIP = 77
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SLURM_LOCAL = os.path.join(ROOT, "scripts", "slurm-local.sh")
LOCK = "/run/lock/nimbus-slurm-test.lock"
JOB_TIMEOUT = 420  # seconds for the whole job; ctest's limit is 900
FRAMES, TILES = 6, 2
PT_SPLITS = 2  # sample splits of the requeued path-tracer frame
TERMINAL = {"COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL", "OUT_OF_MEMORY", "BOOT_FAIL", "DEADLINE",
            "PREEMPTED"}


def say(text):
    print("test_slurm: " + text, flush=True)


def sh(*args, check=True, timeout=120):
    p = subprocess.run(list(args), capture_output=True, text=True, timeout=timeout)
    if check and p.returncode != 0:
        raise RuntimeError("%s failed (%d): %s%s" % (" ".join(args), p.returncode, p.stdout, p.stderr))
    return p


def pixels(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    data = np.asarray(inp.read_image(oiio.FLOAT))
    inp.close()
    return data


def shot():
    """A procedural cloud that turns and drifts over frames 1-6 while the camera moves."""
    return {
        "camera": {"from": [{"frame": 1, "value": [0, 1, 9]}, {"frame": 6, "value": [2, 1.5, 8.5]}],
                   "to": [0, 0, 0], "up": [0, 1, 0], "fov": 35, "resolution": [160, 120]},
        "lights": [{"name": "sun", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [3, 3, 3]}],
        "volumes": [{"name": "cloud",
                     "source": {"type": "procedural", "generator": "cloud", "radius": 2, "voxel_size": 0.05,
                                "octaves": 4, "seed": 7},
                     "transform": [{"frame": 1, "value": {"translate": [0, 0, 0]}},
                                   {"frame": 6, "value": {"rotate": [50, 0, 1, 0], "translate": [0.6, 0, 0]}}],
                     "medium": {"sigma_s": [3, 3, 3], "sigma_a": 0.05}}],
        "render": {"method": "wkb", "threads": 1},
        "output": {"file": "out/cloud.$F4.exr"},
    }


def pt_shot():
    """One path-traced frame of the cloud, long enough (about 10 s a split on one core) for a
    checkpoint to be written and the task requeued while it still renders. (At 512 spp a split
    took 1.5 s on an idle machine: it wrote its first checkpoint at 99% and finished before the
    requeue reached it, and the second run found no checkpoint to resume.)"""
    s = shot()
    s["camera"]["resolution"] = [96, 72]
    s["render"] = {"method": "pathtrace", "spp": 3584, "threads": 1}
    s["output"] = {"file": "outpt/cloud.$F4.exr"}
    return s


def array_states(job_ids):
    """{"<job>_<index>": state} of every array task of the jobs (completed ones are kept MinJobAge)."""
    p = sh("squeue", "-h", "-r", "--states=all", "-j", ",".join(job_ids), "-o", "%i %T", check=False)
    states = {}
    for line in p.stdout.splitlines():
        parts = line.split()
        if len(parts) == 2:
            states[parts[0]] = parts[1]
    return states


def task_pids(job_dir):
    """{pid: (array job id, index)} of the nimbus render processes of this job (by their environment)."""
    found = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open("/proc/%s/cmdline" % entry, "rb") as f:
                argv = f.read().split(b"\0")
            with open("/proc/%s/environ" % entry, "rb") as f:
                env = dict(v.split(b"=", 1) for v in f.read().split(b"\0") if b"=" in v)
        except OSError:
            continue
        if len(argv) > 2 and argv[1] == b"render" and env.get(b"NIMBUS_FARM_TEST") == job_dir.encode():
            found[int(entry)] = (env.get(b"SLURM_ARRAY_JOB_ID", b"").decode(), env.get(b"SLURM_ARRAY_TASK_ID", b"").decode())
    return found


def wait_for_checkpoint(job_dir, job, tasks, deadline):
    """The index of a render task whose log shows a checkpoint written and no end yet."""
    while time.time() < deadline:
        for index in range(tasks):
            try:
                with open(os.path.join(job_dir, "logs", "render_%s_%d.err" % (job, index))) as f:
                    log = f.read()
            except OSError:
                continue
            if "nimbus: checkpoint written to" in log and "done on attempt" not in log:
                return index
        time.sleep(0.05)
    return None


def requeue_a_preempted_task(nimbus, d, check):
    """Issue 16 items 6 and 7: a path-tracer sample split requeued by Slurm mid-render resumes
    from its checkpoint, and the frame merged from it is the uninterrupted one bit for bit."""
    t0 = time.time()
    scene = os.path.join(d, "pt.json")
    with open(scene, "w") as f:
        json.dump(pt_shot(), f)
    job_dir = os.path.join(d, "jobpt")
    p = subprocess.run([nimbus, "farm", "submit", scene, "--frames", "1-1", "--sample-splits", str(PT_SPLITS),
                        "--checkpoint", "1", "--engine", "slurm", "--job-dir", job_dir,
                        "--sbatch-arg=--cpus-per-task=1"], capture_output=True, text=True, cwd=d, timeout=120)
    if p.returncode != 0:
        raise RuntimeError("farm submit (pathtrace) failed (%d): %s" % (p.returncode, p.stderr))
    say(p.stderr.strip())
    ids = dict(line.split() for line in p.stdout.splitlines())
    jobs = [ids["render"], ids["merge"]]
    render_id = ids["render"]
    states = {}
    try:
        deadline = t0 + JOB_TIMEOUT
        index = wait_for_checkpoint(job_dir, render_id, PT_SPLITS, deadline)
        check(index is not None, "a path-tracer render task wrote a checkpoint while running")
        if index is not None:
            task = "%s_%d" % (render_id, index)
            q = sh("scontrol", "requeue", task, check=False)
            check(q.returncode == 0, "scontrol requeue %s: %s" % (task, (q.stdout + q.stderr).strip() or "ok"))
        while time.time() < deadline:
            states = array_states(jobs)
            if len(states) == PT_SPLITS + 1 and all(s in TERMINAL for s in states.values()):
                break
            time.sleep(1)
        say("job states after %.0f s: %s" % (time.time() - t0, " ".join("%s=%s" % kv for kv in sorted(states.items()))))
    finally:
        sh("scancel", *jobs, check=False)
        for _ in range(60):
            if all(s in TERMINAL for s in array_states(jobs).values()):
                break
            time.sleep(0.5)
    check(len(states) == PT_SPLITS + 1 and all(s == "COMPLETED" for s in states.values()),
          "every task of the path-tracer job COMPLETED")
    if index is None:
        return
    with open(os.path.join(job_dir, "logs", "render_%s_%d.err" % (render_id, index))) as f:
        log = f.read()
    second = log.split("Slurm restart 1", 1)
    resumed = re.search(r"^nimbus: resuming from \S+ at (\d+) samples per pixel$", second[-1], re.M)
    check(len(second) == 2 and resumed is not None and int(resumed.group(1)) > 0 and
          "rendering from the start" not in second[1] and "done on attempt 1" in second[1],
          "the requeued task's second run resumed from its checkpoint (%s samples per pixel) and finished" %
          (resumed.group(1) if resumed else "no resume line"))
    if len(second) == 2 and resumed is None:
        print("--- requeued task's log\n" + log[-3000:])
    # Each render task again by hand, uninterrupted, into another folder; then their merge.
    with open(os.path.join(job_dir, "plan.json")) as f:
        plan = json.load(f)
    renders = [t for t in plan["tasks"] if t["kind"] == "render"]
    merge = [t for t in plan["tasks"] if t["kind"] == "merge"][0]
    ref_dir = os.path.join(d, "uninterrupted")
    os.makedirs(ref_dir, exist_ok=True)
    refs = []
    for t in renders:
        out = t["outputs"][0]
        ref = os.path.join(ref_dir, os.path.basename(out))
        cmd = [ref if word == out else word for word in t["command"]] + ["-q"]
        r = subprocess.run(cmd, capture_output=True, text=True, cwd=d, timeout=600)
        check(r.returncode == 0, "%s run uninterrupted by hand: %s" % (t["id"], r.stderr.strip()))
        if r.returncode == 0 and os.path.isfile(out):
            check(np.array_equal(pixels(out), pixels(ref)),
                  "%s: the part written on Slurm == the task run uninterrupted, bit for bit (state layers too)" % t["id"])
        refs.append(ref)
    whole = os.path.join(ref_dir, "merged.exr")
    r = subprocess.run([nimbus, "merge", "-q", whole, *refs], capture_output=True, text=True, timeout=120)
    check(r.returncode == 0, "merge of the uninterrupted parts: " + r.stderr.strip())
    merged = merge["outputs"][0]
    check(os.path.isfile(merged) and r.returncode == 0 and np.array_equal(pixels(merged), pixels(whole)),
          "the frame merged on Slurm == the merge of the uninterrupted parts, bit for bit")
    say("path-tracer requeue: %.0f s" % (time.time() - t0))


def kill_one_mid_render(job_dir, deadline):
    """SIGKILL the nimbus of one render task once its log shows a progress line under 100%."""
    progress = re.compile(r"^nimbus: progress (\d+)% ", re.M)
    while time.time() < deadline:
        for pid, (job, index) in task_pids(job_dir).items():
            try:
                with open(os.path.join(job_dir, "logs", "render_%s_%s.err" % (job, index))) as f:
                    percents = [int(p) for p in progress.findall(f.read())]
            except OSError:
                continue
            if percents and 0 < percents[-1] < 100:
                os.kill(pid, signal.SIGKILL)
                say("killed nimbus (pid %d) of render task %s_%s at %d%%" % (pid, job, index, percents[-1]))
                return index
        time.sleep(0.05)
    return None


class Cluster:
    """The single-host cluster: started here unless one answers already; stopped if started here."""

    def __init__(self):
        self.started = False
        self.watchdog = None

    def __enter__(self):
        if shutil.which("sinfo") and sh("sinfo", "-h", check=False).returncode == 0:
            say("a Slurm cluster answers already: using it, leaving it running")
            return self
        # A watchdog stops the daemons if this process dies without cleaning up (ctest's timeout).
        self.watchdog = subprocess.Popen(
            ["bash", "-c", "while kill -0 %d 2>/dev/null; do sleep 1; done; bash %s stop" % (os.getpid(), SLURM_LOCAL)],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        self.started = True
        p = sh("bash", SLURM_LOCAL, "start", check=False, timeout=300)
        if p.returncode != 0:
            raise RuntimeError("scripts/slurm-local.sh start failed (%d): %s%s" % (p.returncode, p.stdout, p.stderr))
        say(p.stdout.strip().splitlines()[-1])
        return self

    def __exit__(self, *exc):
        if self.started:
            try:
                with open("/run/slurm-local.started") as f:
                    daemons = [line.split() for line in f if line.strip()]
            except OSError:
                daemons = []
            p = sh("bash", SLURM_LOCAL, "stop", check=False)
            say(p.stdout.strip() + p.stderr.strip())
        if self.watchdog:
            self.watchdog.kill()
            self.watchdog.wait()
        if self.started:  # no daemon of this test outlives it
            left = []
            for _ in range(50):
                left = [" ".join(d) for d in daemons if alive(int(d[0]))]
                if not left:
                    break
                time.sleep(0.1)
            if left:
                raise RuntimeError("daemons still running after scripts/slurm-local.sh stop: " + ", ".join(left))
            say("the daemons it started are gone: " + ", ".join(d[1] for d in daemons))
        return False


def alive(pid):
    """A process that is neither gone nor a zombie."""
    try:
        with open("/proc/%d/status" % pid) as f:
            return not any(line.startswith("State:") and "Z" in line.split()[1] for line in f)
    except OSError:
        return False


def main():
    nimbus = os.path.abspath(sys.argv[1])
    if os.geteuid() != 0:
        say("SKIPPED: needs root to start munged, slurmctld and slurmd (run the suite as root)")
        return SKIP
    lock = open(LOCK, "w")
    fcntl.flock(lock, fcntl.LOCK_EX)  # another suite's run of this test finishes first
    p = sh("bash", SLURM_LOCAL, "install", check=False, timeout=900)
    if p.returncode == 3:
        say("SKIPPED: Slurm cannot be installed here: " + (p.stderr.strip() or p.stdout.strip()))
        return SKIP
    if p.returncode != 0:
        raise RuntimeError("scripts/slurm-local.sh install failed (%d): %s" % (p.returncode, p.stderr))

    failures = []

    def check(ok, what):
        if not ok:
            failures.append(what)
        say(("ok: " if ok else "FAILED: ") + what)

    with tempfile.TemporaryDirectory(prefix="nimbus-slurm-") as d, Cluster():
        t0 = time.time()
        scene = os.path.join(d, "shot.json")
        with open(scene, "w") as f:
            json.dump(shot(), f)
        job_dir = os.path.join(d, "job")
        # The tasks inherit the environment (sbatch --export=ALL): the marker finds their processes.
        env = dict(os.environ, NIMBUS_FARM_TEST=job_dir)
        p = subprocess.run([nimbus, "farm", "submit", scene, "--frames", "1-%d" % FRAMES, "--tiles", str(TILES),
                            "--engine", "slurm", "--job-dir", job_dir, "--sbatch-arg=--cpus-per-task=1"],
                           capture_output=True, text=True, cwd=d, env=env, timeout=120)
        if p.returncode != 0:
            raise RuntimeError("farm submit failed (%d): %s" % (p.returncode, p.stderr))
        say(p.stderr.strip())
        ids = dict(line.split() for line in p.stdout.splitlines())
        check(set(ids) == {"render", "merge"}, "farm submit printed the render and merge job ids: %r" % p.stdout)
        jobs = [ids["render"], ids["merge"]]
        try:
            deadline = t0 + JOB_TIMEOUT
            killed = kill_one_mid_render(job_dir, deadline)
            check(killed is not None, "a render task was killed mid-render")
            states = {}
            while time.time() < deadline:
                states = array_states(jobs)
                if len(states) == FRAMES * TILES + FRAMES and all(s in TERMINAL for s in states.values()):
                    break
                time.sleep(1)
            say("job states after %.0f s: %s" % (time.time() - t0, " ".join("%s=%s" % kv for kv in sorted(states.items()))))
        finally:
            sh("scancel", *jobs, check=False)  # nothing left queued or running, whatever happened
            for _ in range(60):
                if all(s in TERMINAL for s in array_states(jobs).values()):
                    break
                time.sleep(0.5)

        render_id, merge_id = jobs
        check(sorted(states) == sorted(["%s_%d" % (render_id, i) for i in range(FRAMES * TILES)] +
                                       ["%s_%d" % (merge_id, i) for i in range(FRAMES)]),
              "%d render and %d merge array tasks" % (FRAMES * TILES, FRAMES))
        check(all(s == "COMPLETED" for s in states.values()), "every array task COMPLETED")
        if killed is not None:
            with open(os.path.join(job_dir, "logs", "render_%s_%s.err" % (render_id, killed))) as f:
                log = f.read()
            check("attempt 1 of 3 killed by signal 9: retrying" in log and "done on attempt 2" in log,
                  "the killed task was retried and succeeded (its log)")

        # The same frames in one process.
        p = subprocess.run([nimbus, "render", scene, "-q", "--frames", "1-%d" % FRAMES, "-o",
                            os.path.join(d, "whole", "cloud.$F4.exr")], capture_output=True, text=True, cwd=d)
        check(p.returncode == 0, "render --frames in one process: " + p.stderr.strip())
        for frame in range(1, FRAMES + 1):
            merged = os.path.join(d, "out", "cloud.%04d.exr" % frame)
            if not os.path.isfile(merged):
                check(False, "frame %d merged" % frame)
                continue
            check(np.array_equal(pixels(merged), pixels(os.path.join(d, "whole", "cloud.%04d.exr" % frame))),
                  "frame %d: merged tiles == the frame rendered in one process, bit for bit" % frame)
        check(not np.array_equal(pixels(os.path.join(d, "whole", "cloud.0001.exr")),
                                 pixels(os.path.join(d, "whole", "cloud.%04d.exr" % FRAMES))), "the shot is animated")
        requeue_a_preempted_task(nimbus, d, check)
        if failures:
            for name in sorted(os.listdir(os.path.join(job_dir, "logs"))):
                with open(os.path.join(job_dir, "logs", name)) as f:
                    text = f.read().strip()
                if text:
                    print("--- %s\n%s" % (name, text[-2000:]))
        say("%.0f s in all" % (time.time() - t0))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
