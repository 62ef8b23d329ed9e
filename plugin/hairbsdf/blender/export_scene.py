"""The whole export: an evaluated depsgraph -> the SceneDesc dict of docs/scene_desc.md
(plain Python + NumPy, no bpy objects), plus an ExportReport with the warnings.

    desc, report = export_scene(depsgraph)                  # inside RenderEngine.render
    desc, report = export_scene(bpy.context.evaluated_depsgraph_get(), render=True)

`render` selects Cycles' final-render rules (render_step, all children, modifiers'
show_render); the default follows depsgraph.mode.  save_scene/load_scene write and read
a SceneDesc as one .npz file (no bpy needed to read it).
"""

from __future__ import annotations

import time

import numpy as np

from ._common import ExportError  # noqa: F401 (re-exported for the engine)
from ._common import ExportReport, blender_version, default_tilt, lookup3_hash_uint2, matrix_to_numpy
from .export_camera import export_camera
from .export_hair import CurvesCache, HairBuffer, camera_inside_hair, export_curves_object, export_particle_hair
from .export_lights import export_light
from .export_materials import MaterialTable
from .export_mesh import MESH_LIKE, MeshBuffer, MeshCache, export_mesh_object
from .export_world import export_world
from . import passes
from .._blender_versions import (CHIANG_LCG_BEFORE, CURVE_CULLING_BEFORE, HUANG_GLASS_TABLES_5_FROM,
                                 LIGHT_TREE_FROM)
from ..render import SCENE_DESC_VERSION
from ..scene_file import load_scene, save_scene  # noqa: F401 (re-exported: no bpy needed to read a file)


def _get(obj, name, default):
    return getattr(obj, name, default) if obj is not None else default


def engine_settings(scene) -> dict:
    """The engine's own settings (ui.py's scene.hairbsdf), with defaults when the add-on's
    properties are not registered."""
    s = getattr(scene, "hairbsdf", None)
    return {"threads": int(_get(s, "threads", 0)), "tilt": str(_get(s, "tilt", "AUTO")),
            "accuracy": str(_get(s, "accuracy", "CYCLES")),
            "huang_sampler": str(_get(s, "huang_sampler", "CYCLES"))}


def export_integrator(scene, view_layer, render: bool, settings: dict, report) -> dict:
    cy = getattr(scene, "cycles", None)
    if cy is None:
        report.warn("the Cycles add-on is disabled; hairbsdf uses Cycles' default settings")
    g = lambda name, default: _get(cy, name, default)  # noqa: E731
    samples = int(g("samples", 4096) if render else g("preview_samples", 1024))
    layer_mode = g("use_layer_samples", "USE")
    layer_samples = int(getattr(view_layer, "samples", 0)) if view_layer is not None else 0
    if render and layer_samples > 0 and layer_mode != "IGNORE":
        samples = min(samples, layer_samples) if layer_mode == "BOUNDED" else layer_samples
    seed = int(g("seed", 0))
    if g("use_animated_seed", False):
        seed_base = seed
        seed = lookup3_hash_uint2(int(scene.frame_current) & 0xFFFFFFFF, seed_base & 0xFFFFFFFF)
        sub = float(getattr(scene, "frame_subframe", 0.0))
        if sub != 0.0:
            seed = (seed + lookup3_hash_uint2(int(sub * 2147483647) & 0xFFFFFFFF, seed_base & 0xFFFFFFFF))
        seed &= 0xFFFFFFFF
    ftype = g("pixel_filter_type", "BLACKMAN_HARRIS")
    # Cycles' Blender sync forces the box filter to 1 px whatever filter_width says.
    fwidth = 1.0 if ftype == "BOX" else float(g("filter_width", 1.5))
    tilt = settings.get("tilt", "AUTO")
    tilt = default_tilt() if tilt in ("AUTO", "", None) else tilt
    ignored = []
    if render and g("use_denoising", False):
        ignored.append("Denoising")
    if g("use_fast_gi", False):
        ignored.append("Fast GI")
    if render and float(g("time_limit", 0.0)) > 0.0:
        ignored.append("Time Limit")
    if ignored:
        report.warn("Cycles settings hairbsdf ignores (the image may differ from Cycles): " + ", ".join(ignored))
    return {
        "samples": max(samples, 1),
        "seed": seed,
        "max_bounces": int(g("max_bounces", 12)),
        "diffuse_bounces": int(g("diffuse_bounces", 4)),
        "glossy_bounces": int(g("glossy_bounces", 4)),
        "transmission_bounces": int(g("transmission_bounces", 12)),
        "transparent_bounces": int(g("transparent_max_bounces", 8)),
        "min_light_bounces": int(g("min_light_bounces", 0)),
        "filter_type": ftype,
        "filter_width": fwidth,
        "exposure": float(g("film_exposure", 1.0)),
        "film_transparent": bool(scene.render.film_transparent),
        "light_sampling_threshold": float(g("light_sampling_threshold", 0.01)),
        "light_tree": bool(g("use_light_tree", True)) if blender_version() >= LIGHT_TREE_FROM else False,
        # Cycles < 3.6 draws Chiang's longitudinal sample numbers from a per-hit LCG (correlated).
        "chiang_lcg": blender_version() < CHIANG_LCG_BEFORE,
        "filter_glossy": float(g("blur_glossy", 1.0)),
        "clamp_direct": float(g("sample_clamp_direct", 0.0)),
        "clamp_indirect": float(g("sample_clamp_indirect", 10.0)),
        "tilt": tilt,
        "accuracy": settings.get("accuracy", "CYCLES").lower(),
        "huang_sampler": settings.get("huang_sampler", "CYCLES").lower(),
        # Cycles 5.x regenerated Huang's energy-compensation tables (docs/blender5.md).
        "huang_glass_albedo_table": "5.x" if blender_version() >= HUANG_GLASS_TABLES_5_FROM else "4.x",
        "passes": passes.requested(view_layer) if render else [],
    }


