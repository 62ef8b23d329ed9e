"""Helpers shared by the exporter modules: the export report, version checks, socket
lookup and small conversions.  Imports bpy lazily so the pure helpers can be tested
without Blender."""

from __future__ import annotations

import numpy as np

from .._blender_versions import tilt_convention


# The engine's settings (ui.py's scene.hairbsdf) that are scene keys: the property's name -> the key's path in
# the scene schema, whose choices and default the property takes (an enum's identifiers are the names in
# capitals) and where the exporter writes its value (scene_value).
SCENE_SETTINGS = {"tilt": "integrator.tilt", "accuracy": "integrator.accuracy",
                  "huang_sampler": "integrator.huang_sampler", "wavefront": "integrator.wavefront",
                  "curve_intersector": "curve_intersector"}


def scene_value(name: str, value):
    """The scene's value of engine setting `name`: an enum's identifier back to the schema's name."""
    if not isinstance(value, str):
        return value
    from ..render import schema_choices
    return next(choice for choice in schema_choices(SCENE_SETTINGS[name]) if choice.upper() == value)


class ExportError(Exception):
    """A scene the renderer cannot render at all (no camera, unsupported camera type...).
    The engine reports it with report({'ERROR'}) and renders nothing."""


class ExportReport:
    """Warnings collected during one export, de-duplicated, in order, plus timings and
    counts for the stats line and the tests."""

    MAX_WARNINGS = 200

    def __init__(self):
        self.warnings: list[str] = []
        self.errors: list[str] = []
        self.timings: dict[str, float] = {}
        self.counts: dict[str, int] = {}
        self._seen: set[str] = set()
        self._dropped = 0

    def warn(self, message: str) -> None:
        if message in self._seen:
            return
        self._seen.add(message)
        if len(self.warnings) >= self.MAX_WARNINGS:
            self._dropped += 1
            return
        self.warnings.append(message)

    def error(self, message: str) -> None:
        self.errors.append(message)

    def add_count(self, key: str, n: int) -> None:
        self.counts[key] = self.counts.get(key, 0) + int(n)

    def all_warnings(self) -> list[str]:
        if self._dropped:
            return self.warnings + [f"... and {self._dropped} more warnings"]
        return list(self.warnings)

    def as_dict(self) -> dict:
        return {"warnings": self.all_warnings(), "errors": list(self.errors),
                "timings": dict(self.timings), "counts": dict(self.counts)}


def blender_version() -> tuple:
    import bpy
    return tuple(bpy.app.version)


# The identifier of a setting's automatic choice: the tilt's (the running Blender's convention; the scene key has
# no such value) and curve_intersector's (the scene schema's AUTO, chosen by the scene's size).
AUTO = "AUTO"
# The engine's tilt choice "Auto" (ui.py's tilt setting, the exporter's reading of it): default_tilt().
TILT_AUTO = (AUTO, "Auto", "That of the running Blender: 4.2 for Blender 4.2+, else 3.4")


def default_tilt() -> str:
    """Principled Hair tilt convention of the running Blender (docs/cycles.md §0, §5b)."""
    return tilt_convention(blender_version())


def matrix_to_numpy(m) -> np.ndarray:
    """mathutils.Matrix (4x4) -> float64 (4, 4), rows as in Blender (M @ column vector)."""
    return np.array([tuple(row) for row in m], dtype=np.float64).reshape(4, 4)


