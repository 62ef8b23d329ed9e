"""Mesh export: evaluated triangles (loop_triangles, foreach_get) in world space with a
scene material index per triangle (the object's slot of the polygon's material_index), the
corner normals Cycles shades with (split normals: the face normal on flat faces, smooth
vertex normals on smooth ones) and, when a shading program reads them, the UV maps at each
triangle corner. Other mesh attributes read by programs (colour attributes) are not exported
yet and read 0 (docs/engine.md)."""

from __future__ import annotations

import time

import numpy as np

from ._common import matrix_to_numpy, transform_points
from .shading_network import UV_ATTRIBUTE

MESH_LIKE = ("MESH", "CURVE", "SURFACE", "META", "FONT")


class MeshBuffer:
    def __init__(self):
        self.vertices: list[np.ndarray] = []
        self.triangles: list[np.ndarray] = []
        self.material: list[np.ndarray] = []
        self.normals: list[np.ndarray] = []
        self.attributes: list[dict] = []  # per object: {name: (T, 12) float32 RGBA per corner}
        self.objects: list[np.ndarray] = []  # per object: its index, once per triangle
        self.reversed: list[np.ndarray] = []  # per object: 1 per triangle where its corners are reversed
        self._nverts = 0

    def add(self, verts, tris, mat, normals, attributes=None, reversed_corners=False):
        if tris.shape[0] == 0:
            return
        self.vertices.append(verts)
        self.triangles.append(tris + self._nverts)
        self.material.append(mat)
        self.normals.append(normals)
        self.attributes.append(attributes or {})
        self.objects.append(np.full(tris.shape[0], len(self.objects), np.int32))
        self.reversed.append(np.full(tris.shape[0], int(bool(reversed_corners)), np.int32))
        self._nverts += verts.shape[0]

    def finish(self, attribute_names=()) -> dict:
        """The `meshes` dict of docs/scene_desc.md; `attribute_names`: the attributes the shading
        programs read, in their VM order (rows of 0 where an object lacks one)."""
        if not self.triangles:
            return {"vertices": np.zeros((0, 3), np.float32), "triangles": np.zeros((0, 3), np.int32),
                    "triangle_material": np.zeros(0, np.int32), "triangle_normals": np.zeros((0, 9), np.float32)}
        out = {"vertices": np.ascontiguousarray(np.concatenate(self.vertices), np.float32),
               "triangles": np.ascontiguousarray(np.concatenate(self.triangles), np.int32),
               "triangle_material": np.concatenate(self.material).astype(np.int32),
               "triangle_normals": np.ascontiguousarray(np.concatenate(self.normals), np.float32),
               "triangle_object": np.concatenate(self.objects).astype(np.int32)}
        reversed_corners = np.concatenate(self.reversed)
        if reversed_corners.any():
            out["triangle_reversed"] = reversed_corners
        if any(self.attributes) and attribute_names:
            out["attributes"] = [
                {"name": name, "data": np.ascontiguousarray(np.concatenate(
                    [a.get(name, np.zeros((t.shape[0], 12), np.float32)) for a, t in zip(self.attributes, self.triangles)]),
                    np.float32)}
                for name in attribute_names]
        return out


class MeshCache:
    """Object-space triangles per evaluated datablock, shared by instances."""

    def __init__(self):
        self._cache = {}

    def get(self, obj):
        data = obj.data
        key = (data.as_pointer(), data.name, obj.type) if data is not None else None
        if key is not None and key in self._cache:
            return self._cache[key]
        arrays = mesh_local_arrays(obj)
        if key is not None and obj.type == "MESH":
            self._cache[key] = arrays
        return arrays


