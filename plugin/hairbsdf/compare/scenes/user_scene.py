"""user_scene: what users' scenes reach and the other library scenes do not, in one picture.

* particle hair on an emitter that its parent scales non-uniformly and that is rotated inside that
  parent (a sheared world transform);
* a Curves object under a transform with a negative scale;
* a ground mesh whose Diffuse colour is an Image Texture read through the mesh's UVs (a checker the
  builder writes as a float EXR);
* a sun, a point, a spot and an area (disk) light;
* Clamp Direct and Clamp Indirect above 0;
* an HDRI world (the hdri_swatch sky, an Environment Texture the builder writes);
* an emissive quad under a negative scale (Emission shader on a mesh, light-sampled by Cycles from
  its front only in 4.x).
"""

import math
import os

import bpy

import catalog
import hdri_swatch
import scene_lib as lib

# The clamps are written once, in the catalog's deliberate_settings (the harness's tests read them there).
DELIBERATE = catalog.SCENES["user_scene"]["deliberate_settings"]
CLAMP_DIRECT = DELIBERATE["cycles.sample_clamp_direct"]
CLAMP_INDIRECT = DELIBERATE["cycles.sample_clamp_indirect"]
WORLD_STRENGTH = 0.4
CHECKER_SIZE = 16  # texels per side; 4 x 4 checks
HAIR_MATERIAL = dict(parametrization="MELANIN", melanin=0.35, melanin_redness=0.5, tint=(1.0, 1.0, 1.0),
                     roughness=0.3, radial_roughness=0.3, coat=0.0, ior=1.55, offset=0.0349066)
CURVES_MATERIAL = dict(parametrization="COLOR", color=(0.25, 0.12, 0.06), roughness=0.35, radial_roughness=0.3,
                       coat=0.0, ior=1.55, offset=0.0349066)
EMITTER_PARENT_SCALE = (2.0, 1.0, 0.7)
EMITTER_ROTATION = (0.35, 0.0, 0.6)  # radians, inside the scaled parent: the world transform is sheared
CURVES_SCALE = (-1.3, 1.0, 0.9)
GLOW_SCALE = (-1.0, 1.0, 1.0)


