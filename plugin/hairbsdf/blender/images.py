"""Blender images -> scene-linear float RGB (H, W, 3) or RGBA (H, W, 4) arrays, row 0 = the
image's top row. The world's Environment Texture reads RGB, the shading programs' Image Texture
nodes RGBA (alpha associated as Cycles' image loader does, see read_image_rgba).

Files are read with OpenImageIO (the pip wheel in bpy 4.5's venv, Debian's python3-openimageio in
Blender 3.4), as Cycles reads them; packed, generated or missing files fall back to Blender's own
pixel buffer. Colour spaces: Linear / Linear Rec.709 / Non-Color / Raw pass through, sRGB is
decoded with the sRGB transfer function; in a working space other than Linear Rec.709 (Blender 5.x)
sRGB and linear Rec.709 images are then converted into it, as Cycles converts them; any other
space is read as linear with a warning.
Alpha: files are read with their alpha as stored (straight stays straight, as Cycles configures
OpenImageIO) and associated here as Cycles' loader does (read_image_rgba). sRGB files and 8-bit
sRGB buffers: the Image Texture path keeps the encoded values and the VM decodes after
interpolating, as Cycles; so does the world's path (read_image_rgb).
"""

from __future__ import annotations

import os

import numpy as np

from ._common import working_space

LINEAR_SPACES = {"Linear", "Linear Rec.709", "Linear CIE-XYZ E", "Linear CIE-XYZ D65", "Non-Color", "Raw",
                 "Scene Linear", "scene_linear"}
SRGB_SPACES = {"sRGB", "sRGB 2.1"}
REC709_LINEAR_SPACES = {"Linear", "Linear Rec.709"}


def _convert_to_working(image, pixels, associated, is_byte, is_srgb, to_working):
    """An image in a working space other than Rec.709, as Cycles' loader converts it: 8-bit files
    are stored as half floats (Cycles does the same with 16-bit files, which stay float32 here),
    straight alpha is associated first; the conversion
    divides by alpha, decodes sRGB, applies the Rec.709 -> working matrix and multiplies by alpha
    again (alpha ignored for alpha mode None and Channel Packed). Returns (pixels, associated)."""
    def half(x):
        return x.astype(np.float16).astype(np.float32) if is_byte else x

    ignore_alpha = getattr(image, "alpha_mode", "STRAIGHT") in ("NONE", "CHANNEL_PACKED")
    px = half(pixels)
    alpha = px[:, :, 3:4]
    if not associated and not ignore_alpha:
        px[:, :, :3] = half(px[:, :, :3] * alpha)
        associated = True
    # Alpha is divided out and multiplied back where it is neither 0 nor 1, and never when ignored.
    scale = np.zeros(alpha.shape, bool) if ignore_alpha else (alpha > 0.0) & (alpha != 1.0)
    rgb = np.where(scale, px[:, :, :3] / np.where(scale, alpha, 1.0), px[:, :, :3])
    if is_srgb:
        rgb = srgb_to_linear(rgb)
    rgb = np.einsum("ij,hwj->hwi", to_working, rgb.astype(np.float64)).astype(np.float32)
    px[:, :, :3] = half(np.where(scale, rgb * alpha, rgb))
    return px, associated


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    v = np.asarray(values, dtype=np.float32)
    return np.where(v <= 0.04045, v / 12.92, ((np.maximum(v, 0.04045) + 0.055) / 1.055) ** 2.4).astype(np.float32)


def _read_file(path: str):
    """((H, W, 4) float32, alpha associated in the file, 8 bits per channel) from the file with
    OpenImageIO, or (None, False, False) when it cannot be read."""
    from .._deps import require
    oiio = require("OpenImageIO", "compare", "the hairbsdf engine's image textures")
    # As Cycles: keep unassociated alpha as it is in the file (OpenImageIO would otherwise
    # associate it on read, for 8-bit sRGB files in linear space); read_image_rgba associates.
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    buf = oiio.ImageBuf(path, 0, 0, config)
    if buf.has_error:
        return None, False, False
    pixels = np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float32)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    if pixels.ndim != 3 or pixels.shape[2] < 1:
        return None, False, False
    spec = buf.spec()
    associated = not bool(spec.get_int_attribute("oiio:UnassociatedAlpha", 0))
    is_byte = spec.format.basetype == oiio.UINT8
    return _rgba(pixels, alpha_channel=spec.alpha_channel), associated, is_byte


def _rgba(pixels, alpha_channel=-1):
    """(H, W, C) -> (H, W, 4): grey replicated, alpha 1 when absent."""
    h, w, c = pixels.shape
    out = np.ones((h, w, 4), np.float32)
    if c < 3:  # grey (and grey + alpha)
        out[:, :, :3] = pixels[:, :, :1]
        if c == 2:
            out[:, :, 3] = pixels[:, :, 1]
    else:
        out[:, :, :3] = pixels[:, :, :3]
        a = alpha_channel if alpha_channel is not None and 0 <= alpha_channel < c else (3 if c >= 4 else -1)
        if a >= 0:
            out[:, :, 3] = pixels[:, :, a]
    return out


def _read_blender_buffer(image):
    """Blender's pixel buffer (bottom row first, RGBA), flipped to top row first, as RGBA."""
    w, h = int(image.size[0]), int(image.size[1])
    if w <= 0 or h <= 0:
        return None
    channels = int(image.channels)
    buf = np.empty(w * h * channels, dtype=np.float32)
    image.pixels.foreach_get(buf)
    return _rgba(np.ascontiguousarray(buf.reshape(h, w, channels)[::-1]))


