"""Blender scene -> nimbus scene document (the JSON format of docs/scene-format.md, as a dict).

Everything is exported in Blender units, which nimbus reads as metres (Cycles does the same:
its coefficients are per scene unit). The light and medium conversions follow Cycles 3.4, so
that a scene lit and shaded for Cycles renders with the same radiometry in nimbus; the table
with the reasoning is in docs/embedding.md, "Parameter mapping".
"""
import math
import os
import re

import bpy

# Cycles' Principled Volume defaults (a volume object without a material renders with these).
PRINCIPLED_DEFAULTS = {
    "Color": (0.5, 0.5, 0.5),
    "Density": 1.0,
    "Anisotropy": 0.0,
    "Absorption Color": (0.0, 0.0, 0.0),
    "Density Attribute": "density",
    "Temperature Attribute": "temperature",
    "Blackbody Intensity": 0.0,
    "Emission Strength": 0.0,
}


class ExportError(Exception):
    """A scene nimbus cannot render as asked (shown to the user as the render's error)."""


def _vec(v):
    return [float(v[0]), float(v[1]), float(v[2])]


def _rgb(color, scale=1.0):
    return [float(color[0]) * scale, float(color[1]) * scale, float(color[2]) * scale]


def _axes(matrix):
    """Position and the local +X, +Y, -Z axes of an object matrix (normalised)."""
    m = matrix.to_3x3()
    x, y, z = m.col[0].copy(), m.col[1].copy(), m.col[2].copy()
    return matrix.translation, x, y, z


def _row_major(matrix):
    return [float(matrix[r][c]) for r in range(4) for c in range(4)]


class NameTable:
    """Light names as nimbus needs them: [A-Za-z0-9_]+, unique (they name AOVs light_<name>)."""

    def __init__(self):
        self.used = set()

    def __call__(self, name):
        base = re.sub(r"[^A-Za-z0-9_]", "_", name) or "light"
        candidate, i = base, 1
        while candidate in self.used:
            candidate = "%s_%d" % (base, i)
            i += 1
        self.used.add(candidate)
        return candidate


def vertical_fov(camera, width, height, pixel_aspect=1.0):
    """The vertical field of view in degrees of a perspective camera, as Blender frames it."""
    aspect = width * pixel_aspect / float(height)
    fit = camera.sensor_fit
    if fit == "AUTO":
        fit, sensor = ("HORIZONTAL" if aspect >= 1.0 else "VERTICAL"), camera.sensor_width
    else:
        sensor = camera.sensor_width if fit == "HORIZONTAL" else camera.sensor_height
    half = math.atan(sensor / (2.0 * camera.lens))
    if fit == "HORIZONTAL":
        half = math.atan(math.tan(half) / aspect)
    return math.degrees(2.0 * half)


def export_camera(obj, width, height, pixel_aspect, warnings):
    cam = obj.data
    if cam.type != "PERSP":
        raise ExportError("nimbus renders perspective cameras only (camera '%s' is %s)" % (obj.name, cam.type))
    if cam.shift_x != 0.0 or cam.shift_y != 0.0:
        warnings.append("camera shift is not supported and is ignored")
    position, x, y, z = _axes(obj.matrix_world)
    forward = (-z).normalized()
    return {
        "from": _vec(position),
        "to": _vec(position + forward),
        "up": _vec(y.normalized()),
        "fov": vertical_fov(cam, width, height, pixel_aspect),
        "resolution": [width, height],
    }


