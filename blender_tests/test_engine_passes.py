"""Render passes of the HAIRBSDF engine in Blender (plugin/hairbsdf/blender/passes.py), per
Blender: with Depth, Normal, Hair Lobes and Variance switched on in the view layer, the
compositor's Render Layers node offers every pass as an output, a multilayer EXR holds them, the
four lobe passes add up to Combined on the hair (a transparent film: nothing but hair emits
towards the camera), Depth is the camera distance on hair and 1e10 on the background, Normal is
unit length on hair, and Variance is non-negative and non-zero where there is noise."""

import os

import numpy as np
import pytest

from blender_env import ENGINE_KINDS, need_renderer, record

pytestmark = pytest.mark.blender

PASSES = r'''
import os
hb = register_engine()
from hairbsdf.blender import engine
scene = hs.reset(width=48, height=36, spp=8, curve_shape="THICK", film_transparent=True)
scene.hairbsdf.threads = 2
scene.render.engine = "HAIRBSDF"
mat = hs.hair_material("Hair", parametrization="MELANIN", melanin=0.25, roughness=0.3)
hs.curves_grid("Fur", nx=5, ny=3, size=0.8, n_points=6, length=0.8, radius=0.04, material=mat)
hs.make_camera(location=(0.0, -3.0, 0.5), target=(0.0, 0.0, 0.4))
hs.make_light("SUN", energy=3.0, location=(2, -2, 3))
scene.world = bpy.data.worlds.new("W"); scene.world.use_nodes = False; scene.world.color = (0.1, 0.1, 0.12)
layer = bpy.context.view_layer
layer.use_pass_z = True
layer.use_pass_normal = True
layer.hairbsdf.pass_hair_lobes = True
layer.hairbsdf.pass_variance = True
# The compositor's Render Layers node
scene.use_nodes = True
tree = scene.node_tree if hasattr(scene, "node_tree") and scene.node_tree is not None else None
if tree is None and hasattr(scene, "compositing_node_group"):  # Blender 5.x: a node group
    tree = scene.compositing_node_group or bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
    scene.compositing_node_group = tree
sockets = []
if tree is not None:
    node = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers"), None)
    if node is None:
        node = tree.nodes.new("CompositorNodeRLayers")
    node.scene = scene
    node.layer = layer.name
    sockets = [s.name for s in node.outputs if s.enabled]
ims = scene.render.image_settings
if hasattr(ims, "media_type"):  # Blender 5.x: multilayer EXR is a media type of its own
    ims.media_type = "MULTI_LAYER_IMAGE"
ims.file_format = "OPEN_EXR_MULTILAYER"
ims.color_depth = "32"
scene.render.filepath = os.path.join(TMP, "passes.exr")
bpy.ops.render.render(write_still=True)
emit({"version": bpy.app.version_string, "sockets": sockets, "exr": scene.render.filepath,
      "status": engine.LAST_RENDER.get("status"), "warnings": engine.LAST_RENDER.get("warnings", []),
      "layer": layer.name})
'''


def _read_layers(path):
    import OpenImageIO as oiio

    # one part with every channel (Blender 3.4, 4.5), or one part per pass (Blender 5.x)
    channels = {}
    for part in range(oiio.ImageBuf(path).nsubimages):
        buf = oiio.ImageBuf(path, part, 0)
        assert not buf.has_error, buf.geterror()
        pixels = np.asarray(buf.get_pixels(oiio.FLOAT))
        channels.update({n: pixels[..., i] for i, n in enumerate(buf.spec().channelnames)})
    return channels


def test_passes_reach_the_compositor_and_the_exr(run_blender, engine_kind, renderer_available):
    need_renderer(engine_kind, renderer_available)
    r = run_blender(engine_kind, PASSES).result
    record(f"engine_passes_{ENGINE_KINDS[engine_kind]}", {k: v for k, v in r.items() if k != "exr"})
    assert r["status"] == "ok", r
    wanted = ["Hair R", "Hair TT", "Hair TRT", "Hair TRRT", "Hair TTs", "Hair TRTs", "Variance", "Depth", "Normal"]
    missing = [w for w in wanted if w not in r["sockets"]]
    assert not missing, (missing, r["sockets"])
    ch = _read_layers(r["exr"])
    layer = r["layer"]

    def rgb(name):
        return np.stack([ch[f"{layer}.{name}.{c}"] for c in "RGB"], -1)

    combined = np.stack([ch[f"{layer}.Combined.{c}"] for c in "RGBA"], -1)
    hair = combined[..., 3] > 0.999
    assert hair.sum() > 100
    lobes = sum(rgb(n) for n in ("Hair R", "Hair TT", "Hair TRT", "Hair TRRT", "Hair TTs", "Hair TRTs"))
    assert np.all(rgb("Hair TTs") == 0) and np.all(rgb("Hair TRTs") == 0)  # Principled Hair has no medulla
    np.testing.assert_allclose(lobes, combined[..., :3], rtol=1e-4, atol=1e-6)
    assert rgb("Hair TRT")[hair].sum() > 0 and rgb("Hair R")[hair].sum() > 0
    depth = ch[f"{layer}.Depth.Z"] if f"{layer}.Depth.Z" in ch else ch[f"{layer}.Depth.V"]
    assert np.all((depth[hair] > 2.0) & (depth[hair] < 4.0)), depth[hair].min()
    assert np.all(depth[combined[..., 3] == 0] == 1e10)
    normal = np.stack([ch[f"{layer}.Normal.{c}"] for c in "XYZ"], -1)
    # averaged over 8 samples of a curved surface: slightly shorter than 1
    assert np.all(np.abs(np.linalg.norm(normal[hair], axis=-1) - 1) < 0.2)
    variance = rgb("Variance")
    assert np.all(variance >= 0) and variance[hair].max() > 0
