"""One Cycles render of bench_pathtrace_vs_cycles's scene; runs inside Blender:

    blender -b --factory-startup --python cycles_render.py -- SPEC.json

SPEC.json (written by bench_pathtrace_vs_cycles.cpp, the same values as its nimbus scene):
  vdb            the cloud (.vdb, grid "density", the grid's own index-to-world transform)
  camera         {"from", "to", "up", "fov" (vertical, degrees), "resolution": [w, h]}
  sun            {"direction" (of travel, world), "irradiance" (W/m^2, grey)}
  medium         {"density_scale" (1/m per unit density), "albedo", "g"}
  max_depth      nimbus's max_depth: scattering events per path (Cycles: bounces = max_depth - 1)
  seed, time_limit (seconds of sampling, 0 = none), samples, threads
  output         EXR path (RGBA float, the Combined pass)
  result         JSON path: {"render_seconds", "blender"}

The scene follows the mapping of docs/validation.md ("Parameter mapping"), here in the direction
nimbus -> Blender, with nothing left to conversion: the volume object has the identity matrix
(so Cycles' object-space density needs no correction) and world axes are used as they are.
  Principled Volume: Density = density_scale, Color = albedo, Absorption Color = black, so
    sigma_s = Density * albedo and sigma_a = Density * (1 - albedo): sigma_t = density_scale.
  Sun: Strength = irradiance, Angle 0 (a delta direction, as nimbus's "angle": 0), local -Z
    along the direction of travel.
  Camera: sensor fit Vertical, so the field of view given is the vertical one, as nimbus's.
  One-pixel box filter (nimbus's pixel footprint), no denoising, no adaptive sampling, no
    clamping, no world (black background, lit by the sun alone). Transparent bounces 64: Cycles
    counts crossings of the volume's bounding hull as transparent bounces (0 renders black).

render_seconds is the wall time of bpy.ops.render.render() alone: depsgraph evaluation (the VDB
read), Cycles' scene sync (volume upload, BVH), sampling and the read-back into the render
result. Blender's start-up, building the scene here and writing the EXR are outside it. The
samples reached are in Cycles' progress lines on stdout ("Sample N/M"), which the bench reads:
under a time limit the EXR's cycles.ViewLayer.samples holds the requested M instead."""
import json
import math
import sys
import time

import bpy
from mathutils import Matrix, Vector

spec = json.load(open(sys.argv[sys.argv.index("--") + 1]))


def frame(forward, up):
    """Rotation whose local -Z is `forward` and local +Y is `up` made orthogonal to it (Blender's
    camera and light convention)."""
    z = -Vector(forward).normalized()
    x = Vector(up).cross(z).normalized()
    y = z.cross(x)
    return Matrix((x, y, z)).transposed().to_4x4()


for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj, do_unlink=True)
scene = bpy.context.scene
scene.world = None

volume = bpy.data.volumes.new("cloud")
volume.filepath = spec["vdb"]
cloud = bpy.data.objects.new("cloud", volume)
scene.collection.objects.link(cloud)
material = bpy.data.materials.new("cloud")
material.use_nodes = True
nodes = material.node_tree.nodes
for node in list(nodes):
    if node.type != "OUTPUT_MATERIAL":
        nodes.remove(node)
principled = nodes.new("ShaderNodeVolumePrincipled")
medium = spec["medium"]
principled.inputs["Color"].default_value = (medium["albedo"],) * 3 + (1.0,)
principled.inputs["Density"].default_value = medium["density_scale"]
principled.inputs["Anisotropy"].default_value = medium["g"]
principled.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
output = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
material.node_tree.links.new(principled.outputs["Volume"], output.inputs["Volume"])
volume.materials.append(material)

sun = bpy.data.lights.new("sun", "SUN")
sun.energy = spec["sun"]["irradiance"]
sun.color = (1.0, 1.0, 1.0)
sun.angle = 0.0
sun_object = bpy.data.objects.new("sun", sun)
direction = Vector(spec["sun"]["direction"])
helper = Vector((0.0, 0.0, 1.0)) if abs(direction.normalized().z) < 0.9 else Vector((0.0, 1.0, 0.0))
sun_object.matrix_world = frame(direction, helper)
scene.collection.objects.link(sun_object)

cam = spec["camera"]
camera = bpy.data.cameras.new("camera")
camera.sensor_fit = "VERTICAL"
camera.sensor_height = 24.0
camera.lens = camera.sensor_height / (2.0 * math.tan(math.radians(cam["fov"]) / 2.0))
camera_object = bpy.data.objects.new("camera", camera)
camera_object.matrix_world = Matrix.Translation(cam["from"]) @ frame(Vector(cam["to"]) - Vector(cam["from"]), cam["up"])
scene.collection.objects.link(camera_object)
scene.camera = camera_object

render = scene.render
render.engine = "CYCLES"
render.resolution_x, render.resolution_y = cam["resolution"]
render.resolution_percentage = 100
render.threads_mode, render.threads = "FIXED", spec["threads"]
render.use_persistent_data = False
c = scene.cycles
c.device = "CPU"
c.samples = spec["samples"]
c.time_limit = spec["time_limit"]
c.seed = spec["seed"]
c.use_animated_seed = False
c.use_denoising = False
c.use_adaptive_sampling = False
c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
c.pixel_filter_type, c.filter_width = "BOX", 1.0
bounces = max(spec["max_depth"] - 1, 0)  # Cycles' volume bounces 0 = single scattering (nimbus max_depth 1)
c.max_bounces = c.volume_bounces = bounces
c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 0
c.transparent_max_bounces = 64  # crossings of the volume's bounding hull count as transparent bounces

start = time.perf_counter()
bpy.ops.render.render()
seconds = time.perf_counter() - start

settings = render.image_settings
settings.file_format, settings.color_mode, settings.color_depth = "OPEN_EXR", "RGBA", "32"
settings.exr_codec = "ZIP"
bpy.data.images["Render Result"].save_render(spec["output"], scene=scene)
json.dump({"render_seconds": seconds, "blender": bpy.app.version_string}, open(spec["result"], "w"))
print("cycles_render: %.3f s -> %s" % (seconds, spec["output"]))
