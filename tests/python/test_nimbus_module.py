"""Tests of the Python module `nimbus` (plugins/python/NimbusModule.cpp), run by ctest with
Debian's /usr/bin/python3 and PYTHONPATH at build/python.

The same scene built three ways (a JSON file, load_dict, code) must render the same floats;
AOVs are float32 numpy views of the frame's buffers with the documented shapes; cancel stops a
render within a few tiles; pyopenvdb grids and volume plugins render like the files they stand
for; errors are nimbus.InputError with the C status and the scene format's key path."""
import json
import os
import sys
import tempfile
import threading
import time
import unittest

import numpy as np

import nimbus

TORUS_PLUGIN = os.environ.get("NIMBUS_TORUS_PLUGIN", "")

# One scene, as the JSON format has it. Renders are deterministic on any thread count (STYLE
# rule 7), so any difference between the three ways must come from the scene.
SCENE = {
    "camera": {"from": [0, 0.5, 4], "to": [0, 0, 0], "fov": 35, "resolution": [40, 30]},
    "lights": [
        {"type": "distant", "name": "sun", "direction": [0.4, -1, -0.3], "irradiance": [3, 2.8, 2.5]},
        {"type": "point", "name": "bulb", "position": [1.5, 1, 1.5], "intensity": 4},
    ],
    "volumes": [
        {
            "name": "ball",
            "source": {"type": "procedural", "generator": "sphere", "radius": 1.0, "voxel_size": 0.05},
            "transform": {"translate": [0.1, 0, 0]},
            "medium": {"sigma_s": [2, 2.2, 2.4], "sigma_a": 0.1, "phase": {"type": "hg", "g": 0.4}},
        }
    ],
    "render": {"spp": 2, "threads": 2, "seed": 7},
}


def build_in_code():
    scene = nimbus.Scene()
    camera = scene.camera
    camera["from"] = (0, 0.5, 4)
    camera["to"] = [0, 0, 0]
    camera["fov"] = np.int64(35)  # numpy scalars pass as numbers
    camera["resolution"] = np.array([40, 30])
    scene.add(nimbus.Light("distant", name="sun", direction=(0.4, -1, -0.3), irradiance=(3, 2.8, 2.5)))
    scene.add(nimbus.Light("point", {"name": "bulb", "position": (1.5, 1, 1.5)}, intensity=4))
    ball = nimbus.Volume("procedural", {"name": "ball", "source.generator": "sphere", "source.radius": 1.0,
                                        "source.voxel_size": 0.05})
    ball["transform"] = {"translate": [0.1, 0, 0]}
    ball.update({"medium.sigma_s": [2, 2.2, 2.4], "medium.sigma_a": 0.1, "medium.phase.g": 0.4})
    scene.add(ball)
    scene["render.spp"] = 2
    scene["render.threads"] = 2
    scene["render.seed"] = 7
    scene.commit()
    return scene


def assert_same_frames(test, a, b):
    test.assertEqual(a.keys(), b.keys())
    for name in a.keys():
        test.assertTrue(np.array_equal(a[name], b[name]), name)


class SameSceneThreeWays(unittest.TestCase):
    def test_file_dict_and_code_render_identically(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "scene.json")
            with open(path, "w") as f:
                json.dump(SCENE, f)
            from_file = nimbus.render(nimbus.load(path))
        from_dict = nimbus.render(nimbus.load_dict(SCENE))
        from_code = nimbus.render(build_in_code())
        self.assertGreater(from_code["alpha"].max(), 0.5)
        assert_same_frames(self, from_file, from_dict)
        assert_same_frames(self, from_file, from_code)

    def test_written_json_is_the_scene(self):
        scene = build_in_code()
        again = nimbus.load_dict(scene.to_dict())
        assert_same_frames(self, nimbus.render(scene), nimbus.render(again))


