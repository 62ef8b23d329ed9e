"""Hair lit only by an emissive mesh quad, Cycles against the HAIRBSDF engine, with Clamp
Direct/Indirect off and at 1 (the emissive-mesh row of docs/engine.md). Cycles light-samples
emissive meshes; the engine reaches them by BSDF rays only, so its contributions are rare and
large: the same mean without clamping, far more noise, and a clamp cuts much more.

  .venv/bin/python lab/emissive_mesh_clamp.py [--spp 128] [--seeds 4]

Prints, per clamp, each engine's image mean over the hair pixels (mean of the seeds' means and
its standard error), the ratio and z. 64 x 48 px, 2 threads, bpy."""
import argparse
import math

import bpy
import numpy as np


def hair_curves(material):
    """Twelve vertical strands (radius 0.02, 5 keys) in two rows."""
    curves = bpy.data.hair_curves.new("Hair")
    obj = bpy.data.objects.new("Hair", curves)
    bpy.context.scene.collection.objects.link(obj)
    xs = np.linspace(-0.4, 0.4, 6)
    roots = [(x, y, 0.0) for y in (-0.2, 0.2) for x in xs]
    curves.add_curves([5] * len(roots))
    pos = np.array([(x, y, 0.6 * k / 4) for x, y, _ in roots for k in range(5)], np.float32)
    curves.position_data.foreach_set("vector", pos.ravel())
    radius = curves.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", np.full(len(pos), 0.02, np.float32))
    curves.materials.append(material)
    return obj


def hair_material():
    m = bpy.data.materials.new("Hair")
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    ph = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
    ph.parametrization = "MELANIN"
    ph.inputs["Melanin"].default_value = 0.2
    ph.inputs["Roughness"].default_value = 0.3
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(ph.outputs[0], out.inputs["Surface"])
    return m


def emission_material(strength):
    m = bpy.data.materials.new("Lamp")
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = (1.0, 0.9, 0.8, 1.0)
    e.inputs["Strength"].default_value = strength
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    return m


def build(spp):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = 64, 48, 100
    r.threads_mode, r.threads = "FIXED", 2
    r.image_settings.file_format = "OPEN_EXR"
    scene.view_settings.view_transform = "Standard"
    scene.cycles.samples = spp
    scene.cycles.max_bounces = 2
    scene.cycles.device = "CPU"
    scene.cycles_curves.shape = "THICK"
    r.film_transparent = True  # alpha marks the hair pixels
    world = bpy.data.worlds.new("W")
    world.use_nodes = False
    world.color = (0.0, 0.0, 0.0)
    scene.world = world
    hair_curves(hair_material())
    # a 0.5 quad above and in front of the hair, facing it, outside the camera's view
    bpy.ops.mesh.primitive_plane_add(size=0.5, location=(0.0, -1.0, 1.5), rotation=(3.83, 0.0, 0.0))
    bpy.context.active_object.data.materials.append(emission_material(30.0))
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location = (0.0, -3.0, 0.3)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.camera = cam
    return scene


def render(scene, engine, path):
    scene.render.engine = engine
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path, check_existing=False)
    px = np.array(img.pixels[:], np.float32).reshape(img.size[1], img.size[0], 4)
    bpy.data.images.remove(img)
    return px


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spp", type=int, default=128)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--out", default="/tmp/emissive_mesh_clamp")
    a = ap.parse_args()
    import os

    import hairbsdf.blender
    os.makedirs(a.out, exist_ok=True)
    for clamp in (0.0, 1.0):
        scene = build(a.spp)
        hairbsdf.blender.register()
        scene.cycles.sample_clamp_direct = scene.cycles.sample_clamp_indirect = clamp
        means = {}
        mask = None
        for seed in range(a.seeds):
            scene.cycles.seed = seed
            imgs = {e: render(scene, e, os.path.join(a.out, f"{e}_{clamp}_{seed}.exr")) for e in ("CYCLES", "HAIRBSDF")}
            if mask is None:
                mask = (imgs["CYCLES"][..., 3] > 0.5) & (imgs["HAIRBSDF"][..., 3] > 0.5)
            for e, px in imgs.items():
                means.setdefault(e, []).append(float(px[mask][:, :3].mean()))
        stats = {e: (np.mean(v), np.std(v, ddof=1) / math.sqrt(len(v))) for e, v in means.items()}
        (c, sc), (o, so) = stats["CYCLES"], stats["HAIRBSDF"]
        print(f"clamp {clamp:g}: Cycles {c:.6f} ± {sc:.1e}, HAIRBSDF {o:.6f} ± {so:.1e}, ratio {o / c:.3f}, "
              f"z {(o - c) / math.hypot(sc, so):.1f} ({int(mask.sum())} hair pixels, {a.seeds} seeds x {a.spp} spp)")
        hairbsdf.blender.unregister()


if __name__ == "__main__":
    main()