def export_light(obj, matrix, name, warnings):
    """One Blender light as a nimbus light, in Cycles' radiometric units (W, W/m^2)."""
    light = obj.data
    position, x, y, z = _axes(matrix)
    down = _vec((-z).normalized())  # lights shine along their local -Z
    color = light.color
    if light.type == "SUN":
        return {"type": "distant", "name": name, "direction": down, "irradiance": _rgb(color, light.energy),
                "angle": min(math.degrees(light.angle), 179.0)}
    # Point and spot lights of power P (W) radiate P / (4 pi) W/sr (Cycles' point-light
    # normalisation, also for spots, whose cone only masks).
    intensity = _rgb(color, light.energy / (4.0 * math.pi))
    if light.type == "POINT":
        r = light.shadow_soft_size
        if r > 0.0:
            # A sphere of radiance L has intensity pi r^2 L in every direction.
            return {"type": "sphere", "name": name, "position": _vec(position), "radius": r,
                    "radiance": _rgb(color, light.energy / (4.0 * math.pi * math.pi * r * r))}
        return {"type": "point", "name": name, "position": _vec(position), "intensity": intensity}
    if light.type == "SPOT":
        if light.shadow_soft_size > 0.0:
            warnings.append("spot light '%s': radius is ignored (nimbus spots are points)" % obj.name)
        half = 0.5 * light.spot_size
        # Cycles ramps the intensity by smoothstep over cos(angle) in [cos(half), cos(half) +
        # blend (1 - cos(half))]; nimbus's softness is the width in degrees of its ramp inside
        # the edge, so the ramp starts at the same angle.
        inner_cos = math.cos(half) + light.spot_blend * (1.0 - math.cos(half))
        softness = math.degrees(half - math.acos(min(1.0, inner_cos)))
        return {"type": "spot", "name": name, "position": _vec(position), "direction": down,
                "intensity": intensity, "cone_angle": math.degrees(light.spot_size),
                "cone_softness": max(0.0, softness)}
    if light.type == "AREA":
        sx, sy = x.length, y.length  # the object's scale sizes the light
        w = light.size * sx
        h = (light.size_y if light.shape in ("RECTANGLE", "ELLIPSE") else light.size) * sy
        area = w * h
        if light.shape in ("DISK", "ELLIPSE"):
            area *= math.pi / 4.0
            # The same area and aspect as a rectangle: nimbus has rectangular area lights.
            w, h = w * math.sqrt(math.pi) / 2.0, h * math.sqrt(math.pi) / 2.0
            warnings.append("area light '%s': %s approximated by a rectangle of the same area" %
                            (obj.name, light.shape.lower()))
        if getattr(light, "spread", math.pi) < math.pi - 1e-6:
            warnings.append("area light '%s': spread is ignored (nimbus area lights are Lambertian)" % obj.name)
        # Cycles: an area light of power P emits radiance P / (pi A) from its front face.
        return {"type": "rect", "name": name, "center": _vec(position), "normal": down,
                "up": _vec(y.normalized()), "size": [w, h],
                "radiance": _rgb(color, light.energy / (math.pi * area))}
    raise ExportError("light '%s': unsupported type %s" % (obj.name, light.type))


def _input(node, name):
    """An unlinked input's value; a linked one (a texture) is not followed: its default is used."""
    socket = node.inputs.get(name)
    if socket is None:
        return PRINCIPLED_DEFAULTS[name], False
    value = socket.default_value
    if hasattr(value, "__len__") and not isinstance(value, str):
        value = tuple(value)[:3]
    return value, socket.is_linked


def principled_volume(material):
    """The Principled Volume node feeding the material output's Volume socket, or None."""
    if material is None or not material.use_nodes or material.node_tree is None:
        return None
    for node in material.node_tree.nodes:
        if node.type == "OUTPUT_MATERIAL" and node.is_active_output:
            links = node.inputs["Volume"].links
            if links and links[0].from_node.type == "PRINCIPLED_VOLUME":
                return links[0].from_node
    return None


def medium_from_material(material, label, warnings):
    """Principled Volume -> nimbus medium (Cycles 3.4, svm_node_principled_volume):
    sigma_s = Density * Color, sigma_a = Density * max(1 - Color, 0) * max(1 - sqrt(Absorption), 0),
    HG g = Anisotropy. nimbus multiplies the coefficients by the density grid, as Cycles multiplies
    Density by the density attribute."""
    node = principled_volume(material)
    values = dict(PRINCIPLED_DEFAULTS)
    if node is None:
        if material is not None:
            warnings.append("%s: material '%s' has no Principled Volume; its defaults are used" % (label, material.name))
    else:
        for name in ("Color", "Density", "Anisotropy", "Absorption Color", "Blackbody Intensity",
                     "Emission Strength"):
            value, linked = _input(node, name)
            if linked:
                warnings.append("%s: %s is linked to other nodes; nimbus uses its value %s" % (label, name, value))
            values[name] = value
        for name in ("Density Attribute", "Temperature Attribute"):
            socket = node.inputs.get(name)
            if socket is not None:
                values[name] = socket.default_value
        if values["Emission Strength"] > 0.0:
            warnings.append("%s: Emission is not exported (nimbus emits from temperature/flame grids)" % label)
    color = values["Color"]
    absorption = [max(1.0 - c, 0.0) * max(1.0 - math.sqrt(max(a, 0.0)), 0.0)
                  for c, a in zip(color, values["Absorption Color"])]
    g = max(-0.999, min(0.999, float(values["Anisotropy"])))
    medium = {
        "sigma_s": [float(max(c, 0.0)) for c in color],
        "sigma_a": absorption,
        "density_scale": float(max(values["Density"], 0.0)),
        "phase": {"type": "hg", "g": g},
        "emission_scale": float(max(values["Blackbody Intensity"], 0.0)),
    }
    return medium, values["Density Attribute"], values["Temperature Attribute"]