def _read(image, warn, keep_srgb_bytes=False, fallback="black"):
    """(RGBA (H, W, 4) or None, alpha associated, sRGB-encoded, 8 bits per channel):
    scene-linear, except that with `keep_srgb_bytes` an sRGB file or 8-bit buffer keeps its
    encoded values (then sRGB-encoded is True)."""
    import bpy

    pixels = None
    path = ""
    from_file = associated = is_byte = False
    if getattr(image, "source", "FILE") == "FILE" and image.packed_file is None:
        path = bpy.path.abspath(image.filepath, library=image.library)
        if path and os.path.exists(path):
            pixels, associated, is_byte = _read_file(path)
            from_file = pixels is not None
    if pixels is None:
        try:
            pixels = _read_blender_buffer(image)
            # Blender's float buffers are premultiplied and linear, its byte buffers straight
            # and encoded.
            associated = bool(getattr(image, "is_float", False))
            is_byte = not associated
        except Exception:  # noqa: BLE001 - a broken image must not stop the render
            pixels = None
    if pixels is None:
        warn(f"image '{image.name}' has no pixels (file '{path}' missing or unreadable); using {fallback}")
        return None, associated, False, False
    space = image.colorspace_settings.name
    encoded = False
    # A working space other than Linear Rec.709 (Blender 5.x): Cycles converts sRGB and linear
    # Rec.709 images into it texel by texel on load (its sRGB shortcut holds only when the
    # working space is Rec.709), which the matrix below reproduces.
    working = working_space()
    to_working = working.rec709_to_scene_linear
    raw_values = from_file or is_byte  # Blender's float buffers are scene-linear already
    if to_working is not None and raw_values and (space in SRGB_SPACES or space in REC709_LINEAR_SPACES):
        pixels, associated = _convert_to_working(image, pixels, associated, is_byte, space in SRGB_SPACES,
                                                 to_working)
    elif space in SRGB_SPACES:
        # Files and Blender's byte buffers hold encoded values; its float buffers are linear.
        # Cycles keeps every sRGB file encoded, float ones too (Blender 5.x reads the float EXRs
        # it writes as sRGB), and decodes after interpolating.
        if keep_srgb_bytes and raw_values:
            encoded = True
        elif raw_values:
            pixels[:, :, :3] = srgb_to_linear(pixels[:, :, :3])
    elif space not in LINEAR_SPACES and space != working.name:
        warn(f"image '{image.name}': colour space '{space}' is not supported; read as linear")
    if not np.all(np.isfinite(pixels)):
        warn(f"image '{image.name}': NaN/Inf pixels set to 0")
        pixels = np.where(np.isfinite(pixels), pixels, 0.0).astype(np.float32)
    return pixels, associated, encoded, is_byte


def read_image_rgb(image, warn):
    """(RGB (H, W, 3) float32 or None, sRGB-encoded) of a bpy Image for the world's Environment
    Texture: as read_image_rgba loads it (alpha associated; sRGB files and 8-bit sRGB buffers
    keep their encoded values, which the renderer decodes after interpolating, as Cycles), or
    None (after a warning naming the image) when it has no pixels. `warn(message)` reports
    problems."""
    pixels, _, encoded = read_image_rgba(image, warn, fallback="black")
    if pixels is None:
        return None, False
    return np.ascontiguousarray(pixels[:, :, :3]), encoded


def is_data_space(image) -> bool:
    return image.colorspace_settings.name in ("Non-Color", "Raw")


def read_image_rgba(image, warn, fallback="magenta (Cycles' missing-texture colour)"):
    """(RGBA (H, W, 4) float32 or None, alpha associated, sRGB-encoded) of a bpy Image for the
    Image Texture node, as Cycles' image manager loads it: sRGB files (8-bit or float) and 8-bit
    sRGB buffers keep their encoded values (the VM interpolates them and decodes afterwards, as
    Cycles does), every other image is scene-linear; alpha mode None reads alpha 1; Channel Packed and Non-Color images keep
    their channels as they are; otherwise straight alpha is associated (RGB x A) at load, so
    that the node's Color output is associated and is divided by the interpolated alpha only
    when its Alpha output is used. 8-bit images are associated in 8 bits, truncating, as
    Cycles does."""
    pixels, associated, encoded, is_byte = _read(image, warn, keep_srgb_bytes=True, fallback=fallback)
    if pixels is None:
        return None, False, False
    mode = getattr(image, "alpha_mode", "STRAIGHT")
    if mode == "NONE":
        pixels[:, :, 3] = 1.0
        return pixels, False, encoded
    if mode == "CHANNEL_PACKED" or is_data_space(image):
        return pixels, False, encoded
    if not associated:
        if is_byte:
            # Cycles associates 8-bit images in 8 bits, truncating: c = floor(c a / 255)
            # (matched texel for texel against Cycles 4.5.15 renders of an sRGB PNG)
            b = np.round(pixels * 255.0).astype(np.int64)
            pixels[:, :, :3] = ((b[:, :, :3] * b[:, :, 3:4]) // 255).astype(np.float32) / np.float32(255.0)
        else:
            pixels[:, :, :3] *= pixels[:, :, 3:4]
    return pixels, True, encoded
