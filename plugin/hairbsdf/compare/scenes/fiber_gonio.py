"""Fibre goniometer scene for Cycles: one straight thick strand, an orthographic
camera and a delta sun.

Usable from Debian's Blender 3.4 (``blender -b --python ...``) and from the bpy
4.5 module.  Only functions, no top-level side effects (importing this module
does not touch the scene).

Geometry (world space)
----------------------
* The strand axis is the world X axis, from root (-L/2, 0, 0) to tip (+L/2, 0, 0)
  (key index increases with x, so Cycles' tangent X = +x).  Radius ``r`` is
  constant on all keys.  It is a Curves object (type 'CURVES'), rendered by
  Cycles as hair with ``scene.cycles_curves.shape = 'THICK'`` ("3D Curves").
* The camera is orthographic and looks along ``-wo`` (``wo`` = unit vector from
  the strand towards the camera).  Its image x axis is the strand axis
  projected into the image plane, its image y ("up") axis is ``Yc = wo x Xc``.
  The strand axis passes through the image centre.
* The sun's local +Z (the direction *towards* the sun) is ``wi``; angle 0
  (delta light).

Offset h of a pixel (see bsdf_check/README.md for the derivation):
``h = s / r`` where ``s`` is the signed offset of the pixel centre from the
image centre along the image's up axis ``Yc`` (rows counted from the bottom).
This equals ``-dot(P - C, Y) / r`` with Cycles' ``Y = normalize(X x wo)`` (= -Yc).
"""

import math
import os
import runpy

import bpy

from mathutils import Matrix, Vector  # noqa: E402  (after bpy: bpy module mode)


STRAND_NAME = "GonioStrand"
CAMERA_NAME = "GonioCamera"
SUN_NAME = "GonioSun"
HAIR_MATERIAL_NAME = "GonioHair"


# --------------------------------------------------------------------------
# versions

def blender_version():
    """(major, minor, patch) of the running Blender."""
    return tuple(bpy.app.version)


def blender_version_string():
    return bpy.app.version_string


# The package's named version cut-offs (hairbsdf/_blender_versions.py), read by path: this file runs inside
# Blender without the package.
VERSIONS = runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir,
                                       "_blender_versions.py"))


def has_hair_model_enum():
    """Whether ShaderNodeBsdfHairPrincipled has its model enum (CHIANG/HUANG)."""
    return blender_version() >= VERSIONS["HAIR_MODEL_ENUM_FROM"]


def default_tilt_convention():
    """The running Blender's Principled Hair tilt convention: '3.4' (tilt on the light angle) or '4.2'."""
    return VERSIONS["tilt_convention"](blender_version())


# --------------------------------------------------------------------------
# scene and render settings

