"""Shared helpers for the comparison harness's scene builders (Blender 3.4 and 4.x).

Functions only; importing this module touches no scene.  Every builder calls
``parity_settings(scene, ...)``, which sets every Cycles setting that changes pixels
(docs/cycles.md §6) explicitly, so a factory default can never leak into a comparison:

* curve shape and subdivisions, Filter Glossy 0, clamps 0, Light Threshold 0,
  denoising and adaptive sampling off, path guiding off, bounce limits, pixel filter,
  seed (not animated), samples, time limit 0, film exposure 1;
* view transform Standard, look None, exposure 0, gamma 1 (3.4's default is Filmic, 4.x's AgX);
  linear 32-bit EXR output;
* per light (4.x): soft falloff off (3.4 has none), so both versions light alike.

API differences handled here:
* 3.4 has no ``Curves.add_curves``: hair is made by geometry nodes from a hidden guide mesh
  (Object Info -> Mesh to Curve -> Catmull-Rom -> Set Curve Radius from a point attribute
  -> Set Material), see ``curves_from_polylines``;
* 3.4 has no Principled Hair ``model`` enum (it is always Chiang);
* 3.4 has no ``use_light_tree`` / ``use_soft_falloff``;
* the Named Attribute node has one output per type in 3.4 and a single one in 4.x.
"""

import math
import os
import random
import sys

import bpy

from mathutils import Vector  # noqa: E402  (after bpy: bpy module mode)

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

import fiber_gonio as fg  # noqa: E402  (materials, node helpers)

# --------------------------------------------------------------------------- versions


def version():
    return tuple(bpy.app.version)


def has_model_enum():
    return fg.has_hair_model_enum()


def default_tilt():
    return fg.default_tilt_convention()


# --------------------------------------------------------------------------- settings

DEFAULT_BOUNCES = dict(max_bounces=16, diffuse_bounces=4, glossy_bounces=16, transmission_bounces=16,
                       volume_bounces=0, transparent_max_bounces=8)


def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def parity_settings(scene, *, width, height, spp, seed=0, threads=0, bounces=None,
                    curve_shape="THICK", subdivisions=3, pixel_filter="BLACKMAN_HARRIS",
                    filter_width=1.5, film_transparent=False, osl=False):
    """Sets every parity-relevant Cycles and output setting (module docstring)."""
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    try:
        bpy.context.preferences.addons["cycles"].preferences.compute_device_type = "NONE"
    except Exception:  # pragma: no cover - module mode without add-on prefs
        pass
    cy.shading_system = bool(osl)
    cy.samples = int(spp)
    if hasattr(cy, "time_limit"):
        cy.time_limit = 0.0
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    if hasattr(cy, "use_preview_denoising"):
        cy.use_preview_denoising = False
    cy.seed = int(seed)
    cy.use_animated_seed = False
    b = dict(DEFAULT_BOUNCES)
    b.update(bounces or {})
    for k, v in b.items():
        setattr(cy, k, int(v))
    cy.min_light_bounces = 0
    cy.min_transparent_bounces = 0
    cy.light_sampling_threshold = 0.0
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    if hasattr(cy, "use_guiding"):
        cy.use_guiding = False
    if hasattr(cy, "use_fast_gi"):
        cy.use_fast_gi = False
    if hasattr(cy, "use_light_tree"):
        cy.use_light_tree = True  # 4.x default, named so the report shows it
    cy.pixel_filter_type = pixel_filter
    cy.filter_width = float(filter_width)
    cy.film_exposure = 1.0
    if hasattr(cy, "film_transparent"):  # an alias of render.film_transparent, gone in 5.0
        cy.film_transparent = bool(film_transparent)
    scene.cycles_curves.shape = curve_shape
    scene.cycles_curves.subdivisions = int(subdivisions)
    for vl in scene.view_layers:
        if hasattr(vl, "use_strand"):
            vl.use_strand = True
        if hasattr(vl, "samples"):
            vl.samples = 0
    r = scene.render
    r.resolution_x, r.resolution_y = int(width), int(height)
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.use_border = False
    r.use_motion_blur = False
    r.use_simplify = False
    r.threads_mode = "FIXED" if threads else "AUTO"
    if threads:
        r.threads = int(threads)
    r.use_persistent_data = False
    r.use_file_extension = True
    r.film_transparent = bool(film_transparent)
    ims = r.image_settings
    ims.file_format = "OPEN_EXR"
    ims.color_mode = "RGBA"
    ims.color_depth = "32"
    ims.exr_codec = "ZIP"
    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    vs.use_curve_mapping = False
    scene.display_settings.display_device = "sRGB"
    return scene


