"""Hair export: Curves objects (foreach_get + NumPy, no per-point Python) and legacy
particle hair (ParticleSystem.co_hair per key, everything else vectorised), both with
Cycles' semantics (docs/cycles.md §3.1):

* keys are transformed to world space by the instance matrix and radii scaled by
  |det M|^(1/3) (Hair::apply_transform) when the matrix is a uniform scale; otherwise Cycles
  keeps the curves in object space and intersects them there, and so do we (`curve_object`);
* Curves: point-domain `radius` or 0.005 when absent; every curve uses the object's first
  material slot (Cycles ignores the curve-domain `material_index`, checked with Cycles
  3.4.1 and 4.5.15);
* particle hair: 2^render_step + 1 keys (+ kink_extra_steps for spiral kink), only the
  children when a child type is set, radius rad_scale*0.5*(root..tip) shaped over the
  normalised object-space arc length, 0 at a closed tip, material slot `material - 1`;
* Random = lookup3 hash of the curve index within the object (all particle systems of
  an object counted together), computed before invalid strands are dropped.
"""

from __future__ import annotations

import itertools
import time

import numpy as np

from ..render import schema_choices
from ._common import curves_object_space, radius_scale, transform_points, working_space
from .images import srgb_to_linear
from .shading_network import UV_ATTRIBUTE

DEFAULT_CURVES_RADIUS = 0.005


class HairBuffer:
    """All strands of the scene, concatenated."""

    def __init__(self):
        self.points: list[np.ndarray] = []      # (P_i, 4) float32
        self.counts: list[np.ndarray] = []      # (C_i,) int64 points per curve
        self.random: list[np.ndarray] = []      # (C_i,) float32
        self.material: list[np.ndarray] = []    # (C_i,) int32
        self.length: list[np.ndarray] = []      # (C_i,) float32
        self.normals: list = []                 # (P_i, 3) float32 world curve normals, or None
        self.intercept: list = []               # (P_i,) float32 Hair Info > Intercept, or None
        self.attributes: list = []              # {name: (domain, (P_i, 4) float32 RGBA per point)}
        self.object_space: list = []            # 12 float64 (world from object) when kept there, or None
        self._random_cache = np.zeros(0, np.float32)

    def curve_random(self, n: int) -> np.ndarray:
        """Cycles' Hair Info > Random of curves 0..n-1 (float32, as Cycles stores it)."""
        if n > self._random_cache.size:
            import hairbsdf
            self._random_cache = np.asarray(
                hairbsdf.cycles_curve_random(np.arange(max(n, 2 * self._random_cache.size), dtype=np.int64)),
                dtype=np.float32)
        return self._random_cache[:n]

    def add(self, points, counts, random, material, length, normals=None, intercept=None, attributes=None,
            object_space=None):
        if counts.size == 0:
            return
        self.object_space.append(object_space)
        self.normals.append(normals)
        self.intercept.append(intercept)
        self.attributes.append(attributes or {})
        self.points.append(points)
        self.counts.append(counts)
        self.random.append(random)
        self.material.append(material)
        self.length.append(length)

    def finish(self, attribute_names=()) -> dict:
        """The `curves` dict of docs/scene_desc.md; `attribute_names`: the curve attributes the
        shading programs read, in their VM order (absent on an object: 0)."""
        if self.counts:
            # One object (the common case of a big groom): no concatenated copy of the keys.
            pts = self.points[0] if len(self.points) == 1 else np.concatenate(self.points)
            self.points = []
            pts = np.ascontiguousarray(pts, dtype=np.float32)
            counts = np.concatenate(self.counts)
            offsets = np.zeros(counts.size + 1, np.int32)
            np.cumsum(counts, out=offsets[1:])
            extra = {}
            if any(n is not None for n in self.normals):  # zero = Cycles' fallback frame
                extra["normals"] = np.ascontiguousarray(np.concatenate(
                    [n if n is not None else np.zeros((c.sum(), 3), np.float32)
                     for n, c in zip(self.normals, self.counts)]), dtype=np.float32)
            self.normals = []
            if any(i is not None for i in self.intercept):
                extra["point_intercept"] = np.concatenate(
                    [i if i is not None else np.zeros(c.sum(), np.float32)
                     for i, c in zip(self.intercept, self.counts)]).astype(np.float32)
            if attribute_names:
                extra["attributes"] = [self._attribute(name, counts) for name in attribute_names]
            if any(m is not None for m in self.object_space):
                index = [-1 if m is None else k for k, m in enumerate(self.object_space)]
                extra["curve_object"] = np.repeat(np.array(index, np.int32), [c.size for c in self.counts])
                extra["object_transforms"] = np.array([m if m is not None else np.eye(3, 4).reshape(12)
                                                       for m in self.object_space], np.float64)
            self.object_space = []
            self.intercept, self.attributes = [], []
            return {**extra, "points": pts, "curve_offsets": offsets,
                    "curve_random": np.concatenate(self.random).astype(np.float32),
                    "curve_material": np.concatenate(self.material).astype(np.int32),
                    "curve_intercept_total": np.concatenate(self.length).astype(np.float32)}
        return {"points": np.zeros((0, 4), np.float32), "curve_offsets": np.zeros(1, np.int32),
                "curve_random": np.zeros(0, np.float32), "curve_material": np.zeros(0, np.int32),
                "curve_intercept_total": np.zeros(0, np.float32)}


    def _attribute(self, name, counts) -> dict:
        parts = [a.get(name) for a in self.attributes]
        per_point = np.concatenate([p[1] if p is not None else np.zeros((c.sum(), 4), np.float32)
                                    for p, c in zip(parts, self.counts)])
        if all(p is None or p[0] == "CURVE" for p in parts):
            starts = _curve_starts(counts)
            return {"name": name, "domain": "CURVE", "data": np.ascontiguousarray(per_point[starts], np.float32)}
        return {"name": name, "domain": "POINT", "data": np.ascontiguousarray(per_point, np.float32)}


