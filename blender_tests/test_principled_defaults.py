"""The Principled Hair defaults of the Python API (hairbsdf.PRINCIPLED_HAIR_DEFAULTS, HUANG_DEFAULTS,
read from the C++ PrincipledHairInputs struct through the scene schema) are Blender 4.5's node
defaults: every input socket of a fresh node (the node carries the sockets of both models)."""

import numpy as np
import pytest

from hairbsdf.principled import HUANG_DEFAULTS, PRINCIPLED_HAIR_DEFAULTS

pytestmark = pytest.mark.blender

NODE_DEFAULTS = r'''
m = bpy.data.materials.new("Hair"); m.use_nodes = True
node = m.node_tree.nodes.new("ShaderNodeBsdfHairPrincipled")
out = {}
for socket in node.inputs:
    if hasattr(socket, "default_value"):
        v = socket.default_value
        out[socket.name.lower().replace(" ", "_")] = [float(x) for x in v][:3] if hasattr(v, "__len__") else float(v)
emit(out)
'''


def test_api_defaults_are_blender_45_node_defaults(run_blender):
    blender = run_blender("bpy", NODE_DEFAULTS).result
    blender.pop("weight", None)  # the closure weight socket, not a Principled Hair input
    assert set(blender) == set(HUANG_DEFAULTS), "the node's inputs are not HUANG_DEFAULTS' keys"
    assert set(PRINCIPLED_HAIR_DEFAULTS) < set(HUANG_DEFAULTS)
    wrong = {k: (v, blender[k]) for k, v in HUANG_DEFAULTS.items()
             if not np.allclose(np.atleast_1d(v), np.atleast_1d(blender[k]), rtol=1e-5, atol=1e-7)}
    wrong.update({k: (v, blender[k]) for k, v in PRINCIPLED_HAIR_DEFAULTS.items() if v != HUANG_DEFAULTS[k]})
    assert not wrong, f"API defaults that differ from Blender 4.5's node (ours, Blender): {wrong}"
