"""Report images: display transforms, colour maps and a dependency-free PNG writer."""

from __future__ import annotations

import math
import struct
import zlib

import numpy as np

from .._deps import require
from .metrics import luminance, rgb, srgb_oetf

# Anchors (0..255) of the colour maps; interpolated linearly.
MAGMA = [(0, 0, 4), (28, 16, 68), (79, 18, 123), (129, 37, 129), (181, 54, 122), (229, 80, 100), (251, 135, 97),
         (254, 194, 135), (252, 253, 191)]
# Diverging on black, so that "no difference" is dark like an empty render: negative (hairbsdf
# darker than Cycles) blue, positive (brighter) orange.
DIVERGING = [(120, 200, 255), (40, 110, 230), (20, 30, 90), (0, 0, 0), (90, 30, 10), (230, 110, 30),
             (255, 215, 120)]


def colormap(x, anchors):
    """x in [0, 1] (any shape) -> (..., 3) uint8."""
    a = np.asarray(anchors, dtype=np.float64)
    x = np.clip(np.nan_to_num(np.asarray(x, np.float64), nan=0.0), 0.0, 1.0)
    pos = x * (len(a) - 1)
    i = np.minimum(pos.astype(int), len(a) - 2)
    f = (pos - i)[..., None]
    return np.round(a[i] * (1 - f) + a[i + 1] * f).astype(np.uint8)


def css_gradient(anchors, steps=None):
    a = anchors
    stops = ["rgb(%d,%d,%d) %.1f%%" % (c[0], c[1], c[2], 100.0 * k / (len(a) - 1)) for k, c in enumerate(a)]
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
    """Blender's Standard view with an exposure of ev stops, as 8-bit RGB."""
    return np.round(srgb_oetf(rgb(img) * (2.0 ** ev)) * 255).astype(np.uint8)


def signed_map(values, scale):
    return colormap(0.5 + 0.5 * np.asarray(values) / max(scale, 1e-30), DIVERGING)


def log_map(values, lo, hi):
    v = np.log10(np.maximum(np.asarray(values, np.float64), 10.0 ** lo))
    return colormap((v - lo) / (hi - lo), MAGMA)


def write_png(path, img):
    """8-bit RGB(A) or grey PNG, row 0 at the top (zlib only)."""
    a = np.asarray(img)
    if a.dtype != np.uint8:
        a = np.clip(np.round(a), 0, 255).astype(np.uint8)
    if a.ndim == 2:
        a = a[..., None]
    h, w, c = a.shape
    ctype = {1: 0, 3: 2, 4: 6}[c]
    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, ctype, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)
    return path


def write_exr(path, img):
    """Linear float EXR through OpenImageIO."""
    oiio = require("OpenImageIO", "compare", "hairbsdf compare")
    a = np.ascontiguousarray(img, dtype=np.float32)
    spec = oiio.ImageSpec(a.shape[1], a.shape[0], a.shape[2], oiio.FLOAT)
    spec.attribute("compression", "zip")
    out = oiio.ImageOutput.create(str(path))
    if out is None:  # pragma: no cover
        return False
    ok = out.open(str(path), spec)
    ok = ok and out.write_image(a)
    out.close()
    return bool(ok)
