"""Settings (scene.nimbus), preferences and the Render Properties panel."""
import bpy

from . import backend


class NimbusPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    python_path: bpy.props.StringProperty(
        name="Python module directory",
        description="Directory holding nimbus.cpython-311-*.so (build/python); empty: as installed",
        subtype="DIR_PATH",
    )
    cli_path: bpy.props.StringProperty(
        name="nimbus executable",
        description="The nimbus command line (build/bin/nimbus); empty: as installed, then $PATH",
        subtype="FILE_PATH",
    )

    def draw(self, context):
        self.layout.prop(self, "python_path")
        self.layout.prop(self, "cli_path")
        self.layout.label(text="Found: " + backend.describe())


class NimbusSettings(bpy.types.PropertyGroup):
    method: bpy.props.EnumProperty(
        name="Method",
        items=[
            ("single", "Single scattering", "Emission and single scattering with deep shadow maps"),
            ("wkb", "WKB multiple scattering", "Adds Tessendorf's multiple-scattering term"),
            ("pathtrace", "Path tracing", "Unbiased OpenCL reference"),
        ],
        default="single",
    )
    spp: bpy.props.IntProperty(name="Samples", default=0, min=0, soft_max=1024,
                               description="Camera samples per pixel (path samples for path tracing); 0: the "
                               "method's default (4; path tracing: until the noise target)")
    adaptive_threshold: bpy.props.FloatProperty(
        name="Adaptive threshold", default=0.05, min=0.0, max=1.0, precision=3,
        description="Single and WKB: a pixel whose mean has a relative standard error above this takes more "
        "samples, up to Adaptive max samples (0: every pixel takes Samples)")
    adaptive_max_spp: bpy.props.IntProperty(name="Adaptive max samples", default=0, min=0, soft_max=4096,
                                            description="Single and WKB: the most samples a pixel takes "
                                            "(0: 4 x Samples)")
    seed: bpy.props.IntProperty(name="Seed", default=1, min=0)
    step: bpy.props.FloatProperty(name="Step", default=0.5, min=0.001, max=100.0,
                                  description="March step, as a fraction of the smallest voxel")
    shadow_map_resolution: bpy.props.IntProperty(name="Shadow map resolution", default=256, min=8, max=16384)
    max_depth: bpy.props.IntProperty(name="Max depth", default=0, min=0,
                                     description="Path tracing: longest path in scattering events (0: unbounded)")
    threads: bpy.props.IntProperty(name="Threads", default=0, min=0, description="0: all cores")
    backend: bpy.props.EnumProperty(
        name="Backend",
        items=[
            ("AUTO", "Automatic", "The Python module if it loads, else the command line"),
            ("MODULE", "Python module", "Render inside Blender through the nimbus module"),
            ("CLI", "Command line", "Run the nimbus executable on the exported scene"),
        ],
        default="AUTO",
    )
    export_json: bpy.props.StringProperty(
        name="Export scene", subtype="FILE_PATH",
        description="Also write the rendered scene here as nimbus JSON (for `nimbus render` on a farm)",
    )


class NIMBUS_PT_render(bpy.types.Panel):
    bl_label = "nimbus"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {"NIMBUS"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        s = context.scene.nimbus
        col = self.layout.column()
        for name in ("method", "spp", "adaptive_threshold", "adaptive_max_spp", "seed", "step", "shadow_map_resolution", "max_depth", "threads",
                     "backend", "export_json"):
            col.prop(s, name)


# Blender's own panels that apply unchanged (dimensions, output, colour management, passes).
def _compatible_panels():
    names = ("RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_output", "RENDER_PT_color_management",
             "VIEWLAYER_PT_layer_passes", "DATA_PT_lens", "DATA_PT_camera", "DATA_PT_light", "DATA_PT_EEVEE_light",
             "DATA_PT_volume_file", "DATA_PT_volume_grids", "MATERIAL_PT_preview")
    return [getattr(bpy.types, n) for n in names if hasattr(bpy.types, n)]


classes = (NimbusPreferences, NimbusSettings, NIMBUS_PT_render)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.nimbus = bpy.props.PointerProperty(type=NimbusSettings)
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES.add("NIMBUS")


def unregister():
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES.discard("NIMBUS")
    del bpy.types.Scene.nimbus
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
