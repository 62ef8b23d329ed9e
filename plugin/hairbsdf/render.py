"""The path tracer: render a scene_desc dict (docs/scene_desc.md) as Cycles would.

    from hairbsdf.render import render
    out = render(scene, progress=lambda f: ..., cancel=lambda: False, threads=0)
    out["combined"]          # (H, W, 4) float32 linear RGBA, row 0 at the top
    out["stats"]             # samples, seconds, rays, peak_memory_bytes, nan_count, warnings, ...
    out["hair_r"], ...       # the passes named in scene["integrator"]["passes"] (PASSES below)

This module validates the dict's structure (a missing key, a wrong type or shape, an unknown
enum value raises ValueError / TypeError naming the key) and converts arrays to the dtypes
the C++ side reads. Invalid *content* (NaN/Inf coordinates, zero-radius or zero-length
strands, bad material indices, an empty scene, no lights) is not an error: the renderer
drops or repairs it and lists what it did in ``stats["warnings"]``.

The C++ module ``hairbsdf._render`` (Embree + TBB) is imported only when ``render`` is
called, so ``import hairbsdf`` never loads TBB (bpy ships its own libtbb.so.12).
"""

from __future__ import annotations

import numbers
from typing import Callable, Optional

import numpy as np

CURVE_SHAPES = ("RIBBONS", "THICK", "THICK_LINEAR")
EMISSION_SAMPLING = ("AUTO", "NONE", "FRONT", "BACK", "FRONT_BACK")  # materials' emission_sampling
CAMERA_TYPES = ("PERSP", "ORTHO")
SENSOR_FITS = ("AUTO", "HORIZONTAL", "VERTICAL")
LIGHT_TYPES = ("SUN", "POINT", "SPOT", "AREA")
AREA_SHAPES = ("SQUARE", "RECTANGLE", "DISK", "ELLIPSE")
FILTER_TYPES = ("BLACKMAN_HARRIS", "GAUSSIAN", "BOX")
CLOSURE_TYPES = ("principled_hair", "diffuse", "emission", "cycles_hair", "hair_model")
CYCLES_HAIR_COMPONENTS = ("REFLECTION", "TRANSMISSION")
HAIR_MODELS = ("CHIANG", "HUANG")
PARAMETRIZATIONS = ("COLOR", "MELANIN", "ABSORPTION")
TILTS = ("4.2", "3.4")
ACCURACIES = ("cycles", "exact")
HUANG_SAMPLERS = ("cycles", "mixture")  # the engine's Huang BSDF sampler (docs/huang.md §10)
HUANG_GLASS_ALBEDO_TABLES = ("4.x", "5.x")  # Huang energy-compensation tables of Cycles 4.x / 5.x (docs/blender5.md)
# integrator["passes"] -> result keys: hair_lobes -> hair_r, hair_tt, hair_trt, hair_trrt (H, W, 3);
# depth -> depth (H, W); normal -> normal (H, W, 3); variance -> variance (H, W, 3) (docs/engine.md)
PASSES = ("hair_lobes", "depth", "normal", "variance")
HAIR_INPUTS = ("color", "melanin", "melanin_redness", "tint", "absorption_coefficient", "roughness",
               "radial_roughness", "coat", "ior", "offset", "random_color", "random_roughness", "random",
               "aspect_ratio", "reflection", "transmission", "secondary_reflection")  # the last four: Huang
_HAIR_COLOR_INPUTS = ("color", "tint", "absorption_coefficient")


