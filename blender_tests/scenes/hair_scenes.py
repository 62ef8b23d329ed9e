"""Scene builders for the exporter and engine tests: particle hair (with children), Curves
made by geometry nodes (realized or instanced), meshes, lights, cameras and materials.

Works in Debian's Blender 3.4 (`blender -b --python ...`) and in the bpy 4.5 module.
Functions only, no side effects on import.  Blender 3.4 has no Curves.add_curves, so Curves
are made with geometry nodes; `apply_modifiers` turns them into plain Curves data when a
test needs to edit the points (foreach_set).
"""

import math

import bpy

import fiber_gonio as fg

try:  # mathutils after bpy (bpy module mode)
    from mathutils import Matrix, Vector  # noqa: F401
except ImportError:  # pragma: no cover
    Matrix = Vector = None


def version():
    return tuple(bpy.app.version)


# --------------------------------------------------------------------------- scene

def reset(width=32, height=24, spp=4, curve_shape="THICK", film_transparent=True):
    """Empty factory scene with deterministic Cycles settings (fiber_gonio.setup_render) and
    Blackman-Harris 1.5 px, Standard view transform, EXR output."""
    fg.reset_scene()
    scene = fg.setup_render(width=width, height=height, spp=spp, curve_shape=curve_shape,
                            filter_width=1.5)
    scene.render.film_transparent = film_transparent
    return scene


def link(obj, scene=None):
    (scene or bpy.context.scene).collection.objects.link(obj)
    return obj


def look_at(obj, location, target, up=(0.0, 0.0, 1.0)):
    """Place an object (camera / light) at `location` looking down its -Z at `target`."""
    loc = Vector(location)
    d = (Vector(target) - loc).normalized()
    obj.location = loc
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = d.to_track_quat("-Z", "Y")
    return obj


def make_camera(location=(0.0, -3.0, 0.5), target=(0.0, 0.0, 0.5), lens=50.0, kind="PERSP",
                ortho_scale=2.0, sensor_fit="AUTO", shift=(0.0, 0.0), name="Camera"):
    cam = bpy.data.cameras.new(name)
    cam.type = kind
    cam.lens = lens
    cam.ortho_scale = ortho_scale
    cam.sensor_fit = sensor_fit
    cam.shift_x, cam.shift_y = shift
    cam.clip_start = 0.01
    cam.clip_end = 100.0
    obj = link(bpy.data.objects.new(name, cam))
    look_at(obj, location, target)
    bpy.context.scene.camera = obj
    return obj


def make_light(kind="SUN", location=(2.0, -2.0, 3.0), target=(0.0, 0.0, 0.0), energy=3.0,
               color=(1.0, 1.0, 1.0), name=None, **props):
    data = bpy.data.lights.new(name or kind.title(), kind)
    data.energy = energy
    data.color = color
    for k, v in props.items():
        setattr(data, k, v)
    obj = link(bpy.data.objects.new(name or kind.title(), data))
    look_at(obj, location, target)
    return obj


def make_plane(size=2.0, location=(0.0, 0.0, 0.0), name="Plane"):
    bpy.ops.mesh.primitive_plane_add(size=size, location=location)
    obj = bpy.context.active_object
    obj.name = name
    return obj


# --------------------------------------------------------------------------- materials

def _clear(nt):
    for n in list(nt.nodes):
        nt.nodes.remove(n)


def hair_material(name="Hair", parametrization="MELANIN", **params):
    """Principled Hair (Chiang) material; params are fiber_gonio.set_hair_params keys."""
    mat = fg.make_hair_material(name)
    fg.set_hair_params(mat, dict(params, parametrization=parametrization))
    return mat


