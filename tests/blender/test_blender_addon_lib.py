"""Helpers shared by test_blender_addon.py and cycles_crosscheck.py."""
import numpy as np
import OpenImageIO as oiio
import pyopenvdb as vdb


def read_layers(path):
    """{layer: (height, width, channels) float32}, channel suffixes in R, G, B, A / Z order."""
    image = oiio.ImageInput.open(path)
    assert image is not None, oiio.geterror()
    spec = image.spec()
    pixels = image.read_image(oiio.FLOAT)
    image.close()
    order = {"R": 0, "G": 1, "B": 2, "A": 3, "Z": 0, "X": 0}
    layers = {}
    for index, name in enumerate(spec.channelnames):
        layer, _, channel = name.rpartition(".")
        layers.setdefault(layer, []).append((order.get(channel, 9), index))
    return {layer: pixels[..., [i for _, i in sorted(ch)]] for layer, ch in layers.items()}


def smoke_vdb(path, fire=False):
    """A soft noisy ball of density, 40^3 voxels of 5 cm; with fire, also `flame` (the core) and
    `temperature` (kelvin) grids, as Blender's fluid caches write them."""
    n = 40
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float32)
    c = (n - 1) / 2.0
    r = np.sqrt((x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2) / c
    wobble = 0.15 * np.sin(0.7 * x) * np.sin(0.5 * y + 1.0) * np.sin(0.6 * z + 2.0)
    density = np.clip((1.0 - r + wobble) * 2.0, 0.0, 1.0).astype(np.float32)
    grid = vdb.FloatGrid()
    grid.copyFromArray(density, ijk=(-n // 2, -n // 2, -n // 2))
    grid.name = "density"
    grid.gridClass = vdb.GridClass.FOG_VOLUME
    grid.transform = vdb.createLinearTransform(voxelSize=0.05)
    grids = [grid]
    if fire:
        flame = np.clip(2.0 * density - 1.0, 0.0, 1.0).astype(np.float32)
        for name, values in (("flame", flame), ("temperature", (1200.0 + 800.0 * flame).astype(np.float32))):
            g = vdb.FloatGrid()
            g.copyFromArray(values, ijk=(-n // 2, -n // 2, -n // 2))
            g.name = name
            g.transform = vdb.createLinearTransform(voxelSize=0.05)
            grids.append(g)
    vdb.write(path, grids=grids)