class _Checker:
    """Helpers that raise errors naming the key path, e.g. scene['lights'][0]['strength']."""

    @staticmethod
    def dict(key, value):
        if not isinstance(value, dict):
            raise TypeError(f"{key}: expected a dict, got {type(value).__name__}")
        return value

    @staticmethod
    def string(key, value):
        if not isinstance(value, str):
            raise TypeError(f"{key}: expected a string")
        return value

    @staticmethod
    def list(key, value):
        if not isinstance(value, (list, tuple)):
            raise TypeError(f"{key}: expected a list, got {type(value).__name__}")
        return list(value)

    @staticmethod
    def required(key, d, name):
        if name not in d:
            raise ValueError(f"{key}['{name}']: missing (required, see docs/scene_desc.md)")
        return d[name]

    @staticmethod
    def real(key, value):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise TypeError(f"{key}: expected a number, got {type(value).__name__}")
        return float(value)

    @staticmethod
    def integer(key, value, minimum=None):
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise TypeError(f"{key}: expected an integer, got {type(value).__name__}")
        if minimum is not None and value < minimum:
            raise ValueError(f"{key}: must be >= {minimum}, got {value}")
        return int(value)

    @staticmethod
    def boolean(key, value):
        if not isinstance(value, (bool, np.bool_)):
            raise TypeError(f"{key}: expected a bool, got {type(value).__name__}")
        return bool(value)

    @staticmethod
    def choice(key, value, allowed):
        if not isinstance(value, str):
            raise TypeError(f"{key}: expected a string, one of {list(allowed)}")
        if value not in allowed:
            raise ValueError(f"{key}: {value!r} is not allowed; use one of {list(allowed)}")
        return value

    @staticmethod
    def vector(key, value, n, what="numbers"):
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{key}: expected {n} {what}") from exc
        if arr.shape != (n,):
            raise ValueError(f"{key}: expected {n} {what}, got shape {arr.shape}")
        return tuple(float(v) for v in arr)

    @staticmethod
    def matrix4(key, value):
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{key}: expected a 4x4 matrix") from exc
        if arr.shape != (4, 4):
            raise ValueError(f"{key}: expected a 4x4 matrix, got shape {arr.shape}")
        return np.ascontiguousarray(arr)

    @staticmethod
    def array(key, value, dtype, cols):
        """(N, cols) or, for cols None, (N,) array converted to dtype; integers must be integral."""
        if isinstance(value, np.ndarray):
            arr = value
        else:
            try:
                arr = np.asarray(value)
            except (TypeError, ValueError) as exc:
                raise TypeError(f"{key}: expected an array") from exc
        if arr.size == 0:
            arr = arr.reshape((0,) if cols is None else (0, cols)).astype(dtype)
        if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_):
            raise TypeError(f"{key}: dtype {arr.dtype} is not allowed; pass numbers")
        want = (1 if cols is None else 2)
        if arr.ndim != want or (cols is not None and arr.shape[1] != cols):
            shape = "(N,)" if cols is None else f"(N, {cols})"
            raise ValueError(f"{key}: expected shape {shape}, got {arr.shape}")
        if np.issubdtype(dtype, np.integer):
            if not np.issubdtype(arr.dtype, np.integer):
                if not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
                    raise TypeError(f"{key}: expected integers")
            if arr.size and (arr.min() < np.iinfo(np.int32).min or arr.max() > np.iinfo(np.int32).max):
                raise ValueError(f"{key}: values outside the int32 range")
        return np.ascontiguousarray(arr, dtype=dtype)