def emission_material(name="Emit", color=(1.0, 1.0, 1.0), strength=1.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    _clear(nt)
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = tuple(color) + (1.0,)
    em.inputs["Strength"].default_value = strength
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(em.outputs[0], out.inputs["Surface"])
    return mat


def diffuse_material(name="Diffuse", color=(0.8, 0.8, 0.8)):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    _clear(nt)
    bs = nt.nodes.new("ShaderNodeBsdfDiffuse")
    bs.inputs["Color"].default_value = tuple(color) + (1.0,)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(bs.outputs[0], out.inputs["Surface"])
    return mat


def add_slot(obj, mat):
    obj.data.materials.append(mat)
    return len(obj.data.materials) - 1


# --------------------------------------------------------------------------- particle hair

def add_particle_hair(obj, count=40, length=0.3, render_step=3, display_step=2, child_type="NONE",
                      children_render=3, children_display=2, radius_scale=0.02, root=1.0, tip=0.25,
                      shape=0.0, close_tip=True, material_slot=1, seed=0, kink=None, name="Hair"):
    """Adds a hair particle system to a mesh object; returns the ParticleSystem."""
    mod = obj.modifiers.new(name, "PARTICLE_SYSTEM")
    psys = mod.particle_system
    psys.seed = seed
    st = psys.settings
    st.type = "HAIR"
    st.count = count
    st.hair_length = length
    st.render_step = render_step
    st.display_step = display_step
    st.child_type = child_type
    if hasattr(st, "child_nbr"):  # 3.x
        st.child_nbr = children_display
    else:  # 4.x
        st.child_percent = children_display
    st.rendered_child_count = children_render
    st.radius_scale = radius_scale
    st.root_radius = root
    st.tip_radius = tip
    st.shape = shape
    st.use_close_tip = close_tip
    st.material = material_slot
    if kink is not None:
        st.kink = kink
    return psys


# --------------------------------------------------------------------------- Curves via geometry nodes

def _geometry_group(name):
    return fg._new_geometry_node_group(name)


def curves_grid(name="Curves", nx=4, ny=3, size=1.0, n_points=6, length=0.5, radius=0.01,
                realize=True, remove_radius=False, material=None, location=(0.0, 0.0, 0.0),
                extra_grid=None):
    """A Curves object made by geometry nodes: a vertical Curve Line (n_points keys, radius
    `radius`) instanced on every vertex of an nx x ny grid of `size`, realized or left as
    instances.  extra_grid=(nx, ny, n_points, z_offset) joins a second grid with another
    key count (varying curve lengths in one object)."""
    curves = bpy.data.hair_curves.new(name)
    obj = link(bpy.data.objects.new(name, curves))
    obj.location = location
    ng = _geometry_group(name + "Nodes")
    N, L = ng.nodes, ng.links

    def grid_instances(gx, gy, npts, z0):
        grid = N.new("GeometryNodeMeshGrid")
        grid.inputs["Size X"].default_value = size
        grid.inputs["Size Y"].default_value = size
        grid.inputs["Vertices X"].default_value = gx
        grid.inputs["Vertices Y"].default_value = gy
        line = N.new("GeometryNodeCurvePrimitiveLine")
        line.mode = "POINTS"
        line.inputs["Start"].default_value = (0.0, 0.0, z0)
        line.inputs["End"].default_value = (0.0, 0.0, z0 + length)
        res = N.new("GeometryNodeResampleCurve")
        fg.set_node_mode(res, "mode", "COUNT")
        res.inputs["Count"].default_value = npts
        stype = N.new("GeometryNodeCurveSplineType")
        stype.spline_type = "CATMULL_ROM"
        rad = N.new("GeometryNodeSetCurveRadius")
        rad.inputs["Radius"].default_value = radius
        inst = N.new("GeometryNodeInstanceOnPoints")
        L.new(line.outputs["Curve"], res.inputs["Curve"])
        L.new(res.outputs["Curve"], stype.inputs["Curve"])
        L.new(stype.outputs["Curve"], rad.inputs["Curve"])
        L.new(grid.outputs["Mesh"], inst.inputs["Points"])
        L.new(rad.outputs["Curve"], inst.inputs["Instance"])
        return inst.outputs["Instances"]

    geo = grid_instances(nx, ny, n_points, 0.0)
    if extra_grid is not None:
        join = N.new("GeometryNodeJoinGeometry")
        L.new(geo, join.inputs[0])
        gx, gy, npts, z0 = extra_grid
        L.new(grid_instances(gx, gy, npts, z0), join.inputs[0])
        geo = join.outputs[0]
    if realize:
        real = N.new("GeometryNodeRealizeInstances")
        L.new(geo, real.inputs["Geometry"])
        geo = real.outputs["Geometry"]
        if remove_radius:
            rm = N.new("GeometryNodeRemoveAttribute")
            if hasattr(rm, "pattern_mode"):
                rm.pattern_mode = "EXACT"
            rm.inputs["Name"].default_value = "radius"
            L.new(geo, rm.inputs["Geometry"])
            geo = rm.outputs["Geometry"]
    setmat = N.new("GeometryNodeSetMaterial")
    setmat.name = "SetMaterial"
    if material is not None:
        setmat.inputs["Material"].default_value = material
    L.new(geo, setmat.inputs["Geometry"])
    out = N.new("NodeGroupOutput")
    L.new(setmat.outputs["Geometry"], out.inputs[0])
    mod = obj.modifiers.new("Grid", "NODES")
    mod.node_group = ng
    if material is not None:
        curves.materials.append(material)
    return obj


def apply_modifiers(obj):
    """Turn a geometry-nodes Curves object into plain Curves data (to edit points)."""
    bpy.context.view_layer.objects.active = obj
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    for mod in list(obj.modifiers):
        bpy.ops.object.modifier_apply(modifier=mod.name)
    return obj


def set_curve_positions(obj, positions):
    """foreach_set the object's Curves positions (flat float sequence)."""
    d = obj.data
    d.position_data.foreach_set("vector", positions)
    d.update_tag()


def curve_positions(obj):
    import numpy as np
    d = obj.data
    pos = np.empty(len(d.points) * 3, np.float32)
    d.position_data.foreach_get("vector", pos)
    return pos


def deg(x):
    return math.radians(x)


# --------------------------------------------------------------------------- showcase

def showcase_scene(width=240, height=160, spp=64, curve_shape="THICK", children=12):
    """The side-by-side scene (lab/engine_side_by_side.py, docs/engine.md): a grey
    ground plane; a patch of particle hair with interpolated children (melanin) and a
    Curves object made by geometry nodes (coloured, tilted); lit by a sun, a point light,
    a rectangular area light and a uniform world. Cycles' default integrator settings
    (bounces 12/4/4/12, Filter Glossy 1, light threshold 0.01) except: no denoising, no
    adaptive sampling, Clamp Indirect 0 (docs/engine.md: clamping is where the two
    estimators differ), opaque film, Standard view transform. Works in 3.4 and 4.x."""
    scene = reset(width=width, height=height, spp=spp, curve_shape=curve_shape, film_transparent=False)
    cy = scene.cycles
    cy.max_bounces, cy.diffuse_bounces, cy.glossy_bounces, cy.transmission_bounces = 12, 4, 4, 12
    cy.transparent_max_bounces = 8
    cy.blur_glossy = 1.0
    cy.light_sampling_threshold = 0.01
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    scene.render.film_transparent = False

    ground = make_plane(size=6.0, location=(0.0, 0.0, 0.0), name="Ground")
    add_slot(ground, diffuse_material("GroundGrey", (0.35, 0.35, 0.35)))

    patch = make_plane(size=1.2, location=(-0.75, 0.0, 0.001), name="Scalp")
    add_slot(patch, diffuse_material("ScalpSkin", (0.45, 0.3, 0.25)))
    hair = hair_material("BrownHair", parametrization="MELANIN", melanin=0.55, melanin_redness=0.6,
                         roughness=0.3, radial_roughness=0.3, coat=0.1, random_color=0.3)
    add_slot(patch, hair)
    psys = add_particle_hair(patch, count=220, length=0.55, render_step=3, display_step=2,
                             child_type="INTERPOLATED", children_render=children, children_display=children,
                             radius_scale=0.006, root=1.0, tip=0.3, close_tip=False, material_slot=2, seed=3)
    st = psys.settings
    st.use_hair_bspline = False
    if hasattr(st, "child_length"):
        st.child_length = 0.9
    st.clump_factor = 0.3
    st.roughness_2 = 0.05
    patch.rotation_euler = (0.0, 0.25, 0.0)

    blond = hair_material("BlondCurves", parametrization="COLOR", color=(0.55, 0.38, 0.2),
                          roughness=0.25, radial_roughness=0.4, coat=0.0)
    fur = curves_grid("Curves", nx=14, ny=10, size=0.9, n_points=8, length=0.7, radius=0.006,
                      material=blond, location=(0.75, 0.1, 0.0))
    fur.rotation_euler = (0.35, -0.3, 0.2)

    make_camera(location=(0.2, -3.4, 1.55), target=(0.0, 0.0, 0.35), lens=42.0)
    make_light("SUN", energy=2.5, location=(2.0, -1.0, 3.0), target=(0.0, 0.0, 0.0), name="Sun", angle=0.05)
    make_light("POINT", energy=120.0, location=(-1.8, -1.6, 1.4), name="Point", shadow_soft_size=0.15,
               color=(1.0, 0.85, 0.7))
    area = make_light("AREA", energy=80.0, location=(1.6, -1.8, 1.2), target=(0.3, 0.0, 0.3), name="Area",
                      shape="RECTANGLE", size=0.8, color=(0.7, 0.8, 1.0))
    area.data.size_y = 0.4
    world = bpy.data.worlds.new("SkyGrey")
    fg.set_world_color(world, (0.05, 0.06, 0.08))
    scene.world = world
    return scene
