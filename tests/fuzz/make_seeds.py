#!/usr/bin/python3
"""Writes the seed corpora of the fuzz harnesses (tests/fuzz/corpus/<harness>/), a few small
valid (and a few deliberately bad) files per format: what libFuzzer starts from (issue 18,
item 5). The files are committed (each a few KB at most); rerun this to regenerate them after a
format gains a feature worth seeding:

    /usr/bin/python3 tests/fuzz/make_seeds.py

Needs Debian's python3-openvdb and python3-openimageio (hence /usr/bin/python3). The contents
are fixed; only the VDB files' header UUIDs (random, OpenVDB's writer) change between runs.
"""
import json
import os
import shutil
import struct
import sys

import numpy as np
import OpenImageIO as oiio
import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "corpus")
SCENE_DATA = os.path.join(HERE, "..", "scene", "data")


def fresh(name):
    d = os.path.join(CORPUS, name)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    return d


# ---- scene: the document, then NUL-separated --set assignments (fuzz_scene.cpp) ---------------

def scene_seeds():
    d = fresh("scene")

    def put(name, document, overrides=()):
        data = document.encode() + b"".join(b"\0" + o.encode() for o in overrides)
        with open(os.path.join(d, name), "wb") as f:
            f.write(data)

    for f in sorted(os.listdir(SCENE_DATA)):
        if f.endswith(".json") and f != "invalid_syntax.json":
            with open(os.path.join(SCENE_DATA, f)) as src:
                put(f, src.read())
    # --default with overrides: the empty document (fuzz_scene.cpp).
    put("default_sets", "", ["camera.fov=1e-10", "render.method=wkb", "lights[0].irradiance=[1,2,3]",
                             "volumes[0].medium.density_scale=3e29", "output.file=out/$F4.exr"])
    put("default_method", "", ["render.method=\"pathtrace\"", "render.spp=4", "camera.crop=[0,0.5,0.25,1]"])
    put("animated", json.dumps({
        "camera": {"from": [{"frame": 1, "value": [0, 1, 9]}, {"frame": 48, "value": [3, 1, 7]}],
                   "fov": [{"frame": 1, "value": 30}, {"frame": 10, "value": 45}],
                   "shutter": [-0.25, 0.25]},
        "volumes": [{"source": {"type": "procedural", "generator": "cloud", "radius": 2},
                     "transform": [{"frame": 1, "value": {"translate": [0, 0, 0]}},
                                   {"frame": 24, "value": {"rotate": [90, 0, 1, 0], "translate": [1, 0, 0]}}]}],
        "render": {"frame": 12, "fps": 24}}), ["render.frame=30"])
    put("geometry", json.dumps({
        "camera": {"holdout_depth": {"file": "z.$F4.exr", "channel": "Z"}},
        "lights": [{"type": "environment", "map": "sky.exr", "rotate": 90, "intensity": 2},
                   {"type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle": 40}],
        "volumes": [{"source": {"type": "vdb", "file": "smoke.$F4.vdb",
                                "grids": {"density": "density", "temperature": "temp"}},
                     "medium": {"velocity_scale": 1}}],
        "geometry": [{"name": "wall", "type": "mesh", "file": "wall.obj", "transform": {"translate": [0, 0, -2]}},
                     {"type": "sphere", "radius": 0.5, "transform": {"translate": [1, 0.5, 0]}, "shadows": False},
                     {"type": "plane", "size": [20, 20], "holdout": False}]}),
        ["geometry[0].holdout=false", "volumes[0].source.grids.vel=\"v\""])


# ---- vdb: files written by OpenVDB's own writer ------------------------------------------------
# Every grid lies in index coordinates [0, 4096)^3, under one root child: each top-level node
# writes its 32^3 child and value masks unpacked (8 KiB), so a grid across the origin's eight
# octants would cost 70 KB of masks.

def ball(grid, radius, value=1.0, center=(4, 4, 4)):
    acc = grid.getAccessor()
    for i in range(-radius, radius + 1):
        for j in range(-radius, radius + 1):
            for k in range(-radius, radius + 1):
                if i * i + j * j + k * k <= radius * radius:
                    acc.setValueOn((center[0] + i, center[1] + j, center[2] + k), value)


def float_grid(name, voxel=0.1):
    g = vdb.FloatGrid()
    g.name = name
    g.transform = vdb.createLinearTransform(voxelSize=voxel)
    return g


