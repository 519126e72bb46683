"""nimbus for Blender: a render engine that exports the scene to nimbus and renders it.

Install (docs/embedding.md, "Blender add-on"):  bash scripts/install-blender-addon.sh [BUILD_DIR]

The engine ("nimbus" in Render Properties > Render Engine) exports the active camera, the
lights (sun, point, spot, area) and the volume objects (OpenVDB files, with the Principled
Volume's density, colour, absorption and anisotropy mapped to a nimbus medium) to the nimbus
JSON scene format, renders it with the chosen method through the `nimbus` Python module (or
the `nimbus` command line), and returns the beauty as the Combined pass and the nimbus AOVs as
render passes (L0, L1, L2plus, light_<name>, Depth).
"""

bl_info = {
    "name": "nimbus",
    "author": "nimbus developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Render Properties > Render Engine > nimbus",
    "description": "Production volume rendering (single scattering, WKB multiple scattering, path tracing)",
    "category": "Render",
}

if "bpy" in locals():  # add-on reload
    import importlib

    importlib.reload(export)  # noqa: F821
    importlib.reload(backend)  # noqa: F821
    importlib.reload(engine)  # noqa: F821
    importlib.reload(ui)  # noqa: F821
else:
    from . import backend, engine, export, ui

import bpy  # noqa: E402


def register():
    ui.register()
    bpy.utils.register_class(engine.NimbusRenderEngine)


def unregister():
    bpy.utils.unregister_class(engine.NimbusRenderEngine)
    ui.unregister()
