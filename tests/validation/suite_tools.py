"""suite_tools.py: what scripts/make-references, scripts/validate-suite and test_references.py share.

The suites (tests/validation/README.md): scene files under tests/validation/<suite>/, their
path-tracer references under tests/validation/references/<suite>/<scene>.exr, the noise floors
in tests/validation/references/noise.json. Images are read and written with OpenImageIO
(Debian's python3 bindings, /usr/bin/python3), as tests/cli/test_cli.py does.

The error metric is nimbus compare's (src/compare/ErrorMetrics.cpp): over every pixel and
channel, relMSE = mean of (x - ref)^2 / (ref^2 + eps) with eps = (0.1 mean(ref))^2; energy error
= (sum x - sum ref) / sum ref. The reference's noise floor is the same relMSE with the variance of
the reference in place of (x - ref)^2: for the beauty from its `variance` AOV (the variance of
the pixel mean of the channel-averaged beauty, docs/pathtracer.md), against the channel-averaged
beauty, exactly as `referenceNoiseRelMse` does.
"""

import json
import os
import subprocess

import numpy as np
import OpenImageIO as oiio

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SUITES = ("calibration", "validation")
REFERENCES = os.path.join(HERE, "references")
NOISE_FILE = os.path.join(REFERENCES, "noise.json")
# The AOVs a reference keeps: colour AOVs as half (nimbus's own choice, docs/output.md), the
# variance as float (half would flush the small variances of dim pixels to zero).
REFERENCE_AOVS = ("beauty", "L1", "L2plus", "variance")


def scene_names(suite):
    d = os.path.join(HERE, suite)
    return sorted(f[:-5] for f in os.listdir(d) if f.endswith(".json"))


def scene_path(suite, name):
    return os.path.join(HERE, suite, name + ".json")


def reference_path(suite, name):
    return os.path.join(REFERENCES, suite, name + ".exr")


def default_nimbus():
    return os.path.join(ROOT, "build", "bin", "nimbus")


# ---- images ----------------------------------------------------------------------------------

def read_layers(path):
    """{layer: array (h, w, channels)} and the spec's nimbus:* metadata. The main layer (R, G, B,
    A: the beauty again; Z: the depth again) is left out; a 1-channel AOV (alpha.A, depth.Z,
    variance.Y) is an array of one channel."""
    inp = oiio.ImageInput.open(path)
    if not inp:
        raise RuntimeError(oiio.geterror())
    spec = inp.spec()
    px = np.asarray(inp.read_image(oiio.FLOAT), dtype=np.float64)
    inp.close()
    chans = {}
    for i, name in enumerate(spec.channelnames):
        layer, _, c = name.rpartition(".")
        if layer:
            chans.setdefault(layer, []).append((c, px[..., i]))
    order = "RGBA"
    layers = {k: np.stack([a for _, a in sorted(v, key=lambda t: order.find(t[0]))], -1) for k, v in chans.items()}
    meta = {a.name: a.value for a in spec.extra_attribs if a.name.startswith("nimbus:")}
    return layers, meta


def write_layers(path, layers, meta):
    """A multi-layer EXR in nimbus's layout (docs/output.md): R, G, B, A (the beauty), then
    `<layer>.R/.G/.B(.A)`, a 1-channel layer as its one channel (`variance.Y`); colour as half,
    the variance as float; zip."""
    h, w, _ = layers["beauty"].shape
    names, fmts, planes = [], [], []
    def add(name, plane, fmt):
        names.append(name), fmts.append(fmt), planes.append(plane)
    for c, i in zip("RGBA", range(4)):
        add(c, layers["beauty"][..., i], oiio.HALF)
    for layer in sorted(layers):
        a = layers[layer]
        fmt = oiio.FLOAT if layer == "variance" else oiio.HALF
        if a.shape[-1] == 1:
            add(layer + "." + {"alpha": "A", "depth": "Z"}.get(layer, "Y"), a[..., 0], oiio.FLOAT)
            continue
        for i in range(a.shape[-1]):
            add(layer + "." + "RGBA"[i], a[..., i], fmt)
    spec = oiio.ImageSpec(w, h, len(names), oiio.FLOAT)
    spec.channelnames = tuple(names)
    spec.channelformats = tuple(oiio.TypeDesc(f) for f in fmts)
    spec.attribute("compression", "zip")
    for k, v in sorted(meta.items()):
        spec.attribute(k, str(v))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp.exr"
    out = oiio.ImageOutput.create(tmp)
    if not out or not out.open(tmp, spec):
        raise RuntimeError(oiio.geterror())
    out.write_image(np.stack(planes, -1).astype(np.float32))
    out.close()
    os.replace(tmp, path)


# ---- metrics (src/compare/ErrorMetrics.cpp) --------------------------------------------------

def _eps(ref):
    m = float(np.mean(ref))
    return max((0.1 * m) ** 2, 1e-20)


def rel_mse(x, ref):
    x, ref = x[..., :3], ref[..., :3]
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + _eps(ref))))


def energy_error(x, ref):
    s = float(np.sum(ref[..., :3]))
    return (float(np.sum(x[..., :3])) - s) / s if s != 0 else 0.0


def beauty_noise_floor(layers):
    """referenceNoiseRelMse: mean of variance / (lum^2 + eps) over pixels, lum the channel mean."""
    lum = layers["beauty"][..., :3].mean(-1)
    m = float(lum.mean())
    eps = (0.1 * m) ** 2 + 1e-20
    return float(np.mean(layers["variance"][..., 0] / (lum ** 2 + eps)))


def split_noise_floor(a, b, ref, ratio=0.25):
    """The relMSE floor of the mean of two independent renders a and b, per channel: the variance
    of their mean is ratio * (a - b)^2 in expectation (1/4 for an equal split)."""
    a, b, ref = a[..., :3], b[..., :3], ref[..., :3]
    return float(np.mean(ratio * (a - b) ** 2 / (ref ** 2 + _eps(ref))))


# ---- rendering -------------------------------------------------------------------------------

def render(nimbus, scene, out, method, sets=(), aovs=REFERENCE_AOVS, env=None):
    """One `nimbus render`; returns the EXR's layers and metadata."""
    cmd = [nimbus, "render", scene, "-q", "--method", method, "-o", out,
           "--set", "output.aovs=" + json.dumps(list(aovs)), "--set", "output.preview="]
    for s in sets:
        cmd += ["--set", s]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    if r.returncode != 0:
        raise RuntimeError("%s failed (%d): %s" % (" ".join(cmd), r.returncode, r.stdout.strip()))
    return read_layers(out)


def load_noise():
    if not os.path.exists(NOISE_FILE):
        return {}
    with open(NOISE_FILE) as f:
        return json.load(f)