def _check_curves(scene, out):
    if scene.get("curves") is None:
        return
    key = "scene['curves']"
    c = _Checker.dict(key, scene["curves"])
    req = lambda name: _Checker.required(key, c, name)  # noqa: E731
    points = _Checker.array(f"{key}['points']", req("points"), np.float32, 4)
    offsets = _Checker.array(f"{key}['curve_offsets']", req("curve_offsets"), np.int32, None)
    n_curves = max(len(offsets) - 1, 0)
    if len(offsets) == 0 and len(points) > 0:
        raise ValueError(f"{key}['curve_offsets']: expected C + 1 entries for {len(points)} points")
    if len(offsets):
        if offsets[0] != 0 or offsets[-1] != len(points):
            raise ValueError(f"{key}['curve_offsets']: must start at 0 and end at len(points) = {len(points)}")
        if np.any(np.diff(offsets) < 0):
            raise ValueError(f"{key}['curve_offsets']: must be non-decreasing")
    random = _Checker.array(f"{key}['curve_random']", req("curve_random"), np.float32, None)
    material = _Checker.array(f"{key}['curve_material']", req("curve_material"), np.int32, None)
    for name, arr in (("curve_random", random), ("curve_material", material)):
        if len(arr) != n_curves:
            raise ValueError(f"{key}['{name}']: expected one value per curve ({n_curves}), got {len(arr)}")
    curves = {"points": points, "curve_offsets": offsets, "curve_random": random, "curve_material": material}
    if c.get("curve_intercept_total") is not None:
        curves["curve_intercept_total"] = _Checker.array(f"{key}['curve_intercept_total']",
                                                         c["curve_intercept_total"], np.float32, None)
    if c.get("point_intercept") is not None:
        intercept = _Checker.array(f"{key}['point_intercept']", c["point_intercept"], np.float32, None)
        if len(intercept) != len(points):
            raise ValueError(f"{key}['point_intercept']: expected one value per point ({len(points)}), "
                             f"got {len(intercept)}")
        curves["point_intercept"] = intercept
    if c.get("curve_object") is not None:
        curve_object = _Checker.array(f"{key}['curve_object']", c["curve_object"], np.int32, None)
        if len(curve_object) != n_curves:
            raise ValueError(f"{key}['curve_object']: expected one value per curve ({n_curves}), got {len(curve_object)}")
        if c.get("object_transforms") is None:
            raise ValueError(f"{key}['object_transforms']: missing (required with curve_object)")
        transforms = _Checker.array(f"{key}['object_transforms']", c["object_transforms"], np.float64, 12)
        for k, m in enumerate(transforms.reshape(-1, 3, 4)):
            if not np.all(np.isfinite(m)) or np.linalg.det(m[:, :3]) == 0.0:
                raise ValueError(f"{key}['object_transforms'][{k}]: expected a finite, invertible row-major 3x4 "
                                 "matrix (world from object)")
        if len(curve_object) and (curve_object.min() < -1 or curve_object.max() >= len(transforms)):
            raise ValueError(f"{key}['curve_object']: expected -1 (world space) or an index into object_transforms "
                             f"(0 to {len(transforms) - 1})")
        curves["curve_object"], curves["object_transforms"] = curve_object, transforms
    if c.get("attributes") is not None:
        attrs = []
        for i, a in enumerate(_Checker.list(f"{key}['attributes']", c["attributes"])):
            ak = f"{key}['attributes'][{i}]"
            a = _Checker.dict(ak, a)
            name = _Checker.string(f"{ak}['name']", _Checker.required(ak, a, "name"))
            domain = _Checker.choice(f"{ak}['domain']", _Checker.required(ak, a, "domain"), ("POINT", "CURVE"))
            data = _Checker.array(f"{ak}['data']", _Checker.required(ak, a, "data"), np.float32, 4)
            want = len(points) if domain == "POINT" else n_curves
            if len(data) != want:
                raise ValueError(f"{ak}['data']: expected one RGBA row per {domain.lower()} ({want}), got {len(data)}")
            attrs.append({"name": name, "domain": domain, "data": data})
        curves["attributes"] = attrs
    if c.get("normals") is not None:
        normals = _Checker.array(f"{key}['normals']", c["normals"], np.float32, 3)
        if len(normals) != len(points):
            raise ValueError(f"{key}['normals']: expected one normal per point ({len(points)}), got {len(normals)}")
        curves["normals"] = normals
    out["curves"] = curves
    if "curve_shape" in scene:
        out["curve_shape"] = _Checker.choice("scene['curve_shape']", scene["curve_shape"], CURVE_SHAPES)
    if "curve_subdivisions" in scene:
        out["curve_subdivisions"] = _Checker.integer("scene['curve_subdivisions']", scene["curve_subdivisions"], 0)
    if scene.get("curve_backface_culling") is not None:
        out["curve_backface_culling"] = _Checker.boolean("scene['curve_backface_culling']",
                                                         scene["curve_backface_culling"])