def checker_pixels():
    """(CHECKER_SIZE, CHECKER_SIZE, 4) linear RGBA: 4 x 4 checks of warm light and cool dark grey."""
    import numpy as np

    rows, cols = np.mgrid[0:CHECKER_SIZE, 0:CHECKER_SIZE]
    odd = ((rows // 4 + cols // 4) % 2)[..., None]
    rgb = np.where(odd == 1, np.array([0.7, 0.6, 0.45]), np.array([0.15, 0.2, 0.28]))
    out = np.ones((CHECKER_SIZE, CHECKER_SIZE, 4), np.float32)
    out[..., :3] = rgb
    return out


def write_exr(name, pixels, path):
    """Saves (H, W, 4) float pixels (row 0 at the top) as an EXR with Blender's image API."""
    h, w = pixels.shape[:2]
    img = bpy.data.images.new(name, w, h, float_buffer=True, alpha=True)
    img.pixels.foreach_set(pixels[::-1].ravel())  # Blender's rows start at the bottom
    img.filepath_raw = path
    img.file_format = "OPEN_EXR"
    img.save()
    bpy.data.images.remove(img)


def load_linear(path):
    image = bpy.data.images.load(path)
    image.colorspace_settings.name = hdri_swatch.linear_colorspace()  # 5.x reads its own EXRs as sRGB
    return image


def textured_ground(scene, image):
    """A 2 x 2 m quad at z = 0 with UVs 0..1 and a Diffuse BSDF coloured by the image on those UVs."""
    me = bpy.data.meshes.new("UserGround")
    me.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    uv = me.uv_layers.new(name="UVMap")
    for loop, (u, v) in zip(me.loops, [(0, 0), (1, 0), (1, 1), (0, 1)]):
        uv.data[loop.index].uv = (u, v)
    me.update()
    obj = bpy.data.objects.new("UserGround", me)
    scene.collection.objects.link(obj)
    mat, nt, out = lib._fresh_material("UserGroundChecker")
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Roughness"].default_value = 0.0
    tex = nt.nodes.new("ShaderNodeTexImage")  # Vector unlinked: the active UV map, as Cycles reads it
    tex.image = image
    tex.interpolation = "Closest"
    nt.links.new(tex.outputs["Color"], diffuse.inputs["Color"])
    nt.links.new(diffuse.outputs[0], out.inputs["Surface"])
    me.materials.append(mat)
    return obj


def emissive_quad(scene):
    """A 0.4 x 0.3 m quad behind the hair, facing the camera, mirrored (scale x -1: its world-space
    winding is reversed), with an Emission shader sampled from its front only (4.x's Emission
    Sampling; 3.x samples both sides)."""
    me = bpy.data.meshes.new("UserGlow")
    me.from_pydata([(-0.2, 0, -0.15), (0.2, 0, -0.15), (0.2, 0, 0.15), (-0.2, 0, 0.15)], [], [(0, 1, 2, 3)])
    me.update()
    obj = bpy.data.objects.new("UserGlow", me)
    obj.location = (0.05, 0.5, 0.7)
    obj.rotation_euler = (-0.3, 0.0, 0.2)
    obj.scale = GLOW_SCALE
    scene.collection.objects.link(obj)
    mat, nt, out = lib._fresh_material("UserGlowEmission")
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (1.0, 0.75, 0.45, 1.0)
    em.inputs["Strength"].default_value = 4.0
    nt.links.new(em.outputs[0], out.inputs["Surface"])
    if hasattr(mat.cycles, "emission_sampling"):
        mat.cycles.emission_sampling = "FRONT"
    me.materials.append(mat)
    return obj


def sheared_particle_hair(scene):
    """Particle hair on a small grid whose world transform is a shear (rotated inside a scaled parent)."""
    n = 4
    verts = [(-0.1 + 0.2 * i / (n - 1), -0.1 + 0.2 * j / (n - 1), 0.0) for j in range(n) for i in range(n)]
    faces = [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i) for j in range(n - 1)
             for i in range(n - 1)]
    me = bpy.data.meshes.new("UserEmitter")
    me.from_pydata(verts, [], faces)
    me.update()
    emitter = bpy.data.objects.new("UserEmitter", me)
    scene.collection.objects.link(emitter)
    parent = bpy.data.objects.new("UserEmitterParent", None)
    scene.collection.objects.link(parent)
    parent.location = (-0.45, 0.0, 0.05)
    parent.scale = EMITTER_PARENT_SCALE
    emitter.parent = parent
    emitter.rotation_euler = EMITTER_ROTATION
    emitter.data.materials.append(lib.diffuse_material("UserEmitterSkin", (0.3, 0.25, 0.2)))
    emitter.data.materials.append(lib.hair_material("UserParticleHair", HAIR_MATERIAL))
    lib.particle_hair(scene, emitter, "UserHair", count=200, length=0.22, seed=5, material_slot=2, radius=0.004,
                      tip_radius=0.001, render_step=3, random_factor=0.1)
    return emitter


def mirrored_curves(scene):
    """Wavy strands as a Curves object whose transform has a negative scale."""
    r = lib.rng(11)
    lines = []
    for k in range(40):
        root = (0.12 * (k % 8) / 7 - 0.06 + r.uniform(-0.01, 0.01), 0.1 * (k // 8) / 4 - 0.05, 0.0)
        lines.append(lib.wavy_strand(root, (0.3, 0.0, 1.0), 0.45, 8, r, wave=0.03, jitter=0.005))
    mat = lib.hair_material("UserCurvesHair", CURVES_MATERIAL)
    obj = lib.curves_from_polylines(scene, "UserCurves", lines, 0.006, mat)
    obj.location = (0.45, 0.05, 0.0)
    obj.scale = CURVES_SCALE
    return obj


def build(scene, cfg):
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        curve_shape="THICK", subdivisions=3, osl=cfg.get("osl", False),
                        bounces=dict(max_bounces=8, glossy_bounces=8, transmission_bounces=8))
    scene.cycles.sample_clamp_direct = CLAMP_DIRECT
    scene.cycles.sample_clamp_indirect = CLAMP_INDIRECT
    asset_dir = cfg.get("asset_dir") or bpy.app.tempdir
    sky_path = os.path.join(asset_dir, "user_scene_sky.exr")
    checker_path = os.path.join(asset_dir, "user_scene_checker.exr")
    hdri_swatch.write_sky(sky_path)
    write_exr("UserCheckerSource", checker_pixels(), checker_path)

    world = lib.set_world(scene, (0.0, 0.0, 0.0), WORLD_STRENGTH, name="UserWorld")
    nt = world.node_tree
    bg = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBackground")
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = load_linear(sky_path)
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])

    textured_ground(scene, load_linear(checker_path))
    emissive_quad(scene)
    sheared_particle_hair(scene)
    mirrored_curves(scene)

    lib.sun_light(scene, (-0.4, -0.6, 0.7), energy=1.5, angle_deg=5.0)
    lib.point_light(scene, (0.9, -0.7, 0.9), energy=25.0, radius=0.1)
    spot = lib._light(scene, "SPOT", "UserSpot", 60.0, (1.0, 0.95, 0.9), (-0.9, -0.9, 1.3), (-0.45, 0.0, 0.2))
    spot.data.spot_size = math.radians(40.0)
    spot.data.spot_blend = 0.3
    spot.data.shadow_soft_size = 0.05
    lib.area_light(scene, (0.2, -0.6, 1.6), (0.0, 0.0, 0.2), energy=20.0, size=0.5, shape="DISK")
    lib.perspective_camera(scene, (0.0, -2.3, 0.9), (0.0, 0.0, 0.3), lens=40.0)
    return dict(clamp_direct=CLAMP_DIRECT, clamp_indirect=CLAMP_INDIRECT, world_strength=WORLD_STRENGTH,
                emitter_parent_scale=EMITTER_PARENT_SCALE, emitter_rotation=EMITTER_ROTATION,
                curves_scale=CURVES_SCALE, lights=["SUN", "POINT", "SPOT", "AREA (disk)"],
                textures=["checker on the ground's UVs", "HDRI world"], emissive="mirrored quad, Emission strength 4, sampled from the front (4.x)",
                glow_scale=GLOW_SCALE)