def volume_file(obj, depsgraph):
    data = obj.data
    grids = data.grids
    path = getattr(grids, "frame_filepath", "") or data.filepath
    path = bpy.path.abspath(path, library=data.library)
    if not path:
        raise ExportError("volume '%s' has no OpenVDB file" % obj.name)
    return bpy.path.native_pathsep(path)


def object_space_density(volume_data, matrix):
    """Cycles' object_volume_density: with the volume's render space 'OBJECT' (Blender's default)
    density is per object-space unit, so Cycles divides it by the length the object matrix gives
    the unit diagonal (1/s for a uniform scale s); 'WORLD' leaves it alone."""
    render = getattr(volume_data, "render", None)
    if render is None or getattr(render, "space", "OBJECT") != "OBJECT":
        return 1.0
    from mathutils import Vector

    length = (matrix.to_3x3() @ Vector((1.0, 1.0, 1.0)).normalized()).length
    return 1.0 / length if length > 1e-9 else 1.0


def export_volume(obj, matrix, depsgraph, warnings):
    label = "volume '%s'" % obj.name
    material = obj.active_material
    medium, density_name, temperature_name = medium_from_material(material, label, warnings)
    medium["density_scale"] *= object_space_density(obj.data, matrix)
    grids = {"density": density_name}
    data = obj.data
    try:
        data.grids.load()
        names = {g.name for g in data.grids}
    except Exception:  # noqa: BLE001 - an unreadable file is reported by nimbus with its path
        names = set()
    if names and density_name not in names:
        raise ExportError("%s: no grid '%s' (Density Attribute) in %s; grids: %s" %
                          (label, density_name, volume_file(obj, depsgraph), ", ".join(sorted(names))))
    if medium["emission_scale"] > 0.0:
        if temperature_name in names:
            grids["temperature"] = temperature_name
        # Blender's fluid caches write the fire's intensity as a `flame` grid (older caches and
        # other tools: `heat`); nimbus's default shader multiplies the blackbody emission by it.
        flame = next((n for n in ("flame", "heat") if n in names), None)
        if flame is not None:
            grids["flame"] = flame
    return {
        "name": obj.name,
        "source": {"type": "vdb", "file": volume_file(obj, depsgraph), "grids": grids},
        "transform": _row_major(matrix),
        "medium": medium,
    }


def export_world(world, warnings):
    """A world's uniform background colour as an environment light, or None."""
    if world is None:
        return None
    color, strength = world.color, 1.0
    if world.use_nodes and world.node_tree is not None:
        color, strength = None, 0.0
        for node in world.node_tree.nodes:
            if node.type == "OUTPUT_WORLD" and node.is_active_output:
                links = node.inputs["Surface"].links
                if links and links[0].from_node.type == "BACKGROUND":
                    bg = links[0].from_node
                    if bg.inputs["Color"].is_linked:
                        warnings.append("world: a textured background is exported as its colour value")
                    color, strength = bg.inputs["Color"].default_value, bg.inputs["Strength"].default_value
        if color is None:
            return None
    radiance = _rgb(color, strength)
    if max(radiance) <= 0.0:
        return None
    return {"type": "environment", "name": "world", "radiance": radiance}


# Meshes in a collection of this name are holdouts (docs/embedding.md, "Geometry").
HOLDOUT_COLLECTION = "holdout"


def is_holdout(obj):
    """A holdout: in a collection named `holdout`, or with Blender's own holdout flag (Object >
    Visibility > Holdout)."""
    if getattr(obj, "is_holdout", False):
        return True
    original = getattr(obj, "original", obj)
    return any(c.name == HOLDOUT_COLLECTION for c in original.users_collection)


def _file_name(name, used):
    base = re.sub(r"[^A-Za-z0-9_.-]", "_", name) or "mesh"
    candidate, i = base, 1
    while candidate in used:
        candidate = "%s_%d" % (base, i)
        i += 1
    used.add(candidate)
    return candidate + ".obj"


