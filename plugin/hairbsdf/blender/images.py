"""Blender images -> scene-linear float RGB arrays (H, W, 3), row 0 = the image's top row.

Files are read with OpenImageIO (the pip wheel in bpy 4.5's venv, Debian's python3-openimageio in
Blender 3.4), as Cycles reads them; packed, generated or missing files fall back to Blender's own
pixel buffer. Colour spaces: Linear / Linear Rec.709 / Non-Color / Raw pass through, sRGB is
decoded with the sRGB transfer function; any other space is read as linear with a warning.
Difference from Cycles: Cycles interpolates 8-bit sRGB textures before decoding them; here each
texel is decoded first (the two agree at texel centres).
"""

from __future__ import annotations

import os

import numpy as np

LINEAR_SPACES = {"Linear", "Linear Rec.709", "Linear CIE-XYZ E", "Linear CIE-XYZ D65", "Non-Color", "Raw",
                 "Scene Linear", "scene_linear"}
SRGB_SPACES = {"sRGB", "sRGB 2.1"}


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    v = np.asarray(values, dtype=np.float32)
    return np.where(v <= 0.04045, v / 12.92, ((np.maximum(v, 0.04045) + 0.055) / 1.055) ** 2.4).astype(np.float32)


def _read_file(path: str):
    """(H, W, 3) float32 from the file with OpenImageIO, or None when it cannot be read."""
    try:
        import OpenImageIO as oiio
    except ImportError:
        return None
    buf = oiio.ImageBuf(path)
    if buf.has_error:
        return None
    pixels = np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float32)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    if pixels.ndim != 3 or pixels.shape[2] < 1:
        return None
    if pixels.shape[2] < 3:  # grey (and grey + alpha): replicate the first channel
        pixels = np.repeat(pixels[:, :, :1], 3, axis=2)
    return np.ascontiguousarray(pixels[:, :, :3])


def _read_blender_buffer(image):
    """Blender's pixel buffer (bottom row first, RGBA), flipped to top row first."""
    w, h = int(image.size[0]), int(image.size[1])
    if w <= 0 or h <= 0:
        return None
    channels = int(image.channels)
    buf = np.empty(w * h * channels, dtype=np.float32)
    image.pixels.foreach_get(buf)
    buf = buf.reshape(h, w, channels)[::-1]
    if channels < 3:
        buf = np.repeat(buf[:, :, :1], 3, axis=2)
    return np.ascontiguousarray(buf[:, :, :3])


def read_image_linear(image, warn):
    """Scene-linear RGB of a bpy Image, or None (after a warning naming the image) when it has
    no pixels. `warn(message)` reports problems."""
    import bpy

    pixels = None
    source = "file"
    path = ""
    if getattr(image, "source", "FILE") == "FILE" and image.packed_file is None:
        path = bpy.path.abspath(image.filepath, library=image.library)
        if path and os.path.exists(path):
            pixels = _read_file(path)
    if pixels is None:
        source = "buffer"
        try:
            pixels = _read_blender_buffer(image)
        except Exception:  # noqa: BLE001 - a broken image must not stop the render
            pixels = None
    if pixels is None:
        warn(f"image '{image.name}' has no pixels (file '{path}' missing or unreadable); using black")
        return None
    space = image.colorspace_settings.name
    if space in SRGB_SPACES:
        # Files and Blender's byte buffers hold encoded values; its float buffers are linear.
        if source == "file" or not bool(getattr(image, "is_float", False)):
            pixels = srgb_to_linear(pixels)
    elif space not in LINEAR_SPACES:
        warn(f"image '{image.name}': colour space '{space}' is not supported; read as linear")
    if not np.all(np.isfinite(pixels)):
        warn(f"image '{image.name}': NaN/Inf pixels set to 0")
        pixels = np.where(np.isfinite(pixels), pixels, 0.0).astype(np.float32)
    return pixels
