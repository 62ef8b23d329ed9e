"""Report images: the display transform, colour maps (matplotlib's) and image files (OpenImageIO)."""

from __future__ import annotations

import math

import numpy as np

from .._deps import require
from .metrics import luminance, rgb, srgb_oetf

WHAT = "the hairbsdf compare report"
# matplotlib colour maps. SEQUENTIAL for errors >= 0; DIVERGING ("berlin", matplotlib >= 3.10) is
# black in the middle, so "no difference" is dark like an empty render: negative (ours darker than
# the reference) blue, positive (brighter) orange.
SEQUENTIAL = "magma"
DIVERGING = "berlin"


def _cmap(name):
    mpl = require("matplotlib", "compare", WHAT)
    return mpl.colormaps[name]


def colormap(x, name):
    """x in [0, 1] (any shape; NaN as 0) -> (..., 3) uint8 through matplotlib's map `name`."""
    x = np.clip(np.nan_to_num(np.asarray(x, np.float64), nan=0.0), 0.0, 1.0)
    return np.round(_cmap(name)(x)[..., :3] * 255).astype(np.uint8)


def css_gradient(name, steps=9):
    """CSS linear-gradient of matplotlib's map `name`, sampled at `steps` stops."""
    c = colormap(np.linspace(0.0, 1.0, steps), name)
    stops = ["rgb(%d,%d,%d) %.1f%%" % (r, g, b, 100.0 * k / (steps - 1)) for k, (r, g, b) in enumerate(c)]
    return "linear-gradient(to right, %s)" % ", ".join(stops)


def auto_exposure(ref):
    """EV (multiple of 0.5) that maps the 99.5th percentile of ref's luminance to about 0.85."""
    lum = luminance(ref)
    p = float(np.percentile(lum, 99.5)) if lum.size else 0.0
    if not np.isfinite(p) or p <= 0:
        return 0.0
    ev = math.log2(0.85 / p)
    return float(np.clip(np.round(ev * 2) / 2, -12, 12))


def display(img, ev=0.0):
    """Blender's Standard view (the sRGB transfer function) with an exposure of ev stops, as 8-bit RGB."""
    return np.round(srgb_oetf(rgb(img) * (2.0 ** ev)) * 255).astype(np.uint8)


def signed_map(values, scale):
    return colormap(0.5 + 0.5 * np.asarray(values) / max(scale, 1e-30), DIVERGING)


def log_map(values, lo, hi):
    v = np.log10(np.maximum(np.asarray(values, np.float64), 10.0 ** lo))
    return colormap((v - lo) / (hi - lo), SEQUENTIAL)


def _write(path, a, fmt, attrs=None):
    oiio = require("OpenImageIO", "compare", WHAT)
    if a.ndim == 2:
        a = a[..., None]
    spec = oiio.ImageSpec(a.shape[1], a.shape[0], a.shape[2], fmt)
    for k, v in (attrs or {}).items():
        spec.attribute(k, v)
    out = oiio.ImageOutput.create(str(path))
    if out is None:
        raise OSError("OpenImageIO cannot write %s: %s" % (path, oiio.geterror()))
    ok = out.open(str(path), spec) and out.write_image(a)
    err = out.geterror()
    out.close()
    if not ok:
        raise OSError("OpenImageIO could not write %s: %s" % (path, err))
    return path


def write_png(path, img):
    """8-bit RGB(A) or grey PNG (row 0 at the top) through OpenImageIO; img is display-referred
    (uint8, or floats 0..255 rounded)."""
    a = np.asarray(img)
    if a.dtype != np.uint8:
        a = np.clip(np.round(a), 0, 255).astype(np.uint8)
    oiio = require("OpenImageIO", "compare", WHAT)
    return _write(path, np.ascontiguousarray(a), oiio.UINT8, {"oiio:ColorSpace": "sRGB"})


def write_exr(path, img, attrs=None):
    """Linear float EXR (zip) through OpenImageIO; attrs: extra header attributes (str/int/float).
    Returns True (an OSError says why a write failed)."""
    oiio = require("OpenImageIO", "compare", WHAT)
    a = np.ascontiguousarray(img, dtype=np.float32)
    _write(path, a, oiio.FLOAT, dict({"compression": "zip"}, **(attrs or {})))
    return True