# Read back by the harness for its report (also for user .blend files, to flag settings that
# break parity).  (attribute path, value that parity needs or None for "recorded only").
PARITY_KEYS = (
    ("cycles.samples", None), ("cycles.seed", None), ("cycles.use_animated_seed", False),
    ("cycles.use_denoising", False), ("cycles.use_adaptive_sampling", False),
    ("cycles.blur_glossy", 0.0), ("cycles.sample_clamp_direct", 0.0), ("cycles.sample_clamp_indirect", 0.0),
    ("cycles.light_sampling_threshold", 0.0), ("cycles.use_guiding", False), ("cycles.use_light_tree", None),
    ("cycles.max_bounces", None), ("cycles.diffuse_bounces", None), ("cycles.glossy_bounces", None),
    ("cycles.transmission_bounces", None), ("cycles.volume_bounces", None),
    ("cycles.transparent_max_bounces", None), ("cycles.min_light_bounces", None),
    ("cycles.caustics_reflective", None), ("cycles.caustics_refractive", None),
    ("cycles.pixel_filter_type", None), ("cycles.filter_width", None), ("cycles.film_exposure", None),
    ("render.film_transparent", None), ("cycles.shading_system", None), ("cycles.device", None),
    ("cycles_curves.shape", None), ("cycles_curves.subdivisions", None),
    ("render.resolution_x", None), ("render.resolution_y", None), ("render.resolution_percentage", None),
    ("render.use_motion_blur", False),
    ("view_settings.view_transform", None), ("view_settings.look", None), ("view_settings.exposure", None),
    ("view_settings.gamma", None),
)


def read_parity_settings(scene):
    """(settings dict, list of warnings for values that break parity)."""
    out, warnings = {}, []
    for path, need in PARITY_KEYS:
        obj = scene
        ok = True
        for part in path.split("."):
            if not hasattr(obj, part):
                ok = False
                break
            obj = getattr(obj, part)
        if not ok:
            continue
        v = obj
        if isinstance(v, float):
            v = round(v, 6)
        out[path] = v
        if need is not None and v != need:
            warnings.append("%s = %r (parity needs %r)" % (path, v, need))
    soft = [o.name for o in scene.objects if o.type == "LIGHT" and getattr(o.data, "use_soft_falloff", False)
            and o.data.type in ("POINT", "SPOT", "AREA")]
    if soft:
        warnings.append("soft falloff on lights %s (Blender 3.4 has none)" % ", ".join(sorted(soft)))
    return out, warnings


# --------------------------------------------------------------------------- world, camera, lights


def set_world(scene, color=(0.0, 0.0, 0.0), strength=1.0, name="HarnessWorld"):
    world = bpy.data.worlds.new(name)
    scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = tuple(color) + (1.0,)
    bg.inputs["Strength"].default_value = float(strength)
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(bg.outputs[0], out.inputs["Surface"])
    return world


def look_at(obj, location, target, up_axis="Y"):
    obj.location = Vector(location)
    d = Vector(target) - Vector(location)
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = d.to_track_quat("-Z", up_axis)
    return obj


def perspective_camera(scene, location, target, lens=50.0, name="HarnessCamera"):
    cam = bpy.data.cameras.new(name)
    cam.type = "PERSP"
    cam.lens = float(lens)
    cam.sensor_fit = "AUTO"
    cam.sensor_width = 36.0
    cam.clip_start, cam.clip_end = 0.01, 100.0
    cam.shift_x = cam.shift_y = 0.0
    cam.dof.use_dof = False
    obj = bpy.data.objects.new(name, cam)
    scene.collection.objects.link(obj)
    scene.camera = obj
    return look_at(obj, location, target)


def ortho_camera(scene, location, target, ortho_scale, name="HarnessCamera"):
    cam = bpy.data.cameras.new(name)
    cam.type = "ORTHO"
    cam.ortho_scale = float(ortho_scale)
    cam.sensor_fit = "AUTO"
    cam.clip_start, cam.clip_end = 0.01, 100.0
    cam.dof.use_dof = False
    obj = bpy.data.objects.new(name, cam)
    scene.collection.objects.link(obj)
    scene.camera = obj
    return look_at(obj, location, target)


