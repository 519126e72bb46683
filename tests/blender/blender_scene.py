"""Runs inside Blender (blender -b --factory-startup --python blender_scene.py -- OUT_DIR VDB).

Enables the installed add-on, builds a scene with a VDB volume (Principled Volume material) and
a sun, renders it with nimbus by each method into OUT_DIR/blender_<method>.exr (multilayer,
float) and has the engine write the scene it rendered to OUT_DIR/scene_<method>.json.
test_blender_addon.py checks the results. With a third argument "crosscheck" it renders the
scene with Cycles and nimbus pathtrace instead (cycles_crosscheck.py)."""
import math
import os
import sys

import addon_utils
import bpy
from mathutils import Vector

out_dir, vdb_path, *mode = sys.argv[sys.argv.index("--") + 1:]
fire_vdb_path = os.path.join(os.path.dirname(vdb_path), "fire.vdb")

if addon_utils.enable("nimbus_blender", default_set=True) is None:
    sys.exit("blender_scene: the nimbus_blender add-on is not installed")

for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj, do_unlink=True)
scene = bpy.context.scene
scene.world = None  # lit by the sun alone

volume = bpy.data.volumes.new("smoke")
volume.filepath = vdb_path
smoke = bpy.data.objects.new("smoke", volume)
scene.collection.objects.link(smoke)
smoke.location = (0.2, 0.0, 0.1)
smoke.rotation_euler = (0.0, 0.0, 0.3)
smoke.scale = (1.2, 1.2, 1.2)

material = bpy.data.materials.new("smoke")
material.use_nodes = True
nodes = material.node_tree.nodes
for node in list(nodes):
    if node.type != "OUTPUT_MATERIAL":
        nodes.remove(node)
principled = nodes.new("ShaderNodeVolumePrincipled")
principled.inputs["Color"].default_value = (0.8, 0.7, 0.6, 1.0)
principled.inputs["Density"].default_value = 3.0
principled.inputs["Anisotropy"].default_value = 0.3
principled.inputs["Absorption Color"].default_value = (0.2, 0.3, 0.4, 1.0)
output = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
material.node_tree.links.new(principled.outputs["Volume"], output.inputs["Volume"])
volume.materials.append(material)

sun = bpy.data.lights.new("key", "SUN")
sun.energy = 3.0
sun.color = (1.0, 0.95, 0.9)
sun.angle = 0.0
sun_object = bpy.data.objects.new("key", sun)
sun_object.rotation_euler = (math.radians(40.0), 0.0, math.radians(30.0))
scene.collection.objects.link(sun_object)

camera = bpy.data.cameras.new("camera")
camera.lens = 40.0
camera_object = bpy.data.objects.new("camera", camera)
camera_object.location = (0.5, -6.0, 1.5)
camera_object.rotation_euler = (Vector((0.2, 0.0, 0.1)) - camera_object.location).to_track_quat("-Z", "Y").to_euler()
scene.collection.objects.link(camera_object)
scene.camera = camera_object

scene.render.engine = "NIMBUS"
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
scene.view_layers[0].use_pass_z = True
settings = scene.render.image_settings
settings.file_format = "OPEN_EXR_MULTILAYER"
settings.color_depth = "32"

if mode == ["crosscheck"]:
    # cycles_crosscheck.py: the same scene with Cycles and nimbus pathtrace, 4 seeds each,
    # all scattering orders and single scattering only.
    scene.render.resolution_x, scene.render.resolution_y = 96, 72
    c = scene.cycles
    c.device, c.samples, c.use_denoising, c.use_adaptive_sampling = "CPU", 128, False, False
    c.max_bounces = c.volume_bounces = c.transparent_max_bounces = 64
    c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    # A near-zero filter width: every Cycles sample goes through its pixel's centre, where nimbus
    # jitters over the pixel; the two differ only where a pixel straddles a silhouette.
    c.filter_width = 0.01
    c.volume_step_rate = 0.25
    scene.nimbus.method, scene.nimbus.spp, scene.nimbus.max_depth = "pathtrace", 128, 64
    for seed in range(4):
        for bounces, tag in ((64, "all"), (0, "single")):
            scene.render.engine, c.seed, c.volume_bounces = "CYCLES", seed, bounces
            scene.render.filepath = os.path.join(out_dir, "cycles_%s_%d.exr" % (tag, seed))
            bpy.ops.render.render(write_still=True)
        scene.render.engine, scene.nimbus.seed = "NIMBUS", seed + 1
        scene.render.filepath = os.path.join(out_dir, "nimbus_%d.exr" % seed)
        bpy.ops.render.render(write_still=True)
        print("blender_scene: crosscheck seed", seed)
    sys.exit(0)

