"""Hair lit only by an emissive mesh quad, Cycles against the HAIRBSDF engine, with Clamp
Direct/Indirect off and at 1 (the emissive-mesh row of docs/engine.md). Cycles light-samples
emissive meshes; an engine that reaches them by BSDF rays only has rare, large contributions:
the same mean without clamping, far more noise, and a clamp cuts much more (0.056 of Cycles'
mean at clamp 1 before the engine light-sampled them too; about 1.0 since).

  .venv/bin/python lab/emissive_mesh_clamp.py [--spp 128] [--seeds 4]

Prints, per clamp, each engine's image mean over the hair pixels (mean of the seeds' means and
its standard error), the ratio and z. 64 x 48 px, 2 threads, bpy."""
import argparse
import math
import os
import sys

import bpy
import numpy as np

import hairbsdf.compare

sys.path.insert(0, os.path.join(os.path.dirname(hairbsdf.compare.__file__), "scenes"))
import scene_lib as lib  # noqa: E402  (the harness's scene helpers)


def emission_material(strength):
    mat, nt, out = lib._fresh_material("Lamp")
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = (1.0, 0.9, 0.8, 1.0)
    e.inputs["Strength"].default_value = strength
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    return mat


def build(spp):
    scene = lib.reset_scene()
    lib.parity_settings(scene, width=64, height=48, spp=spp, threads=2, bounces=dict(max_bounces=2), film_transparent=True)
    lib.set_world(scene)  # black
    hair = lib.hair_material("Hair", {"parametrization": "MELANIN", "melanin": 0.2, "roughness": 0.3})
    strands = [[(x, y, 0.15 * k) for k in range(5)] for y in (-0.2, 0.2) for x in np.linspace(-0.4, 0.4, 6)]
    lib.curves_from_polylines(scene, "Hair", strands, 0.02, hair)
    # a 0.5 quad above and in front of the hair, facing it, outside the camera's view
    bpy.ops.mesh.primitive_plane_add(size=0.5, location=(0.0, -1.0, 1.5), rotation=(3.83, 0.0, 0.0))
    bpy.context.active_object.data.materials.append(emission_material(30.0))
    lib.perspective_camera(scene, (0.0, -3.0, 0.3), (0.0, 0.0, 0.3))
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
