#!/usr/bin/python3
"""`nimbus farm submit --engine slurm` without a cluster (issue 16, item 6; docs/farm.md, "Slurm"),
and the progress lines a farm's log shows.

- --dry-run writes the job folder (render.sbatch, merge.sbatch, submit.sh, plan.json, logs/) and
  submits nothing; the array scripts, run here by bash as Slurm would run them (one process per
  SLURM_ARRAY_TASK_ID, the merges after every render), produce the frames of `render --frames`
  bit for bit (wkb, 3 frames of an animated procedural cloud in 2 tiles).
- The scripts' retries: a task killed by signal 9 on its first attempt is run again and succeeds;
  exit 2 is not retried; a task failing every time stops after 1 + retries attempts with its exit.
- Submission through a stand-in sbatch on PATH: the arrays' order, `--dependency=afterok:<render
  id>`, the job ids on stdout and in jobs.json; sbatch refusing the merge array: exit 2, one line,
  the render array cancelled (a stand-in scancel); no sbatch on PATH: exit 2, one line, nothing
  written; a non-empty --job-dir and another --engine: exit 2, one line.
- Progress off a terminal: "nimbus: progress P% frame F elapsed Es eta Ts", one line per 5% step,
  percent increasing, the last at 100% with eta 0s.

The cluster test (a real single-host Slurm) is tests/farm/test_slurm.py.

Run by ctest with Debian's python3:  test_farm_submit.py NIMBUS_BINARY [-k NAME]
"""
import json
import os
import re
import stat
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import OpenImageIO as oiio

NIMBUS = None
PROGRESS = re.compile(r"^nimbus: progress (\d{1,3})% frame (-?\d+) elapsed (\d+\.\d)s eta (\d+s|-)( cancelled)?$")


def run(*args, cwd=None, env=None):
    p = subprocess.run([NIMBUS, *args], capture_output=True, text=True, timeout=600, cwd=cwd, env=env)
    return p.returncode, p.stdout, p.stderr