def reset_scene():
    """Empty factory scene (no default cube/camera/light)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def setup_render(scene=None, width=4, height=160, spp=1, seed=0, threads=2,
                 filter_width=0.01, curve_shape="THICK", pixel_filter="BLACKMAN_HARRIS"):
    """Cycles CPU settings for a deterministic direct-light-only render.

    Pixel filter: Blender's Cycles sync forces the BOX filter to 1 px whatever
    filter_width says (intern/cycles/blender/sync.cpp), so a narrow filter must be
    Gaussian or Blackman-Harris.  With 1 spp the only camera sample of a pixel
    sits at its centre (measured: within 1e-4 px, any seed, 3.4 and 4.5)."""
    scene = scene or bpy.context.scene
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    try:
        bpy.context.preferences.addons["cycles"].preferences.compute_device_type = "NONE"
    except Exception:  # pragma: no cover - addon prefs may be missing in module mode
        pass
    cy.samples = spp
    if hasattr(cy, "time_limit"):
        cy.time_limit = 0.0
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    if hasattr(cy, "use_preview_denoising"):
        cy.use_preview_denoising = False
    cy.seed = seed
    cy.use_animated_seed = False
    # direct light only
    cy.max_bounces = 0
    cy.diffuse_bounces = 0
    cy.glossy_bounces = 0
    cy.transmission_bounces = 0
    cy.volume_bounces = 0
    cy.transparent_max_bounces = 0
    cy.min_light_bounces = 0
    cy.light_sampling_threshold = 0.0
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    if hasattr(cy, "use_guiding"):
        cy.use_guiding = False
    # pixel filter: (almost) a point sample at the pixel centre (see docstring)
    cy.pixel_filter_type = pixel_filter
    cy.filter_width = filter_width
    cy.film_exposure = 1.0
    if hasattr(cy, "film_transparent"):  # an alias of render.film_transparent, gone in 5.0
        cy.film_transparent = False
    # curves
    scene.cycles_curves.shape = curve_shape
    scene.cycles_curves.subdivisions = 2
    for vl in scene.view_layers:
        vl.use_strand = True
    # output
    r = scene.render
    r.resolution_x = width
    r.resolution_y = height
    r.resolution_percentage = 100
    r.pixel_aspect_x = 1.0
    r.pixel_aspect_y = 1.0
    r.use_border = False
    r.threads_mode = "FIXED"
    r.threads = threads
    r.use_persistent_data = False
    r.use_file_extension = True
    r.film_transparent = False
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
    # black world
    world = scene.world or bpy.data.worlds.new("GonioWorld")
    scene.world = world
    set_world_color(world, (0.0, 0.0, 0.0))
    return scene


def set_world_color(world, color):
    """A world of one colour in every Blender. Before 5.0: nodes off and world.color. From 5.0
    a world always renders its node tree (use_nodes is deprecated, reads True and ignores
    False), and a new world comes with a Background of 0.05 grey: that node gets the colour
    (docs/blender5.md)."""
    world.color = tuple(color[:3])
    if blender_version() < VERSIONS["WORLD_ALWAYS_NODES_FROM"]:
        world.use_nodes = False
        return
    nt = world.node_tree
    bg = next((n for n in nt.nodes if n.bl_idname == "ShaderNodeBackground"), None)
    out = next((n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld"), None)
    if bg is None:
        bg = nt.nodes.new("ShaderNodeBackground")
    if out is None:
        out = nt.nodes.new("ShaderNodeOutputWorld")
    for link in list(out.inputs["Surface"].links):
        nt.links.remove(link)
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    bg.inputs["Color"].default_value = tuple(color[:3]) + (1.0,)
    bg.inputs["Strength"].default_value = 1.0


# --------------------------------------------------------------------------
# strand

def set_node_mode(node, prop, value, socket="Mode"):
    """Sets a node's enum option: a property (3.4, 4.x) or, where Blender 5.x turned it into a
    menu input socket (Resample Curve, Set Curve Normal: "Mode"), that socket, whose values are
    the items' names ('COUNT' -> 'Count', 'Z_UP' -> 'Z Up', 'MINIMUM_TWIST' -> 'Minimum Twist')."""
    if hasattr(node, prop):
        setattr(node, prop, value)
        return
    sock = node.inputs[socket]
    names = {"Z_UP": "Z Up"}
    sock.default_value = names.get(value, value.replace("_", " ").title())


def _new_geometry_node_group(name):
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    if hasattr(ng, "interface"):  # 4.0+
        ng.interface.new_socket(name="Geometry", in_out="OUTPUT",
                                socket_type="NodeSocketGeometry")
    else:  # 3.x
        ng.outputs.new("NodeSocketGeometry", "Geometry")
    return ng