class Arrays(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.frame = nimbus.render(nimbus.load_dict(SCENE))

    def test_tiny_field_of_view_renders_finite(self):
        # Issue 18, failure 4: an int overflow in tile culling at fov 1e-10 wrote out of bounds and
        # killed the host process (Python included).
        for method in ("single", "wkb"):
            doc = json.loads(json.dumps(SCENE))
            doc["camera"]["fov"] = 1e-10
            doc["camera"]["resolution"] = [16, 12]
            doc["render"].update(method=method, spp=1)
            frame = nimbus.render(nimbus.load_dict(doc))
            self.assertTrue(np.all(np.isfinite(frame["beauty"])), method)

    def test_shapes_and_dtypes(self):
        f = self.frame
        self.assertEqual(f.keys(), ["beauty", "L0", "L1", "alpha", "depth", "light_sun", "light_bulb"])
        self.assertEqual(f["beauty"].shape, (30, 40, 4))
        for name in ("L0", "L1", "light_sun", "light_bulb"):
            self.assertEqual(f[name].shape, (30, 40, 3), name)
        for name in ("alpha", "depth"):
            self.assertEqual(f[name].shape, (30, 40), name)
        for name, a in f.aovs().items():
            self.assertEqual(a.dtype, np.float32, name)
            self.assertTrue(a.flags.c_contiguous, name)
        # Beauty's alpha channel is the alpha AOV; its RGB is L0 + L1.
        self.assertTrue(np.array_equal(f["beauty"][..., 3], f["alpha"]))
        np.testing.assert_allclose(f["beauty"][..., :3], f["L0"] + f["L1"], rtol=1e-6, atol=1e-7)

    def test_views_share_the_frame_buffer(self):
        a, b = self.frame["beauty"], self.frame["beauty"]
        self.assertTrue(np.shares_memory(a, b))  # no copy: both view the frame's own floats
        self.assertFalse(a.flags.writeable)
        with self.assertRaises(ValueError):
            a[0, 0, 0] = 1.0
        view = memoryview(self.frame.aov("depth"))  # the buffer protocol without numpy
        self.assertEqual((view.format, view.shape, view.readonly), ("f", (30, 40), True))

    def test_array_outlives_frame_and_session(self):
        frame = nimbus.render(nimbus.load_dict(SCENE))
        beauty = frame["beauty"]
        expected = beauty.copy()
        del frame
        import gc
        gc.collect()
        self.assertTrue(np.array_equal(beauty, expected))


class Cancel(unittest.TestCase):
    def big_scene(self):
        scene = nimbus.load_dict(SCENE)
        scene["render.spp"] = 64
        scene.camera["resolution"] = (320, 240)  # 300 tiles of 16^2, tens of seconds uncancelled
        scene.commit()
        return scene

    def test_cancel_from_another_thread_returns_promptly(self):
        started = threading.Event()
        session = nimbus.Session(self.big_scene(), progress=lambda f: started.set())
        session.start()
        self.assertTrue(started.wait(60))
        self.assertEqual(session.state[0], "running")
        t0 = time.monotonic()
        session.cancel()
        with self.assertRaises(nimbus.Cancelled) as caught:
            session.wait()
        elapsed = time.monotonic() - t0
        self.assertEqual(caught.exception.status, "NIMBUS_ERROR_CANCELLED")
        self.assertLess(elapsed, 2.0)  # one tile of 16^2 pixels x 64 samples per thread
        self.assertEqual(session.state[0], "failed")

    def test_progress_returning_false_cancels(self):
        calls = []

        def progress(fraction):
            calls.append(fraction)
            return False

        t0 = time.monotonic()
        with self.assertRaises(nimbus.Cancelled):
            nimbus.render(self.big_scene(), progress=progress)
        self.assertLess(time.monotonic() - t0, 10.0)
        self.assertLess(len(calls), 10)

    def test_exception_in_progress_propagates(self):
        def progress(fraction):
            raise KeyError("from the callback")

        with self.assertRaises(KeyError):
            nimbus.render(self.big_scene(), progress=progress)

    def test_busy(self):
        gate = threading.Event()
        entered = threading.Event()

        def progress(fraction):
            entered.set()
            gate.wait(60)

        session = nimbus.Session(self.big_scene(), progress=progress)
        session.start()
        self.assertTrue(entered.wait(60))
        with self.assertRaises(nimbus.Error) as caught:
            session.start()
        self.assertEqual(caught.exception.status, "NIMBUS_ERROR_BUSY")
        self.assertFalse(session.wait(0.01))
        session.cancel()
        gate.set()
        with self.assertRaises(nimbus.Cancelled):
            session.wait()


class Volumes(unittest.TestCase):
    def scene_with(self, volume):
        scene = nimbus.load_dict({k: v for k, v in SCENE.items() if k != "volumes"})
        scene.add(volume)
        scene.commit()
        return scene

    def test_pyopenvdb_grid_renders_like_its_file(self):
        import pyopenvdb as vdb
        grid = vdb.createLevelSetSphere(radius=1.0, voxelSize=0.05)
        grid.transform = vdb.createLinearTransform(voxelSize=0.05)
        dense = np.zeros((48, 48, 48), dtype=np.float32)
        grid.copyToArray(dense, ijk=(-24, -24, -24))
        fog = vdb.FloatGrid()
        fog.copyFromArray(np.clip(-dense / 0.1, 0.0, 1.0).astype(np.float32), ijk=(-24, -24, -24))
        fog.transform = vdb.createLinearTransform(voxelSize=0.05)
        self.assertEqual(fog.name, "")  # an unnamed grid: named after its role on the copy
        medium = {"medium.sigma_s": 3}
        from_grid = nimbus.render(self.scene_with(nimbus.Volume.from_grid(fog, medium)))
        self.assertEqual(fog.name, "")
        self.assertGreater(from_grid["alpha"].max(), 0.5)
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "ball.vdb")
            fog.name = "density"
            vdb.write(path, grids=[fog])
            from_file = nimbus.render(self.scene_with(nimbus.Volume("vdb", {"source.file": path, **medium})))
        assert_same_frames(self, from_grid, from_file)

    @unittest.skipUnless(TORUS_PLUGIN, "NIMBUS_TORUS_PLUGIN not set")
    def test_plugin_volume(self):
        torus = nimbus.Volume("plugin", {"source.path": TORUS_PLUGIN, "source.params.voxel_size": 0.04,
                                         "source.params.seed": 3, "medium.sigma_s": 6})
        frame = nimbus.render(self.scene_with(torus))
        self.assertGreater(frame["alpha"].max(), 0.5)
        bad = nimbus.Volume("plugin", {"source.path": TORUS_PLUGIN, "source.params.octaves": 99})
        with self.assertRaises(nimbus.InputError) as caught:
            nimbus.render(self.scene_with(bad))
        self.assertIn("volumes[0].source.path: libnimbus_torus.so: init failed", str(caught.exception))

    def test_base_dir_anchors_relative_vdb_paths(self):
        import pyopenvdb as vdb
        with tempfile.TemporaryDirectory() as tmp:
            grid = vdb.FloatGrid()
            grid.name = "density"
            grid.fill((-4, -4, -4), (4, 4, 4), 1.0)
            grid.transform = vdb.createLinearTransform(voxelSize=0.1)
            vdb.write(os.path.join(tmp, "cube.vdb"), grids=[grid])
            doc = dict(SCENE, volumes=[{"source": {"type": "vdb", "file": "cube.vdb"}}])
            frame = nimbus.render(nimbus.load_dict(doc, base_dir=tmp))
            self.assertGreater(frame["alpha"].max(), 0.3)
            with self.assertRaises(nimbus.InputError):
                nimbus.render(nimbus.load_dict(doc))  # relative to the working directory: not there


