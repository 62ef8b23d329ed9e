"""World export: a uniform background colour (Background/Emission colour x strength, Mix
and Add Shader folded) plus at most one equirectangular Environment Texture feeding a
Background / Emission Color (optionally through a Mapping node on Texture Coordinate >
Generated); other nodes are reported and their socket values used. Inputs computed by nodes
(a Math node on the Strength, a Mix Shader's Fac) become registers of the world's program,
which the scene loader runs once (docs/shading_vm.md); inputs that depend on the hit are
reported and their socket values used."""

from __future__ import annotations

import numpy as np

from ..render import schema_choices, schema_default
from ._common import find_socket, mapping_matrix, rgb
from .export_materials import MaterialTranslator
from .images import read_image_rgb
from .shading_network import AttributeTable, Value


def export_world(scene, report, images=None) -> dict:
    """The world of docs/scene_desc.md, walked by the materials' translator (MaterialTranslator.walk:
    one walk of muted nodes, Mix and Add Shader for both). It has its own attribute table (the
    world's inputs never read attributes per hit); `images` is the scene's image table
    (shading_network.ImageTable) that its program's Image Texture nodes index."""
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
    tr = MaterialTranslator(report, AttributeTable(images))
    tr.begin(f"World '{world.name}'")
    tr.per_hit_weights = False
    net = tr.network
    vol = find_socket(out.inputs, "Volume")
    if vol is not None and tr._link_source(vol) is not None:
        tr.warn("the Volume output is not supported and is ignored")
    src = tr._link_source(find_socket(out.inputs, "Surface"))
    color = [0.0, 0.0, 0.0]
    computed = []  # Values of the colour terms that nodes compute (summed by the program)
    texture = {}

    def background(node, weight):
        t = node.bl_idname
        if t in ("ShaderNodeBackground", "ShaderNodeEmission"):
            s = _value(net, tr.value(node, "Strength", "float", 1.0))
            linked = tr._link_source(find_socket(node.inputs, "Color"))
            if linked is not None and linked[0].bl_idname == "ShaderNodeTexEnvironment" and not linked[0].mute:
                tex_weight = tr.times(weight, s)
                constant = net.constant_of(tex_weight)
                if texture:
                    tr.warn(f"only one Environment Texture is supported; '{linked[0].name}' is ignored")
                elif constant is None or any(w != 0 for w in constant):
                    texture.update(_environment_texture(tr, linked[0], linked[1], tex_weight))
                return
            c = _value(net, tr.value(node, "Color", "color", (0.05, 0.05, 0.05)))
            term = tr.times(tr.times(weight, c), s)
            constant = net.constant_of(term)
            if constant is None:
                computed.append(term)
                return
            for k in range(3):
                color[k] += constant[k]
        else:
            tr.warn(f"node '{node.name}' ({getattr(node, 'bl_label', t)}) is not supported as a world shader; ignored")

    if src is not None:
        tr.walk(src[0], src[1], net.constant((1.0, 1.0, 1.0)), background)
    result = {"color": tuple(float(c) for c in color), "mis": world_mis(world),
              "map_resolution": world_map_resolution(world)}
    pending = []
    if computed:
        total = net.constant(result["color"])
        for term in computed:
            total = net.add(total, term)
        pending.append((result, "color", total, "color"))
    if texture.get("pixels") is not None:
        result["texture"] = texture
        pending.append((texture, "weight", texture["weight"], "color"))
    program = net.finish(pending) if pending else None
    if program is not None:
        result["program"] = program
    return result


def _value(net, v):
    """A strength or colour as a Value of the world's network."""
    if isinstance(v, Value):
        return v
    return net.constant(v if isinstance(v, tuple) else (v,))


def world_mis(world) -> bool:
    """World > Settings > Sampling: Method (4.x, off for None) or Multiple Importance (3.x).
    The renderer samples the world as a light only when it also has a texture, as Cycles
    enables its background light only for a spatially varying world (render/lights.h)."""
    cw = world.cycles  # the Cycles add-on's world settings (export requires the add-on)
    if hasattr(cw, "sampling_method"):
        return cw.sampling_method != "NONE"
    return bool(getattr(cw, "sample_as_light", True))


def world_map_resolution(world) -> int:
    """World > Settings > Map Resolution when Sampling is Manual; 0 (Automatic) lets the renderer take
    the environment texture's size, as Cycles does for its importance map (render/lights.cpp)."""
    cw = world.cycles
    if getattr(cw, "sampling_method", "AUTOMATIC") == "MANUAL":
        return int(getattr(cw, "sample_map_resolution", 0))
    return 0


def _environment_texture(tr, node, output, weight) -> dict:
    """The scene_desc texture entry of an Environment Texture node, {} when unusable (warned)."""
    if output.identifier != "Color":
        tr.warn(f"'{node.name}' > {output.name} is not supported (only Color); ignored")
        return {}
    if node.projection != "EQUIRECTANGULAR":
        tr.warn(f"'{node.name}': projection {node.projection} is not supported (only Equirectangular); ignored")
        return {}
    if node.image is None:
        # Cycles shows its missing-texture colour (magenta); say so rather than guess.
        tr.warn(f"'{node.name}' has no image; Cycles renders its missing-texture colour, hairbsdf black")
        return {}
    interpolation = str(node.interpolation).upper()  # Blender's "Closest", "Linear", ...
    if interpolation not in schema_choices("world.texture.interpolation"):
        fallback = schema_default("world.texture.interpolation")
        tr.warn(f"'{node.name}': interpolation {node.interpolation} is not supported; using {fallback.title()}")
        interpolation = fallback
    matrix = _lookup_matrix(tr, node)
    pixels, srgb_encoded = read_image_rgb(node.image, tr.warn)
    if pixels is None or matrix is None:
        return {}
    return {"pixels": pixels, "weight": weight, "interpolation": interpolation,
            "srgb_encoded": srgb_encoded, "matrix": matrix}


def _lookup_matrix(tr, node):
    """The Vector input: unlinked (the direction), or Mapping on Texture Coordinate > Generated."""
    src = tr._link_source(find_socket(node.inputs, "Vector"))
    if src is None:
        return np.eye(3, 4)
    mapping, _ = src
    if mapping.bl_idname == "ShaderNodeTexCoord" and src[1].identifier in ("Generated", "Object"):
        return np.eye(3, 4)
    if mapping.bl_idname != "ShaderNodeMapping":
        tr.warn(f"'{node.name}' > Vector from '{mapping.name}' is not supported (use none, or Mapping on "
                "Texture Coordinate > Generated); using the view direction")
        return np.eye(3, 4)
    inner = tr._link_source(find_socket(mapping.inputs, "Vector"))
    if inner is None or inner[0].bl_idname != "ShaderNodeTexCoord" or inner[1].identifier not in ("Generated",
                                                                                                  "Object"):
        tr.warn(f"Mapping '{mapping.name}' must take Texture Coordinate > Generated; ignoring the mapping")
        return np.eye(3, 4)
    values = {}
    for name in ("Location", "Rotation", "Scale"):
        sock = find_socket(mapping.inputs, name)
        if sock is None or not getattr(sock, "enabled", True):
            values[name] = (0.0, 0.0, 0.0) if name != "Scale" else (1.0, 1.0, 1.0)
            continue
        if tr._link_source(sock) is not None:
            tr.warn(f"Mapping '{mapping.name}' > {name} is linked; using its socket value")
        values[name] = tuple(float(v) for v in sock.default_value)
    return mapping_matrix(mapping.vector_type, values["Location"], values["Rotation"], values["Scale"])