def make_strand_geometry_nodes(length=1.0, radius=0.05, n_points=9, name=STRAND_NAME):
    """A Curves object whose geometry is generated by a geometry-nodes modifier:
    Curve Line -> Resample Curve (n_points) -> Set Spline Type (Catmull-Rom)
    -> Set Curve Radius -> Realize Instances.  Works in Blender 3.4 and 4.x."""
    curves = bpy.data.hair_curves.new(name)
    obj = bpy.data.objects.new(name, curves)
    bpy.context.scene.collection.objects.link(obj)
    ng = _new_geometry_node_group(name + "Nodes")
    nodes, links = ng.nodes, ng.links
    line = nodes.new("GeometryNodeCurvePrimitiveLine")
    line.mode = "POINTS"
    line.inputs["Start"].default_value = (-0.5 * length, 0.0, 0.0)
    line.inputs["End"].default_value = (0.5 * length, 0.0, 0.0)
    resample = nodes.new("GeometryNodeResampleCurve")
    set_node_mode(resample, "mode", "COUNT")
    resample.inputs["Count"].default_value = n_points
    stype = nodes.new("GeometryNodeCurveSplineType")
    stype.spline_type = "CATMULL_ROM"
    rad = nodes.new("GeometryNodeSetCurveRadius")
    rad.inputs["Radius"].default_value = radius
    realize = nodes.new("GeometryNodeRealizeInstances")
    setmat = nodes.new("GeometryNodeSetMaterial")
    setmat.name = "SetMaterial"
    out = nodes.new("NodeGroupOutput")
    links.new(line.outputs["Curve"], resample.inputs["Curve"])
    links.new(resample.outputs["Curve"], stype.inputs["Curve"])
    links.new(stype.outputs["Curve"], rad.inputs["Curve"])
    links.new(rad.outputs["Curve"], realize.inputs["Geometry"])
    links.new(realize.outputs["Geometry"], setmat.inputs["Geometry"])
    links.new(setmat.outputs["Geometry"], out.inputs[0])
    mod = obj.modifiers.new("GonioStrandGN", "NODES")
    mod.node_group = ng
    return obj


def make_strand_add_curves(length=1.0, radius=0.05, n_points=9, name=STRAND_NAME):
    """Blender 4.x only: Curves.add_curves + position/radius attributes."""
    curves = bpy.data.hair_curves.new(name)
    curves.add_curves([n_points])
    if hasattr(curves, "set_types"):
        curves.set_types(type="CATMULL_ROM")
    xs = [(-0.5 + i / (n_points - 1)) * length for i in range(n_points)]
    for i, p in enumerate(curves.points):
        p.position = (xs[i], 0.0, 0.0)
        p.radius = radius
    obj = bpy.data.objects.new(name, curves)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def make_strand(length=1.0, radius=0.05, n_points=9, method="geometry_nodes"):
    """method: 'geometry_nodes' (3.4 and 4.x) or 'add_curves' (4.x only)."""
    if method == "geometry_nodes":
        return make_strand_geometry_nodes(length, radius, n_points)
    if method == "add_curves":
        return make_strand_add_curves(length, radius, n_points)
    raise ValueError(method)


def evaluated_strand_points(obj):
    """(positions, radii) of the evaluated curves geometry (for checks)."""
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    data = ev.data
    pos = [tuple(p.position) for p in data.points]
    rad = [p.radius for p in data.points]
    return pos, rad, len(data.curves)


# --------------------------------------------------------------------------
# materials

HAIR_INPUT_NAMES = {
    "color": "Color",
    "melanin": "Melanin",
    "melanin_redness": "Melanin Redness",
    "tint": "Tint",
    "absorption_coefficient": "Absorption Coefficient",
    "roughness": "Roughness",
    "radial_roughness": "Radial Roughness",
    "coat": "Coat",
    "ior": "IOR",
    "offset": "Offset",
    "random_color": "Random Color",
    "random_roughness": "Random Roughness",
}


def make_hair_material(name=HAIR_MATERIAL_NAME):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    hair = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
    hair.name = "Hair"
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.name = "Output"
    if hasattr(out, "target"):
        out.target = "ALL"
    nt.links.new(hair.outputs[0], out.inputs["Surface"])
    return mat


def node_input(node, name):
    """Input socket by name, including unavailable ones (in 4.x ``inputs[name]``
    does not find sockets hidden by the current parametrization)."""
    for sock in node.inputs:
        if sock.name == name:
            return sock
    raise KeyError(name)