_RAY_VISIBILITY = ("visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission",
                   "visible_volume_scatter", "visible_shadow")


def _check_visibility(obj, report):
    """Cycles' per-object ray visibility and holdout are not supported: say so."""
    hidden = [p[len("visible_"):] for p in _RAY_VISIBILITY if not getattr(obj, p, True)]
    if hidden:
        report.warn(f"object '{obj.name}': ray visibility ({', '.join(hidden)} off) is not supported; it is visible "
                    "to all rays")
    if getattr(obj, "is_holdout", False) or getattr(obj, "is_shadow_catcher", False):
        report.warn(f"object '{obj.name}': holdout / shadow catcher is not supported; rendered as a normal object")


def export_scene(depsgraph, *, render=None, settings=None, cancel=None):
    """Returns (scene_desc, report).  Raises ExportError for scenes that cannot be rendered
    (no camera...) and KeyboardInterrupt when `cancel()` returns True."""
    t_start = time.perf_counter()
    report = ExportReport()
    scene = depsgraph.scene
    view_layer = depsgraph.view_layer
    if render is None:
        render = getattr(depsgraph, "mode", "RENDER") == "RENDER"
    if settings is None:
        settings = engine_settings(scene)
    camera = export_camera(depsgraph, report)
    use_strand = bool(getattr(view_layer, "use_strand", True))
    if not use_strand:
        report.warn(f"view layer '{view_layer.name}' has Hair (strands) disabled; no hair is rendered")

    materials = MaterialTable(report)
    hair = HairBuffer()
    meshes = MeshBuffer()
    lights = []
    curves_cache, mesh_cache = CurvesCache(), MeshCache()
    n_inst = 0
    unrealized = {}
    for inst in depsgraph.object_instances:
        n_inst += 1
        if cancel is not None and (n_inst & 255) == 0 and cancel():
            raise KeyboardInterrupt
        obj = inst.object
        typ = obj.type
        if typ not in MESH_LIKE and typ not in ("CURVES", "LIGHT"):
            continue
        show_self = bool(getattr(inst, "show_self", True))
        show_particles = bool(getattr(inst, "show_particles", True))
        if typ == "LIGHT":
            if show_self:
                lt = export_light(obj, inst.matrix_world, report)
                if lt is not None:
                    lights.append(lt)
            continue
        _check_visibility(obj, report)
        matrix = matrix_to_numpy(inst.matrix_world)
        if not np.all(np.isfinite(matrix)):
            report.warn(f"object '{obj.name}' has a non-finite transform; skipped")
            continue
        if typ == "CURVES":
            if show_self and use_strand:
                export_curves_object(obj, matrix, hair, materials, report, curves_cache)
            continue
        if show_self:
            n_tris = export_mesh_object(obj, matrix, meshes, materials, report, mesh_cache)
            if typ == "CURVE" and n_tris == 0 and inst.is_instance:
                parent = inst.parent.name if inst.parent is not None else obj.name
                unrealized[parent] = unrealized.get(parent, 0) + 1
        if typ == "MESH" and show_particles and use_strand and len(obj.particle_systems):
            export_particle_hair(obj, matrix, hair, materials, report, render=render, cancel=cancel)
    t_objects = time.perf_counter()
    for parent, n in unrealized.items():
        # Geometry-nodes curve instances reach renderers as legacy curve objects without a
        # bevel; Cycles renders nothing for them (checked with 3.4.1 and 4.5.15), nor do we.
        report.warn(f"'{parent}' has {n} un-realized geometry-nodes curve instance(s); like Cycles, they are "
                    "not rendered as hair (add a Realize Instances node)")

    curves_cache = mesh_cache = None  # object-space copies are not needed any more (memory)
    curves = hair.finish(materials.attributes.names)
    n_curves = curves["curve_random"].size
    # Back faces of 3D curves: Cycles 3.4 never reports them, Cycles 4.5 does (measured with 3.4.1 and
    # 4.5.15; docs/engine.md, which also says why the cause in 3.x is not the Embree build option).
    shape = str(_get(getattr(scene, "cycles_curves", None), "shape", "RIBBONS"))
    subdiv = int(_get(getattr(scene, "cycles_curves", None), "subdivisions", 2))
    if shape not in ("RIBBONS", "THICK", "THICK_LINEAR"):
        report.warn(f"curve shape {shape} is not supported; rendered as 3D curves (THICK)")
        shape = "THICK"
    # Linear 3D Curves (5.x) are Embree's round linear curves, to which the build's back-face
    # culling applies (docs/blender5.md), so they are culled in every Blender that has them.
    cull_curves = blender_version() < CURVE_CULLING_BEFORE or shape == "THICK_LINEAR"
    if n_curves == 0:
        report.warn("the scene has no hair to render (no visible Curves objects or particle hair)")
    else:
        inside = camera_inside_hair(curves, camera["matrix_world"][:3, 3])
        if inside and cull_curves:
            report.warn(f"the camera is inside {inside} hair strand(s); as in this Blender's Cycles, their back "
                        "faces are culled and the camera sees through them")
        elif inside:
            report.warn(f"the camera is inside {inside} hair strand(s); it sees their inner walls (3D curves "
                        "are open tubes and, as in Cycles 3.6+, not back-face culled)")
    integrator = export_integrator(scene, view_layer, render, settings, report)
    world = export_world(scene, report, materials.attributes.images)
    desc = {
        "version": SCENE_DESC_VERSION,
        "curves": curves,
        "curve_shape": shape,
        "curve_subdivisions": subdiv,
        "curve_backface_culling": cull_curves,
        "meshes": meshes.finish(materials.attributes.names),
        "materials": materials.materials,
        "camera": camera,
        "lights": lights,
        "world": world,
        "images": materials.attributes.images.images,
        "integrator": integrator,
        "source": {"blender_version": ".".join(str(v) for v in blender_version()),
                   "scene": scene.name, "view_layer": view_layer.name if view_layer else "",
                   "frame": int(scene.frame_current), "render": bool(render)},
    }
    report.counts.update({"curves": int(n_curves), "points": int(curves["points"].shape[0]),
                          "triangles": int(desc["meshes"]["triangles"].shape[0]), "lights": len(lights),
                          "materials": len(desc["materials"]), "instances": n_inst})
    report.timings["objects"] = t_objects - t_start
    report.timings["total"] = time.perf_counter() - t_start
    return desc, report