def _check_meshes(scene, out):
    if scene.get("meshes") is None:
        return
    key = "scene['meshes']"
    m = _Checker.dict(key, scene["meshes"])
    vertices = _Checker.array(f"{key}['vertices']", _Checker.required(key, m, "vertices"), np.float32, 3)
    triangles = _Checker.array(f"{key}['triangles']", _Checker.required(key, m, "triangles"), np.int32, 3)
    material = _Checker.array(f"{key}['triangle_material']", _Checker.required(key, m, "triangle_material"),
                              np.int32, None)
    if len(material) != len(triangles):
        raise ValueError(f"{key}['triangle_material']: expected one value per triangle ({len(triangles)})")
    out["meshes"] = {"vertices": vertices, "triangles": triangles, "triangle_material": material}
    if m.get("triangle_normals") is not None:
        normals = _Checker.array(f"{key}['triangle_normals']", m["triangle_normals"], np.float32, 9)
        if len(normals) != len(triangles):
            raise ValueError(f"{key}['triangle_normals']: expected one row of 3 corner normals per triangle "
                             f"({len(triangles)})")
        out["meshes"]["triangle_normals"] = normals
    if m.get("triangle_object") is not None:
        objects = _Checker.array(f"{key}['triangle_object']", m["triangle_object"], np.int32, None)
        if len(objects) != len(triangles):
            raise ValueError(f"{key}['triangle_object']: expected one object id per triangle ({len(triangles)})")
        out["meshes"]["triangle_object"] = objects
    if m.get("attributes") is not None:
        attrs = []
        curve_names = [a["name"] for a in (out.get("curves") or {}).get("attributes", [])]
        for i, a in enumerate(_Checker.list(f"{key}['attributes']", m["attributes"])):
            ak = f"{key}['attributes'][{i}]"
            a = _Checker.dict(ak, a)
            name = _Checker.string(f"{ak}['name']", _Checker.required(ak, a, "name"))
            if i < len(curve_names) and name != curve_names[i]:
                raise ValueError(f"{ak}['name']: expected {curve_names[i]!r}, the curves' attribute {i} (one attribute "
                                 "list for both, in the programs' order)")
            data = _Checker.array(f"{ak}['data']", _Checker.required(ak, a, "data"), np.float32, 12)
            if len(data) != len(triangles):
                raise ValueError(f"{ak}['data']: expected one row of 3 RGBA corners per triangle ({len(triangles)}), "
                                 f"got {len(data)}")
            attrs.append({"name": name, "data": data})
        out["meshes"]["attributes"] = attrs


def _check_model_param(key, value):
    """A hair_model parameter: a bool, a number, a string (a choice) or an RGB triple."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, str):
        return value
    if isinstance(value, numbers.Real):
        return float(value)
    if value is None or isinstance(value, dict) or not hasattr(value, "__len__"):
        raise TypeError(f"{key}: expected a number, an RGB triple, a string or a bool, got {type(value).__name__}")
    return _Checker.vector(key, value, 3, "numbers (r, g, b)")


def _check_hair_model(key, c, out):
    """The `hair_model` closure: structure here; names, types and ranges against the model's
    schema in the model factory when the renderer builds it (errors name the material)."""
    from . import _core

    allowed = tuple(_core.zoo_model_names()) + ("plugin",)
    out["model"] = _Checker.choice(f"{key}['model']", _Checker.required(key, c, "model"), allowed)
    if out["model"] == "plugin":
        path = _Checker.required(key, c, "path")
        if not isinstance(path, str):
            raise TypeError(f"{key}['path']: expected a string (the plugin library's path)")
        out["path"] = path
    params = _Checker.dict(f"{key}['params']", c.get("params", {}))
    for name in params:
        if not isinstance(name, str):
            raise TypeError(f"{key}['params']: parameter names must be strings, got {name!r}")
    out["params"] = {name: _check_model_param(f"{key}['params']['{name}']", v) for name, v in params.items()}


def _check_closure(key, c):
    c = _Checker.dict(key, c)
    kind = _Checker.choice(f"{key}['type']", _Checker.required(key, c, "type"), CLOSURE_TYPES)
    out = {"type": kind, "weight": _Checker.vector(f"{key}['weight']", c.get("weight", (1.0, 1.0, 1.0)), 3)}
    if kind == "hair_model":
        _check_hair_model(key, c, out)
    elif kind == "principled_hair":
        out["model"] = _Checker.choice(f"{key}['model']", c.get("model", "CHIANG"), HAIR_MODELS)
        out["parametrization"] = _Checker.choice(f"{key}['parametrization']", c.get("parametrization", "COLOR"),
                                                 PARAMETRIZATIONS)
        inputs = _Checker.dict(f"{key}['inputs']", c.get("inputs", {}))
        checked = {}
        for name, value in inputs.items():
            k = f"{key}['inputs']['{name}']"
            if name not in HAIR_INPUTS:
                raise ValueError(f"{k}: unknown input; allowed: {list(HAIR_INPUTS)}")
            if name == "random" and value is None:
                checked[name] = None
            elif isinstance(value, dict):
                checked[name] = _check_register(k, value)
            elif name in _HAIR_COLOR_INPUTS:
                checked[name] = _Checker.vector(k, value, 3)
            else:
                checked[name] = _Checker.real(k, value)
        out["inputs"] = checked
    elif kind == "cycles_hair":
        out["component"] = _Checker.choice(f"{key}['component']", c.get("component", "REFLECTION"),
                                           CYCLES_HAIR_COMPONENTS)
        out["color"] = _Checker.vector(f"{key}['color']", c.get("color", (0.8, 0.8, 0.8)), 3)
        out["offset"] = _Checker.real(f"{key}['offset']", c.get("offset", 0.0))
        out["roughness_u"] = _Checker.real(f"{key}['roughness_u']", c.get("roughness_u", 0.1))
        out["roughness_v"] = _Checker.real(f"{key}['roughness_v']", c.get("roughness_v", 1.0))
    else:
        color = c.get("color", (0.8, 0.8, 0.8))
        out["color"] = (_check_register(f"{key}['color']", color) if isinstance(color, dict)
                        else _Checker.vector(f"{key}['color']", color, 3))
        if kind == "emission":
            strength = c.get("strength", 1.0)
            out["strength"] = (_check_register(f"{key}['strength']", strength) if isinstance(strength, dict)
                               else _Checker.real(f"{key}['strength']", strength))
    return out


def _check_register(key, value):
    """A closure input driven by the material's program: {"register": slot}."""
    if set(value) != {"register"}:
        raise ValueError(f"{key}: expected a number or {{'register': slot}}, got keys {sorted(value)}")
    return {"register": _Checker.integer(f"{key}['register']", value["register"], 0)}