def set_hair_params(mat, params):
    """params: dict with 'parametrization' ('COLOR'|'MELANIN'|'ABSORPTION') and
    the snake_case keys of HAIR_INPUT_NAMES.  The Random socket stays unlinked
    (Cycles then uses the per-curve Hair Info > Random attribute)."""
    hair = mat.node_tree.nodes["Hair"]
    if has_hair_model_enum():
        hair.model = params.get("model", "CHIANG")
    hair.parametrization = params["parametrization"]
    for key, sock in HAIR_INPUT_NAMES.items():
        if key not in params:
            continue
        v = params[key]
        inp = node_input(hair, sock)
        if isinstance(v, (list, tuple)):
            n = len(inp.default_value)
            v = tuple(v) + (1.0,) * (n - len(v))
        inp.default_value = v
    assert not node_input(hair, "Random").is_linked
    return hair


def make_emission_probe_material(kind, offset=(0.0, 0.0, 0.0), name=None):
    """Emission shaders for geometry checks.
    kind 'position': emission colour = world position of the hit + offset.
    kind 'normal'  : emission colour = shading normal + offset.
    kind 'hairinfo': emission colour = (Random, Is Strand, Intercept) of Hair Info."""
    mat = bpy.data.materials.new(name or ("GonioProbe_" + kind))
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Strength"].default_value = 1.0
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(em.outputs[0], out.inputs["Surface"])
    if kind in ("position", "normal"):
        geo = nt.nodes.new("ShaderNodeNewGeometry")
        add = nt.nodes.new("ShaderNodeVectorMath")
        add.operation = "ADD"
        add.inputs[1].default_value = offset
        nt.links.new(geo.outputs["Position" if kind == "position" else "Normal"], add.inputs[0])
        nt.links.new(add.outputs[0], em.inputs["Color"])
    elif kind == "hairinfo":
        hi = nt.nodes.new("ShaderNodeHairInfo")
        comb = nt.nodes.new("ShaderNodeCombineXYZ")
        nt.links.new(hi.outputs["Random"], comb.inputs[0])
        nt.links.new(hi.outputs["Is Strand"], comb.inputs[1])
        nt.links.new(hi.outputs["Intercept"], comb.inputs[2])
        nt.links.new(comb.outputs[0], em.inputs["Color"])
    else:
        raise ValueError(kind)
    return mat


def assign_material(obj, mat):
    """Material slot 0 of the strand.  Geometry created by geometry nodes does
    not inherit the data's material list, so the node tree's Set Material node
    is updated too."""
    data = obj.data
    if len(data.materials) == 0:
        data.materials.append(mat)
    else:
        data.materials[0] = mat
    for mod in obj.modifiers:
        if mod.type == "NODES" and mod.node_group is not None:
            node = mod.node_group.nodes.get("SetMaterial")
            if node is not None:
                node.inputs["Material"].default_value = mat


# --------------------------------------------------------------------------
# directions and frames (pure python, no numpy needed)

def _norm(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b))


STRAND_AXIS = (1.0, 0.0, 0.0)


def view_direction(theta_o_deg, psi_deg):
    """wo for a strand along +x: sin(theta_o) along the axis, the rest at
    azimuth psi around the axis (psi = 90 deg: camera on +z)."""
    t, p = math.radians(theta_o_deg), math.radians(psi_deg)
    return (math.sin(t), math.cos(t) * math.cos(p), math.cos(t) * math.sin(p))


def cycles_frame(wo, X=STRAND_AXIS):
    """Cycles' Chiang frame for view direction wo: Y = normalize(X x wo), Z = X x Y."""
    Y = _norm(_cross(X, wo))
    Z = _cross(X, Y)
    return X, Y, Z


