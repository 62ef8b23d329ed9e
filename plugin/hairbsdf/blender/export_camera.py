"""Camera export (docs/scene_desc.md "camera"): Blender's raw camera values, the matrix
without scale (as Cycles and RenderEngine.camera_model_matrix), the final resolution."""

from __future__ import annotations

import numpy as np

from ..render import schema_choices
from ._common import ExportError, matrix_to_numpy


def render_resolution(scene):
    r = scene.render
    w = int(r.resolution_x * r.resolution_percentage / 100)
    h = int(r.resolution_y * r.resolution_percentage / 100)
    return max(w, 1), max(h, 1)


def export_camera(depsgraph, report) -> dict:
    scene = depsgraph.scene
    cam_obj = scene.camera
    if cam_obj is None:
        raise ExportError("the scene has no active camera (Scene properties > Camera)")
    cam_eval = cam_obj.evaluated_get(depsgraph)
    if cam_eval.type != "CAMERA":
        raise ExportError(f"the active camera '{cam_obj.name}' is a {cam_eval.type.lower()} object, not a camera")
    cam = cam_eval.data
    if cam.type not in schema_choices("camera.type"):
        raise ExportError(f"camera '{cam_obj.name}': {cam.type} cameras are not supported (perspective and "
                          "orthographic only)")
    m = matrix_to_numpy(cam_eval.matrix_world)
    axes = m[:3, :3]
    norms = np.linalg.norm(axes, axis=0)
    if not np.all(np.isfinite(m)) or np.any(norms <= 0.0):
        raise ExportError(f"camera '{cam_obj.name}' has a degenerate or non-finite transform")
    m[:3, :3] = axes / norms  # scale does not change a Blender/Cycles camera
    r = scene.render
    w, h = render_resolution(scene)
    if getattr(cam, "dof", None) is not None and cam.dof.use_dof:
        report.warn(f"camera '{cam_obj.name}': depth of field is not supported and is ignored")
    # A render region needs nothing here: the full frame is rendered and Blender keeps the region
    # (and crops it) when the engine writes the whole frame (checked in 3.4 and 4.5).
    if r.use_motion_blur:
        report.warn("motion blur is not supported and is ignored")
    if not (cam.clip_start > 0.0 and cam.clip_end > cam.clip_start):
        report.warn(f"camera '{cam_obj.name}': clip range {cam.clip_start:g}..{cam.clip_end:g} is empty")
    return {
        "type": cam.type,
        "matrix_world": m,
        "resolution": (w, h),
        "pixel_aspect": float(r.pixel_aspect_y) / float(r.pixel_aspect_x),
        "sensor_fit": cam.sensor_fit,
        "sensor_width": float(cam.sensor_width),
        "sensor_height": float(cam.sensor_height),
        "lens": float(cam.lens),
        "ortho_scale": float(cam.ortho_scale),
        "shift_x": float(cam.shift_x),
        "shift_y": float(cam.shift_y),
        "clip_start": float(cam.clip_start),
        "clip_end": float(cam.clip_end),
    }