def _check_program(key, p):
    p = _Checker.dict(key, p)
    code = _Checker.array(f"{key}['code']", _Checker.required(key, p, "code"), np.int32, None)
    constants = _Checker.array(f"{key}['constants']", _Checker.required(key, p, "constants"), np.float32, None)
    registers = _Checker.integer(f"{key}['registers']", _Checker.required(key, p, "registers"), len(constants))
    return {"code": code, "constants": constants, "registers": registers}


def _check_materials(scene, out):
    if scene.get("materials") is None:
        return
    mats = []
    for i, m in enumerate(_Checker.list("scene['materials']", scene["materials"])):
        key = f"scene['materials'][{i}]"
        m = _Checker.dict(key, m)
        closures = _Checker.list(f"{key}['closures']", _Checker.required(key, m, "closures"))
        name = _Checker.string(f"{key}['name']", m.get("name", ""))
        mat = {"name": name,
               "closures": [_check_closure(f"{key}['closures'][{j}]", c) for j, c in enumerate(closures)]}
        if m.get("program") is not None:
            mat["program"] = _check_program(f"{key}['program']", m["program"])
        if m.get("emission_sampling") is not None:
            mat["emission_sampling"] = _Checker.choice(f"{key}['emission_sampling']", m["emission_sampling"],
                                                       EMISSION_SAMPLING)
        mats.append(mat)
    out["materials"] = mats


def _check_camera(scene, out):
    key = "scene['camera']"
    c = _Checker.dict(key, _Checker.required("scene", scene, "camera"))
    cam = {"type": _Checker.choice(f"{key}['type']", _Checker.required(key, c, "type"), CAMERA_TYPES),
           "matrix_world": _Checker.matrix4(f"{key}['matrix_world']", _Checker.required(key, c, "matrix_world"))}
    res = _Checker.required(key, c, "resolution")
    if not isinstance(res, (list, tuple, np.ndarray)) or len(res) != 2:
        raise ValueError(f"{key}['resolution']: expected (width, height)")
    w = _Checker.integer(f"{key}['resolution'][0]", res[0] if not isinstance(res[0], np.integer) else int(res[0]), 1)
    h = _Checker.integer(f"{key}['resolution'][1]", res[1] if not isinstance(res[1], np.integer) else int(res[1]), 1)
    if w > 65536 or h > 65536:
        raise ValueError(f"{key}['resolution']: at most 65536 x 65536")
    cam["resolution"] = (w, h)
    if "sensor_fit" in c:
        cam["sensor_fit"] = _Checker.choice(f"{key}['sensor_fit']", c["sensor_fit"], SENSOR_FITS)
    for name in ("pixel_aspect", "sensor_width", "sensor_height", "lens", "ortho_scale", "shift_x", "shift_y",
                 "clip_start", "clip_end"):
        if c.get(name) is not None:
            cam[name] = _Checker.real(f"{key}['{name}']", c[name])
    out["camera"] = cam


