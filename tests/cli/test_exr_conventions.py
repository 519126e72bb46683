#!/usr/bin/python3
"""The EXR a render leaves, read as a compositor reads it (issue 17, items 3 and 4): the main layer
R, G, B, A and a single Z; the scene, the camera matrices and the statistics in the header;
checkpoints under a name that says so; the preview's OCIO config, view, look and exposure checked
before anything is written.

Run by ctest with Debian's python3 (OpenImageIO's bindings):
    test_exr_conventions.py NIMBUS_BINARY [-k NAME]
"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np
import OpenImageIO as oiio

NIMBUS = None
SHIPPED_CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "src", "io", "ocio",
                              "config.ocio")


def run(*args, env=None):
    p = subprocess.run([NIMBUS, *args], capture_output=True, text=True, timeout=600, env=env)
    return p.returncode, p.stdout, p.stderr


def env_without_ocio(**extra):
    env = {k: v for k, v in os.environ.items() if k not in ("OCIO", "NIMBUS_OCIO_CONFIG")}
    env.update(extra)
    return env


def small_scene(**overrides):
    scene = {
        "camera": {"from": [1.5, 1.0, 6], "to": [0.2, 0, 0], "up": [0, 1, 0], "fov": 40, "resolution": [48, 32]},
        "lights": [{"name": "key", "type": "distant", "direction": [0.3, -1, -0.2], "irradiance": [2, 2, 2]}],
        "volumes": [{"name": "ball", "source": {"type": "procedural", "generator": "sphere", "radius": 1.0,
                                                "voxel_size": 0.1},
                     "medium": {"sigma_s": [2, 2, 2], "sigma_a": [0.1, 0.1, 0.1]}}],
        "render": {"method": "single", "spp": 1},
    }
    scene.update(overrides)
    return scene


def read_exr(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    spec = inp.spec()
    pixels = np.asarray(inp.read_image(oiio.FLOAT))
    inp.close()
    return spec, pixels


def attribute(spec, name):
    """By name, ignoring case: OpenImageIO writes "worldtocamera" as OpenEXR's "worldToCamera"."""
    for a in spec.extra_attribs:
        if a.name.lower() == name.lower():
            return a
    return None


def read_png(path):
    inp = oiio.ImageInput.open(path)
    assert inp, oiio.geterror()
    pixels = np.asarray(inp.read_image(oiio.UINT8)).astype(np.int32)
    inp.close()
    return pixels


def project(m44, p):
    """p (x, y, z, 1) M with OpenEXR's row vectors, divided by w."""
    m = np.asarray(m44, dtype=np.float64).reshape(4, 4)
    q = np.array([p[0], p[1], p[2], 1.0]) @ m
    return q[:3] / q[3]


