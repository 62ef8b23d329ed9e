"""Light export (docs/scene_desc.md "lights"): Blender's raw values as Cycles' light sync
reads them (intern/cycles/blender/light.cpp).  strength = colour x energy, times
2^exposure and the blackbody colour when those 4.x properties are set (measured against
Cycles 4.5: both scale the light linearly); Cycles' normalisation is the renderer's job.

Blender < 4.0 (Cycles 3.x; measured against Blender 3.4.1 renders of the calibration cases,
blender_tests/render_units, docs/engine.md):
  * AREA radiance is power / (4 area), not power / (pi area) (blender/blender#109404,
    changed in 4.0): strength x pi/4;
  * SPOT attenuation is cos(angle to the axis) x the smoothstep blend, and the cone ignores
    the object's scale: "spot_cosine": True and the matrix without its scale;
  * point and spot lights have no Soft Falloff property and behave as with it on (4.0 has
    no property either, but sphere lights: soft falloff off; 4.1 added the option).
"""

from __future__ import annotations

import numpy as np

from .._blender_versions import LIGHTS_4_FROM
from ._common import blender_version, find_socket, matrix_to_numpy, rgb


def _strength(light, report, name):
    s = np.array(rgb(light.color), np.float64) * float(light.energy)
    if hasattr(light, "exposure"):
        s *= 2.0 ** float(light.exposure)
    if getattr(light, "use_temperature", False):
        s *= np.array(rgb(light.temperature_color), np.float64)
    if getattr(light, "use_nodes", False) and light.node_tree is not None:
        s *= _emission_factor(light.node_tree, report, name)
    return tuple(float(c) for c in s)


def _emission_factor(nt, report, name):
    """Colour x strength of a light's Emission node (constant inputs only)."""
    out = None
    for node in nt.nodes:
        if node.bl_idname == "ShaderNodeOutputLight" and getattr(node, "is_active_output", True):
            out = node
            break
    if out is None:
        return np.ones(3)
    sock = find_socket(out.inputs, "Surface")
    if sock is None or not sock.is_linked:
        return np.zeros(3)
    node = sock.links[0].from_node
    if node.bl_idname != "ShaderNodeEmission":
        report.warn(f"light '{name}': node '{node.name}' ({node.bl_idname}) is not supported; the light's "
                    "nodes are ignored")
        return np.ones(3)
    col, stren = find_socket(node.inputs, "Color"), find_socket(node.inputs, "Strength")
    for s in (col, stren):
        if s is not None and s.is_linked:
            report.warn(f"light '{name}': '{node.name}' > '{s.name}' is linked; its node value is used")
    return np.array(rgb(col.default_value), np.float64) * float(stren.default_value)


def export_light(obj, matrix, report):
    light = obj.data
    m = matrix_to_numpy(matrix)
    if not np.all(np.isfinite(m)):
        report.warn(f"light '{obj.name}' has a non-finite transform; skipped")
        return None
    strength = _strength(light, report, obj.name)
    pos = tuple(float(c) for c in m[:3, 3])
    z = m[:3, 2]
    nz = np.linalg.norm(z)
    zdir = z / nz if nz > 0 else np.array([0.0, 0.0, 1.0])
    legacy = blender_version() < LIGHTS_4_FROM  # Cycles 3.x light semantics (module docstring)
    if hasattr(light, "use_soft_falloff"):
        soft = bool(light.use_soft_falloff)
    else:
        soft = legacy  # 3.x: disk lights (soft falloff); 4.0: spheres without the option
    out = None
    if light.type == "SUN":
        out = {"type": "SUN", "direction": tuple(float(c) for c in zdir), "strength": strength,
               "angle": float(light.angle)}
    elif light.type == "POINT":
        out = {"type": "POINT", "position": pos, "strength": strength,
               "radius": float(light.shadow_soft_size), "soft_falloff": soft}
    elif light.type == "SPOT":
        out = {"type": "SPOT", "position": pos, "direction": tuple(float(-c) for c in zdir),
               "strength": strength, "radius": float(light.shadow_soft_size), "soft_falloff": soft,
               "spot_size": float(light.spot_size), "spot_blend": float(light.spot_blend), "matrix_world": m}
        if legacy:
            unscaled = m.copy()
            norms = np.linalg.norm(unscaled[:3, :3], axis=0)
            unscaled[:3, :3] /= np.where(norms > 0, norms, 1.0)
            out.update(matrix_world=unscaled, spot_cosine=True)
    elif light.type == "AREA":
        out = {"type": "AREA", "matrix_world": m, "shape": light.shape, "size_x": float(light.size),
               "size_y": float(light.size_y if light.shape in ("RECTANGLE", "ELLIPSE") else light.size),
               "strength": strength}
        if hasattr(light, "spread"):  # missing: the scene's default
            out["spread"] = float(light.spread)
        if legacy:
            out["strength"] = tuple(c * 0.25 * np.pi for c in strength)
    else:
        report.warn(f"light '{obj.name}': type {light.type} is not supported; skipped")
        return None
    if hasattr(light, "normalize"):
        out["normalize"] = bool(light.normalize)
    # Object > Visibility > Ray Visibility: Camera is off for new lights (3.0+): camera rays
    # do not see the light. The other ray types are not supported (the light reaches all).
    if hasattr(obj, "visible_camera"):  # missing: the scene's default
        out["visible_camera"] = bool(obj.visible_camera)
    hidden = [p[len("visible_"):] for p in ("visible_diffuse", "visible_glossy", "visible_transmission")
              if not getattr(obj, p, True)]
    if hidden:
        report.warn(f"light '{obj.name}': ray visibility ({', '.join(hidden)} off) is not supported; it lights "
                    "all rays")
    cl = light.cycles  # the Cycles add-on's light settings (export requires the add-on)
    if hasattr(cl, "use_multiple_importance_sampling"):
        out["use_mis"] = bool(cl.use_multiple_importance_sampling)
    if hasattr(cl, "cast_shadow") and not cl.cast_shadow:
        report.warn(f"light '{obj.name}': Cast Shadow off is not supported; it casts shadows")
    return out
