"""The world's Environment Texture through the whole engine path, per Blender, per pixel: a
camera looking into an empty scene sees only the world, so at 1 sample per pixel (the pixel
centre in both renderers) every pixel is one texture lookup. Cycles and HAIRBSDF render the same
scene in one process; they must agree per pixel (median relative error <= 1e-4, p99 <= 2e-3, the
fibre goniometer's limits). Cases: Linear and Closest interpolation, a Mapping node (rotation,
scale, location; Point and Texture types) on Texture Coordinate > Generated, views of the horizon,
the u = 0 seam with the zenith, and the nadir, and a Mix Shader that weights the texture and adds a uniform colour;
the same Mix Shader muted (Blender's internal link passes its first shader input) and with its uniform
Background muted (a muted Background has no shader input to pass, so that input is empty).
The texture is a 32 x 16 float EXR with gradients and a checker, written by the test."""

import numpy as np
import pytest

from blender_env import ENGINE_KINDS, need_renderer, record

pytestmark = pytest.mark.blender

WORLD = r'''
import os
hb = register_engine()
from hairbsdf.blender import engine
scene = hs.reset(width=48, height=36, spp=1, film_transparent=False)
scene.cycles.max_bounces = 0
scene.cycles.filter_width = 0.01
scene.hairbsdf.threads = 2
W, H = 32, 16
img = bpy.data.images.new("EnvSource", W, H, float_buffer=True, alpha=False)
rows, cols = np.mgrid[0:H, 0:W]
px = np.zeros((H, W, 4), np.float32)
px[..., 0] = 0.2 + cols / W
px[..., 1] = 0.1 + 1.5 * rows / H
px[..., 2] = np.where((rows // 2 + cols // 2) % 2 == 0, 0.5, 1.5)
px[..., 3] = 1.0
img.pixels.foreach_set(px.ravel())
path = os.path.join(TMP, "env.exr")
img.filepath_raw = path
img.file_format = "OPEN_EXR"
img.save()
env_image = bpy.data.images.load(path)

world = bpy.data.worlds.new("EnvWorld")
world.use_nodes = True
scene.world = world
nt = world.node_tree
for n in list(nt.nodes):
    nt.nodes.remove(n)
out_node = nt.nodes.new("ShaderNodeOutputWorld")
bg = nt.nodes.new("ShaderNodeBackground")
bg.inputs["Strength"].default_value = 1.3
tex = nt.nodes.new("ShaderNodeTexEnvironment")
tex.image = env_image
nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
nt.links.new(bg.outputs[0], out_node.inputs["Surface"])
coord = nt.nodes.new("ShaderNodeTexCoord")
mapping = nt.nodes.new("ShaderNodeMapping")
const_bg = nt.nodes.new("ShaderNodeBackground")
const_bg.inputs["Color"].default_value = (0.3, 0.2, 0.1, 1.0)
mix = nt.nodes.new("ShaderNodeMixShader")
mix.inputs["Fac"].default_value = 0.25

cam = hs.make_camera(location=(0.0, 0.0, 0.0), target=(1.0, 0.0, 0.0), lens=10.0)
VIEWS = {"horizon": (1.0, 0.3, 0.1), "seam_zenith": (-1.0, 0.2, 1.6), "nadir": (0.4, -1.0, -1.8)}

def set_case(case):
    tex.interpolation = "Closest" if case == "closest" else "Linear"
    for link in list(nt.links):
        if link.to_node in (tex, out_node):
            nt.links.remove(link)
    nt.links.new(bg.outputs[0], out_node.inputs["Surface"])
    if case in ("mapping_point", "mapping_texture"):
        mapping.vector_type = "POINT" if case == "mapping_point" else "TEXTURE"
        mapping.inputs["Location"].default_value = (0.1, -0.2, 0.05)
        mapping.inputs["Rotation"].default_value = (0.3, -0.2, 1.1)
        mapping.inputs["Scale"].default_value = (1.0, 1.4, 0.8)
        nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    mix.mute = case == "mix_muted"
    const_bg.mute = case == "mix_background_muted"
    if case.startswith("mix"):
        for link in list(nt.links):
            if link.to_node == out_node:
                nt.links.remove(link)
        nt.links.new(bg.outputs[0], mix.inputs[1])
        nt.links.new(const_bg.outputs[0], mix.inputs[2])
        nt.links.new(mix.outputs[0], out_node.inputs["Surface"])

out = {}
for case in ARGS["cases"]:
    set_case(case)
    # every view for Linear, the seam and zenith view for the others (CI time)
    for view, target in VIEWS.items() if case == "linear" else [("seam_zenith", VIEWS["seam_zenith"])]:
        hs.look_at(cam, (0.0, 0.0, 0.0), target)
        r = {eng: px[..., :3] for eng, px in render_engines(scene, f"{case}_{view}_").items()}
        assert engine.LAST_RENDER.get("status") == "ok", engine.LAST_RENDER
        cy, ours = r["CYCLES"].reshape(-1, 3), r["HAIRBSDF"].reshape(-1, 3)
        rel = np.abs(ours - cy) / np.maximum(np.abs(cy), 1e-3)
        out[f"{case}/{view}"] = {"median": float(np.median(rel)), "p99": float(np.percentile(rel, 99)),
                                 "max": float(rel.max()), "cycles_mean": float(cy.mean()),
                                 "ours_mean": float(ours.mean()),
                                 # the scene has no geometry on purpose
                                 "warnings": [w for w in engine.LAST_RENDER.get("warnings", [])
                                              if "no hair" not in w and "no geometry" not in w]}
emit({"version": bpy.app.version_string, "cases": out})
'''

CASES = ["linear", "closest", "mapping_point", "mapping_texture", "mix", "mix_muted", "mix_background_muted"]


def test_environment_texture_matches_cycles_per_pixel(run_blender, engine_kind, renderer_available):
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, WORLD, args={"cases": CASES}).result
    record(f"engine_world_texture_{ENGINE_KINDS[engine_kind]}", r)
    lines, bad = [], []
    for name, m in r["cases"].items():
        lines.append(f"{name:28s} median {m['median']:.1e} p99 {m['p99']:.1e} max {m['max']:.1e} "
                     f"mean Cycles {m['cycles_mean']:.5f} ours {m['ours_mean']:.5f}")
        if not (m["median"] <= 1e-4 and m["p99"] <= 2e-3) or m["warnings"]:
            bad.append(name)
    print("\n" + "\n".join(lines))
    assert not bad, f"{r['version']}: per-pixel mismatch or warnings in {bad}\n" + "\n".join(lines) + \
        "\n" + str({k: r["cases"][k]["warnings"] for k in bad})