def write_obj(obj, path):
    """The evaluated mesh's triangles (modifiers applied) in object space as a Wavefront OBJ:
    `v` lines and triangle `f` lines, nothing else. Returns the triangle count."""
    import numpy as np

    mesh = obj.to_mesh()
    try:
        mesh.calc_loop_triangles()
        verts = np.empty(len(mesh.vertices) * 3, dtype=np.float64)
        mesh.vertices.foreach_get("co", verts)
        tris = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
        mesh.loop_triangles.foreach_get("vertices", tris)
    finally:
        obj.to_mesh_clear()
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w") as f:
        f.write("# nimbus: Blender object %s, object space\n" % obj.name)
        for x, y, z in verts.reshape(-1, 3):
            f.write("v %.9g %.9g %.9g\n" % (x, y, z))
        for a, b, c in tris.reshape(-1, 3) + 1:
            f.write("f %d %d %d\n" % (a, b, c))
    return len(tris) // 3


def export_mesh(obj, matrix, mesh_dir, files, warnings):
    """A visible mesh object as nimbus geometry (docs/scene-format.md, geometry): holdouts (the
    `holdout` collection or Blender's holdout flag) cut the camera's view and cast shadows unless
    their shadow visibility is off; other meshes are shadow casters only, unseen by the camera
    (nimbus renders volumes: a surface render composited over it shows them). None for a mesh
    that would change nothing. `files` maps an object's name to its OBJ file, written once per
    object (instances share it)."""
    holdout = is_holdout(obj)
    shadows = bool(getattr(obj, "visible_shadow", True))
    label = "mesh '%s'" % obj.name
    if not holdout and not shadows:
        warnings.append("%s: casts no shadow and is no holdout; not exported" % label)
        return None
    if obj.name not in files:
        path = os.path.join(mesh_dir, _file_name(obj.name, set(os.path.basename(f) for f, _ in files.values())))
        files[obj.name] = (path, write_obj(obj, path))
    path, triangles = files[obj.name]
    if triangles == 0:
        warnings.append("%s: has no faces; not exported" % label)
        return None
    return {"name": obj.name, "type": "mesh", "file": path, "transform": _row_major(matrix),
            "holdout": holdout, "shadows": shadows}


def scene_document(depsgraph, warnings=None, mesh_dir=None):
    """The nimbus scene for the evaluated Blender scene. warnings collects what was approximated.
    Mesh objects are written as OBJ files into mesh_dir (an absolute directory; None: meshes are
    not exported, with a warning if there are any)."""
    warnings = [] if warnings is None else warnings
    scene = depsgraph.scene
    r = scene.render
    width = max(1, int(r.resolution_x * r.resolution_percentage / 100))
    height = max(1, int(r.resolution_y * r.resolution_percentage / 100))
    if scene.camera is None:
        raise ExportError("the scene has no camera")
    if r.use_border:
        warnings.append("render region (border) is ignored: nimbus renders the full frame")
    if r.use_motion_blur:
        warnings.append("motion blur is not supported by the nimbus add-on and is ignored")
    camera = scene.camera.evaluated_get(depsgraph)
    doc = {
        "version": 1,
        "camera": export_camera(camera, width, height, r.pixel_aspect_x / r.pixel_aspect_y, warnings),
        "lights": [],
        "volumes": [],
    }
    names = NameTable()
    world = export_world(scene.world, warnings)
    if world is not None:
        world["name"] = names("world")
        doc["lights"].append(world)
    files, geometry, skipped_meshes = {}, [], 0
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type == "LIGHT":
            doc["lights"].append(export_light(obj, instance.matrix_world.copy(), names(obj.name), warnings))
        elif obj.type == "VOLUME":
            doc["volumes"].append(export_volume(obj, instance.matrix_world.copy(), depsgraph, warnings))
        elif obj.type == "MESH":
            if mesh_dir is None:
                skipped_meshes += 1
                continue
            g = export_mesh(obj, instance.matrix_world.copy(), mesh_dir, files, warnings)
            if g is not None:
                geometry.append(g)
    if skipped_meshes:
        warnings.append("%d mesh object(s) not exported (no directory for their files)" % skipped_meshes)
    if geometry:
        # Unique names (nimbus reports objects by name; instances share their object's).
        used = set()
        for g in geometry:
            base, name, i = g["name"], g["name"], 1
            while name in used:
                name = "%s_%d" % (base, i)
                i += 1
            used.add(name)
            g["name"] = name
        doc["geometry"] = geometry
    s = scene.nimbus
    doc["render"] = {
        "method": s.method,
        "spp": s.spp,
        "adaptive_threshold": s.adaptive_threshold,
        "adaptive_max_spp": s.adaptive_max_spp,
        "seed": s.seed,
        "step": s.step,
        "shadow_map_resolution": s.shadow_map_resolution,
        "max_depth": s.max_depth,
        "threads": s.threads,
    }
    return doc
