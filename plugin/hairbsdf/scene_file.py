"""A SceneDesc (docs/scene_desc.md) as one .npz file, readable without Blender: `save_scene`
writes the arrays and a JSON tree that points at them, `load_scene` reads them back.
(`hairbsdf.blender.export_scene` re-exports both.)"""

from __future__ import annotations

import json

import numpy as np


def _flatten(obj, path, arrays):
    if isinstance(obj, np.ndarray):
        key = "a%d" % len(arrays)
        arrays[key] = obj
        return {"__array__": key}
    if isinstance(obj, dict):
        return {k: _flatten(v, path + "/" + k, arrays) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        items = [_flatten(v, path, arrays) for v in obj]
        return {"__tuple__": items} if isinstance(obj, tuple) else items
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    return obj


def _unflatten(obj, arrays):
    if isinstance(obj, dict):
        if "__array__" in obj:
            return arrays[obj["__array__"]]
        if "__tuple__" in obj:
            return tuple(_unflatten(v, arrays) for v in obj["__tuple__"])
        return {k: _unflatten(v, arrays) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_unflatten(v, arrays) for v in obj]
    return obj


def save_scene(path, desc: dict, extra: dict | None = None) -> None:
    """Write a SceneDesc (and optional JSON-able `extra`) to one .npz file."""
    arrays = {}
    tree = _flatten(desc, "", arrays)
    meta = json.dumps({"scene": tree, "extra": extra or {}})
    np.savez(path, __meta__=np.array(meta), **arrays)


def load_scene(path):
    """(desc, extra) from save_scene's file."""
    with np.load(path, allow_pickle=False) as f:
        meta = json.loads(str(f["__meta__"]))
        arrays = {k: f[k] for k in f.files if k != "__meta__"}
    return _unflatten(meta["scene"], arrays), meta.get("extra", {})