class Errors(unittest.TestCase):
    def test_parameter_errors(self):
        scene = nimbus.Scene()
        cases = [
            (lambda: scene.set("render.sp", 2), "NIMBUS_ERROR_UNKNOWN_PARAMETER", "did you mean 'spp'"),
            (lambda: scene.camera.set("fov", "wide"), "NIMBUS_ERROR_WRONG_TYPE", "camera.fov: expected a number"),
            (lambda: scene.camera.set("fov", 190), "NIMBUS_ERROR_BAD_INPUT", "camera.fov: must be in (0, 180)"),
            (lambda: nimbus.Light("spot", cone_angle=-3), "NIMBUS_ERROR_BAD_INPUT", "light.cone_angle"),
            (lambda: nimbus.Light("distant", enabled=True), "NIMBUS_ERROR_UNKNOWN_PARAMETER", "light.enabled"),
            (lambda: scene.set("render.spp", True), "NIMBUS_ERROR_WRONG_TYPE", "render.spp"),
            (lambda: nimbus.load_dict({"render": {"method": "raytrace"}}), "NIMBUS_ERROR_BAD_INPUT", "render.method"),
        ]
        for call, status, text in cases:
            with self.assertRaises(nimbus.InputError) as caught:
                call()
            self.assertIsInstance(caught.exception, ValueError)
            self.assertEqual(caught.exception.status, status)
            self.assertIn(text, str(caught.exception))
        with self.assertRaises(TypeError):
            scene.set("render.spp", object())
        with self.assertRaises(nimbus.Error) as caught:
            nimbus.render(nimbus.Scene(), commit=False)
        self.assertEqual(caught.exception.status, "NIMBUS_ERROR_NOT_COMMITTED")


if __name__ == "__main__":
    print("nimbus", nimbus.__version__, "from", nimbus.__file__, "python", sys.version.split()[0])
    unittest.main(verbosity=2)