def transform_points(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 affine matrix to (N, 3) points; float32 math and result, as Cycles
    transforms keys in float."""
    m = np.asarray(matrix, dtype=np.float64)
    if np.array_equal(m[:3, :3], np.eye(3)):  # translation only (common): the same floats, faster
        return np.asarray(points, dtype=np.float32) + m[:3, 3].astype(np.float32)
    out = np.asarray(points, dtype=np.float32) @ m[:3, :3].T.astype(np.float32)
    out += m[:3, 3].astype(np.float32)
    return out


def radius_scale(matrix: np.ndarray) -> float:
    """|det M|^(1/3), Cycles' radius scale for an applied object transform (Hair::apply_transform)."""
    det = float(np.linalg.det(np.asarray(matrix, dtype=np.float64)[:3, :3]))
    return abs(det) ** (1.0 / 3.0)


def curves_object_space(matrix: np.ndarray):
    """None when Cycles applies `matrix` to an object's curves (a uniform scale with rotation
    and translation, by its transform_uniform_scale test: the squared lengths of the 3 x 3
    part's rows and columns agree within 1e-6, in float32); otherwise the matrix's top 3 rows
    flattened (12 float64), and the curves stay in object space (docs/cycles.md §3.1)."""
    m = np.asarray(matrix, dtype=np.float64)
    m3 = m[:3, :3].astype(np.float32)
    rows = [m3[i, 0] * m3[i, 0] + m3[i, 1] * m3[i, 1] + m3[i, 2] * m3[i, 2] for i in range(3)]
    cols = [m3[0, j] * m3[0, j] + m3[1, j] * m3[1, j] + m3[2, j] * m3[2, j] for j in range(3)]
    if all(abs(float(rows[0] - v)) < 1e-6 for v in rows[1:] + cols):
        return None
    return np.ascontiguousarray(m[:3, :4].reshape(12))


def _euler_xyz(rx, ry, rz):
    """Blender's XYZ Euler rotation matrix (X applied first)."""
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    x = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    y = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    z = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return z @ y @ x


def mapping_matrix(vector_type, location, rotation, scale):
    """3 x 4 matrix M with lookup = M (direction, 1) for a Mapping node (Blender's formulas)."""
    r = _euler_xyz(*rotation)
    s = np.asarray(scale, dtype=np.float64)
    t = np.asarray(location, dtype=np.float64)
    m = np.zeros((3, 4))
    if vector_type == "POINT":
        m[:, :3], m[:, 3] = r * s[None, :], t
    elif vector_type == "VECTOR":
        m[:, :3] = r * s[None, :]
    elif vector_type == "NORMAL":  # the lookup normalises: the final normalize does not matter
        with np.errstate(divide="ignore"):
            m[:, :3] = r * np.where(s != 0, 1.0 / s, 0.0)[None, :]
    else:  # TEXTURE: the inverse transform
        with np.errstate(divide="ignore"):
            inv_s = np.where(s != 0, 1.0 / s, 0.0)
        m[:, :3] = inv_s[:, None] * r.T
        m[:, 3] = -(m[:, :3] @ t)
    return m


def find_socket(sockets, name: str):
    """Socket by identifier, then by name, without `sockets[name]` (in 4.5 that raises
    KeyError for sockets hidden by the node's current mode)."""
    for s in sockets:
        if s.identifier == name:
            return s
    for s in sockets:
        if s.name == name:
            return s
    return None


def rgb(value, n: int = 3) -> tuple:
    """First three components of a colour/vector value as floats."""
    v = tuple(float(c) for c in value)
    if len(v) == 1:
        v = v * 3
    return v[:n]


# Cycles' rgb_to_y in Linear Rec.709 (the Y row of its Rec.709 -> XYZ D65 matrix), the weights of
# Blender's implicit colour -> float socket conversion there. Not the four-digit Rec.709 weights of
# C++ luminance() (_core.LUMINANCE_WEIGHTS), which the models and metrics use: another fact.
CYCLES_REC709_RGB_TO_Y = (0.2126729, 0.7151522, 0.0721750)
REC709_WORKING_SPACES = ("Linear Rec.709", "Linear")


class WorkingSpace:
    """The blend file's working colour space (Blender 5.x, File > Color Management; Linear
    Rec.709 before), which Cycles renders in: colour -> float conversions weigh the channels by
    its luminance (Cycles' rgb_to_y, the Y row of its RGB -> XYZ D65 matrix) and images are
    converted into it. Blender's own colour management (mathutils.Color) gives both."""

    def __init__(self, name, rec709_to_scene_linear, luminance):
        self.name = name
        self.rec709_to_scene_linear = rec709_to_scene_linear  # 3 x 3 numpy array, None for Rec.709
        self.luminance = luminance


def working_space() -> WorkingSpace:
    import bpy
    colorspace = getattr(bpy.data, "colorspace", None)
    name = str(getattr(colorspace, "working_space", "") or "Linear Rec.709")
    cached = _WORKING_SPACES.get(name)
    if cached is not None:
        return cached
    if name in REC709_WORKING_SPACES:
        space = WorkingSpace(name, None, CYCLES_REC709_RGB_TO_Y)
    else:
        from mathutils import Color
        basis = [Color(tuple(float(i == j) for j in range(3))) for i in range(3)]
        to_working = np.array([tuple(c.from_rec709_linear_to_scene_linear()) for c in basis], np.float64).T
        luminance = tuple(float(c.from_scene_linear_to_xyz_d65()[1]) for c in basis)
        space = WorkingSpace(name, to_working, luminance)
    _WORKING_SPACES[name] = space
    return space


_WORKING_SPACES = {}


def luminance_weights():
    """Cycles' colour -> float weights in the file's working space."""
    return working_space().luminance


def lookup3_hash_uint2(kx: int, ky: int) -> int:
    """Cycles' hash_uint2 (Bob Jenkins lookup3 'final'), util/hash.h."""
    def rot(x, k):
        return ((x << k) | (x >> (32 - k))) & 0xFFFFFFFF

    a = b = c = (0xDEADBEEF + (2 << 2) + 13) & 0xFFFFFFFF
    a = (a + kx) & 0xFFFFFFFF
    b = (b + ky) & 0xFFFFFFFF
    c ^= b; c = (c - rot(b, 14)) & 0xFFFFFFFF
    a ^= c; a = (a - rot(c, 11)) & 0xFFFFFFFF
    b ^= a; b = (b - rot(a, 25)) & 0xFFFFFFFF
    c ^= b; c = (c - rot(b, 16)) & 0xFFFFFFFF
    a ^= c; a = (a - rot(c, 4)) & 0xFFFFFFFF
    b ^= a; b = (b - rot(a, 14)) & 0xFFFFFFFF
    c ^= b; c = (c - rot(b, 24)) & 0xFFFFFFFF
    return c
