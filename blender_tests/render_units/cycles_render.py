"""Renders the calibration cases (unit_cases.py) with Cycles and writes an .npz: one
(H, W, 4) float32 image per case (row 0 at the top, like our renderer) plus the
render seconds of each case.

Run with the bpy 4.5 module:  .venv/bin/python cycles_render.py --out f.npz [--cases a,b] [--samples N]
"""

import argparse
import json
import os
import shutil
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Matrix  # noqa: E402

import unit_cases as C  # noqa: E402


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def settings(scene, c, samples, threads):
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = samples
    cy.time_limit = 0.0
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = 0
    cy.use_animated_seed = False
    b = c["bounces"]
    cy.max_bounces, cy.diffuse_bounces, cy.glossy_bounces, cy.transmission_bounces = b[0], b[1], b[2], b[3]
    cy.transparent_max_bounces = b[4]
    cy.volume_bounces = 0
    cy.min_light_bounces = 0
    cy.min_transparent_bounces = 0
    cy.light_sampling_threshold = c.get("light_threshold", 0.0)
    cy.sample_clamp_direct, cy.sample_clamp_indirect = c.get("clamp", (0.0, 0.0))
    cy.blur_glossy = c.get("filter_glossy", 0.0)
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.use_guiding = False
    cy.pixel_filter_type = "BLACKMAN_HARRIS"
    cy.filter_width = 1.5
    cy.film_exposure = 1.0
    scene.cycles_curves.shape = c["shape"]
    scene.cycles_curves.subdivisions = 2
    r = scene.render
    r.resolution_x, r.resolution_y = c.get("resolution", (C.WIDTH, C.HEIGHT))
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.threads_mode = "FIXED"
    r.threads = threads
    r.film_transparent = c.get("film_transparent", False)
    ims = r.image_settings
    ims.file_format = "OPEN_EXR"
    ims.color_mode = "RGBA"
    ims.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    world = bpy.data.worlds.new("W")
    world.use_nodes = False
    world.color = (c["world"],) * 3
    scene.world = world


def link(obj):
    bpy.context.scene.collection.objects.link(obj)
    return obj


def diffuse_material(color=None):
    m = bpy.data.materials.new("Plane")
    m.use_nodes = True
    nt = m.node_tree
    bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*(color or C.DIFFUSE["color"]), 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0
    out = nt.nodes["Material Output"]
    nt.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return m


def hair_material():
    m = bpy.data.materials.new("Hair")
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    h = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
    h.model = C.HAIR["model"]
    h.parametrization = C.HAIR["parametrization"]
    names = {"melanin": "Melanin", "melanin_redness": "Melanin Redness", "roughness": "Roughness",
             "radial_roughness": "Radial Roughness", "coat": "Coat", "ior": "IOR", "offset": "Offset",
             "random_roughness": "Random Roughness", "random_color": "Random Color"}
    for k, v in C.HAIR["inputs"].items():
        sock = next(s for s in h.inputs if s.name == names[k])
        sock.default_value = v
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(h.outputs[0], out.inputs["Surface"])
    return m


def build(c):
    if c.get("plane", True):
        v, t = C.plane()
        me = bpy.data.meshes.new("Plane")
        me.from_pydata([tuple(map(float, p)) for p in v], [], [tuple(map(int, f)) for f in t])
        me.materials.append(diffuse_material())
        link(bpy.data.objects.new("Plane", me))
    if c["hair"]:
        pts, off = C.hair_patch(**c.get("patch", {}))
        cv = bpy.data.hair_curves.new("Hair")
        cv.add_curves([int(off[i + 1] - off[i]) for i in range(len(off) - 1)])
        cv.set_types(type="CATMULL_ROM")
        cv.points.foreach_set("position", pts[:, :3].astype(np.float32).ravel())
        cv.points.foreach_set("radius", pts[:, 3].astype(np.float32).ravel())
        kind = c.get("hair_material", "hair")
        cv.materials.append(hair_material() if kind == "hair" else
                            diffuse_material((0.0, 0.0, 0.0) if kind == "black" else None))
        link(bpy.data.objects.new("Hair", cv))
    for i, l in enumerate(c["lights"]):
        ld = bpy.data.lights.new(f"L{i}", l["type"])
        ld.energy = l["energy"]
        ld.color = l.get("color", (1.0, 1.0, 1.0))
        ld.normalize = True
        ld.exposure = 0.0
        ld.use_shadow = True
        if l["type"] == "SUN":
            ld.angle = l.get("angle", 0.0)
        elif l["type"] in ("POINT", "SPOT"):
            ld.shadow_soft_size = l.get("radius", 0.0)
            ld.use_soft_falloff = l.get("soft_falloff", True)
            if l["type"] == "SPOT":
                ld.spot_size = l["spot_size"]
                ld.spot_blend = l["spot_blend"]
        else:
            ld.shape = l["shape"]
            ld.size = l["size_x"]
            if l["shape"] in ("RECTANGLE", "ELLIPSE"):
                ld.size_y = l["size_y"]
            ld.spread = l.get("spread", 3.141592653589793)
        ob = link(bpy.data.objects.new(f"L{i}", ld))
        m = l.get("matrix", C.matrix(loc=l.get("loc", (0, 0, 0))))
        ob.matrix_world = Matrix([list(map(float, row)) for row in m])
    cam = c["camera"]
    cd = bpy.data.cameras.new("Cam")
    cd.type = cam["type"]
    cd.sensor_fit = cam.get("sensor_fit", "AUTO")
    cd.shift_x = cam.get("shift_x", 0.0)
    cd.shift_y = cam.get("shift_y", 0.0)
    cd.sensor_width = 36.0
    cd.sensor_height = 24.0
    cd.lens = cam.get("lens", 50.0)
    cd.ortho_scale = cam.get("ortho_scale", 1.0)
    cd.clip_start = 0.01
    cd.clip_end = 100.0
    co = link(bpy.data.objects.new("Cam", cd))
    co.matrix_world = Matrix([list(map(float, row)) for row in cam["matrix"]])
    bpy.context.scene.camera = co


def read_exr(path):
    img = bpy.data.images.load(path, check_existing=False)
    try:
        w, h = img.size
        buf = np.empty(w * h * img.channels, np.float32)
        img.pixels.foreach_get(buf)
        return buf.reshape(h, w, img.channels)[::-1].copy()  # row 0 at the top
    finally:
        bpy.data.images.remove(img)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--cases", default="")
    ap.add_argument("--samples", type=int, default=0)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:])
    names = [n for n in args.cases.split(",") if n] or C.CASE_NAMES
    tmp = tempfile.mkdtemp(prefix="render_units_")
    images, seconds = {}, {}
    try:
        for name in names:
            c = C.case(name)
            scene = reset()
            settings(scene, c, args.samples or c["samples"], args.threads)
            build(c)
            scene.render.filepath = os.path.join(tmp, name + ".exr")
            t0 = time.time()
            bpy.ops.render.render(write_still=True)
            seconds[name] = time.time() - t0
            images[name] = read_exr(scene.render.filepath)
            print(f"[cycles] {name}: {seconds[name]:.2f} s, mean {images[name][..., :3].mean():.5f}", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    np.savez_compressed(args.out, meta=json.dumps({"version": bpy.app.version_string, "seconds": seconds}),
                        **{"img_" + k: v for k, v in images.items()})


if __name__ == "__main__":
    main()