def pixels(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    data = np.asarray(inp.read_image(oiio.FLOAT))
    inp.close()
    return data


def cloud_shot(width=32, height=24):
    """A procedural cloud that turns and drifts over frames 1-6 while the camera moves."""
    return {
        "camera": {"from": [{"frame": 1, "value": [0, 1, 9]}, {"frame": 6, "value": [2, 1.5, 8.5]}],
                   "to": [0, 0, 0], "up": [0, 1, 0], "fov": 35, "resolution": [width, height]},
        "lights": [{"name": "sun", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [3, 3, 3]}],
        "volumes": [{"name": "cloud",
                     "source": {"type": "procedural", "generator": "cloud", "radius": 2, "voxel_size": 0.1,
                                "octaves": 3, "seed": 7},
                     "transform": [{"frame": 1, "value": {"translate": [0, 0, 0]}},
                                   {"frame": 6, "value": {"rotate": [50, 0, 1, 0], "translate": [0.6, 0, 0]}}],
                     "medium": {"sigma_s": [3, 3, 3], "sigma_a": 0.05}}],
        "render": {"method": "wkb"},
        "output": {"file": "out/cloud.$F4.exr"},
    }


def write_executable(path, text):
    with open(path, "w") as f:
        f.write(text)
    os.chmod(path, os.stat(path).st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)


def one_line(test, err):
    test.assertEqual(len(err.strip().splitlines()), 1, err)
    test.assertTrue(err.startswith("nimbus: error: farm submit: "), err)


class FarmSubmit(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name
        self.scene = self.path("shot.json")
        with open(self.scene, "w") as f:
            json.dump(cloud_shot(), f)
        os.makedirs(self.path("bin"))

    def tearDown(self):
        self.dir.cleanup()

    def path(self, *parts):
        return os.path.join(self.d, *parts)

    def submit(self, *args, env=None):
        return run("farm", "submit", self.scene, "--engine", "slurm", *args, cwd=self.d, env=env)

    def run_array(self, script, count, env=None):
        """Runs an array script as Slurm would: one bash per index; returns (exit, stderr) per index."""
        results = []
        for i in range(count):
            e = dict(env or os.environ, SLURM_ARRAY_TASK_ID=str(i), SLURM_ARRAY_JOB_ID="7")
            p = subprocess.run(["bash", script], capture_output=True, text=True, timeout=600, cwd="/", env=e)
            results.append((p.returncode, p.stderr))
        return results

    def test_dry_run_scripts_render_the_frames(self):
        job = self.path("job")
        code, out, err = self.submit("--frames", "1-3", "--tiles", "2", "--dry-run", "--job-dir", job)
        self.assertEqual(code, 0, err)
        self.assertEqual(out, "", "a dry run submits nothing and prints no job id")
        self.assertEqual(sorted(os.listdir(job)), ["logs", "merge.sbatch", "plan.json", "render.sbatch", "submit.sh"])
        with open(os.path.join(job, "plan.json")) as f:
            plan = json.load(f)
        with open(os.path.join(job, "render.sbatch")) as f:
            render = f.read()
        with open(os.path.join(job, "merge.sbatch")) as f:
            merge = f.read()
        for line in ("#SBATCH --array=0-5", "#SBATCH --requeue", "#SBATCH --open-mode=append",
                     "#SBATCH --output=%s/logs/render_%%A_%%a.out" % job,
                     "#SBATCH --error=%s/logs/render_%%A_%%a.err" % job, "#SBATCH --chdir=%s" % self.d):
            self.assertIn(line + "\n", render)
        self.assertIn("#SBATCH --array=0-2\n", merge)
        for script in ("render.sbatch", "merge.sbatch", "submit.sh"):
            self.assertEqual(subprocess.run(["bash", "-n", os.path.join(job, script)]).returncode, 0, script)
        with open(os.path.join(job, "submit.sh")) as f:
            self.assertIn("--dependency=afterok:$render --kill-on-invalid-dep=yes merge.sbatch", f.read())

        # The renders (any order, any directory), then the merges: the frames of --frames.
        results = self.run_array(os.path.join(job, "render.sbatch"), 6)
        for i, (rc, err) in enumerate(results):
            self.assertEqual(rc, 0, err)
            task = plan["groups"][0]["tasks"][i]
            self.assertIn("nimbus-farm: %s: done on attempt 1" % task, err)
            progress = [line for line in err.splitlines() if line.startswith("nimbus: progress")]
            self.assertTrue(progress and all(PROGRESS.match(line) for line in progress), err)
        for rc, err in self.run_array(os.path.join(job, "merge.sbatch"), 3):
            self.assertEqual(rc, 0, err)
        rc, _, err = run("render", self.scene, "-q", "--frames", "1-3", "-o", self.path("whole", "c.$F4.exr"),
                         cwd=self.d)
        self.assertEqual(rc, 0, err)
        for frame in (1, 2, 3):
            merged = pixels(self.path("out", "cloud.%04d.exr" % frame))
            whole = pixels(self.path("whole", "c.%04d.exr" % frame))
            self.assertTrue(np.array_equal(merged, whole), "frame %d: merged tiles == the whole frame" % frame)
        self.assertFalse(np.array_equal(pixels(self.path("whole", "c.0001.exr")),
                                         pixels(self.path("whole", "c.0003.exr"))), "the shot is animated")
        # An index outside the array is refused.
        e = dict(os.environ, SLURM_ARRAY_TASK_ID="3")
        p = subprocess.run(["bash", os.path.join(job, "merge.sbatch")], capture_output=True, text=True, env=e)
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn("no task '3' in this array (0-2)", p.stderr)

    def retry_job(self, shim, retries="2"):
        """A one-frame unsplit job whose tasks run `shim` (as --nimbus) instead of nimbus."""
        nimbus = self.path("bin", "nimbus-shim")
        write_executable(nimbus, shim.replace("@NIMBUS@", NIMBUS).replace("@DIR@", self.d))
        job = self.path("job")
        code, _, err = self.submit("--frames", "2", "--retries", retries, "--dry-run", "--job-dir", job,
                                   "--nimbus", nimbus)
        self.assertEqual(code, 0, err)
        [(rc, err)] = self.run_array(os.path.join(job, "render.sbatch"), 1)
        return rc, err

    def test_killed_task_is_retried(self):
        # The first attempt is killed by signal 9 (as kill -9 of nimbus mid-render); the retry renders.
        rc, err = self.retry_job("#!/bin/bash\n"
                                 "if mkdir @DIR@/first-attempt 2>/dev/null; then kill -9 $$; fi\n"
                                 "exec @NIMBUS@ \"$@\"\n")
        self.assertEqual(rc, 0, err)
        self.assertIn("nimbus-farm: render.f0002: attempt 1 of 3 killed by signal 9: retrying", err)
        self.assertIn("nimbus-farm: render.f0002: done on attempt 2", err)
        self.assertTrue(os.path.isfile(self.path("out", "cloud.0002.exr")))

    def test_bad_input_is_not_retried(self):
        rc, err = self.retry_job("#!/bin/bash\necho attempt >> @DIR@/attempts\nexit 2\n")
        self.assertEqual(rc, 2, err)
        self.assertIn("attempt 1 exit 2 (bad input): not retried", err)
        with open(self.path("attempts")) as f:
            self.assertEqual(len(f.read().splitlines()), 1)

    def test_retries_run_out(self):
        rc, err = self.retry_job("#!/bin/bash\necho attempt >> @DIR@/attempts\nexit 1\n", retries="3")
        self.assertEqual(rc, 1, err)
        self.assertIn("attempt 4 of 4 exit 1: no retries left", err)
        with open(self.path("attempts")) as f:
            self.assertEqual(len(f.read().splitlines()), 4)

    def fake_slurm(self, merge_fails=False):
        """Stand-ins for sbatch and scancel that log their arguments."""
        log = self.path("sbatch.log")
        write_executable(self.path("bin", "sbatch"),
                         "#!/bin/bash\n"
                         "echo \"$*\" >> %s\n"
                         "n=$(wc -l < %s)\n"
                         "if [ \"$n\" -eq 2 ] && [ %d -eq 1 ]; then\n"
                         "  echo 'sbatch: error: Batch job submission failed: Invalid partition name specified' >&2\n"
                         "  exit 1\n"
                         "fi\n"
                         "echo \"$((40 + n));nimbus-local\"\n" % (log, log, int(merge_fails)))
        write_executable(self.path("bin", "scancel"), "#!/bin/bash\necho \"$*\" >> %s\n" % self.path("scancel.log"))
        return dict(os.environ, PATH=self.path("bin") + ":" + os.environ["PATH"]), log

    def test_submit_prints_job_ids_and_chains_the_merges(self):
        env, log = self.fake_slurm()
        job = self.path("job")
        code, out, err = self.submit("--frames", "1-3", "--tiles", "2", "--job-dir", job, env=env)
        self.assertEqual(code, 0, err)
        self.assertEqual(out, "render 41\nmerge 42\n")
        self.assertIn("render array 41 (6 task(s)), merge array 42 (3 task(s), afterok:41)", err)
        with open(log) as f:
            calls = f.read().splitlines()
        self.assertEqual(calls, ["--parsable %s/render.sbatch" % job,
                                 "--parsable --dependency=afterok:41 --kill-on-invalid-dep=yes %s/merge.sbatch" % job])
        with open(os.path.join(job, "jobs.json")) as f:
            self.assertEqual(json.load(f), {"render": "41", "render_tasks": 6, "merge": "42", "merge_tasks": 3})
        # An unsplit shot is one array, no merges.
        code, out, err = self.submit("--frames", "1-3", "--job-dir", self.path("job2"), env=env)
        self.assertEqual(code, 0, err)
        self.assertEqual(out, "render 43\n")
        self.assertFalse(os.path.exists(self.path("job2", "merge.sbatch")))

    def test_sbatch_refusing_the_merges_cancels_the_renders(self):
        env, _ = self.fake_slurm(merge_fails=True)
        code, out, err = self.submit("--frames", "1-3", "--tiles", "2", "--job-dir", self.path("job"), env=env)
        self.assertEqual(code, 2, err)
        self.assertEqual(out, "")
        one_line(self, err)
        self.assertIn("sbatch refused the merge array (exit 1): sbatch: error: Batch job submission failed: "
                      "Invalid partition name specified; the render array 41 was cancelled", err)
        with open(self.path("scancel.log")) as f:
            self.assertEqual(f.read(), "41\n")

    def test_refusals(self):
        env = dict(os.environ, PATH=self.path("bin"))  # no sbatch there
        code, out, err = self.submit("--frames", "1-3", "--job-dir", self.path("job"), env=env)
        self.assertEqual(code, 2, err)
        one_line(self, err)
        self.assertIn("sbatch is not on PATH", err)
        self.assertFalse(os.path.exists(self.path("job")), "nothing written")

        os.makedirs(self.path("full"))
        open(self.path("full", "old.log"), "w").close()
        code, _, err = self.submit("--frames", "1-3", "--dry-run", "--job-dir", self.path("full"))
        self.assertEqual(code, 2, err)
        one_line(self, err)
        self.assertIn("exists and is not an empty folder", err)

        code, _, err = run("farm", "submit", self.scene, "--engine", "deadline", "--dry-run", cwd=self.d)
        self.assertEqual(code, 2, err)
        one_line(self, err)
        self.assertIn("--engine 'deadline'", err)

        # The plan's own checks come first: several frames need a frame token in the output.
        code, _, err = self.submit("--frames", "1-3", "-o", "out/same.exr", "--dry-run", "--job-dir", self.path("j3"))
        self.assertEqual(code, 2, err)
        self.assertIn("has no frame token", err)
        self.assertFalse(os.path.exists(self.path("j3")))

    def test_default_job_dir(self):
        code, _, err = self.submit("--frames", "1-2", "--dry-run")
        self.assertEqual(code, 0, err)
        [name] = os.listdir(self.path("nimbus-farm"))
        self.assertRegex(name, r"^shot\.\d{8}-\d{6}$")
        self.assertIn("render.sbatch", os.listdir(self.path("nimbus-farm", name)))


class ProgressLines(unittest.TestCase):
    def test_progress_off_a_terminal(self):
        with tempfile.TemporaryDirectory() as d:
            scene = os.path.join(d, "shot.json")
            with open(scene, "w") as f:
                json.dump(cloud_shot(64, 48), f)
            code, _, err = run("render", scene, "--frame", "4", "-o", os.path.join(d, "a.exr"), cwd=d)
            self.assertEqual(code, 0, err)
            lines = [line for line in err.splitlines() if line.startswith("nimbus: progress")]
            matches = [PROGRESS.match(line) for line in lines]
            self.assertTrue(all(matches), lines)
            percents = [int(m.group(1)) for m in matches]
            self.assertEqual(percents, sorted(percents), "percent increases")
            self.assertEqual(len(set(p // 5 for p in percents[:-1])), len(percents) - 1, "at most one line per 5%")
            self.assertLessEqual(len(lines), 21)
            self.assertTrue(all(m.group(2) == "4" for m in matches), "the frame rendered")
            self.assertEqual((percents[-1], matches[-1].group(4)), (100, "0s"), "the last line")
            self.assertNotIn("\r", err)
            # -q: none.
            code, _, err = run("render", scene, "-q", "-o", os.path.join(d, "b.exr"), cwd=d)
            self.assertEqual((code, err), (0, ""))


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main()
