"""The Blender add-on end to end, run by ctest with Debian's /usr/bin/python3:

1. installs the add-on with scripts/install-blender-addon.sh into a private Blender user
   directory (BLENDER_USER_SCRIPTS / BLENDER_USER_CONFIG: the machine's Blender is untouched);
2. `blender -b --factory-startup --python blender_scene.py` enables it, builds a scene with a VDB
   volume and a sun, renders it with nimbus by each method (single, wkb, pathtrace) and writes
   the scene it rendered as JSON;
3. `nimbus render` renders each JSON;
4. the two images must agree: Blender keeps the float render, the CLI's EXR stores colour as
   half, so Blender's floats rounded to half must equal the CLI's halves exactly (the same
   scene, seed and renderer give the same floats; the only rounding is the EXR's).

Usage: test_blender_addon.py BLENDER NIMBUS_CLI BUILD_DIR SOURCE_DIR"""
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_blender_addon_lib import read_layers, smoke_vdb  # noqa: E402

blender, cli, build_dir, source_dir = sys.argv[1:5]
passed = failed = 0


def check(condition, what):
    global passed, failed
    if condition:
        passed += 1
    else:
        failed += 1
        print("FAILED:", what)


def run(cmd, env=None):
    t0 = time.monotonic()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        print(proc.stdout[-4000:], proc.stderr[-4000:])
        sys.exit("command failed (%d): %s" % (proc.returncode, " ".join(cmd)))
    return proc, time.monotonic() - t0


