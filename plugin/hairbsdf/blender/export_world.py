"""World export: a uniform background colour (Background/Emission colour x strength, Mix
and Add Shader folded); textures and other nodes are reported and their socket values
used."""

from __future__ import annotations

from ._common import find_socket, rgb
from .export_materials import MaterialTranslator


def export_world(scene, report) -> dict:
    world = scene.world
    if world is None:
        return {"color": (0.0, 0.0, 0.0)}
    if not getattr(world, "use_nodes", False) or world.node_tree is None:
        return {"color": rgb(world.color)}
    nt = world.node_tree
    try:
        out = nt.get_output_node("CYCLES")
    except Exception:  # pragma: no cover
        out = None
    if out is None:
        return {"color": (0.0, 0.0, 0.0)}
    tr = MaterialTranslator(report)
    tr.material_name = world.name
    tr.warn = lambda msg: report.warn(f"World '{world.name}': {msg}")
    vol = find_socket(out.inputs, "Volume")
    if vol is not None and tr._link_source(vol) is not None:
        tr.warn("the Volume output is not supported and is ignored")
    src = tr._link_source(find_socket(out.inputs, "Surface"))
    color = [0.0, 0.0, 0.0]

    def walk(node, weight, depth=0):
        if depth > 32:
            return
        t = node.bl_idname
        if t in ("ShaderNodeBackground", "ShaderNodeEmission"):
            c = tr.value(node, "Color", "color", (0.05, 0.05, 0.05))
            s = tr.value(node, "Strength", "float", 1.0)
            for k in range(3):
                color[k] += weight[k] * c[k] * s
        elif t == "ShaderNodeMixShader":
            f = min(max(tr.value(node, "Fac", "float", 0.5), 0.0), 1.0)
            shaders = [s for s in node.inputs if s.type == "SHADER"]
            for sock, w in zip(shaders, (1.0 - f, f)):
                s2 = tr._link_source(sock)
                if s2 is not None and w > 0:
                    walk(s2[0], tuple(x * w for x in weight), depth + 1)
        elif t == "ShaderNodeAddShader":
            for sock in (s for s in node.inputs if s.type == "SHADER"):
                s2 = tr._link_source(sock)
                if s2 is not None:
                    walk(s2[0], weight, depth + 1)
        else:
            tr.warn(f"node '{node.name}' ({getattr(node, 'bl_label', t)}) is not supported as a world shader; ignored")

    if src is not None:
        walk(src[0], (1.0, 1.0, 1.0))
    return {"color": tuple(float(c) for c in color)}
