"""The nimbus RenderEngine: export, render, and hand the image and AOVs back to Blender."""
import json
import os

import bpy
import numpy as np

from . import backend, export

# nimbus AOVs that become Blender passes of their own (beauty is Combined, alpha is Combined's
# alpha, depth is Blender's Depth pass when the view layer has it).
COLOR_AOVS = ("L0", "L1", "L2plus")


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
        scene = depsgraph.scene
        settings = scene.nimbus
        warnings = []
        try:
            document = export.scene_document(depsgraph, warnings)
        except export.ExportError as e:
            self.report({"ERROR"}, "nimbus: " + str(e))
            return
        for w in warnings:
            self.report({"WARNING"}, "nimbus: " + w)
        if settings.export_json:
            path = bpy.path.abspath(settings.export_json)
            os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
            with open(path, "w") as f:
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
        layer.passes["Combined"].rect = to_blender(aovs["beauty"])
        depth = layer.passes.get("Depth")
        if depth is not None and "depth" in aovs:
            depth.rect = to_blender(aovs["depth"])
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