with tempfile.TemporaryDirectory(prefix="nimbus-blender-test-") as tmp:
    env = dict(os.environ, BLENDER=blender, BLENDER_USER_SCRIPTS=os.path.join(tmp, "scripts"),
               BLENDER_USER_CONFIG=os.path.join(tmp, "config"))
    smoke = os.path.join(tmp, "smoke.vdb")
    smoke_vdb(smoke)
    smoke_vdb(os.path.join(tmp, "fire.vdb"), fire=True)

    _, t_install = run(["bash", os.path.join(source_dir, "scripts", "install-blender-addon.sh"), build_dir], env)
    installed = os.path.join(tmp, "scripts", "addons", "nimbus_blender")
    check(os.path.isfile(os.path.join(installed, "__init__.py")), "add-on installed in BLENDER_USER_SCRIPTS")
    with open(os.path.join(installed, "paths.json")) as f:
        check(json.load(f)["cli"] == os.path.join(build_dir, "bin", "nimbus"), "paths.json names this build")

    proc, t_blender = run([blender, "-b", "--factory-startup", "--python",
                           os.path.join(source_dir, "tests", "blender", "blender_scene.py"), "--", tmp, smoke], env)
    log = proc.stdout + proc.stderr
    main_log, _, extra_log = log.partition("blender_scene: rendered pathtrace")
    check("nimbus: " not in main_log, "no nimbus warning or error in Blender's log (single, wkb, pathtrace)")
    check("nimbus: motion blur is not supported" in extra_log, "Blender's motion blur is reported as ignored")
    # Blender prints an engine's reports as "Warning: ..." / "Error: ..." (nimbus's own info lines,
    # such as a shader's compile time, are not reports).
    extra_warnings = sorted({line.strip() for line in extra_log.splitlines()
                             if line.startswith(("Warning: nimbus: ", "Error: nimbus: "))})
    check(len(extra_warnings) == 1, "no other warning in the opaque and fire renders: %s" % extra_warnings)

    with open(os.path.join(tmp, "scene_single.json")) as f:
        doc = json.load(f)
    check([l["type"] for l in doc["lights"]] == ["distant"], "one sun exported as a distant light")
    medium = doc["volumes"][0]["medium"]
    # Principled Volume -> medium (docs/embedding.md): sigma_s = Color, sigma_a = (1 - Color)(1 - sqrt(Absorption)).
    check(np.allclose(medium["sigma_s"], [0.8, 0.7, 0.6]), "sigma_s = Color")
    check(np.allclose(medium["sigma_a"], [(1 - 0.8) * (1 - 0.2 ** 0.5), (1 - 0.7) * (1 - 0.3 ** 0.5),
                                          (1 - 0.6) * (1 - 0.4 ** 0.5)], rtol=1e-6), "sigma_a from Absorption Color")
    # Density 3 per object-space unit (the volume's default render space) of an object scaled 1.2.
    check(abs(medium["density_scale"] - 3.0 / 1.2) < 1e-6 and abs(medium["phase"]["g"] - 0.3) < 1e-6,
          "density (object space) and anisotropy")

    t_cli = 0.0
    for method, orders in (("single", ["L0", "L1"]), ("wkb", ["L0", "L1", "L2plus"]),
                           ("pathtrace", ["L0", "L1", "L2plus"])):
        check("blender_scene: rendered %s" % method in proc.stdout, "Blender rendered with %s" % method)
        cli_exr = os.path.join(tmp, "cli_%s.exr" % method)
        _, t = run([cli, "render", os.path.join(tmp, "scene_%s.json" % method), "-o", cli_exr])
        t_cli += t
        mine = read_layers(os.path.join(tmp, "blender_%s.exr" % method))
        theirs = read_layers(cli_exr)
        combined = mine["ViewLayer.Combined"]
        check(combined.shape == (48, 64, 4), "Combined is 64 x 48 RGBA")
        check(combined[..., 3].max() > 0.5 and combined[..., :3].max() > 0.0, "the volume is visible and lit")
        pairs = [("Combined", "beauty")] + [(o, o) for o in orders] + [("light_key", "light_key")]
        for blender_layer, nimbus_layer in pairs:
            blender_layer = "ViewLayer." + blender_layer
            check(blender_layer in mine, "%s: pass %s in Blender's render" % (method, blender_layer))
            if blender_layer not in mine:
                continue
            a = mine[blender_layer].astype(np.float16).astype(np.float32)
            b = theirs[nimbus_layer]
            diff = float(np.abs(a - b).max())
            print("%-9s %-20s vs CLI %-9s max |difference| after rounding to half: %g" %
                  (method, blender_layer, nimbus_layer, diff))
            check(np.array_equal(a, b), "%s: %s equals the CLI's %s" % (method, blender_layer, nimbus_layer))
        # Depth is float in both files: equal as floats where the ray met the volume; Cycles'
        # 1e10 where it met nothing (nimbus writes 0 there).
        depth = mine.get("ViewLayer.Depth")
        expected = np.where(theirs["depth"][..., 0] > 0.0, theirs["depth"][..., 0], np.float32(1e10))
        check(depth is not None and np.array_equal(depth[..., 0], expected),
              "%s: Depth equals the CLI's depth, 1e10 on the background" % method)
        check(depth is not None and (theirs["depth"][..., 0] == 0.0).any(), "%s: some pixels see no volume" % method)

    # Film > Transparent off: alpha 1 everywhere, the colour unchanged.
    _, t = run([cli, "render", os.path.join(tmp, "scene_opaque.json"), "-o", os.path.join(tmp, "cli_opaque.exr")])
    mine = read_layers(os.path.join(tmp, "blender_opaque.exr"))["ViewLayer.Combined"]
    theirs = read_layers(os.path.join(tmp, "cli_opaque.exr"))["beauty"]
    check(np.all(mine[..., 3] == 1.0), "Film > Transparent off: Combined alpha is 1 everywhere")
    check(np.array_equal(mine[..., :3].astype(np.float16).astype(np.float32), theirs[..., :3]),
          "Film > Transparent off: Combined colour equals the CLI's beauty")

    # Fire: the flame grid (and temperature) exported, and the fire seen in L0.
    with open(os.path.join(tmp, "scene_fire.json")) as f:
        fire = json.load(f)["volumes"][0]
    check(fire["source"]["grids"].get("flame") == "flame", "the flame grid is exported (Blackbody Intensity > 0)")
    check(fire["source"]["grids"].get("temperature") == "temperature", "the temperature grid is exported")
    check(fire["medium"]["emission_scale"] == 1.0, "Blackbody Intensity is the emission scale")
    fire_l0 = read_layers(os.path.join(tmp, "blender_fire.exr"))["ViewLayer.L0"]
    smoke_l0 = read_layers(os.path.join(tmp, "blender_single.exr"))["ViewLayer.L0"]
    check(fire_l0[..., 0].max() > 10.0 * max(float(smoke_l0[..., 0].max()), 1e-6), "the fire glows in L0")

    # Geometry: the wall (collection "holdout") and the flagged triangle (Blender's holdout flag)
    # as holdouts, the block as a shadow caster only; their OBJ files beside the exported JSON.
    check("blender_scene: rendered geometry" in proc.stdout, "Blender rendered the scene with meshes")
    with open(os.path.join(tmp, "scene_geometry.json")) as f:
        geometry = {g["name"]: g for g in json.load(f).get("geometry", [])}
    check(sorted(geometry) == ["block", "flagged", "wall"], "three meshes exported: %s" % sorted(geometry))
    flags = {n: (g.get("type"), g.get("holdout"), g.get("shadows")) for n, g in geometry.items()}
    check(flags.get("wall") == ("mesh", True, True), "the wall in collection 'holdout' is a holdout: %s" % flags)
    check(flags.get("flagged") == ("mesh", True, True), "the object with Blender's holdout flag is a holdout")
    check(flags.get("block") == ("mesh", False, True), "the other mesh is a shadow caster only")
    for name, triangles in (("wall", 2), ("block", 12), ("flagged", 1)):
        path = geometry.get(name, {}).get("file", "")
        faces = 0
        if os.path.isfile(path):
            with open(path) as f:
                faces = sum(1 for line in f if line.startswith("f "))
        check(os.path.dirname(path) == os.path.join(tmp, "scene_geometry_meshes") and faces == triangles,
              "%s: %d triangles in %s" % (name, triangles, path))
    cli_exr = os.path.join(tmp, "cli_geometry.exr")
    _, t = run([cli, "render", os.path.join(tmp, "scene_geometry.json"), "-o", cli_exr])
    t_cli += t
    theirs = read_layers(cli_exr)
    mine = read_layers(os.path.join(tmp, "blender_geometry.exr"))["ViewLayer.Combined"]
    check(np.array_equal(mine.astype(np.float16).astype(np.float32), theirs["beauty"]),
          "geometry: Blender's Combined equals the CLI's beauty")
    alone = read_layers(os.path.join(tmp, "cli_single.exr"))
    held = (alone["alpha"][..., 0] > 0.05) & (theirs["alpha"][..., 0] == 0.0)
    check(held.sum() > 100, "the wall holds out the smoke behind it: %d pixels of alpha 0" % held.sum())
    check(np.all(theirs["alpha"][..., 0] <= alone["alpha"][..., 0] + 1e-6), "holdouts only take alpha away")
    seen = theirs["alpha"][..., 0] > 0.0
    l1, l1_alone = theirs["L1"][seen].sum(), alone["L1"][seen].sum()
    print("geometry: %d pixels held out by the wall; L1 %.4g with the block, %.4g without" % (held.sum(), l1, l1_alone))
    check(l1 < 0.97 * l1_alone, "the block shadows the smoke: L1 %.4g with it, %.4g without" % (l1, l1_alone))

    print("timings: install %.1f s, blender render %.1f s, nimbus render %.1f s" % (t_install, t_blender, t_cli))

print("%d passed, %d failed" % (passed, failed))
sys.exit(1 if failed else 0)