def _light(scene, kind, name, energy, color, location, target):
    ld = bpy.data.lights.new(name, kind)
    ld.energy = float(energy)
    ld.color = tuple(color)
    if hasattr(ld, "exposure"):
        ld.exposure = 0.0
    if hasattr(ld, "use_soft_falloff"):
        ld.use_soft_falloff = False
    if hasattr(ld, "use_shadow"):
        ld.use_shadow = True
    if hasattr(ld, "cycles") and hasattr(ld.cycles, "use_multiple_importance_sampling"):
        ld.cycles.use_multiple_importance_sampling = True
    if hasattr(ld, "cycles") and hasattr(ld.cycles, "max_bounces"):
        ld.cycles.max_bounces = 1024
    obj = bpy.data.objects.new(name, ld)
    scene.collection.objects.link(obj)
    look_at(obj, location, target)
    return obj


def area_light(scene, location, target, energy, size=1.0, shape="SQUARE", color=(1, 1, 1), name="HarnessArea"):
    obj = _light(scene, "AREA", name, energy, color, location, target)
    obj.data.shape = shape
    obj.data.size = float(size)
    if shape in ("RECTANGLE", "ELLIPSE"):
        obj.data.size_y = float(size)
    if hasattr(obj.data, "spread"):
        obj.data.spread = math.pi
    return obj


def sun_light(scene, direction_to_sun, energy, angle_deg=0.0, color=(1, 1, 1), name="HarnessSun"):
    obj = _light(scene, "SUN", name, energy, color, (0, 0, 0), (0, 0, 0))
    q = Vector(direction_to_sun).normalized().to_track_quat("Z", "Y")
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = q
    obj.data.angle = math.radians(angle_deg)
    return obj


def point_light(scene, location, energy, radius=0.1, color=(1, 1, 1), name="HarnessPoint"):
    obj = _light(scene, "POINT", name, energy, color, location, (0, 0, 0))
    obj.data.shadow_soft_size = float(radius)
    return obj


# --------------------------------------------------------------------------- materials


def hair_material(name, params, coat_from_hair_info=None):
    """Principled Hair (Chiang unless params['model'] says otherwise) with the snake_case
    inputs of fiber_gonio.HAIR_INPUT_NAMES.  coat_from_hair_info=k links Coat to
    k * Hair Info > Random (a driven input, as the fur_ball scene needs)."""
    mat = fg.make_hair_material(name)
    p = dict(params)
    model = p.pop("model", "CHIANG")
    aspect = p.pop("aspect_ratio", None)
    huang_only = {k: p.pop(k) for k in ("reflection", "transmission", "secondary_reflection") if k in p}
    if model != "CHIANG" and not has_model_enum():
        raise RuntimeError("the %s hair model needs Blender 4.0+" % model)
    if has_model_enum():
        p["model"] = model
    fg.set_hair_params(mat, p)
    node = mat.node_tree.nodes["Hair"]
    if aspect is not None:
        fg.node_input(node, "Aspect Ratio").default_value = float(aspect)
    for key, value in huang_only.items():
        fg.node_input(node, key.replace("_", " ").title()).default_value = float(value)
    if coat_from_hair_info is not None:
        nt = mat.node_tree
        info = nt.nodes.new("ShaderNodeHairInfo")
        mul = nt.nodes.new("ShaderNodeMath")
        mul.operation = "MULTIPLY"
        mul.inputs[1].default_value = float(coat_from_hair_info)
        nt.links.new(info.outputs["Random"], mul.inputs[0])
        nt.links.new(mul.outputs[0], fg.node_input(node, "Coat"))
    return mat