scene.nimbus.spp = 4
# The test compares these renders pixel by pixel (with and without holdouts and shadow casters):
# each pixel the same samples, so adaptive sampling off.
scene.nimbus.adaptive_threshold = 0.0
scene.render.film_transparent = True  # Combined's alpha is the coverage, as in the CLI's EXR
# Every method in-process (the path tracer's OpenCL driver inside Blender's jemalloc process
# included), each writing the scene it rendered for `nimbus render` to repeat.
for method in ("single", "wkb", "pathtrace"):
    scene.nimbus.method = method
    scene.nimbus.export_json = os.path.join(out_dir, "scene_%s.json" % method)
    scene.render.filepath = os.path.join(out_dir, "blender_%s.exr" % method)
    bpy.ops.render.render(write_still=True)
    print("blender_scene: rendered", method, scene.render.filepath)

# Film > Transparent off: Combined is opaque (alpha 1), as Cycles writes it.
scene.render.film_transparent = False
scene.nimbus.method = "single"
scene.nimbus.export_json = os.path.join(out_dir, "scene_opaque.json")
scene.render.filepath = os.path.join(out_dir, "blender_opaque.exr")
bpy.ops.render.render(write_still=True)
print("blender_scene: rendered opaque", scene.render.filepath)

# Fire: the flame and temperature grids are exported when the material emits (Blackbody
# Intensity > 0); motion blur, which the add-on ignores, is reported as a warning.
scene.render.use_motion_blur = True
volume.filepath = fire_vdb_path
principled.inputs["Blackbody Intensity"].default_value = 1.0
scene.nimbus.export_json = os.path.join(out_dir, "scene_fire.json")
scene.render.filepath = os.path.join(out_dir, "blender_fire.exr")
bpy.ops.render.render(write_still=True)
print("blender_scene: rendered fire", scene.render.filepath)

# Geometry (issue 14, item 6): a wall in a collection named "holdout" in front of the right part of
# the smoke, a block between the sun and the smoke (a shadow caster only), and a triangle behind
# the smoke with Blender's own holdout flag.
scene.render.use_motion_blur = False
volume.filepath = vdb_path
principled.inputs["Blackbody Intensity"].default_value = 0.0


def mesh_object(name, verts, faces, collection):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    return obj


holdouts = bpy.data.collections.new("holdout")
scene.collection.children.link(holdouts)
mesh_object("wall", [(0.35, -1.6, -3.0), (3.0, -1.6, -3.0), (3.0, -1.6, 3.0), (0.35, -1.6, 3.0)], [(0, 1, 2, 3)],
            holdouts)
cube = [(x, y, z) for x in (-0.4, 0.4) for y in (-0.4, 0.4) for z in (-0.4, 0.4)]
cube_faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
block = mesh_object("block", cube, cube_faces, scene.collection)
bpy.context.view_layer.update()
sun_direction = (sun_object.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0))).normalized()
block.location = Vector((0.2, 0.0, 0.1)) - 2.6 * sun_direction
flagged = mesh_object("flagged", [(-1.0, 3.0, -1.0), (1.0, 3.0, -1.0), (0.0, 3.0, 1.0)], [(0, 1, 2)],
                      scene.collection)
flagged.is_holdout = True
scene.render.film_transparent = True
scene.nimbus.method = "single"
scene.nimbus.export_json = os.path.join(out_dir, "scene_geometry.json")
scene.render.filepath = os.path.join(out_dir, "blender_geometry.exr")
bpy.ops.render.render(write_still=True)
print("blender_scene: rendered geometry", scene.render.filepath)
