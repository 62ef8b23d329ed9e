"""The Principled Hair defaults of the Python API (hairbsdf.PRINCIPLED_HAIR_DEFAULTS, HUANG_DEFAULTS,
read from the C++ PrincipledHairInputs struct through the scene schema) are Blender 4.5's node
defaults: every input socket of a fresh node (the node carries the sockets of both models); so are
the legacy Hair BSDF's (its table, params/cycles_hair.h). One Blender run reads both nodes."""

import numpy as np
import pytest
from blender_env import require, run_snippet

from hairbsdf.principled import HUANG_DEFAULTS, PRINCIPLED_HAIR_DEFAULTS
from hairbsdf.zoo import CYCLES_HAIR_DEFAULTS

pytestmark = pytest.mark.blender

NODE_DEFAULTS = r'''
def sockets(node, key):
    out = {}
    for socket in node.inputs:
        if hasattr(socket, "default_value") and socket.identifier != "Weight":
            v = socket.default_value
            out[key(socket)] = [float(x) for x in v][:3] if hasattr(v, "__len__") else float(v)
    return out

m = bpy.data.materials.new("Hair"); m.use_nodes = True
principled = m.node_tree.nodes.new("ShaderNodeBsdfHairPrincipled")
hair = m.node_tree.nodes.new("ShaderNodeBsdfHair")
emit({"principled": sockets(principled, lambda s: s.name.lower().replace(" ", "_")),
      "hair": dict(sockets(hair, lambda s: s.identifier), component=hair.component.lower())})
'''


@pytest.fixture(scope="module")
def node_defaults(tmp_path_factory):
    require("bpy")
    return run_snippet("bpy", NODE_DEFAULTS, tmp_path_factory.mktemp("node_defaults")).result


def test_api_defaults_are_blender_45_node_defaults(node_defaults):
    blender = node_defaults["principled"]
    assert set(blender) == set(HUANG_DEFAULTS), "the node's inputs are not HUANG_DEFAULTS' keys"
    assert set(PRINCIPLED_HAIR_DEFAULTS) < set(HUANG_DEFAULTS)
    wrong = {k: (v, blender[k]) for k, v in HUANG_DEFAULTS.items()
             if not np.allclose(np.atleast_1d(v), np.atleast_1d(blender[k]), rtol=1e-5, atol=1e-7)}
    wrong.update({k: (v, blender[k]) for k, v in PRINCIPLED_HAIR_DEFAULTS.items() if v != HUANG_DEFAULTS[k]})
    assert not wrong, f"API defaults that differ from Blender 4.5's node (ours, Blender): {wrong}"


def test_cycles_hair_defaults_are_blender_45_node_defaults(node_defaults):
    """The legacy Hair BSDF's table (hairbsdf.zoo.CYCLES_HAIR_DEFAULTS: cycles_hair_bsdf's keywords, the
    exporter's fallbacks) against a fresh node's component and sockets."""
    blender = node_defaults["hair"]
    sockets = {"component": "component", "color": "Color", "offset": "Offset", "roughness_u": "RoughnessU",
               "roughness_v": "RoughnessV"}
    assert set(CYCLES_HAIR_DEFAULTS) == set(sockets) and set(sockets.values()) <= set(blender)  # and Tangent
    wrong = {k: (v, blender[sockets[k]]) for k, v in CYCLES_HAIR_DEFAULTS.items()
             if (v != blender[sockets[k]] if isinstance(v, str)
                 else not np.allclose(np.atleast_1d(v), np.atleast_1d(blender[sockets[k]]), rtol=1e-5, atol=1e-7))}
    assert not wrong, f"legacy Hair BSDF defaults that differ from Blender 4.5's node (ours, Blender): {wrong}"