def _fresh_material(name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.name = "Output"
    if hasattr(out, "target"):
        out.target = "ALL"
    return mat, nt, out


def diffuse_material(name, color=(0.5, 0.5, 0.5)):
    mat, nt, out = _fresh_material(name)
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = tuple(color) + (1.0,)
    d.inputs["Roughness"].default_value = 0.0
    nt.links.new(d.outputs[0], out.inputs["Surface"])
    return mat


def _principled_hair_node(nt, params):
    node = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
    p = dict(params)
    if has_model_enum():
        node.model = p.pop("model", "CHIANG")
    else:
        p.pop("model", None)
    node.parametrization = p.pop("parametrization")
    for key, v in p.items():
        sock = fg.node_input(node, fg.HAIR_INPUT_NAMES[key])
        if isinstance(v, (list, tuple)):
            v = tuple(v) + (1.0,) * (len(sock.default_value) - len(v))
        sock.default_value = v
    return node


def _hair_bsdf_node(nt, component, color, offset_deg=0.0, roughness_u=0.1, roughness_v=1.0):
    node = nt.nodes.new("ShaderNodeBsdfHair")
    node.component = component
    node.inputs["Color"].default_value = tuple(color) + (1.0,)
    node.inputs["Offset"].default_value = math.radians(offset_deg)
    node.inputs["RoughnessU"].default_value = float(roughness_u)
    node.inputs["RoughnessV"].default_value = float(roughness_v)
    return node


def mix_hair_material(name, fac, principled, hair_bsdf):
    """Mix Shader(fac) of Principled Hair (first) and Hair BSDF (second)."""
    mat, nt, out = _fresh_material(name)
    a = _principled_hair_node(nt, principled)
    b = _hair_bsdf_node(nt, **hair_bsdf)
    mix = nt.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = float(fac)
    nt.links.new(a.outputs[0], mix.inputs[1])
    nt.links.new(b.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    return mat


def add_hair_material(name, principled, hair_bsdf):
    """Add Shader of Principled Hair and Hair BSDF."""
    mat, nt, out = _fresh_material(name)
    a = _principled_hair_node(nt, principled)
    b = _hair_bsdf_node(nt, **hair_bsdf)
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(a.outputs[0], add.inputs[0])
    nt.links.new(b.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Surface"])
    return mat


# --------------------------------------------------------------------------- hair geometry


def _named_attribute_output(node):
    """The float output of a Named Attribute node (one per type in 3.4, one in 4.x)."""
    enabled = [s for s in node.outputs if getattr(s, "enabled", True)]
    return enabled[0]


def curves_from_polylines(scene, name, polylines, radii, material, curve_normal=None):
    """A Curves object whose strands are the given polylines (root first), made by geometry
    nodes from a hidden guide mesh so that it works in Blender 3.4 (no add_curves).

    polylines: list of lists of (x, y, z); radii: list of lists of floats (same shape) or
    one float.  Each strand becomes a Catmull-Rom curve through its points (Cycles treats
    the points as its keys), root = first point.  curve_normal: None or a Set Curve
    Normal mode ('MINIMUM_TWIST', 'Z_UP'; 4.x), for the Huang model's ellipse axis."""
    verts, edges, rad = [], [], []
    for k, line in enumerate(polylines):
        base = len(verts)
        rs = radii[k] if isinstance(radii, (list, tuple)) else [radii] * len(line)
        for i, p in enumerate(line):
            verts.append(tuple(float(c) for c in p))
            rad.append(float(rs[i]))
            if i:
                edges.append((base + i - 1, base + i))
    me = bpy.data.meshes.new(name + "Guide")
    me.from_pydata(verts, edges, [])
    attr = me.attributes.new("hair_radius", "FLOAT", "POINT")
    attr.data.foreach_set("value", rad)
    guide = bpy.data.objects.new(name + "Guide", me)
    scene.collection.objects.link(guide)
    guide.hide_render = True
    guide.hide_viewport = False  # Object Info needs it evaluated
    curves = bpy.data.hair_curves.new(name)
    obj = bpy.data.objects.new(name, curves)
    scene.collection.objects.link(obj)
    ng = fg._new_geometry_node_group(name + "Nodes")
    N, L = ng.nodes, ng.links
    info = N.new("GeometryNodeObjectInfo")
    info.transform_space = "ORIGINAL"
    info.inputs["Object"].default_value = guide
    m2c = N.new("GeometryNodeMeshToCurve")
    stype = N.new("GeometryNodeCurveSplineType")
    stype.spline_type = "CATMULL_ROM"
    named = N.new("GeometryNodeInputNamedAttribute")
    named.data_type = "FLOAT"
    named.inputs["Name"].default_value = "hair_radius"
    srad = N.new("GeometryNodeSetCurveRadius")
    setmat = N.new("GeometryNodeSetMaterial")
    setmat.name = "SetMaterial"
    setmat.inputs["Material"].default_value = material
    out = N.new("NodeGroupOutput")
    L.new(info.outputs["Geometry"], m2c.inputs["Mesh"])
    L.new(m2c.outputs["Curve"], stype.inputs["Curve"])
    L.new(stype.outputs["Curve"], srad.inputs["Curve"])
    L.new(_named_attribute_output(named), srad.inputs["Radius"])
    last = srad.outputs["Curve"]
    if curve_normal is not None:
        sn = N.new("GeometryNodeSetCurveNormal")
        fg.set_node_mode(sn, "mode", curve_normal)
        L.new(last, sn.inputs["Curve"])
        last = sn.outputs["Curve"]
    L.new(last, setmat.inputs["Geometry"])
    L.new(setmat.outputs["Geometry"], out.inputs[0])
    mod = obj.modifiers.new(name + "GN", "NODES")
    mod.node_group = ng
    curves.materials.append(material)
    return obj


def particle_hair(scene, emitter, name, count, length, seed, material_slot=1, radius=0.004,
                  tip_radius=0.0, render_step=3, random_factor=0.0, close_tip=False):
    """Legacy particle hair (Cycles renders it as curves in 3.4 and 4.x): straight strands
    along the emitter normals, optionally randomised (Physics > Velocity > Randomize)."""
    mod = emitter.modifiers.new(name, "PARTICLE_SYSTEM")
    psys = mod.particle_system
    psys.seed = int(seed)
    ps = psys.settings
    ps.name = name + "Settings"
    ps.type = "HAIR"
    ps.use_advanced_hair = True
    ps.count = int(count)
    ps.hair_length = float(length)
    ps.emit_from = "FACE"
    ps.use_emit_random = True
    ps.distribution = "RAND"
    ps.use_even_distribution = True
    ps.normal_factor = 1.0
    ps.factor_random = float(random_factor)
    ps.render_step = int(render_step)
    ps.display_step = int(render_step)
    ps.child_type = "NONE"
    ps.material = int(material_slot)
    ps.root_radius = 1.0
    ps.tip_radius = float(tip_radius) / float(radius) if radius else 0.0
    ps.radius_scale = 2.0 * float(radius)
    ps.shape = 0.0
    ps.use_close_tip = bool(close_tip)
    ps.render_type = "PATH"
    ps.use_hair_bspline = False
    ps.display_method = "RENDER"
    return psys


def uv_sphere(scene, name, radius, location=(0, 0, 0), segments=48, rings=24, hemisphere=False):
    """A UV sphere mesh from Python (no operators, so it works identically everywhere)."""
    verts, faces = [], []
    ring_max = rings // 2 + 1 if hemisphere else rings
    verts.append((0.0, 0.0, radius))
    for i in range(1, ring_max):
        th = math.pi * i / rings
        for j in range(segments):
            ph = 2.0 * math.pi * j / segments
            verts.append((radius * math.sin(th) * math.cos(ph), radius * math.sin(th) * math.sin(ph),
                          radius * math.cos(th)))
    if not hemisphere:
        verts.append((0.0, 0.0, -radius))
    for j in range(segments):
        faces.append((0, 1 + j, 1 + (j + 1) % segments))
    nring = ring_max - 1
    for i in range(nring - 1):
        a, b = 1 + i * segments, 1 + (i + 1) * segments
        for j in range(segments):
            j1 = (j + 1) % segments
            faces.append((a + j, b + j, b + j1, a + j1))
    if not hemisphere:
        last = len(verts) - 1
        a = 1 + (nring - 1) * segments
        for j in range(segments):
            faces.append((a + j, last, a + (j + 1) % segments))
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    for poly in me.polygons:
        poly.use_smooth = True
    me.update()
    obj = bpy.data.objects.new(name, me)
    obj.location = location
    scene.collection.objects.link(obj)
    return obj


def rng(seed):
    return random.Random(int(seed))


def wavy_strand(root, direction, length, n_points, rng_, wave=0.0, wave_axis=(0, 1, 0), jitter=0.0):
    """Points of one strand from root along direction, with a sine wave and jitter."""
    d = Vector(direction).normalized()
    w = Vector(wave_axis).normalized()
    phase = rng_.uniform(0.0, 2.0 * math.pi)
    pts = []
    for i in range(n_points):
        t = i / (n_points - 1)
        p = Vector(root) + d * (length * t) + w * (wave * t * math.sin(phase + 3.0 * math.pi * t))
        if i and jitter:
            p += Vector((rng_.uniform(-1, 1), rng_.uniform(-1, 1), rng_.uniform(-1, 1))) * jitter * t
        pts.append(tuple(p))
    return pts