class ExrConventions(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.d = self.dir.name
        self.out = os.path.join(self.d, "frame.exr")

    def tearDown(self):
        self.dir.cleanup()

    def scene_file(self, scene, name="scene.json"):
        scene.setdefault("output", {}).setdefault("file", self.out)
        path = os.path.join(self.d, name)
        with open(path, "w") as f:
            json.dump(scene, f)
        return path

    def render(self, scene, *args, env=None):
        code, out, err = run("render", self.scene_file(scene), "-q", *args, env=env)
        self.assertEqual(code, 0, err)
        return read_exr(scene["output"]["file"])

    def expect_bad_input(self, args, *fragments, env=None):
        code, _, err = run(*args, env=env)
        self.assertEqual(code, 2, f"exit code for {args}: {code}\n{err}")
        lines = [l for l in err.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, f"one error line expected, got:\n{err}")
        for fragment in fragments:
            self.assertIn(fragment, lines[0])
        self.assertEqual(sorted(os.listdir(self.d)), ["scene.json"], "nothing may be written")
        return lines[0]

    # Channels: A and Z in the main layer, once each, and per-AOV layers one channel per scalar.
    def test_main_layer_has_a_single_a_and_z(self):
        spec, px = self.render(small_scene())
        names = list(spec.channelnames)
        for single in ("R", "G", "B", "A", "Z", "alpha.A", "depth.Z"):
            self.assertEqual(names.count(single), 1, f"{single} in {names}")
        for gone in ("alpha.R", "alpha.G", "alpha.B", "depth.R", "depth.G", "depth.B"):
            self.assertNotIn(gone, names)
        for layer in ("beauty", "L0", "L1", "light_key"):
            for c in "RGB":
                self.assertIn(f"{layer}.{c}", names)
        formats = list(spec.channelformats) or [spec.format] * len(names)
        self.assertEqual(formats[names.index("A")], oiio.HALF)
        self.assertEqual(formats[names.index("R")], oiio.HALF)
        self.assertEqual(formats[names.index("Z")], oiio.FLOAT)
        self.assertEqual(formats[names.index("depth.Z")], oiio.FLOAT)

    def test_compositing_read_takes_alpha_from_a_and_depth_from_z(self):
        spec, px = self.render(small_scene())
        names = list(spec.channelnames)
        self.assertEqual(names[spec.alpha_channel], "A")
        self.assertEqual(names[spec.z_channel], "Z")
        alpha, depth = px[..., spec.alpha_channel], px[..., spec.z_channel]
        self.assertGreater(float(alpha.max()), 0.5, "the ball covers pixels")
        np.testing.assert_allclose(alpha, px[..., names.index("alpha.A")], atol=2.0 ** -11)
        np.testing.assert_array_equal(depth, px[..., names.index("depth.Z")])
        covered = alpha > 0.5
        # The ball (radius 1) is about 6.1 m from the eye.
        self.assertTrue(np.all((depth[covered] > 4.0) & (depth[covered] < 7.5)), depth[covered])

    # The header: the scene, the statistics, whether it is complete.
    def test_scene_json_in_the_header_is_the_scene(self):
        scene = small_scene()
        spec, px = self.render(scene)
        header = json.loads(spec.get_string_attribute("nimbus:scene"))
        self.assertEqual(header["camera"]["resolution"], [48, 32])
        self.assertEqual(header["camera"]["from"], [1.5, 1.0, 6])
        self.assertEqual(header["lights"][0]["name"], "key")
        self.assertEqual(header["render"]["method"], "single")
        self.assertEqual(header["render"]["spp"], 1)
        self.assertEqual(header["output"]["file"], self.out)
        self.assertEqual(spec.get_string_attribute("nimbus:scene_file"), os.path.join(self.d, "scene.json"))
        # The header's scene is the whole document: rendered again it gives the same image and the
        # same scene.
        again = os.path.join(self.d, "again.exr")
        code, _, err = run("render", self.scene_file(header, "again.json"), "-q", "-o", again)
        self.assertEqual(code, 0, err)
        spec2, px2 = read_exr(again)
        np.testing.assert_array_equal(px, px2)
        header2 = json.loads(spec2.get_string_attribute("nimbus:scene"))
        header2["output"]["file"] = self.out
        self.assertEqual(header2, header)

    def test_statistics_and_complete_flag(self):
        spec, _ = self.render(small_scene(render={"method": "single", "spp": 3}))
        self.assertEqual(spec.get_int_attribute("nimbus:complete", -1), 1)
        self.assertEqual(spec.get_int_attribute("nimbus:spp", -1), 3)
        self.assertEqual(attribute(spec, "nimbus:samples").value, 3 * 48 * 32)
        self.assertGreater(attribute(spec, "nimbus:memory_peak_bytes").value, 1e6)
        self.assertGreater(float(spec.get_string_attribute("nimbus:render_time")), 0.0)

    # The camera: a world point projected with worldToNDC lands where the renderer draws it.
    def test_camera_matrices_place_a_point_at_its_pixel(self):
        centre = [0.8, -0.4, 0.3]
        scene = small_scene()
        scene["camera"]["resolution"] = [96, 64]
        scene["volumes"][0]["source"]["radius"] = 0.15
        scene["volumes"][0]["source"]["voxel_size"] = 0.02
        scene["volumes"][0]["transform"] = {"translate": centre}
        scene["volumes"][0]["medium"]["sigma_s"] = [40, 40, 40]
        spec, px = self.render(scene)
        to_camera = attribute(spec, "worldtocamera")
        to_ndc = attribute(spec, "worldtoNDC")
        self.assertIsNotNone(to_camera)
        self.assertIsNotNone(to_ndc)
        self.assertEqual(str(to_camera.type), "matrix")
        self.assertEqual(str(to_ndc.type), "matrix")
        # worldToCamera: the eye at the origin, the point looked at on +z at its distance.
        eye, target = np.array(scene["camera"]["from"]), np.array(scene["camera"]["to"])
        np.testing.assert_allclose(project(to_camera.value, eye), [0, 0, 0], atol=1e-5)
        np.testing.assert_allclose(project(to_camera.value, target), [0, 0, np.linalg.norm(target - eye)], atol=1e-5)
        # worldToNDC: the ball's centre against the alpha-weighted centroid of its image.
        alpha = px[..., spec.alpha_channel]
        ys, xs = np.mgrid[0:alpha.shape[0], 0:alpha.shape[1]]
        centroid = np.array([(alpha * (xs + 0.5)).sum(), (alpha * (ys + 0.5)).sum()]) / alpha.sum()
        ndc = project(to_ndc.value, centre)
        pixel = np.array([ndc[0] * spec.full_width, ndc[1] * spec.full_height])
        self.assertLess(np.linalg.norm(pixel - centroid), 1.0, f"projected {pixel}, rendered at {centroid}")

    # Checkpoints: <stem>.partial.exr with nimbus:complete 0, the final name only at the end.
    def pathtrace_scene(self, spp):
        scene = small_scene(render={"method": "pathtrace", "spp": spp})
        scene["camera"]["resolution"] = [32, 24]
        return scene

    def test_checkpoints_are_partial_files_removed_at_the_end(self):
        scene = self.pathtrace_scene(400)
        code, _, err = run("render", self.scene_file(scene), "--checkpoint", "0.02")
        self.assertEqual(code, 0, err)
        partial = os.path.join(self.d, "frame.partial.exr")
        self.assertIn("checkpoint written to " + partial, err)
        self.assertFalse(os.path.exists(partial), "the stale checkpoint is removed once the frame is complete")
        spec, _ = read_exr(self.out)
        self.assertEqual(spec.get_int_attribute("nimbus:complete", -1), 1)
        self.assertEqual(spec.get_int_attribute("nimbus:spp", -1), 400)

    def test_sigterm_leaves_no_finished_looking_frame(self):
        scene = self.pathtrace_scene(1000000)
        partial = os.path.join(self.d, "frame.partial.exr")
        proc = subprocess.Popen([NIMBUS, "render", self.scene_file(scene), "-q", "--checkpoint", "0.05"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            deadline = time.time() + 300
            while not os.path.exists(partial) and time.time() < deadline and proc.poll() is None:
                time.sleep(0.05)
            self.assertTrue(os.path.exists(partial), "no checkpoint appeared")
            time.sleep(0.2)
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        self.assertEqual(proc.returncode, -signal.SIGTERM)
        self.assertFalse(os.path.exists(self.out), "a killed render left a file at the final name")
        spec, _ = read_exr(partial)
        self.assertEqual(spec.get_int_attribute("nimbus:complete", -1), 0)
        spp = spec.get_int_attribute("nimbus:spp", -1)
        self.assertGreater(spp, 0)
        self.assertLess(spp, 1000000)
        self.assertEqual([n for n in os.listdir(self.d) if "nimbus-tmp" in n], [], "a temporary file was left")

    # OCIO: a missing or broken config, or a view or look it lacks, is bad input before any output.
    def preview_scene(self, **output):
        scene = small_scene()
        scene["output"] = {"file": self.out, "preview": os.path.join(self.d, "frame.png"), **output}
        return scene

    def test_missing_ocio_config_is_bad_input_before_any_output(self):
        line = self.expect_bad_input(["render", self.scene_file(self.preview_scene())], "scene.json",
                                     "output.preview", "/nonexistent", "$OCIO", env=env_without_ocio(OCIO="/nonexistent"))
        self.assertIn("cannot load OCIO config", line)

    def test_broken_ocio_config_is_bad_input(self):
        broken = os.path.join(tempfile.gettempdir(), "nimbus-broken-%d.ocio" % os.getpid())
        with open(broken, "w") as f:
            f.write("ocio_profile_version: 2\nroles: [this is not a config\n")
        try:
            self.expect_bad_input(["render", self.scene_file(self.preview_scene())], "output.preview", broken,
                                  env=env_without_ocio(OCIO=broken))
        finally:
            os.remove(broken)

    def test_unknown_view_names_the_key_and_the_views(self):
        self.expect_bad_input(["render", self.scene_file(self.preview_scene(preview_view="Foo"))],
                              "scene.json: output.preview_view: 'Foo' is not a view of display 'sRGB' in OCIO config",
                              "'ACES 1.0 - SDR Video', 'Standard', 'Raw'", env=env_without_ocio())
        os.remove(os.path.join(self.d, "scene.json"))
        self.expect_bad_input(["render", self.scene_file(self.preview_scene()), "--preview-view", "Foo"],
                              "output.preview_view: 'Foo'", env=env_without_ocio())

    def test_unknown_look_names_the_key(self):
        self.expect_bad_input(["render", self.scene_file(self.preview_scene()), "--preview-look", "Warm"],
                              "output.preview_look: 'Warm' is not a look in OCIO config", "(looks: none)",
                              env=env_without_ocio())

    def test_bad_exposure_is_bad_input(self):
        self.expect_bad_input(["render", self.scene_file(self.preview_scene()), "--exposure", "lots"],
                              "output.exposure")
        os.remove(os.path.join(self.d, "scene.json"))
        self.expect_bad_input(["render", self.scene_file(self.preview_scene(exposure=100))], "output.exposure")

    # Exposure and look, through the Raw view (no transform: the PNG holds the scaled linear
    # values) and against oiiotool's own OCIO display transform.
    def preview_pixels(self, *args, env=None):
        png = os.path.join(self.d, "frame.png")
        code, _, err = run("render", self.scene_file(self.preview_scene()), "-q", *args, env=env)
        self.assertEqual(code, 0, err)
        pixels = read_png(png)
        _, px = read_exr(self.out)
        return pixels, px

    def test_exposure_doubles_the_linear_values_before_the_view(self):
        raw0, px = self.preview_pixels("--preview-view", "Raw", env=env_without_ocio())
        raw1, _ = self.preview_pixels("--preview-view", "Raw", "--exposure", "1", env=env_without_ocio())
        linear = px[..., :3]
        self.assertGreater(float(linear.max()), 0.05)
        # 8-bit rounding plus the EXR's half rounding: within one level.
        for stops, got in ((0, raw0), (1, raw1)):
            want = np.clip(linear * 2.0 ** stops, 0, 1) * 255
            self.assertLessEqual(float(np.abs(got - want).max()), 1.0, f"exposure {stops}")

    def test_default_view_with_exposure_matches_oiiotool(self):
        got, _ = self.preview_pixels("--exposure", "1", env=env_without_ocio())
        ref = os.path.join(self.d, "ref.png")
        p = subprocess.run(["oiiotool", self.out, "--iscolorspace", "Linear Rec.709", "--ch", "R,G,B", "--mulc", "2", "--ociodisplay", "sRGB",
                            "ACES 1.0 - SDR Video", "-d", "uint8", "-o", ref],
                           capture_output=True, text=True, env=env_without_ocio(OCIO=SHIPPED_CONFIG))
        self.assertEqual(p.returncode, 0, p.stderr)
        want = read_png(ref)
        self.assertLessEqual(int(np.abs(got - want).max()), 2, "nimbus's preview against oiiotool's transform")

    def test_look_from_the_active_config(self):
        config = os.path.join(self.d, "..", os.path.basename(self.d) + "-look.ocio")
        with open(SHIPPED_CONFIG) as f:
            text = f.read()
        text += ("\nlooks:\n  - !<Look>\n    name: Warm\n    process_space: Linear Rec.709\n"
                 "    transform: !<CDLTransform> {slope: [2, 1, 1]}\n")
        with open(config, "w") as f:
            f.write(text)
        try:
            env = env_without_ocio(OCIO=config)
            plain, px = self.preview_pixels("--preview-view", "Raw", env=env)
            warm, _ = self.preview_pixels("--preview-view", "Raw", "--preview-look", "Warm", env=env)
        finally:
            os.remove(config)
        want = np.clip(px[..., 0] * 2.0, 0, 1) * 255
        self.assertLessEqual(float(np.abs(warm[..., 0] - want).max()), 1.0, "the look doubles red")
        np.testing.assert_array_equal(warm[..., 1:], plain[..., 1:])


if __name__ == "__main__":
    NIMBUS = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