def _check_lights(scene, out):
    if scene.get("lights") is None:
        return
    lights = []
    for i, l in enumerate(_Checker.list("scene['lights']", scene["lights"])):
        key = f"scene['lights'][{i}]"
        l = _Checker.dict(key, l)
        req = lambda name: _Checker.required(key, l, name)  # noqa: E731,B023
        kind = _Checker.choice(f"{key}['type']", req("type"), LIGHT_TYPES)
        d = {"type": kind, "strength": _Checker.vector(f"{key}['strength']", req("strength"), 3)}
        for name in ("normalize", "use_mis", "visible_camera"):
            if l.get(name) is not None:
                d[name] = _Checker.boolean(f"{key}['{name}']", l[name])
        if kind == "SUN":
            d["direction"] = _Checker.vector(f"{key}['direction']", req("direction"), 3)
            d["angle"] = _Checker.real(f"{key}['angle']", l.get("angle", 0.0))
        elif kind in ("POINT", "SPOT"):
            d["position"] = _Checker.vector(f"{key}['position']", req("position"), 3)
            d["radius"] = _Checker.real(f"{key}['radius']", l.get("radius", 0.0))
            if l.get("soft_falloff") is not None:
                d["soft_falloff"] = _Checker.boolean(f"{key}['soft_falloff']", l["soft_falloff"])
            if kind == "SPOT":
                d["direction"] = _Checker.vector(f"{key}['direction']", req("direction"), 3)
                d["spot_size"] = _Checker.real(f"{key}['spot_size']", req("spot_size"))
                d["spot_blend"] = _Checker.real(f"{key}['spot_blend']", req("spot_blend"))
                if l.get("matrix_world") is not None:
                    d["matrix_world"] = _Checker.matrix4(f"{key}['matrix_world']", l["matrix_world"])
                if l.get("spot_cosine") is not None:
                    d["spot_cosine"] = _Checker.boolean(f"{key}['spot_cosine']", l["spot_cosine"])
        else:
            d["matrix_world"] = _Checker.matrix4(f"{key}['matrix_world']", req("matrix_world"))
            d["shape"] = _Checker.choice(f"{key}['shape']", req("shape"), AREA_SHAPES)
            d["size_x"] = _Checker.real(f"{key}['size_x']", req("size_x"))
            d["size_y"] = _Checker.real(f"{key}['size_y']", l.get("size_y", d["size_x"]))
            d["spread"] = _Checker.real(f"{key}['spread']", l.get("spread", np.pi))
        lights.append(d)
    out["lights"] = lights


def _check_world(scene, out):
    if scene.get("world") is None:
        return
    w = _Checker.dict("scene['world']", scene["world"])
    out["world"] = {"color": _Checker.vector("scene['world']['color']", w.get("color", (0.0, 0.0, 0.0)), 3)}
    if w.get("mis") is not None:
        out["world"]["mis"] = _Checker.boolean("scene['world']['mis']", w["mis"])
    if w.get("map_resolution") is not None:
        out["world"]["map_resolution"] = _Checker.integer("scene['world']['map_resolution']", w["map_resolution"], 0)
    if w.get("texture") is not None:
        key = "scene['world']['texture']"
        t = _Checker.dict(key, w["texture"])
        try:
            pixels = np.asarray(_Checker.required(key, t, "pixels"), dtype=np.float32)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{key}['pixels']: expected an array of numbers") from exc
        if pixels.ndim != 3 or pixels.shape[2] != 3 or pixels.shape[0] < 1 or pixels.shape[1] < 1:
            raise ValueError(f"{key}['pixels']: expected shape (height, width, 3) with height, width >= 1, "
                             f"got {pixels.shape}")
        tex = {"pixels": np.ascontiguousarray(pixels),
               "weight": _Checker.vector(f"{key}['weight']", _Checker.required(key, t, "weight"), 3),
               "interpolation": _Checker.choice(f"{key}['interpolation']", t.get("interpolation", "LINEAR"),
                                                ("LINEAR", "CLOSEST"))}
        if t.get("srgb_encoded") is not None:
            tex["srgb_encoded"] = _Checker.boolean(f"{key}['srgb_encoded']", t["srgb_encoded"])
        if t.get("matrix") is not None:
            try:
                m = np.asarray(t["matrix"], dtype=np.float64)
            except (TypeError, ValueError) as exc:
                raise TypeError(f"{key}['matrix']: expected a 3x4 or 4x4 matrix") from exc
            if m.shape not in ((3, 4), (4, 4)):
                raise ValueError(f"{key}['matrix']: expected a 3x4 or 4x4 matrix, got shape {m.shape}")
            tex["matrix"] = np.ascontiguousarray(m[:3])
        out["world"]["texture"] = tex