def vdb_seeds():
    d = fresh("vdb")
    density = float_grid("density")
    ball(density, 2)
    density["creator"] = "nimbus make_seeds.py"
    density["scale"] = 1.5
    vdb.write(os.path.join(d, "ball.vdb"), grids=[density])

    # Temperature and flame, one holding a negative and a NaN voxel (clamped with a warning).
    temperature = float_grid("temperature")
    ball(temperature, 1, 0.5)
    flame = float_grid("flame")
    ball(flame, 1, 2.0)
    acc = flame.getAccessor()
    acc.setValueOn((6, 4, 4), -1.0)
    acc.setValueOn((4, 6, 4), float("nan"))
    vdb.write(os.path.join(d, "fire.vdb"), grids=[density, temperature, flame])

    # Active tiles: a 16^3 block filled at once becomes eight leaf-sized tiles.
    tiles = float_grid("density")
    tiles.fill((0, 0, 0), (15, 15, 15), 0.5, True)
    vdb.write(os.path.join(d, "tiles.vdb"), grids=[tiles])

    # Velocity blur's vec3 "vel" grid beside the density.
    vel = vdb.Vec3SGrid()
    vel.name = "vel"
    vel.transform = vdb.createLinearTransform(voxelSize=0.1)
    vel.fill((0, 0, 0), (8, 8, 8), (1.0, 0.0, 0.5), True)
    vdb.write(os.path.join(d, "velocity.vdb"), grids=[density, vel])

    # A rotated, non-uniformly scaled transform, and the "heat" name of the flame role.
    skew = vdb.FloatGrid()
    skew.name = "density"
    skew.transform = vdb.createLinearTransform(
        [[0.1, 0.05, 0, 0], [0, 0.2, 0, 0], [0, 0, 0.1, 0], [1, 2, 3, 1]])
    ball(skew, 1)
    heat = float_grid("heat")
    ball(heat, 1, 3.0)
    vdb.write(os.path.join(d, "skew_heat.vdb"), grids=[skew, heat])

    # Bad inputs the loader must refuse with one line: a level set as density, a density of the
    # wrong type.
    level = vdb.createLevelSetSphere(radius=1.0, center=(2.5, 2.5, 2.5), voxelSize=0.5, halfWidth=2.0)
    level.name = "density"
    vdb.write(os.path.join(d, "levelset.vdb"), grids=[level])
    wrong = vdb.Vec3SGrid()
    wrong.name = "density"
    wrong.fill((0, 0, 0), (1, 1, 1), (1.0, 1.0, 1.0), True)
    vdb.write(os.path.join(d, "vec3_density.vdb"), grids=[wrong])


# ---- nvdb: the VDB seeds as NanoVDB files ------------------------------------------------------

def nvdb_seeds():
    """The vdb seeds converted by OpenVDB's vdb_tool (libopenvdb-tools), compressed (ZIP, one
    BLOSC): an uncompressed NanoVDB file holds each upper internal node's whole 32^3 table
    (~270 KB for the smallest grid), too large a seed."""
    import subprocess
    d = fresh("nvdb")
    src = os.path.join(CORPUS, "vdb")
    for name, codec in (("ball", "zip"), ("fire", "zip"), ("velocity", "zip"), ("skew_heat", "zip"),
                        ("levelset", "zip"), ("tiles", "blosc")):
        subprocess.run(["vdb_tool", "-read", os.path.join(src, name + ".vdb"), "-write", "codec=" + codec,
                        os.path.join(d, f"{name}_{codec}.nvdb")], check=True, capture_output=True)


# ---- mesh: OBJ and PLY, hand-written ----------------------------------------------------------

def mesh_seeds():
    d = fresh("mesh")

    def put(name, data):
        with open(os.path.join(d, name), "wb") as f:
            f.write(data if isinstance(data, bytes) else data.encode())

    put("triangle.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    put("quad_uv_normals.obj",
        "# a quad with texture coordinates and normals\nmtllib missing.mtl\no quad\n"
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 1 0\n"
        "usemtl grey\ns off\nf 1/1/1 2/2/1 3/3/1 4/4/1\n")
    put("mixed.obj",
        "g first\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\n"
        "f -5 -4 -3\nf 1 3 5 4\nl 1 2\np 3\ng second\nv 2 0 0 1.0\nv 3 0 0\nv 2 1 0\nf 6//  7// 8//\n")
    put("square.ply",
        "ply\nformat ascii 1.0\ncomment hand-written\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n")
    verts = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.0), (0.5, 0.5, 1.0)]
    faces = [(0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4), (0, 3, 2, 1)]
    for endian, tag in (("<", "little"), (">", "big")):
        header = ("ply\nformat binary_%s_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                  "property float z\nproperty uchar red\nelement face %d\nproperty list uchar uint vertex_indices\n"
                  "end_header\n" % (tag, len(verts), len(faces))).encode()
        body = b"".join(struct.pack(endian + "fffB", *v, 200) for v in verts)
        body += b"".join(struct.pack(endian + "B" + "I" * len(f), len(f), *f) for f in faces)
        put("pyramid_%s.ply" % tag, header + body)
    put("points_only.ply",
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
        "end_header\n0 0 0\n1 1 1\n")