def light_direction(wo, theta_i_deg, dphi_deg, X=STRAND_AXIS):
    """wi with longitudinal angle theta_i and azimuth phi_i = phi_o + dphi,
    where phi is measured in the (Y, Z) plane of cycles_frame(wo) (phi_o = -90 deg)."""
    X, Y, Z = cycles_frame(wo, X)
    ti = math.radians(theta_i_deg)
    phi = math.radians(dphi_deg) - 0.5 * math.pi
    c = math.cos(ti)
    return tuple(math.sin(ti) * X[k] + c * (math.cos(phi) * Y[k] + math.sin(phi) * Z[k])
                 for k in range(3))


def camera_axes(wo, X=STRAND_AXIS):
    """Camera image axes: Xc (image right) = strand axis projected into the
    image plane, Yc (image up) = wo x Xc, Zc = wo (camera looks along -wo)."""
    d = _dot(X, wo)
    Xc = _norm(tuple(X[k] - d * wo[k] for k in range(3)))
    Yc = _cross(wo, Xc)
    return Xc, Yc, tuple(wo)


# --------------------------------------------------------------------------
# camera and sun

def make_camera(name=CAMERA_NAME):
    cam = bpy.data.cameras.new(name)
    cam.type = "ORTHO"
    cam.sensor_fit = "VERTICAL"
    cam.shift_x = 0.0
    cam.shift_y = 0.0
    cam.clip_start = 0.01
    cam.clip_end = 100.0
    obj = bpy.data.objects.new(name, cam)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.camera = obj
    return obj


def place_camera(cam_obj, wo, image_height_world, distance=2.0, X=STRAND_AXIS):
    """Orthographic camera at distance*wo looking at the origin; the vertical
    image extent is image_height_world (sensor_fit VERTICAL)."""
    Xc, Yc, Zc = camera_axes(wo, X)
    m = Matrix(((Xc[0], Yc[0], Zc[0], distance * wo[0]),
                (Xc[1], Yc[1], Zc[1], distance * wo[1]),
                (Xc[2], Yc[2], Zc[2], distance * wo[2]),
                (0.0, 0.0, 0.0, 1.0)))
    cam_obj.matrix_world = m
    cam_obj.data.ortho_scale = image_height_world
    cam_obj.data.sensor_fit = "VERTICAL"
    return Xc, Yc, Zc


def make_sun(name=SUN_NAME):
    light = bpy.data.lights.new(name, "SUN")
    light.angle = 0.0
    light.energy = 1.0
    light.color = (1.0, 1.0, 1.0)
    if hasattr(light, "exposure"):
        light.exposure = 0.0
    if hasattr(light, "use_shadow"):
        light.use_shadow = True
    obj = bpy.data.objects.new(name, light)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def place_sun(sun_obj, wi, strength):
    """Sun whose local +Z points along wi (towards the sun)."""
    q = Vector(wi).to_track_quat("Z", "Y")
    sun_obj.matrix_world = q.to_matrix().to_4x4()
    sun_obj.data.energy = strength
    sun_obj.data.angle = 0.0


# --------------------------------------------------------------------------
# rendering

def render_exr(path, scene=None):
    """Render the scene to an EXR file."""
    scene = scene or bpy.context.scene
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return path


def read_exr_rgba(path):
    """Linear float pixels of an EXR as a flat list (row 0 = bottom), plus (w, h).
    Uses bpy.data.images so it works in both Blenders without OpenImageIO."""
    img = bpy.data.images.load(path, check_existing=False)
    try:
        w, h = img.size
        ch = img.channels
        import numpy as np
        buf = np.empty(w * h * ch, dtype=np.float32)
        img.pixels.foreach_get(buf)
        return buf.reshape(h, w, ch), (w, h)
    finally:
        bpy.data.images.remove(img)


def pixel_offsets(width, height, image_height_world):
    """Signed offset s (world units, along the image up axis Yc) of every pixel
    row centre from the image centre; rows counted from the bottom (bpy pixel
    order).  Returns a list of length height."""
    p = image_height_world / height
    return [(j + 0.5 - 0.5 * height) * p for j in range(height)]
