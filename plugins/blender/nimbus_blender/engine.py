"""The nimbus RenderEngine: export, render, and hand the image and AOVs back to Blender."""
import json
import os
import tempfile

import bpy
import numpy as np

from . import backend, export

# nimbus AOVs that become Blender passes of their own (beauty is Combined, alpha is Combined's
# alpha, depth is Blender's Depth pass when the view layer has it).
COLOR_AOVS = ("L0", "L1", "L2plus")
# Cycles' Depth where a pixel sees nothing (nimbus writes 0 there: docs/output.md).
BACKGROUND_DEPTH = 1e10


def light_aov_names(scene):
    """The light_<name> AOVs the export will produce, in the same order (for the compositor)."""
    names = export.NameTable()
    out = []
    if export.export_world(scene.world, []) is not None:
        out.append("light_" + names("world"))
    for obj in scene.objects:
        if obj.type == "LIGHT" and not obj.hide_render:
            out.append("light_" + names(obj.name))
    return out


def seen_background(document):
    """The radiance nimbus shows behind the volumes: the environment lights' (or background)."""
    skies = [l["radiance"] for l in document.get("lights", []) if l.get("type") == "environment"]
    if not skies:
        return np.array(document.get("background", [0.0, 0.0, 0.0]), dtype=np.float32)
    return np.sum(np.array(skies, dtype=np.float32), axis=0)


def combined_pass(beauty, film_transparent, background):
    """Blender's Combined from nimbus's beauty (whose colour holds the background seen through the
    volumes, T * background, and whose alpha is the coverage 1 - mean T).
    Film > Transparent off: opaque, as Cycles writes it (alpha 1, the background in the colour).
    On: Cycles leaves the world out of the colour; the background's share is taken out again as
    (1 - alpha) * background, exact for grey media and within the spread of T over the channels
    for chromatic ones."""
    out = np.array(beauty, dtype=np.float32, copy=True)
    if not film_transparent:
        out[..., 3] = 1.0
    elif np.any(background > 0.0):
        out[..., :3] -= (1.0 - out[..., 3:4]) * background
        np.maximum(out[..., :3], 0.0, out=out[..., :3])
    return out


def depth_pass(depth):
    """Blender's Depth: nimbus's depth, with Cycles' 1e10 where the ray met nothing."""
    return np.where(depth > 0.0, depth, np.float32(BACKGROUND_DEPTH)).astype(np.float32)


def to_blender(pixels):
    """nimbus rows run from the top, Blender's from the bottom; passes are (pixels, channels)."""
    channels = 1 if pixels.ndim == 2 else pixels.shape[2]
    return np.ascontiguousarray(np.flipud(pixels).reshape(-1, channels))


class NimbusRenderEngine(bpy.types.RenderEngine):
    bl_idname = "NIMBUS"
    bl_label = "nimbus"
    bl_use_preview = False
    bl_use_shading_nodes_custom = False  # materials are node trees (Principled Volume)
    bl_use_postprocess = True

    def render(self, depsgraph):
        settings = depsgraph.scene.nimbus
        warnings = []
        # Mesh objects become OBJ files (export.export_mesh): beside the exported JSON when there is
        # one, so that `nimbus render` of it finds them; else in a directory removed after the render.
        json_path = bpy.path.abspath(settings.export_json) if settings.export_json else ""
        scratch = None
        if json_path:
            mesh_dir = os.path.splitext(json_path)[0] + "_meshes"
        else:
            scratch = tempfile.TemporaryDirectory(prefix="nimbus-blender-meshes-")
            mesh_dir = scratch.name
        try:
            self._render(depsgraph, settings, json_path, mesh_dir, warnings)
        finally:
            if scratch is not None:
                scratch.cleanup()

    def _render(self, depsgraph, settings, json_path, mesh_dir, warnings):
        scene = depsgraph.scene
        try:
            document = export.scene_document(depsgraph, warnings, mesh_dir=mesh_dir)
        except export.ExportError as e:
            self.report({"ERROR"}, "nimbus: " + str(e))
            return
        for w in warnings:
            self.report({"WARNING"}, "nimbus: " + w)
        if json_path:
            os.makedirs(os.path.dirname(json_path) or ".", exist_ok=True)
            with open(json_path, "w") as f:
                json.dump(document, f, indent=2)

        self.update_stats("", "nimbus rendering (%s)" % settings.method)
        try:
            aovs = backend.render(document, settings.backend, progress=self.update_progress,
                                  test_break=self.test_break)
        except backend.RenderError as e:
            self.report({"ERROR"}, "nimbus: " + str(e))
            return
        if aovs is None:  # cancelled
            return

        width, height = document["camera"]["resolution"]
        extra = [n for n in aovs if n in COLOR_AOVS or n.startswith("light_") or n == "variance"]
        for name in extra:
            channels = 1 if aovs[name].ndim == 2 else aovs[name].shape[2]
            self.add_pass(name, channels, "RGB" if channels == 3 else "X")
        result = self.begin_result(0, 0, width, height)
        layer = result.layers[0]
        combined = combined_pass(aovs["beauty"], scene.render.film_transparent, seen_background(document))
        layer.passes["Combined"].rect = to_blender(combined)
        depth = layer.passes.get("Depth")
        if depth is not None and "depth" in aovs:
            depth.rect = to_blender(depth_pass(aovs["depth"]))
        for name in extra:
            layer.passes[name].rect = to_blender(aovs[name])
        self.end_result(result)

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        if renderlayer.use_pass_z:
            self.register_pass(scene, renderlayer, "Depth", 1, "Z", "VALUE")
        names = ["L0", "L1"] + (["L2plus"] if scene.nimbus.method != "single" else [])
        for name in names + light_aov_names(scene):
            self.register_pass(scene, renderlayer, name, 3, "RGB", "COLOR")
        if scene.nimbus.method == "pathtrace":
            self.register_pass(scene, renderlayer, "variance", 1, "X", "VALUE")