# ---- images: OpenEXR (and Radiance HDR) through OpenImageIO ------------------------------------

def write_image(path, pixels, channels, fmt=oiio.FLOAT, compression="zip", tile=None):
    h, w = pixels.shape[:2]
    spec = oiio.ImageSpec(w, h, len(channels), fmt)
    spec.channelnames = tuple(channels)
    spec.attribute("compression", compression)
    if tile:
        spec.tile_width, spec.tile_height = tile
    out = oiio.ImageOutput.create(path)
    if not out or not out.open(path, spec):
        sys.exit("make_seeds: cannot write %s: %s" % (path, oiio.geterror()))
    out.write_image(np.ascontiguousarray(pixels, dtype=np.float32))
    out.close()


def depth_seeds():
    d = fresh("depth")
    y, x = np.mgrid[0:16, 0:16].astype(np.float32)
    z = 2.0 + 0.1 * x + 0.05 * y
    z[0:4, 0:4] = np.inf   # nothing holds out
    z[12:, 12:] = 0.0      # nothing holds out either
    write_image(os.path.join(d, "z16.exr"), z[:, :, None], ["Z"])
    write_image(os.path.join(d, "z16_half_none.exr"), z[:, :, None], ["Z"], oiio.HALF, "none")
    write_image(os.path.join(d, "z8_piz.exr"), z[::2, ::2, None], ["Z"], oiio.FLOAT, "piz")  # resampled
    rgbz = np.dstack([z * 0.1, z * 0.2, z * 0.3, z])
    write_image(os.path.join(d, "rgbz16_tiled_rle.exr"), rgbz, ["R", "G", "B", "Z"], oiio.HALF, "rle", (8, 8))
    write_image(os.path.join(d, "z16x9.exr"), z[:9, :, None], ["Z"])  # another aspect ratio: refused
    bad = z.copy()
    bad[5, 5] = -1.0  # a negative depth: refused
    write_image(os.path.join(d, "z16_negative_b44.exr"), bad[:, :, None], ["Z"], oiio.HALF, "b44")
    write_image(os.path.join(d, "depth_no_z.exr"), z[:, :, None], ["depth"])  # no channel Z: refused


def envmap_seeds():
    d = fresh("envmap")
    v, u = np.mgrid[0:4, 0:8].astype(np.float32)
    sky = np.dstack([0.2 + 0.1 * u, 0.3 + 0.2 * v, np.full_like(u, 0.8)])
    sky[1, 5] = (50.0, 40.0, 30.0)  # a sun
    write_image(os.path.join(d, "sky8x4.exr"), sky, ["R", "G", "B"])
    write_image(os.path.join(d, "sky8x4_rgba_half_piz.exr"), np.dstack([sky, np.ones_like(u)]),
                ["R", "G", "B", "A"], oiio.HALF, "piz")
    write_image(os.path.join(d, "grey4x2_tiled.exr"), sky[::2, ::2, :1], ["Y"], oiio.FLOAT, "none", (2, 2))
    write_image(os.path.join(d, "sky8x4.hdr"), sky, ["R", "G", "B"])
    bad = sky.copy()
    bad[2, 2, 0] = -1.0  # a negative texel: refused
    write_image(os.path.join(d, "negative.exr"), bad, ["R", "G", "B"])
    black = np.zeros_like(sky)  # an all-black map: the sampler's uniform fallback
    write_image(os.path.join(d, "black.exr"), black, ["R", "G", "B"], oiio.HALF, "zip")


if __name__ == "__main__":
    scene_seeds()
    vdb_seeds()
    nvdb_seeds()
    mesh_seeds()
    depth_seeds()
    envmap_seeds()
    for name in sorted(os.listdir(CORPUS)):
        files = os.listdir(os.path.join(CORPUS, name))
        total = sum(os.path.getsize(os.path.join(CORPUS, name, f)) for f in files)
        print("%-8s %2d files, %6d bytes" % (name, len(files), total))
