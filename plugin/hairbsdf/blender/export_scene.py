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
from ._common import (SCENE_SETTINGS, TILT_AUTO, ExportReport, blender_version, default_tilt, lookup3_hash_uint2,
                      matrix_to_numpy, scene_value)
from .export_camera import export_camera
from .export_hair import CurvesCache, HairBuffer, camera_inside_hair, export_curves_object, export_particle_hair
from .export_lights import export_light
from .export_materials import MaterialTable
from .export_mesh import MESH_LIKE, MeshBuffer, MeshCache, export_mesh_object
from .export_world import export_world
from . import passes
from .._blender_versions import (CHIANG_LCG_BEFORE, CURVE_CULLING_BEFORE, HUANG_GLASS_TABLES_5_FROM,
                                 LIGHT_TREE_FROM)
from ..render import SCENE_DESC_VERSION, schema_choices, schema_default
from ..scene_file import load_scene, save_scene  # noqa: F401 (re-exported: no bpy needed to read a file)


def engine_settings(scene) -> dict:
    """The engine's own settings (ui.py's scene.hairbsdf); {} when the add-on's properties are
    not registered: then the scene format's defaults apply, and the running Blender's tilt."""
    s = getattr(scene, "hairbsdf", None)
    names = [] if s is None else [p.identifier for p in s.bl_rna.properties if p.identifier != "rna_type"]
    return {name: getattr(s, name) for name in names}


def cycles_settings(scene, group: str):
    """scene.<group> ("cycles", "cycles_curves"): the exporter reads Cycles' render settings there
    and nowhere else, so each default is the Cycles add-on's own. Without the add-on there are
    none: ExportError."""
    settings = getattr(scene, group, None)
    if settings is None:
        raise ExportError(f"scene.{group} is missing: the Cycles add-on is disabled, and hairbsdf reads the render "
                          "settings from it (sampling, light paths, film, curves); enable it in Preferences > Add-ons")
    return settings


def export_integrator(scene, view_layer, render: bool, settings: dict, report) -> dict:
    cy = cycles_settings(scene, "cycles")
    samples = int(cy.samples if render else cy.preview_samples)
    layer_mode = cy.use_layer_samples
    layer_samples = int(getattr(view_layer, "samples", 0)) if view_layer is not None else 0
    if render and layer_samples > 0 and layer_mode != "IGNORE":
        samples = min(samples, layer_samples) if layer_mode == "BOUNDED" else layer_samples
    seed = int(cy.seed)
    if cy.use_animated_seed:
        seed_base = seed
        seed = lookup3_hash_uint2(int(scene.frame_current) & 0xFFFFFFFF, seed_base & 0xFFFFFFFF)
        sub = float(getattr(scene, "frame_subframe", 0.0))
        if sub != 0.0:
            seed = (seed + lookup3_hash_uint2(int(sub * 2147483647) & 0xFFFFFFFF, seed_base & 0xFFFFFFFF))
        seed &= 0xFFFFFFFF
    ftype = cy.pixel_filter_type
    # Cycles' Blender sync forces the box filter to 1 px whatever filter_width says.
    fwidth = 1.0 if ftype == "BOX" else float(cy.filter_width)
    tilt = settings.get("tilt")  # missing ({}: no add-on properties) means Auto too
    tilt = default_tilt() if tilt in (TILT_AUTO[0], "", None) else tilt
    ignored = []
    if render and cy.use_denoising:
        ignored.append("Denoising")
    if cy.use_fast_gi:
        ignored.append("Fast GI")
    if render and float(cy.time_limit) > 0.0:
        ignored.append("Time Limit")
    if ignored:
        report.warn("Cycles settings hairbsdf ignores (the image may differ from Cycles): " + ", ".join(ignored))
    integrator = {
        "samples": max(samples, 1),
        "seed": seed,
        "max_bounces": int(cy.max_bounces),
        "diffuse_bounces": int(cy.diffuse_bounces),
        "glossy_bounces": int(cy.glossy_bounces),
        "transmission_bounces": int(cy.transmission_bounces),
        "transparent_bounces": int(cy.transparent_max_bounces),
        "min_light_bounces": int(cy.min_light_bounces),
        "filter_type": ftype,
        "filter_width": fwidth,
        "exposure": float(cy.film_exposure),
        "film_transparent": bool(scene.render.film_transparent),
        "light_sampling_threshold": float(cy.light_sampling_threshold),
        # Cycles 4.x picks NEE lights with its light tree (on by default); 3.x has none.
        "light_tree": bool(cy.use_light_tree) if blender_version() >= LIGHT_TREE_FROM else False,
        # Cycles < 3.6 draws Chiang's longitudinal sample numbers from a per-hit LCG (correlated).
        "chiang_lcg": blender_version() < CHIANG_LCG_BEFORE,
        "filter_glossy": float(cy.blur_glossy),
        "clamp_direct": float(cy.sample_clamp_direct),
        "clamp_indirect": float(cy.sample_clamp_indirect),
        "tilt": tilt,
    }
    # The engine's own settings (ui.py) that are integrator keys; not set: the scene's defaults.
    integrator.update((name, scene_value(name, settings[name])) for name, path in SCENE_SETTINGS.items()
                      if path.startswith("integrator.") and name != "tilt" and name in settings)
    # Cycles 5.x regenerated Huang's energy-compensation tables (docs/blender5.md).
    integrator["huang_glass_albedo_table"] = "5.x" if blender_version() >= HUANG_GLASS_TABLES_5_FROM else "4.x"
    integrator["passes"] = passes.requested(view_layer) if render else []
    return integrator


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
    cycles_settings(scene, "cycles")  # before the objects: a scene without Cycles' settings fails at once
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
    curve_settings = cycles_settings(scene, "cycles_curves")
    shape, subdiv = str(curve_settings.shape), int(curve_settings.subdivisions)
    if shape not in schema_choices("curve_shape"):
        shape_default = schema_default("curve_shape")
        report.warn(f"curve shape {shape} is not supported; rendered as {shape_default}")
        shape = shape_default
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
        # the engine's settings that are top-level scene keys (curve_intersector); not set: the defaults
        **{path: scene_value(name, settings[name]) for name, path in SCENE_SETTINGS.items()
           if "." not in path and name in settings},
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

