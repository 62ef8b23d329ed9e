"""hdri_swatch: the swatch's strands lit only by an environment texture (a synthetic 128 x 64
float EXR: a sky gradient, a darker ground and a soft warm sun blob), with Cycles' default
Light Paths settings: Filter Glossy 1, Clamp Indirect 10, Light Threshold 0.01 (Engine II,
issue 4: "an HDRI-lit scene with default Cycles settings")."""

import math
import os

import bpy

import scene_lib as lib
import swatch

WIDTH, HEIGHT = 128, 64
SUN_DIRECTION = (0.55, -0.65, 0.52)  # towards the blob, world space
SUN_PEAK = 5.0


def sky_pixels():
    """(HEIGHT, WIDTH, 4) float RGBA, row 0 = the top of the image (the zenith)."""
    import numpy as np

    rows, cols = np.mgrid[0:HEIGHT, 0:WIDTH]
    theta = math.pi * (rows + 0.5) / HEIGHT                  # 0 at the zenith
    phi = math.pi - 2 * math.pi * (cols + 0.5) / WIDTH        # Cycles' atan2(y, x) of the column
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    up = np.clip(d[..., 2], 0, 1)[..., None]
    sky = (1 - up) * np.array([0.9, 0.85, 0.8]) + up * np.array([0.25, 0.4, 0.8])
    ground = np.array([0.12, 0.1, 0.08])
    rgb = np.where(d[..., 2:3] >= 0, sky, ground)
    s = np.array(SUN_DIRECTION) / np.linalg.norm(SUN_DIRECTION)
    blob = np.exp((d @ s - 1.0) / 0.01)[..., None]            # about 8 degrees wide
    rgb = rgb + SUN_PEAK * blob * np.array([1.0, 0.9, 0.75])
    out = np.ones((HEIGHT, WIDTH, 4), np.float32)
    out[..., :3] = rgb
    return out


def linear_colorspace():
    """The scene-linear Rec.709 colour space's name: 'Linear' in 3.4, 'Linear Rec.709' from 4.0."""
    names = {i.identifier for i in
             bpy.types.ColorManagedInputColorspaceSettings.bl_rna.properties["name"].enum_items}
    return "Linear Rec.709" if "Linear Rec.709" in names else "Linear"


def write_sky(path):
    """Writes the sky as a float EXR with Blender's image API (works in 3.4 and 4.5)."""
    img = bpy.data.images.new("HdriSkySource", WIDTH, HEIGHT, float_buffer=True, alpha=True)
    img.pixels.foreach_set(sky_pixels()[::-1].ravel())  # Blender's rows start at the bottom
    img.filepath_raw = path
    img.file_format = "OPEN_EXR"
    img.save()
    bpy.data.images.remove(img)


def build(scene, cfg):
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        curve_shape="THICK", subdivisions=3, osl=cfg.get("osl", False))
    cy = scene.cycles  # Cycles' defaults, on purpose (the report lists them as parity warnings)
    cy.blur_glossy = 1.0
    cy.sample_clamp_indirect = 10.0
    cy.light_sampling_threshold = 0.01
    path = os.path.join(cfg.get("asset_dir") or bpy.app.tempdir, "hdri_swatch_sky.exr")
    write_sky(path)
    world = lib.set_world(scene, (0.0, 0.0, 0.0), 1.0, name="HdriWorld")
    nt = world.node_tree
    bg = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBackground")
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(path)
    # Blender 5.x tags the EXR it saved as sRGB display-referred (colorInteropID) and reads it back
    # as sRGB; 3.4 and 4.5 read it as linear. The sky is linear in every Blender (docs/blender5.md).
    tex.image.colorspace_settings.name = linear_colorspace()
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    lines, radii = swatch.strands()
    mat = lib.hair_material("HdriHair", swatch.MATERIAL)
    lib.curves_from_polylines(scene, "HdriSwatch", lines, radii, mat)
    lib.perspective_camera(scene, (0.0, -2.2, 0.05), (0.0, 0.0, 0.0), lens=50.0)
    return dict(strands=len(lines), material=swatch.MATERIAL, sky=dict(size=[WIDTH, HEIGHT], sun=SUN_DIRECTION,
                                                                        sun_peak=SUN_PEAK),
                settings="Cycles defaults: Filter Glossy 1, Clamp Indirect 10, Light Threshold 0.01")
