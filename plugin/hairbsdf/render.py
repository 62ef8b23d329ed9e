"""The path tracer: render a scene_desc dict (docs/scene_desc.md) as Cycles would.

    from hairbsdf.render import render
    out = render(scene, progress=lambda f: ..., cancel=lambda: False, threads=0)
    out["combined"]          # (H, W, 4) float32 linear RGBA, row 0 at the top
    out["stats"]             # samples, seconds, rays, peak_memory_bytes, nan_count, warnings, ...
    out["hair_r"], ...       # the passes named in scene["integrator"]["passes"] (PASSES below)

The dict's structure is checked once, in C++, against the scene schema (``scene_schema()``,
declared in plugin/bindings/scene_schema.cpp): a missing key, a wrong type or shape, an unknown
enum value raises ValueError / TypeError naming the key path. Invalid *content* (NaN/Inf coordinates, zero-radius or zero-length
strands, bad material indices, an empty scene, no lights) is not an error: the renderer
drops or repairs it and lists what it did in ``stats["warnings"]``.

The C++ module ``hairbsdf._render`` (Embree + TBB) is imported only when ``render`` is
called, so ``import hairbsdf`` never loads TBB (bpy ships its own libtbb.so.12).
"""

from __future__ import annotations

import functools
import numbers
from typing import Callable, Optional

from . import _core


def scene_schema() -> list:
    """The scene format's keys, one dict per key (path, kind, dtype, columns, required,
    default, allowed, minimum, maximum, only_for, register_link, closed, meaning)."""
    return _core.scene_schema()


def schema_choices(path: str) -> tuple:
    """The names the scene key `path` allows (its schema row's choices), in the row's order."""
    return tuple(next(k["allowed"] for k in scene_schema() if k["path"] == path and k["allowed"]))


# The scene keys of a material's closures and of Principled Hair's inputs (a closure's dict of socket values),
# the scene schema's.
CLOSURES = _core.CLOSURES
PRINCIPLED_HAIR_INPUTS = _core.PRINCIPLED_HAIR_INPUTS


@functools.cache
def principled_hair_input_rows() -> dict:
    """Principled Hair's inputs as the scene schema declares them: key ("roughness") -> its row (with the socket,
    socket_kind, hair_models, kind and default), in the table's order. The one table of the node's inputs."""
    prefix = PRINCIPLED_HAIR_INPUTS + "."
    return {k["path"][len(prefix):]: k for k in scene_schema() if k["path"].startswith(prefix)}


@functools.cache
def schema_default(path: str, closure_type: str = ""):
    """The default of the scene key `path` as a Python value (a bool, int, float, RGB tuple or name), read from
    its schema row, whose default is the renderer's field (render/scene.h); `closure_type` picks the row of keys
    that differ by closure type. KeyError for an unknown key, ValueError for a default that is no value
    (required, or derived from another key)."""
    rows = [k for k in scene_schema() if k["path"] == path and (not k["only_for"] or closure_type in
                                                                  k["only_for"].split())]
    if not rows:
        raise KeyError(f"{path}: no such scene key" + (f" for closure type {closure_type!r}" if closure_type else ""))
    kind, text = rows[0]["kind"], rows[0]["default"]
    try:
        if kind == "bool" and text in ("True", "False"):
            return text == "True"
        if kind in ("int", "float"):
            return int(text) if kind == "int" else float(text)
        if kind == "vector":
            return tuple(float(x) for x in text.strip("()").split(","))
        if kind == "enum" and text in rows[0]["allowed"]:
            return text
    except ValueError:
        pass
    raise ValueError(f"{path}: its default {text!r} is not a value")


# The scene format's version the renderer reads (the exporter writes it): the schema's `version` row.
SCENE_DESC_VERSION = int(next(k["maximum"] for k in scene_schema() if k["path"] == "version"))


# integrator["passes"]' names; _core.render_passes() gives the result keys each adds (docs/engine.md)
PASSES = schema_choices("integrator.passes")


def validate_scene(scene: dict) -> dict:
    """Checks the structure of a scene_desc dict and returns a normalised copy (arrays in the
    dtypes the renderer reads, optional keys filled only where given). Raises ValueError /
    TypeError naming the offending key. The renderer runs the same check."""
    return _core.validate_scene(scene)


def render(scene: dict, *, progress: Optional[Callable[[float], None]] = None,
           cancel: Optional[Callable[[], bool]] = None, threads: int = 0) -> dict:
    """Renders `scene` (docs/scene_desc.md) and returns {"combined": (H, W, 4) float32 RGBA,
    "stats": {samples, seconds, build_seconds, rays, peak_memory_bytes, nan_count, cancelled,
    warnings}} plus the passes scene["integrator"]["passes"] asks for (PASSES). `progress(fraction)` is called a few times per second; `cancel()` is polled
    every 50 ms and stops the render (the image then holds the samples done so far).
    `threads` = 0 uses all cores. The GIL is released while rendering."""
    if progress is not None and not callable(progress):
        raise TypeError("progress: expected a callable(fraction) or None")
    if cancel is not None and not callable(cancel):
        raise TypeError("cancel: expected a callable() -> bool or None")
    if isinstance(threads, bool) or not isinstance(threads, numbers.Integral):
        raise TypeError(f"threads: expected an integer, got {type(threads).__name__}")
    if threads < 0:
        raise ValueError(f"threads: must be >= 0, got {threads}")
    from . import _render  # lazily: loads Embree and TBB

    return _render.render(scene, progress, cancel, int(threads))


__all__ = ["render", "validate_scene", "scene_schema"]