def point_intercept(pos: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Hair Info > Intercept per key as Cycles exports it for Curves: the object-space polyline
    length from the root to the key over the curve's length (0 where the length is 0)."""
    seg = np.zeros(pos.shape[0], np.float32)
    if pos.shape[0] > 1:
        d = np.diff(pos.astype(np.float32), axis=0)
        seg[1:] = np.sqrt(np.einsum("ij,ij->i", d, d))
    starts = _curve_starts(counts)
    seg[starts[starts < seg.size]] = 0.0
    seg[~np.isfinite(seg)] = 0.0
    csum = np.cumsum(seg, dtype=np.float64)
    along = csum - np.repeat(csum[starts] - seg[starts], counts)
    total = np.repeat(along[np.maximum(starts + counts - 1, 0)], counts) if counts.size else along
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(total > 0, along / total, along)
    return out.astype(np.float32)


ATTRIBUTE_READERS = {  # data_type -> (foreach_get property, components)
    "FLOAT": ("value", 1), "INT": ("value", 1), "BOOLEAN": ("value", 1), "INT8": ("value", 1),
    "FLOAT_VECTOR": ("vector", 3), "FLOAT_COLOR": ("color", 4), "BYTE_COLOR": ("color", 4),
    "FLOAT2": ("vector", 2),
}


def curves_uv_name(data, name):
    """The Curves attribute a program's UV attribute name stands for (shading_network.UV_ATTRIBUTE):
    a named map is the attribute of that name; the default UV is, as in Cycles (3.4.1 and 4.5.15,
    checked by rendering Texture Coordinate > UV), the first 2D-vector attribute of the curve
    domain in the attribute order (`surface_uv_coordinate` for hair made by Blender's tools);
    None when there is none (the UV reads 0)."""
    if name != UV_ATTRIBUTE:
        return name[len(UV_ATTRIBUTE):]
    for attr in data.attributes:
        if attr.domain == "CURVE" and attr.data_type == "FLOAT2" and not attr.name.startswith("."):
            return attr.name
    return None


def curves_attribute_rgba(obj, data, name, report):
    """(domain, (P, 4) float32 RGBA per point) of a Curves attribute as Cycles' Attribute node
    reads it (float f -> (f, f, f, 1), vector -> (x, y, z, 1), colour RGBA scene-linear), or None
    when the object does not have it."""
    attr = data.attributes.get(name)
    if attr is None:
        return None
    reader = ATTRIBUTE_READERS.get(attr.data_type)
    if reader is None or attr.domain not in schema_choices("curves.attributes[].domain"):
        report.warn(f"Curves '{obj.name}': attribute '{name}' ({attr.domain} {attr.data_type}) is not supported; "
                    "read as 0")
        return None
    prop, n = reader
    size = len(attr.data)
    raw = np.empty(size * n, np.float64 if attr.data_type in ("INT", "BOOLEAN", "INT8") else np.float32)
    if attr.data_type in ("INT", "BOOLEAN", "INT8"):
        raw = np.array([v.value for v in attr.data], np.float64) if size else raw
    elif attr.data_type == "BYTE_COLOR" and working_space().rec709_to_scene_linear is not None:
        # Blender's `color` is in the working space; Cycles 5.3 renders a hair byte colour as the
        # sRGB-decoded bytes in every working space (test_working_space_matches_cycles).
        attr.data.foreach_get("color_srgb", raw)
        rgba = raw.reshape(size, 4)
        rgba[:, :3] = srgb_to_linear(rgba[:, :3])
    else:
        attr.data.foreach_get(prop, raw)
    raw = np.nan_to_num(raw.reshape(size, n).astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    rgba = np.ones((size, 4), np.float32)
    if n == 1:
        rgba[:, :3] = raw
    else:
        rgba[:, :n] = raw
        if n == 2:  # 2D vector (a UV): (u, v, 0, 1)
            rgba[:, 2] = 0.0
    if attr.domain == "CURVE":
        counts = np.diff(_curve_offsets(data))
        rgba = np.repeat(rgba, counts, axis=0)
    return attr.domain, rgba


def _curve_offsets(data):
    off = np.empty(len(data.curves) + 1, np.int32)
    if hasattr(data, "curve_offset_data"):
        data.curve_offset_data.foreach_get("value", off)
    else:  # pragma: no cover
        firsts = np.empty(len(data.curves), np.int32)
        data.curves.foreach_get("first_point_index", firsts)
        off[:-1] = firsts
        off[-1] = len(data.points)
    return off


# ---------------------------------------------------------------------------- validation

def _curve_starts(counts: np.ndarray) -> np.ndarray:
    starts = np.zeros(counts.size, np.int64)
    if counts.size > 1:
        np.cumsum(counts[:-1], out=starts[1:])
    return starts


def curve_lengths(pos: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Polyline length of each curve (float64 sums of float32 segments, like Cycles'
    float accumulation), from (P, 3) points and per-curve counts."""
    n = counts.size
    if n == 0:
        return np.zeros(0)
    seg = np.zeros(pos.shape[0], np.float32)
    if pos.shape[0] > 1:
        d = np.diff(pos, axis=0)
        seg[1:] = np.sqrt(np.einsum("ij,ij->i", d, d))
    starts = _curve_starts(counts)
    seg[starts[starts < seg.size]] = 0.0  # no segment across curve boundaries
    if not np.isfinite(seg).all():
        seg[~np.isfinite(seg)] = 0.0  # keep NaN/Inf out of the running sum (those strands are dropped)
    csum = np.zeros(pos.shape[0] + 1)
    np.cumsum(seg, dtype=np.float64, out=csum[1:])
    return csum[starts + counts] - csum[starts]


def _per_curve_max(values: np.ndarray, counts: np.ndarray) -> np.ndarray:
    out = np.zeros(counts.size, values.dtype)
    nz = counts > 0
    if nz.any():
        out[nz] = np.maximum.reduceat(values, _curve_starts(counts)[nz])
    return out


def clean_strands(name, pts4, counts, random, material, length, report):
    """Drop strands Cycles would not render sensibly (fewer than two keys, non-finite keys or
    radii, zero length, zero radius everywhere); clamp negative radii to 0. Warns with
    counts. Returns the filtered arrays."""
    n = counts.size
    if n == 0:
        return pts4, counts, random, material, length
    bad_finite = np.zeros(n, bool)
    if not np.isfinite(pts4).all():  # rare: only then the per-point work
        bad_pt = ~np.isfinite(pts4).all(axis=1)
        bad_finite = _per_curve_max(bad_pt.astype(np.uint8), counts) > 0
        pts4[bad_pt] = 0.0
    rad = pts4[:, 3]
    if (rad < 0).any():
        neg = rad < 0
        report.warn(f"'{name}': {int(np.count_nonzero(neg))} hair keys have a negative radius; clamped to 0")
        rad[neg] = 0.0
    rmax = _per_curve_max(rad, counts)
    too_short = counts < 2
    ok = ~(bad_finite | too_short)
    zero_len = ok & ~(length > 0.0)
    zero_rad = ok & (rmax <= 0.0)
    for mask, what in ((bad_finite, "NaN or infinite coordinates"), (too_short, "fewer than 2 keys"),
                       (zero_len, "zero length"), (zero_rad, "zero radius")):
        k = int(np.count_nonzero(mask))
        if k:
            report.warn(f"'{name}': {k} of {n} strands have {what}; skipped")
            report.add_count("strands_skipped", k)
    keep = ~(bad_finite | too_short | zero_len | zero_rad)
    if keep.all():
        return pts4, counts, random, material, length
    keep_pt = np.repeat(keep, counts)
    return (pts4[keep_pt], counts[keep], random[keep], material[keep], length[keep])


# ---------------------------------------------------------------------------- Curves

def curves_local_arrays(data):
    """(positions (P,3) float32, radius (P,) float32, counts (C,) int64, has_radius) of a
    Curves datablock, object space."""
    n_pts = len(data.points)
    n_cur = len(data.curves)
    pos = np.empty(n_pts * 3, np.float32)
    if hasattr(data, "position_data"):
        data.position_data.foreach_get("vector", pos)
    else:  # pragma: no cover - older API
        data.attributes["position"].data.foreach_get("vector", pos)
    pos = pos.reshape(n_pts, 3)
    attr = data.attributes.get("radius")
    has_radius = attr is not None and attr.domain == "POINT" and attr.data_type == "FLOAT"
    if has_radius:
        rad = np.empty(n_pts, np.float32)
        attr.data.foreach_get("value", rad)
    else:
        rad = np.full(n_pts, DEFAULT_CURVES_RADIUS, np.float32)
    off = np.empty(n_cur + 1, np.int32)
    if hasattr(data, "curve_offset_data"):
        data.curve_offset_data.foreach_get("value", off)
    else:  # pragma: no cover
        firsts = np.empty(n_cur, np.int32)
        data.curves.foreach_get("first_point_index", firsts)
        off[:-1] = firsts
        off[-1] = n_pts
    counts = np.diff(off).astype(np.int64)
    return pos, rad, counts, has_radius


def _material_index_warning(obj, data, report):
    attr = data.attributes.get("material_index")
    if attr is None or attr.domain != "CURVE":
        return
    mi = np.empty(len(data.curves), np.int32)
    try:
        attr.data.foreach_get("value", mi)
    except Exception:
        return
    if mi.size and mi.any():
        report.warn(f"Curves '{obj.name}': per-curve material_index is ignored; like Cycles, every "
                    "curve uses the first material slot")


class CurvesCache:
    """Object-space arrays per evaluated Curves datablock, so that N instances of one
    geometry cost one foreach_get."""

    def __init__(self):
        self._cache = {}

    def get(self, data):
        key = (data.as_pointer(), data.name, len(data.points), len(data.curves))
        hit = self._cache.get(key)
        if hit is None:
            pos, rad, counts, _ = curves_local_arrays(data)
            length = curve_lengths(pos, counts)
            hit = (pos, rad, counts, length)
            self._cache[key] = hit
        return hit

    def normals(self, data):
        """Object-space curve normals (P, 3) float32 (Blender's evaluated `Curves.normals`:
        the curve's normal mode, or the Set Curve Normal node's), or None without the API."""
        key = ("normals", data.as_pointer(), data.name, len(data.points))
        hit = self._cache.get(key)
        if hit is None:
            coll = getattr(data, "normals", None)
            if coll is None or len(coll) != len(data.points):
                return None
            # Not foreach_get: Blender 4.5 builds this array for the collection's iterator and
            # frees it when the iterator ends, so foreach_get and coll[i] read freed memory
            # (item 0 comes back as garbage). Reading inside one live iteration is correct;
            # it is a per-point loop (about 1 us a point), paid only for Huang materials.
            hit = np.array([v.vector[:] for v in coll], np.float32).reshape(-1, 3)
            self._cache[key] = hit
        return hit


def export_curves_object(obj, matrix, buffer: HairBuffer, materials, report, cache: CurvesCache):
    """One Curves instance (evaluated object + its world matrix as float64 (4,4))."""
    data = obj.data
    if len(data.curves) == 0:
        return 0
    t0 = time.perf_counter()
    pos, rad, counts, length = cache.get(data)
    _material_index_warning(obj, data, report)
    n = counts.size
    object_space = curves_object_space(matrix)
    pts4 = np.empty((pos.shape[0], 4), np.float32)
    if object_space is None:
        pts4[:, :3] = transform_points(matrix, pos)
        pts4[:, 3] = rad * np.float32(radius_scale(matrix))
    else:
        pts4[:, :3] = pos
        pts4[:, 3] = rad
    random = buffer.curve_random(n).copy()
    mat = np.full(n, materials.slot_indices(obj)[0], np.int32)
    normals = None
    # Per-key extras ride along as columns, so that clean_strands filters them with the keys.
    columns = []
    if materials.uses_huang(int(mat[0])):  # the ellipse's orientation; only Huang reads it
        local = cache.normals(data)
        if local is not None:
            m3 = np.asarray(matrix, np.float64)[:3, :3]
            normals = np.nan_to_num(local.astype(np.float64) @ m3.T).astype(np.float32)
            columns.append(("normals", normals))
    needs_intercept, attribute_names = materials.needs[int(mat[0])]
    if needs_intercept:
        columns.append(("intercept", point_intercept(pos, counts)[:, None]))
    domains = {}
    for name in sorted(attribute_names):
        source = curves_uv_name(data, name) if name.startswith(UV_ATTRIBUTE) else name
        got = None if source is None else curves_attribute_rgba(obj, data, source, report)
        if got is not None:
            domains[name] = got[0]
            columns.append((name, got[1]))
    if columns:
        pts4 = np.concatenate([pts4] + [c for _, c in columns], axis=1)
    pts4, counts, random, mat, length = clean_strands(obj.name, pts4, counts, random, mat,
                                                      length.astype(np.float32), report)
    extras, col = {}, 4
    for name, c in columns:
        extras[name] = np.ascontiguousarray(pts4[:, col:col + c.shape[1]])
        col += c.shape[1]
    pts4 = np.ascontiguousarray(pts4[:, :4])
    normals = extras.pop("normals", None)
    intercept = extras.pop("intercept", None)
    buffer.add(pts4, counts, random, mat, length, normals,
               intercept=None if intercept is None else intercept[:, 0].copy(),
               attributes={name: (domains[name], a) for name, a in extras.items()}, object_space=object_space)
    report.add_count("curves_objects", 1)
    report.timings["curves"] = report.timings.get("curves", 0.0) + time.perf_counter() - t0
    return int(counts.size)


# ---------------------------------------------------------------------------- particle hair

def shape_radius(shape: float, root: float, tip: float, t: np.ndarray) -> np.ndarray:
    """Cycles' shaperadius() over normalised arc length t in [0, 1] (float32 as Cycles)."""
    r = (1.0 - t).astype(np.float32)
    if shape != 0.0:
        e = (1.0 + shape) if shape < 0.0 else 1.0 / (1.0 - shape)
        r = np.power(r, np.float32(e))
    return r * np.float32(root - tip) + np.float32(tip)


def _particle_systems(obj, render: bool):
    for mod in obj.modifiers:
        if mod.type != "PARTICLE_SYSTEM":
            continue
        if not (mod.show_render if render else mod.show_viewport):
            continue
        psys = mod.particle_system
        part = psys.settings
        if part is None or part.type != "HAIR" or part.render_type != "PATH":
            continue
        yield psys, part


CO_HAIR_CHUNK = 8192  # strands per co_hair batch between cancel checks


def _uv_layer_index(mesh, name):
    """Index of the emitter's UV layer a program's UV attribute name stands for: the active
    render layer for the default UV, the named layer otherwise; None when there is none."""
    layers = list(getattr(mesh, "uv_layers", []))
    if name == UV_ATTRIBUTE:
        for i, layer in enumerate(layers):
            if layer.active_render:
                return i
        return 0 if layers else None
    wanted = name[len(UV_ATTRIBUTE):]
    for i, layer in enumerate(layers):
        if layer.name == wanted:
            return i
    return None


def particle_uvs(obj, psys, first, ncurves, names):
    """{name: (ncurves, 4) float32 (u, v, 0, 1)}: each curve's UV as Cycles exports it for
    particle hair (the emitter's UV map at the root, ParticleSystem.uv_on_emitter; checked by
    rendering Texture Coordinate > UV and a UV Map node with bpy 4.5); 0 without that map."""
    mod = next((m for m in obj.modifiers if m.type == "PARTICLE_SYSTEM" and m.particle_system.name == psys.name),
               None)
    particles = psys.particles
    out = {}
    for name in names:
        uv = np.zeros((ncurves, 4), np.float32)
        uv[:, 3] = 1.0
        layer = _uv_layer_index(obj.data, name)
        if layer is not None and mod is not None and len(particles):
            last = len(particles) - 1
            fn = psys.uv_on_emitter
            vals = np.array([tuple(fn(mod, particles[min(p, last)], particle_no=p, uv_no=layer))
                             for p in range(first, first + ncurves)], np.float32).reshape(ncurves, 2)
            uv[:, :2] = vals
        out[name] = uv
    return out


def export_particle_hair(obj, matrix, buffer: HairBuffer, materials, report, render=True, cancel=None):
    """All particle hair systems of one evaluated mesh object, as Cycles' ObtainCacheParticleData
    + ExportCurveSegments.  `matrix`: the instance's world matrix."""
    if getattr(obj.original, "mode", "OBJECT") in ("PARTICLE_EDIT", "EDIT"):
        report.warn(f"'{obj.name}' is in edit mode; like Cycles, its particle hair is not rendered")
        return 0
    t0 = time.perf_counter()
    ob_world = np.array([tuple(r) for r in obj.matrix_world], np.float64)
    try:
        ob_inv = np.linalg.inv(ob_world)
    except np.linalg.LinAlgError:
        report.warn(f"'{obj.name}': singular object matrix; particle hair skipped")
        return 0
    slots = materials.slot_indices(obj)
    all_pts, all_counts, all_len, all_mat, all_t = [], [], [], [], []
    all_uv = {}
    for psys, part in _particle_systems(obj, render):
        totpart = len(psys.particles)
        totchild = len(psys.child_particles)
        if not render:
            totchild = int(float(totchild) * float(part.display_percentage) / 100.0)
        first = totpart if (part.child_type != "NONE" and totchild != 0) else 0
        ncurves = totpart + totchild - first
        if ncurves <= 0:
            continue
        steps = (1 << (part.render_step if render else part.display_step)) + 1
        if part.kink == "SPIRAL":
            steps += part.kink_extra_steps
        co = psys.co_hair
        flat = np.empty(ncurves * steps * 3, np.float64)
        chain = itertools.chain.from_iterable
        for c0 in range(0, ncurves, CO_HAIR_CHUNK):
            if cancel is not None and cancel():
                raise KeyboardInterrupt
            c1 = min(ncurves, c0 + CO_HAIR_CHUNK)
            flat[c0 * steps * 3:c1 * steps * 3] = np.fromiter(
                chain(co(obj, particle_no=p, step=s) for p in range(first + c0, first + c1) for s in range(steps)),
                np.float64, (c1 - c0) * steps * 3)
        pw = flat.reshape(ncurves * steps, 3)
        # Cycles leaves the key at the previous one when co_hair has no data for it; the Python
        # API returns (0, 0, 0) instead: weld those keys to the previous one (step > 0 only).
        zero = ~pw.any(axis=1)
        zero[::steps] = False
        if zero.any():
            idx = np.where(zero, 0, np.arange(pw.shape[0]))
            np.maximum.accumulate(idx, out=idx)
            pw = pw[idx]
        # object space, as Cycles (curve length and the radius shape are measured there)
        po = pw @ ob_inv[:3, :3].T + ob_inv[:3, 3]
        counts = np.full(ncurves, steps, np.int64)
        d = np.diff(po.reshape(ncurves, steps, 3), axis=1)
        seg = np.sqrt(np.einsum("ijk,ijk->ij", d, d))
        t_along = np.zeros((ncurves, steps))
        np.cumsum(seg, axis=1, out=t_along[:, 1:])
        lengths = t_along[:, -1].copy()
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where(lengths[:, None] > 0.0, t_along / lengths[:, None], 0.0)
        t = np.clip(np.nan_to_num(t, nan=0.0), 0.0, 1.0)
        rscale = part.radius_scale * 0.5
        rad = shape_radius(float(part.shape), rscale * part.root_radius, rscale * part.tip_radius, t)
        if part.use_close_tip:
            rad[:, -1] = 0.0
        pts = np.empty((ncurves * steps, 4), np.float32)
        pts[:, :3] = po  # object space for now
        pts[:, 3] = rad.reshape(-1)
        all_pts.append(pts)
        all_counts.append(counts)
        all_len.append(lengths.astype(np.float32))
        all_t.append(t.reshape(-1).astype(np.float32))  # Hair Info > Intercept (curve_time / length)
        slot = min(max(int(part.material) - 1, 0), len(slots) - 1)
        all_mat.append(np.full(ncurves, slots[slot], np.int32))
        # Curve UVs, only when this system's material reads them (Image Texture, UV nodes).
        uv_names = sorted(n for n in materials.needs[slots[slot]][1] if n.startswith(UV_ATTRIBUTE))
        got = particle_uvs(obj, psys, first, ncurves, uv_names)
        for name in set(all_uv) | set(got):
            all_uv.setdefault(name, [np.zeros((c.size, 4), np.float32) for c in all_counts[:-1]])
            all_uv[name].append(got.get(name, np.zeros((ncurves, 4), np.float32)))
        report.add_count("particle_systems", 1)
    if not all_counts:
        return 0
    pts4 = np.concatenate(all_pts)
    counts = np.concatenate(all_counts)
    lengths = np.concatenate(all_len)
    mat = np.concatenate(all_mat)
    object_space = curves_object_space(matrix)
    if object_space is None:
        pts4[:, :3] = transform_points(matrix, pts4[:, :3])
        pts4[:, 3] *= np.float32(radius_scale(matrix))
    random = buffer.curve_random(counts.size).copy()  # index over all systems of the object
    needs_intercept = any(materials.needs[int(m)][0] for m in np.unique(mat))
    columns = []  # per-key extras ride along as columns, so that clean_strands filters them with the keys
    if needs_intercept:
        columns.append(("intercept", np.concatenate(all_t)[:, None]))
    for name in sorted(all_uv):
        columns.append((name, np.repeat(np.concatenate(all_uv[name]), counts, axis=0)))
    if columns:
        pts4 = np.concatenate([pts4] + [c for _, c in columns], axis=1)
    pts4, counts, random, mat, lengths = clean_strands(obj.name, pts4, counts, random, mat, lengths, report)
    extras, col = {}, 4
    for name, c in columns:
        extras[name] = np.ascontiguousarray(pts4[:, col:col + c.shape[1]])
        col += c.shape[1]
    pts4 = np.ascontiguousarray(pts4[:, :4])
    intercept = extras.pop("intercept", None)
    buffer.add(pts4, counts, random, mat, lengths, intercept=None if intercept is None else intercept[:, 0].copy(),
               attributes={name: ("CURVE", a) for name, a in extras.items()}, object_space=object_space)
    report.timings["particle_hair"] = report.timings.get("particle_hair", 0.0) + time.perf_counter() - t0
    return int(counts.size)


# ---------------------------------------------------------------------------- checks

INSIDE_CHUNK = 1 << 20  # keys per chunk of camera_inside_hair (bounded temporaries)


def camera_inside_hair(curves: dict, cam_pos: np.ndarray) -> int:
    """Number of strands whose tube (max radius of the segment's keys) contains the point.
    A camera outside the keys' bounding box (grown by the largest radius) needs no
    per-segment work; otherwise the keys are processed in chunks of INSIDE_CHUNK."""
    pts = curves["points"]
    if pts.shape[0] < 2:
        return 0
    offsets = curves["curve_offsets"]
    if "curve_object" in curves:  # curves kept in object space: this check works in the world
        key_object = np.repeat(curves["curve_object"], np.diff(offsets))
        pts = pts.copy()
        for k, m in enumerate(curves["object_transforms"].reshape(-1, 3, 4)):
            sel = key_object == k
            pts[sel, :3] = transform_points(m, pts[sel, :3])
            pts[sel, 3] *= np.float32(radius_scale(m))
    c = np.asarray(cam_pos, np.float32)
    rmax = float(pts[:, 3].max())
    # per column: an axis-0 reduction of the strided (P, 3) view is ~6x slower
    lo = np.array([pts[:, j].min() for j in range(3)]) - rmax
    hi = np.array([pts[:, j].max() for j in range(3)]) + rmax
    if np.any(c < lo) or np.any(c > hi):
        return 0
    ends = np.zeros(pts.shape[0], bool)  # key k ends a curve: no segment (k, k + 1)
    ends[offsets[1:] - 1] = True
    found = []
    n_seg = pts.shape[0] - 1
    for k0 in range(0, n_seg, INSIDE_CHUNK):
        k1 = min(k0 + INSIDE_CHUNK, n_seg)
        xyz = pts[k0:k1 + 1, :3]
        d = xyz - c
        dist = np.sqrt(np.einsum("ij,ij->i", d, d))
        seg = np.diff(xyz, axis=0)
        seglen = np.sqrt(np.einsum("ij,ij->i", seg, seg))
        # a segment can contain the point only if an end key is within its length + radius
        near = np.minimum(dist[:-1], dist[1:]) <= seglen + rmax
        near &= ~ends[k0:k1]
        idx = np.nonzero(near)[0]
        if idx.size == 0:
            continue
        a = xyz[idx].astype(np.float64)
        ab = seg[idx].astype(np.float64)
        ca = c.astype(np.float64) - a
        denom = np.einsum("ij,ij->i", ab, ab)
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.clip(np.where(denom > 0, np.einsum("ij,ij->i", ca, ab) / denom, 0.0), 0.0, 1.0)
        diff = ca - ab * t[:, None]
        r = np.maximum(pts[k0 + idx, 3], pts[k0 + idx + 1, 3])
        inside = idx[np.sqrt(np.einsum("ij,ij->i", diff, diff)) < r] + k0
        if inside.size:
            found.append(inside)
    if not found:
        return 0
    curve = np.searchsorted(offsets, np.concatenate(found), side="right") - 1
    return int(np.unique(curve).size)