def _check_images(scene, out):
    """The images the shading programs' ImageTexture op samples: [{"name", "pixels" (H, W, 4)}]."""
    if scene.get("images") is None:
        return
    images = []
    for i, im in enumerate(_Checker.list("scene['images']", scene["images"])):
        key = f"scene['images'][{i}]"
        im = _Checker.dict(key, im)
        name = _Checker.string(f"{key}['name']", im.get("name", ""))
        try:
            pixels = np.asarray(_Checker.required(key, im, "pixels"), dtype=np.float32)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{key}['pixels']: expected an array of numbers") from exc
        if pixels.ndim != 3 or pixels.shape[2] != 4 or pixels.shape[0] < 1 or pixels.shape[1] < 1:
            raise ValueError(f"{key}['pixels']: expected shape (height, width, 4) with height, width >= 1, "
                             f"got {pixels.shape}")
        images.append({"name": name, "pixels": np.ascontiguousarray(pixels)})
    out["images"] = images


def _check_integrator(scene, out):
    key = "scene['integrator']"
    s = _Checker.dict(key, _Checker.required("scene", scene, "integrator"))
    d = {"samples": _Checker.integer(f"{key}['samples']", _Checker.required(key, s, "samples"), 0)}
    if s.get("seed") is not None:
        d["seed"] = _Checker.integer(f"{key}['seed']", s["seed"]) & 0xFFFFFFFF
    for name in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "transparent_bounces", "min_light_bounces"):
        if s.get(name) is not None:
            d[name] = _Checker.integer(f"{key}['{name}']", s[name], 0)
    if s.get("filter_type") is not None:
        d["filter_type"] = _Checker.choice(f"{key}['filter_type']", s["filter_type"], FILTER_TYPES)
    for name in ("filter_width", "exposure", "light_sampling_threshold", "filter_glossy", "clamp_direct",
                 "clamp_indirect"):
        if s.get(name) is not None:
            d[name] = _Checker.real(f"{key}['{name}']", s[name])
    if s.get("film_transparent") is not None:
        d["film_transparent"] = _Checker.boolean(f"{key}['film_transparent']", s["film_transparent"])
    for name in ("light_tree", "chiang_lcg"):
        if s.get(name) is not None:
            d[name] = _Checker.boolean(f"{key}['{name}']", s[name])
    if s.get("tilt") is not None:
        d["tilt"] = _Checker.choice(f"{key}['tilt']", s["tilt"], TILTS)
    if s.get("accuracy") is not None:
        d["accuracy"] = _Checker.choice(f"{key}['accuracy']", s["accuracy"], ACCURACIES)
    if s.get("huang_sampler") is not None:
        d["huang_sampler"] = _Checker.choice(f"{key}['huang_sampler']", s["huang_sampler"], HUANG_SAMPLERS)
    if s.get("huang_glass_albedo_table") is not None:
        d["huang_glass_albedo_table"] = _Checker.choice(f"{key}['huang_glass_albedo_table']",
                                                        s["huang_glass_albedo_table"], HUANG_GLASS_ALBEDO_TABLES)
    if s.get("passes") is not None:
        names = _Checker.list(f"{key}['passes']", s["passes"])
        d["passes"] = [_Checker.choice(f"{key}['passes'][{i}]", n, PASSES) for i, n in enumerate(names)]
    out["integrator"] = d


def validate_scene(scene: dict) -> dict:
    """Checks the structure of a scene_desc dict and returns a normalised copy (arrays in the
    dtypes the renderer reads, optional keys filled only where given). Raises ValueError /
    TypeError naming the offending key."""
    _Checker.dict("scene", scene)
    version = scene.get("version", 1)
    if version != 1:
        raise ValueError(f"scene['version']: {version!r} is not supported; use 1")
    out = {"version": 1}
    _check_curves(scene, out)
    _check_meshes(scene, out)
    _check_materials(scene, out)
    _check_camera(scene, out)
    _check_lights(scene, out)
    _check_world(scene, out)
    _check_images(scene, out)
    _check_integrator(scene, out)
    return out


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
    threads = _Checker.integer("threads", threads, 0)
    checked = validate_scene(scene)
    from . import _render  # lazily: loads Embree and TBB

    return _render.render(checked, progress, cancel, threads)


__all__ = ["render", "validate_scene"]
