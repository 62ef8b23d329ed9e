"""Round trip of an exported portable scene (docs/portable_scenes.md) through Blender, run by
test_portable.py in bpy 4.5:

    .venv/bin/python portable_reimport_job.py job.json

job.json: {folder, out, seeds, first_seed, result}.  Starts from an empty file, imports the folder's
scene.usda with Blender's USD importer, re-binds every material from our scene description (USD
carries only preview surfaces), sets the world and the Blender render settings of
render_settings.json, and renders `seeds` Cycles images (seeds first_seed...) into out.  Writes
`result` (JSON) last.
"""

import json
import os
import re
import sys
import traceback

import bpy

HAIR_SOCKETS = {"color": "Color", "melanin": "Melanin", "melanin_redness": "Melanin Redness", "tint": "Tint",
                "absorption_coefficient": "Absorption Coefficient", "roughness": "Roughness",
                "radial_roughness": "Radial Roughness", "coat": "Coat", "ior": "IOR", "offset": "Offset",
                "random_color": "Random Color", "random_roughness": "Random Roughness", "random": "Random",
                "aspect_ratio": "Aspect Ratio", "reflection": "Reflection", "transmission": "Transmission",
                "secondary_reflection": "Secondary Reflection"}
RANDOM_PRIMVAR = "hairbsdf_random"
SKIP_SETTINGS = {"cycles.device", "cycles.shading_system"}


def _socket(node, name):
    return next(s for s in node.inputs if s.name == name)


def material_from_description(m):
    """A Blender material equal to one of our description's materials (single closures only)."""
    closures = m.get("closures") or []
    if m.get("program") or len(closures) != 1 or tuple(closures[0].get("weight", (1, 1, 1))) != (1.0, 1.0, 1.0):
        raise ValueError("material %s: only single closures without node networks are re-bound" % m["name"])
    c = closures[0]
    mat = bpy.data.materials.new("rebound_" + m["name"])
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    if c["type"] == "principled_hair":
        node = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
        node.model = c.get("model", "CHIANG")
        node.parametrization = c.get("parametrization", "COLOR")
        for key, value in c.get("inputs", {}).items():
            if value is None or key not in HAIR_SOCKETS:
                continue  # random None: the per-curve hash, as the socket unlinked
            sock = _socket(node, HAIR_SOCKETS[key])
            sock.default_value = (tuple(value) + (1.0,))[:len(sock.default_value)] if hasattr(value, "__len__") \
                else float(value)
        if c.get("inputs", {}).get("random", 0.0) is None:  # Hair Info > Random: the exported primvar
            attr = nt.nodes.new("ShaderNodeAttribute")
            attr.attribute_type = "GEOMETRY"
            attr.attribute_name = RANDOM_PRIMVAR
            nt.links.new(attr.outputs["Fac"], _socket(node, "Random"))
    elif c["type"] == "diffuse":
        node = nt.nodes.new("ShaderNodeBsdfDiffuse")
        node.inputs["Color"].default_value = tuple(c.get("color", (0.8, 0.8, 0.8))) + (1.0,)
        node.inputs["Roughness"].default_value = 0.0
    elif c["type"] == "emission":
        node = nt.nodes.new("ShaderNodeEmission")
        node.inputs["Color"].default_value = tuple(c.get("color", (0.8, 0.8, 0.8))) + (1.0,)
        node.inputs["Strength"].default_value = float(c.get("strength", 1.0))
    else:
        raise ValueError("material %s: closure %s is not re-bound" % (m["name"], c["type"]))
    nt.links.new(node.outputs[0], out.inputs["Surface"])
    return mat


def set_path(scene, path, value):
    obj, parts = scene, path.split(".")
    for part in parts[:-1]:
        obj = getattr(obj, part)
    setattr(obj, parts[-1], value)


def main():
    with open(sys.argv[-1]) as f:
        job = json.load(f)
    result = dict(ok=False, blender=bpy.app.version_string, renders=[])
    try:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from hairbsdf.scene_file import load_scene
        folder = job["folder"]
        desc, _ = load_scene(os.path.join(folder, "hairbsdf_scene.npz"))
        with open(os.path.join(folder, "render_settings.json")) as f:
            settings = json.load(f)
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
        bpy.ops.wm.usd_import(filepath=os.path.join(folder, "scene.usda"), import_materials=True,
                              create_world_material=False, light_intensity_scale=1.0)
        scene.render.engine = "CYCLES"
        cams = [o for o in scene.objects if o.type == "CAMERA"]
        scene.camera = cams[0]
        for cam in cams:
            if cam.data.type == "ORTHO":  # Blender 4.5's importer reads the apertures (tenths of a unit) as units
                cam.data.ortho_scale /= 10.0
        # materials: ours, by the name the USD material carries
        rebound = {m["name"]: material_from_description(m) for m in desc["materials"] if m["name"] != "__default__"}
        bound = []
        for obj in scene.objects:
            for slot in getattr(obj, "material_slots", []):
                if slot.material is None:
                    continue
                base = re.sub(r"\.\d{3}$", "", slot.material.name)
                if base in rebound:
                    slot.material = rebound[base]
                    bound.append((obj.name, base))
        # Blender's USD importer drops the bindings of curves: the manifest names each hair prim's material
        with open(os.path.join(folder, "portable.json")) as f:
            hair_objects = json.load(f)["hair"]["objects"]
        for h in hair_objects:
            obj = scene.objects.get(h["object"])
            if obj is not None and obj.type == "CURVES" and not obj.data.materials and h["material"] in rebound:
                obj.data.materials.append(rebound[h["material"]])
                bound.append((obj.name, h["material"]))
        result["bound"] = bound
        result["random_attribute"] = sorted(o.name for o in scene.objects if o.type == "CURVES"
                                            and RANDOM_PRIMVAR in o.data.attributes)
        # world: the uniform colour of our description (USD has no Cycles background)
        world = bpy.data.worlds.new("rebound_world")
        scene.world = world
        world.use_nodes = True
        bg = world.node_tree.nodes["Background"]
        bg.inputs["Color"].default_value = tuple(desc["world"]["color"]) + (1.0,)
        bg.inputs["Strength"].default_value = 1.0
        for path, value in settings["blender"].items():
            if path not in SKIP_SETTINGS:
                set_path(scene, path, value)
        scene.cycles.device = "CPU"
        for lt in [o for o in scene.objects if o.type == "LIGHT"]:
            if lt.data.type == "SUN":  # Blender 4.5's importer reads a DistantLight's intensity as strength / 4
                lt.data.energy /= 4.0
            if hasattr(lt.data, "use_soft_falloff"):
                lt.data.use_soft_falloff = False  # as the library's parity settings
        result["lights"] = [dict(name=o.name, type=o.data.type, energy=o.data.energy) for o in scene.objects
                            if o.type == "LIGHT"]
        ims = scene.render.image_settings
        ims.file_format, ims.color_mode, ims.color_depth = "OPEN_EXR", "RGBA", "32"
        os.makedirs(job["out"], exist_ok=True)
        for k in range(int(job["seeds"])):
            scene.cycles.seed = int(job["first_seed"]) + k
            scene.render.filepath = os.path.join(job["out"], "seed_%02d.exr" % k)
            bpy.ops.render.render(write_still=True)
            result["renders"].append(scene.render.filepath)
        result["ok"] = True
    except Exception as exc:
        result.update(error="%s: %s" % (type(exc).__name__, exc), traceback=traceback.format_exc())
    with open(job["result"], "w") as f:
        json.dump(result, f, indent=1, default=str)
    sys.stdout.flush()
    os._exit(0)


if __name__ == "__main__":
    main()
