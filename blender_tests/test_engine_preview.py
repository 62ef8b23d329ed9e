"""Material previews (bl_use_preview): Blender renders the Properties editor's material
thumbnail with the HAIRBSDF engine when it is the scene's engine. Background Blender has no
event loop to copy the result into the icon, so the test checks the engine's own record of
the preview render: it ran on Blender's hair preview scene (particle hair), capped at
engine.PREVIEW_SAMPLES samples, and produced a non-black image without errors."""

import pytest

from blender_env import need_renderer

pytestmark = pytest.mark.blender

PREVIEW = r'''
import time
hb = register_engine()
from hairbsdf.blender import engine
scene = bpy.context.scene
scene.render.engine = "HAIRBSDF"
mat = bpy.data.materials.new("PreviewHair")
mat.use_nodes = True
nt = mat.node_tree
for n in list(nt.nodes):
    nt.nodes.remove(n)
out = nt.nodes.new("ShaderNodeOutputMaterial")
hair = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
nt.links.new(hair.outputs[0], out.inputs[0])
mat.preview_render_type = "HAIR"
engine.LAST_RENDER.clear()
with bpy.context.temp_override(id=mat):
    bpy.ops.ed.lib_id_generate_preview()
t0 = time.time()
while time.time() - t0 < 120 and engine.LAST_RENDER.get("status") in (None, "started"):
    time.sleep(0.1)
info = dict(engine.LAST_RENDER)
emit({"status": info.get("status"), "preview": info.get("preview"), "errors": info.get("errors"),
      "counts": info.get("counts"), "samples": (info.get("stats") or {}).get("samples"),
      "image_mean": info.get("image_mean"), "limit": engine.PREVIEW_SAMPLES})
'''


def test_material_preview_renders_with_the_engine(run_blender, renderer_available):
    need_renderer("bpy", renderer_available)
    r = run_blender("bpy", PREVIEW).result
    assert r["status"] == "ok" and r["preview"] and not r["errors"], r
    assert r["counts"]["curves"] > 100, r["counts"]  # Blender's hair preview object
    assert r["samples"] == r["limit"]
    assert r["image_mean"] > 0.01, r
