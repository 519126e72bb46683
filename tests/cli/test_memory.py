"""Memory known before it is spent (issue 18, item 4), through the CLI.

- render.memory_limit: a render whose estimate exceeds it is bad input (exit 2, one line naming
  the key, the estimate and the limit), refused before anything large is allocated or written;
- `nimbus info` prints the estimate;
- a VDB file with garbage after a valid header is refused (exit 2, one line naming the file)
  without allocating more than its size allows: before, OpenVDB's reader allocated 11-15 GB or
  looped (docs/robustness.md "Memory").

Run by ctest with Debian's python3 (pyopenvdb comes from Debian):
    python3 test_memory.py path/to/nimbus
"""
import json
import os
import random
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import unittest

import pyopenvdb as vdb

NIMBUS = None

# The damaged-file runs may use at most this much resident memory: the process itself (libraries,
# the AX JIT) is about 200 MiB; the bound the reader enforces on a 66 KB file is ~32 x its size.
DAMAGED_VDB_RSS_LIMIT = 512 << 20


def run(*args, cwd=None, timeout=600):
    p = subprocess.run([NIMBUS, *args], capture_output=True, text=True, cwd=cwd, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


# Runs nimbus in a child of a fresh python, so that its peak RSS is the child's alone (the rusage of
# a process's children is their maximum); the address space is capped at 4 GiB so that a regression
# fails with std::bad_alloc instead of exhausting the machine.
MEASURE = r"""
import json, resource, subprocess, sys
def cap():
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
try:
    p = subprocess.run(sys.argv[1:], capture_output=True, text=True, timeout=60, preexec_fn=cap)
    code, err = p.returncode, p.stderr
except subprocess.TimeoutExpired:
    code, err = "timeout", ""
print(json.dumps({"code": code, "stderr": err,
                  "maxrss": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024}))
"""


def run_measured(*args):
    p = subprocess.run([sys.executable, "-c", MEASURE, NIMBUS, *args], capture_output=True, text=True, timeout=120)
    return json.loads(p.stdout)


def small_scene(**overrides):
    scene = {
        "camera": {"from": [0, 0, 6], "to": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "resolution": [32, 24]},
        "lights": [{"name": "key", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [2, 2, 2]}],
        "volumes": [{"name": "ball", "source": {"type": "procedural", "generator": "sphere", "radius": 1.0,
                                                "voxel_size": 0.1},
                     "medium": {"sigma_s": [2, 2, 2], "sigma_a": [0.1, 0.1, 0.1]}}],
        "render": {"method": "single", "spp": 1},
    }
    scene.update(overrides)
    return scene


def bytes_of(text):
    """'12.3 MiB' -> bytes."""
    value, unit = text.split()
    return float(value) * {"KiB": 1024, "MiB": 1 << 20}[unit]


class Memory(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name
        self.out = os.path.join(self.d, "out.exr")

    def tearDown(self):
        self.dir.cleanup()

    def scene_file(self, scene):
        path = os.path.join(self.d, "scene.json")
        scene.setdefault("output", {})["file"] = self.out
        with open(path, "w") as f:
            json.dump(scene, f)
        return path

    def test_info_prints_the_estimate_and_the_limit(self):
        code, out, err = run("info", self.scene_file(small_scene()))
        self.assertEqual(code, 0, err)
        line = [l for l in out.splitlines() if l.strip().startswith("memory:")]
        self.assertEqual(len(line), 1, out)
        m = re.search(r"estimated peak ([\d.]+ [KM]iB) of the limit ([\d.]+ [KM]iB)", line[0])
        self.assertTrue(m, line[0])
        # The default limit: 80% of MemTotal (or of a smaller cgroup limit).
        with open("/proc/meminfo") as f:
            total = int(re.search(r"MemTotal:\s+(\d+)", f.read()).group(1)) * 1024
        limit = bytes_of(m.group(2))
        self.assertLessEqual(limit, 0.8 * total * 1.001)
        self.assertIn("film", line[0])
        # An explicit limit is reported as such.
        code, out, err = run("info", self.scene_file(small_scene()), "--set", "render.memory_limit=1e12")
        self.assertEqual(code, 0, err)
        self.assertIn("(render.memory_limit)", out)

    def test_a_tiny_memory_limit_is_refused_before_rendering(self):
        scene = self.scene_file(small_scene())
        for method in ("single", "wkb", "pathtrace"):
            code, out, err = run("render", scene, "--set", "render.memory_limit=1000000", "--set",
                                 f"render.method={method}", "--preview", os.path.join(self.d, "p.png"))
            self.assertEqual(code, 2, f"{method}: {err}")
            lines = [l for l in err.splitlines() if l.strip()]
            self.assertEqual(len(lines), 1, err)
            self.assertIn("scene.json: render.memory_limit:", lines[0])
            self.assertIn("estimated", lines[0])
            self.assertIn("976.6 KiB", lines[0])  # the limit, 1e6 bytes
            self.assertFalse(os.path.exists(self.out), "an output was written")
            self.assertFalse(os.path.exists(os.path.join(self.d, "p.png")), "a preview was written")
            self.assertEqual(os.listdir(self.d), ["scene.json"], "temporary files left")

    def test_the_estimate_is_the_limit_that_passes(self):
        # A limit just above the estimate `info` printed renders; just below it is refused.
        scene = self.scene_file(small_scene())
        code, out, err = run("info", scene)
        self.assertEqual(code, 0, err)
        estimate = bytes_of(re.search(r"estimated peak ([\d.]+ [KM]iB)", out).group(1))
        code, _, err = run("render", scene, "--set", f"render.memory_limit={estimate * 1.5:.0f}")
        self.assertEqual(code, 0, err)
        code, _, err = run("render", scene, "--set", f"render.memory_limit={estimate * 0.5:.0f}")
        self.assertEqual(code, 2, err)

    def test_a_tiny_shadow_step_is_refused_before_the_shadow_maps_march(self):
        # Each texel ray of a deep shadow map keeps its uncompressed march until the texel is
        # compressed, one vertex per step: at shadow_step 1e-7 voxels that is ~10^9 vertices a ray
        # (docs/robustness.md "Memory"). Refused by the estimate, naming the key, before any march.
        scene = self.scene_file(small_scene())
        code, out, err = run("info", scene)
        self.assertEqual(code, 0, err)
        self.assertIn("deep shadow map marches, while built", out)
        result = run_measured("render", scene, "--set", "render.shadow_step=1e-7")
        self.assertEqual(result["code"], 2, result["stderr"])
        lines = [l for l in result["stderr"].splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, result["stderr"])
        self.assertIn("render.shadow_step", lines[0])
        self.assertIn("deep shadow map marches", lines[0])
        self.assertFalse(os.path.exists(self.out), "an output was written")

    def test_negative_or_nan_limit_is_bad_input(self):
        for value in ("-1", "nan"):
            code, _, err = run("info", self.scene_file(small_scene()), "--set", f"render.memory_limit={value}")
            self.assertEqual(code, 2, err)
            self.assertIn("render.memory_limit", err)

    def test_garbage_after_a_valid_vdb_header_is_refused_within_a_bounded_memory(self):
        grid = vdb.FloatGrid()
        grid.name = "density"
        grid.transform = vdb.createLinearTransform(voxelSize=0.1)
        acc = grid.getAccessor()
        rng = random.Random(1)
        for x in range(24):
            for y in range(24):
                for z in range(24):
                    acc.setValueOn((x, y, z), rng.random())
        good = os.path.join(self.d, "good.vdb")
        vdb.write(good, grids=[grid])
        with open(good, "rb") as f:
            data = f.read()
        self.assertGreater(len(data), 30000)
        # The cuts of docs/robustness.md (300-600 bytes: header and descriptor intact) and more,
        # each followed by random bytes to the original length, and one cut short (truncated).
        cases = [(cut, seed, len(data)) for cut in (300, 400, 500, 600, 1000, 4000) for seed in (cut, cut + 1)]
        cases.append((2000, 0, 2000))
        for cut, seed, length in cases:
            r = random.Random(seed)
            bad = os.path.join(self.d, f"bad{cut}_{seed}.vdb")
            with open(bad, "wb") as f:
                f.write(data[:cut] + bytes(r.randrange(256) for _ in range(length - cut)))
            s = small_scene()
            s["volumes"][0]["source"] = {"type": "vdb", "file": bad}
            result = run_measured("info", self.scene_file(s))
            with self.subTest(cut=cut, seed=seed):
                self.assertEqual(result["code"], 2, result["stderr"])
                lines = [l for l in result["stderr"].splitlines() if l.strip()]
                self.assertEqual(len(lines), 1, result["stderr"])
                self.assertIn(os.path.basename(bad), lines[0])
                self.assertLess(result["maxrss"], DAMAGED_VDB_RSS_LIMIT, lines[0])
        # The intact file still reads.
        s = small_scene()
        s["volumes"][0]["source"] = {"type": "vdb", "file": good}
        code, _, err = run("info", self.scene_file(s))
        self.assertEqual(code, 0, err)

    def test_a_damaged_compressed_block_is_refused_before_openvdb_reads_it(self):
        # fuzz_vdb's finding (tests/fuzz/regressions/vdb): a leaf's block whose size word claims
        # more uncompressed bytes than the leaf holds; OpenVDB 10's bloscFromStream read them into
        # the leaf's buffer before comparing (heap overflow; `free(): invalid pointer`, SIGABRT).
        # Made here in a file pyopenvdb writes (Blosc, as Debian's OpenVDB writes by default): the
        # last leaf's size word is the one whose block runs to the end of the file.
        grid = vdb.FloatGrid()
        grid.name = "density"
        grid.transform = vdb.createLinearTransform(voxelSize=0.1)
        acc = grid.getAccessor()
        for i in range(512):
            acc.setValueOn((i // 64, i // 8 % 8, i % 8), 1.0 + (i % 7) * 0.5)  # compressible
        good = os.path.join(self.d, "good.vdb")
        vdb.write(good, grids=[grid])
        with open(good, "rb") as f:
            data = f.read()
        words = [at for at in range(len(data) - 8)
                 if 0 < int.from_bytes(data[at:at + 8], "little", signed=True) == len(data) - at - 8]
        self.assertTrue(words)
        word = words[-1]
        s = small_scene()
        s["volumes"][0]["source"] = {"type": "vdb", "file": good}
        code, _, err = run("info", self.scene_file(s))
        self.assertEqual(code, 0, err)
        for name, value in (("overflow", -(512 * 4 + 8182)), ("beyond_the_file", 1 << 40)):
            bad = os.path.join(self.d, f"bad_{name}.vdb")
            with open(bad, "wb") as f:
                f.write(data[:word] + value.to_bytes(8, "little", signed=True) + data[word + 8:])
            s["volumes"][0]["source"] = {"type": "vdb", "file": bad}
            with self.subTest(name):
                code, _, err = run("render", self.scene_file(s), "-q")
                self.assertEqual(code, 2, err)
                lines = [l for l in err.splitlines() if l.strip()]
                self.assertEqual(len(lines), 1, err)
                self.assertIn(bad, lines[0])
                self.assertIn("volumes[0].source.grids.density", lines[0])
                self.assertIn("block", lines[0])
                self.assertFalse(os.path.exists(self.out))

    def test_fuzzed_vdbs_with_garbage_lengths_are_refused_within_a_bounded_memory(self):
        # fuzz_vdb's findings (tests/fuzz/regressions/vdb), each read through OpenVDB's own code:
        # a file whose header says it has no grid offsets (as io::Stream writes) went to io::File,
        # which trusted its lengths (4.5 GB peak RSS, 6.5 s before its error); a grid whose
        # 'file_bbox_max' says type 'int32' with a size word of 12 (OpenVDB reads 4 bytes for an
        # int32 whatever the word says, then took a name's characters for a string length: 1.9 GB).
        for name in ("streamed_header_garbage_counts_oom.vdb", "metadata_size_word_disagrees_with_its_type_oom.vdb"):
            bad = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fuzz", "regressions", "vdb", name)
            s = small_scene()
            s["volumes"][0]["source"] = {"type": "vdb", "file": bad}
            result = run_measured("info", self.scene_file(s))
            with self.subTest(name):
                self.assertEqual(result["code"], 2, result["stderr"])
                lines = [l for l in result["stderr"].splitlines() if l.strip()]
                self.assertEqual(len(lines), 1, result["stderr"])
                self.assertIn(name, lines[0])
                self.assertLess(result["maxrss"], DAMAGED_VDB_RSS_LIMIT, lines[0])

    def test_fuzzed_nanovdb_with_shared_children_is_refused_within_a_bounded_memory(self):
        # fuzz_nvdb's finding (tests/fuzz/regressions/nvdb): a 300 KB grid whose upper node points
        # many times at the same lower node. Every offset lay inside the grid; NanoVDB's conversion
        # unfolded the shared nodes into 2.6 GB of distinct ones before any memory check, and the
        # load ended in "volume empty" with exit 0. The layout check counts the nodes it reaches.
        for name in ("shared_lower_nodes_unfold_to_2_6_gb.nvdb", "shared_lower_nodes_unfold_to_1_7_gb.nvdb"):
            found = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fuzz", "regressions", "nvdb", name)
            bad = os.path.join(self.d, "grid.nvdb")  # the reader knows NanoVDB by its extension
            shutil.copyfile(found, bad)
            s = small_scene()
            s["volumes"][0]["source"] = {"type": "vdb", "file": bad}
            s["render"]["memory_limit"] = 64 * 1024 * 1024
            result = run_measured("info", self.scene_file(s))
            with self.subTest(name):
                self.assertEqual(result["code"], 2, result["stderr"])
                lines = [l for l in result["stderr"].splitlines() if l.strip()]
                self.assertEqual(len(lines), 1, result["stderr"])
                self.assertIn("children shared", lines[0])
                self.assertLess(result["maxrss"], DAMAGED_VDB_RSS_LIMIT, lines[0])


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