def mesh_local_arrays(obj):
    """(vertices (V,3) float32, triangles (T,3) int32, material_index (T,) int32, corner normals
    (T,9) float32) of an evaluated object, object space.  Uses to_mesh() so the evaluated data is
    not touched."""
    try:
        mesh = obj.to_mesh()
    except RuntimeError:
        mesh = None
    if mesh is None:
        return (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), np.zeros(0, np.int32),
                np.zeros((0, 9), np.float32), {})
    try:
        if hasattr(mesh, "calc_loop_triangles"):  # 3.x; 4.x computes them on access
            mesh.calc_loop_triangles()
        nv = len(mesh.vertices)
        nt = len(mesh.loop_triangles)
        verts = np.empty(nv * 3, np.float32)
        mesh.vertices.foreach_get("co", verts)
        tris = np.empty(nt * 3, np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
        mat = np.empty(nt, np.int32)
        mesh.loop_triangles.foreach_get("material_index", mat)
        if hasattr(mesh, "calc_normals_split"):  # before 4.1 split normals are computed on request
            mesh.calc_normals_split()
        normals = np.empty(nt * 9, np.float32)
        mesh.loop_triangles.foreach_get("split_normals", normals)
        return verts.reshape(nv, 3), tris.reshape(nt, 3), mat, normals.reshape(nt, 9), _corner_uvs(mesh, nt)
    finally:
        obj.to_mesh_clear()


def _corner_uvs(mesh, n_triangles) -> dict:
    """{attribute name: (T, 12) float32}: every UV map at the triangle corners as (u, v, 0, 1),
    named as the shading programs name them (UV_ATTRIBUTE + map name; UV_ATTRIBUTE alone for
    the map Cycles renders with, the active-render one)."""
    if not len(mesh.uv_layers):
        return {}
    loops = np.empty(n_triangles * 3, np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    out = {}
    for layer in mesh.uv_layers:
        uv = np.empty(len(mesh.loops) * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        corners = np.zeros((n_triangles * 3, 4), np.float32)
        corners[:, :2] = uv.reshape(-1, 2)[loops]
        corners[:, 3] = 1.0
        out[UV_ATTRIBUTE + layer.name] = corners.reshape(n_triangles, 12)
        if layer.active_render:
            out[UV_ATTRIBUTE] = out[UV_ATTRIBUTE + layer.name]
    return out


def export_mesh_object(obj, matrix, buffer: MeshBuffer, materials, report, cache: MeshCache):
    t0 = time.perf_counter()
    verts, tris, mat_idx, normals, uvs = cache.get(obj)
    if tris.shape[0] == 0:
        return 0
    slots = materials.slot_indices(obj)
    lut = np.asarray(slots, np.int32)
    mat = lut[np.clip(mat_idx, 0, len(slots) - 1)]
    world = transform_points(matrix, verts)
    finite = np.isfinite(world).all(axis=1)
    if not finite.all():
        bad = ~finite[tris].all(axis=1)
        report.warn(f"Mesh '{obj.name}': {int(bad.sum())} triangles have NaN or infinite vertices; skipped")
        tris, mat, normals = tris[~bad], mat[~bad], normals[~bad]
        uvs = {name: corners[~bad] for name, corners in uvs.items()}
        world = np.where(finite[:, None], world, 0.0).astype(np.float32)
    # Normals transform with the inverse transpose of the object matrix (non-uniform scale).
    m3 = matrix_to_numpy(matrix)[:3, :3]
    try:
        normal_matrix = np.linalg.inv(m3).T
    except np.linalg.LinAlgError:
        normal_matrix = np.eye(3)
    n = normals.reshape(-1, 3).astype(np.float64) @ normal_matrix.T
    mirrored = bool(np.linalg.det(m3) < 0)
    if mirrored:
        # A negative scale reverses the winding in world space; Cycles keeps Ng where Blender shows
        # the normal (object_negative_scale_applied), which decides back faces and the emitting
        # side that Emission Sampling samples. Corners 0 and 2 swap, with their normals and UVs; the
        # engine takes a hair frame's dP/du from the original order (`triangle_reversed`).
        tris = tris[:, ::-1]
        n = n.reshape(-1, 3, 3)[:, ::-1].reshape(-1, 3)
        uvs = {name: corners.reshape(-1, 3, 4)[:, ::-1].reshape(-1, 12) for name, corners in uvs.items()}
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(length > 0, n / np.where(length > 0, length, 1.0), 0.0)
    wanted = set(materials.attributes.names)
    buffer.add(world, tris, mat, n.reshape(-1, 9).astype(np.float32),
               {name: corners for name, corners in uvs.items() if name in wanted}, reversed_corners=mirrored)
    report.add_count("mesh_objects", 1)
    report.add_count("triangles", tris.shape[0])
    report.timings["meshes"] = report.timings.get("meshes", 0.0) + time.perf_counter() - t0
    return int(tris.shape[0])
