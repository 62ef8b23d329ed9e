"""The Blender half of `hairbsdf scenes export` (portable.py), run in bpy 4.5 or 5.3:

    .venv/bin/python portable_job.py job.json

job.json: {blend, res, spp, out_dir, result}.  Opens the built library scene and writes into out_dir:
  hairbsdf_scene.npz   our scene description as the engine reads it (export_scene.save_scene)
  scene.usda           geometry, camera and lights through Blender's USD exporter, with every hair
                       strand (particle hair and its children included) first replaced by a Curves
                       object made from the exported description: radius per key (USD widths),
                       Catmull-Rom basis, the material, and Hair Info > Random as a curve attribute
                       (primvar hairbsdf_random)
  blender_settings     (in the result JSON) the Blender properties that change pixels
Writes `result` (JSON) last; its "ok" says whether it worked.
"""

import json
import math
import os
import sys
import traceback

import bpy
import numpy as np

# The harness's own job script, beside this one (its folder is on sys.path when run as a script).
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_job import _scene_lib as _scene_lib_in, _write_json, exit_blender_process  # noqa: E402

RANDOM_ATTRIBUTE = "hairbsdf_random"


def _scene_lib():
    return _scene_lib_in(os.path.join(os.path.dirname(os.path.abspath(__file__)), "scenes"))


def hair_sources(depsgraph):
    """Original objects whose hair Cycles renders: Curves objects (or objects whose modifiers make
    curves) and meshes with particle hair systems."""
    curves_objects, particle_objects = set(), set()
    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj.type == "CURVES":
            curves_objects.add((inst.parent or obj).original.name if inst.is_instance else obj.original.name)
        elif obj.type == "MESH" and len(obj.particle_systems):
            particle_objects.add(obj.original.name)
    return sorted(curves_objects), sorted(particle_objects)


def replace_hair(desc, materials_by_index):
    """One new Curves object per (object space, material) group of the description's strands."""
    c = desc["curves"]
    points, offsets = c["points"], c["curve_offsets"]
    n_curves = len(offsets) - 1
    if n_curves == 0:
        return []
    curve_object = c.get("curve_object")
    if curve_object is None:
        curve_object = np.full(n_curves, -1, np.int32)
    transforms = c.get("object_transforms")
    made = []
    for space in np.unique(curve_object):
        for mat in np.unique(c["curve_material"]):
            idx = np.nonzero((curve_object == space) & (c["curve_material"] == mat))[0]
            if idx.size == 0:
                continue
            sizes = (offsets[idx + 1] - offsets[idx]).astype(int)
            keys = np.concatenate([np.arange(offsets[i], offsets[i + 1]) for i in idx])
            name = "hair_%s" % materials_by_index[int(mat)]["name"] + ("" if space < 0 else "_space%d" % space)
            data = bpy.data.hair_curves.new(name)
            data.add_curves([int(s) for s in sizes])
            data.position_data.foreach_set("vector", points[keys, :3].astype(np.float32).ravel())
            radius = data.attributes.get("radius") or data.attributes.new("radius", "FLOAT", "POINT")
            radius.data.foreach_set("value", points[keys, 3].astype(np.float32))
            rnd = data.attributes.new(RANDOM_ATTRIBUTE, "FLOAT", "CURVE")
            rnd.data.foreach_set("value", c["curve_random"][idx].astype(np.float32))
            data.set_types(type="CATMULL_ROM")  # Cycles interpolates every strand's keys as Catmull-Rom
            bmat = bpy.data.materials.get(materials_by_index[int(mat)]["name"])
            if bmat is not None:
                data.materials.append(bmat)
            obj = bpy.data.objects.new(name, data)
            if space >= 0:
                m = np.eye(4)
                m[:3, :] = np.asarray(transforms[int(space)], np.float64).reshape(3, 4)
                obj.matrix_world = [list(r) for r in m]
            bpy.context.scene.collection.objects.link(obj)
            made.append(dict(object=name, material=materials_by_index[int(mat)]["name"], curves=int(idx.size),
                             points=int(keys.size), object_space=int(space)))
    return made


def orthographic_camera_prims(scene):
    """Blender 4.5's USD writer leaves an orthographic camera's Camera prim out (only its Xform is
    written). Returns {Xform name: usda text of the Camera prim} per UsdGeomCamera: the apertures in
    tenths of a stage unit span the view (ortho_scale on the larger side for sensor fit AUTO)."""
    r = scene.render
    w, h = r.resolution_x * r.pixel_aspect_x, r.resolution_y * r.pixel_aspect_y
    out = {}
    for obj in scene.objects:
        if obj.type != "CAMERA" or obj.data.type != "ORTHO":
            continue
        cam = obj.data
        fit = cam.sensor_fit if cam.sensor_fit != "AUTO" else ("HORIZONTAL" if w >= h else "VERTICAL")
        width = cam.ortho_scale if fit == "HORIZONTAL" else cam.ortho_scale * w / h
        height = width * h / w
        larger = max(width, height)
        out[obj.name] = (
            '        def Camera "%s"\n        {\n'
            '            float2 clippingRange = (%r, %r)\n'
            '            float horizontalAperture = %r\n'
            '            float horizontalApertureOffset = %r\n'
            '            token projection = "orthographic"\n'
            '            float verticalAperture = %r\n'
            '            float verticalApertureOffset = %r\n'
            '        }\n' % (cam.name, cam.clip_start, cam.clip_end, 10 * width, 10 * cam.shift_x * larger,
                             10 * height, 10 * cam.shift_y * larger))
    return out


def add_orthographic_cameras(usda_path, prims):
    """Inserts the Camera prims into their Xforms of the written .usda (top-level Xforms under /root)."""
    with open(usda_path) as f:
        text = f.read()
    added = []
    for name, prim in prims.items():
        head = '    def Xform "%s"\n    {\n' % name
        start = text.find(head)
        if start < 0:
            continue
        end = text.find("\n    }\n", start)  # the Xform's closing brace, 4 spaces in
        if 'def Camera' in text[start:end]:
            continue
        text = text[:end + 1] + "\n" + prim + text[end + 1:]
        added.append(name)
    with open(usda_path, "w") as f:
        f.write(text)
    return added


USD_LIGHT_INTENSITY = {  # UsdLux intensity per unit of Blender energy, normalize = 1 (docs/portable_scenes.md)
    "SUN": 1.0,            # DistantLight: irradiance W/m^2, as Cycles' sun strength
    "AREA": 1.0 / math.pi,  # RectLight/DiskLight: radiance = intensity / area = P / (pi A), Cycles 4.x
    "POINT": 1.0 / math.pi,  # SphereLight: radiance = intensity / (4 pi r^2) = P / (4 pi^2 r^2), Cycles 4.x
    "SPOT": 1.0 / math.pi,
}


def fix_lights(usda_path, scene):
    """Blender 4.5's USD writer turns every light's colour temperature on (6500 K, which tints Blender's
    own re-import by up to 4 %) and writes a sun's strength / 4. Rewrites intensity, colour and
    enableColorTemperature of each light prim from the Blender light. Returns what it changed."""
    with open(usda_path) as f:
        text = f.read()
    changed = []
    for obj in scene.objects:
        if obj.type != "LIGHT":
            continue
        light = obj.data
        head = '    def Xform "%s"\n' % obj.name
        start = text.find(head)
        if start < 0:
            continue
        end = text.find("\n    }\n", start)
        block = text[start:end]
        lines = block.split("\n")
        old = [l.strip() for l in lines if "inputs:intensity" in l or "inputs:enableColorTemperature" in l
               or "inputs:color " in l]
        keep = [l for l in lines if not ("inputs:intensity" in l or "inputs:enableColorTemperature" in l
                                         or "inputs:color " in l)]
        prim = next(i for i, l in enumerate(keep) if l.strip().startswith("def ") and "Light" in l)
        scale = float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
        colour = [float(c) for c in light.color]
        if getattr(light, "use_temperature", False):
            colour = [c * t for c, t in zip(colour, light.temperature_color)]
        new = ["            color3f inputs:color = (%r, %r, %r)" % tuple(colour),
               "            bool inputs:enableColorTemperature = 0",
               "            float inputs:intensity = %r" % (scale * USD_LIGHT_INTENSITY.get(light.type, 1.0))]
        body = next(i for i in range(prim + 1, len(keep)) if keep[i].strip() == "{")  # after any (metadata)
        keep[body + 1:body + 1] = new
        text = text[:start] + "\n".join(keep) + text[end:]
        changed.append(dict(light=obj.name, type=light.type, blender_wrote=old, written=[l.strip() for l in new]))
    with open(usda_path, "w") as f:
        f.write(text)
    return changed


def main():
    with open(sys.argv[-1]) as f:
        job = json.load(f)
    result = dict(ok=False, blender=bpy.app.version_string)
    try:
        from hairbsdf.blender.export_scene import export_scene, save_scene
        lib = _scene_lib()
        bpy.ops.wm.open_mainfile(filepath=job["blend"], load_ui=False)
        scene = bpy.context.scene
        scene.render.resolution_x, scene.render.resolution_y = (int(v) for v in job["res"])
        scene.render.resolution_percentage = 100
        scene.cycles.samples = int(job["spp"])
        scene.cycles.seed = 0
        scene.cycles.use_animated_seed = False
        out = job["out_dir"]
        os.makedirs(out, exist_ok=True)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        desc, report = export_scene(depsgraph, render=True)
        save_scene(os.path.join(out, "hairbsdf_scene.npz"), desc, extra={"report": report.as_dict()})
        result["blender_settings"], result["parity_warnings"] = lib.read_parity_settings(scene)
        result["export_warnings"] = list(report.as_dict().get("warnings", []))

        # hair: the strands as Cycles sees them (children, radii) become Curves objects
        curves_objects, particle_objects = hair_sources(depsgraph)
        for name in curves_objects:
            bpy.data.objects.remove(bpy.data.objects[name])
        for name in particle_objects:
            obj = bpy.data.objects[name]
            for mod in [m for m in obj.modifiers if m.type == "PARTICLE_SYSTEM"]:
                obj.modifiers.remove(mod)
        result["hair_objects"] = replace_hair(desc, desc["materials"])
        result["replaced"] = dict(curves_objects=curves_objects, particle_objects=particle_objects)

        # the substitution must not change what Cycles renders: export again and compare
        desc2, _ = export_scene(bpy.context.evaluated_depsgraph_get(), render=True)
        check = {}
        for key in ("vertices", "triangles"):
            a, b = desc["meshes"][key], desc2["meshes"][key]
            check["meshes." + key] = bool(a.shape == b.shape and np.array_equal(a, b))
        p1, p2 = desc["curves"]["points"], desc2["curves"]["points"]
        check["curves.count"] = int(desc["curves"]["curve_random"].size) == int(desc2["curves"]["curve_random"].size)
        check["curves.points"] = bool(p1.shape == p2.shape and (p1.size == 0 or np.allclose(
            np.sort(p1, axis=0), np.sort(p2, axis=0), rtol=0, atol=1e-5)))
        result["substitution_check"] = check

        usd = os.path.join(out, "scene.usda")
        options = dict(filepath=usd, selected_objects_only=False, visible_objects_only=True,
                       export_animation=False, export_hair=False, export_curves=True, export_meshes=True,
                       export_lights=True, export_cameras=True, export_materials=True,
                       generate_preview_surface=True, export_textures=False, evaluation_mode="RENDER",
                       convert_world_material=True, export_custom_properties=False)
        known = {p.identifier for p in bpy.ops.wm.usd_export.get_rna_type().properties}
        result["usd_options_unknown"] = sorted(set(options) - known)  # e.g. visible_objects_only in 5.x
        bpy.ops.wm.usd_export(**{k: v for k, v in options.items() if k in known})
        result["usd"] = os.path.basename(usd)
        result["usd_fixes"] = dict(orthographic_cameras=add_orthographic_cameras(usd, orthographic_camera_prims(scene)),
                                   lights=fix_lights(usd, scene))
        result["ok"] = all(check.values())
        if not result["ok"]:
            result["error"] = "replacing the hair by Curves objects changed the scene: %s" % check
    except Exception as exc:
        result.update(ok=False, error="%s: %s" % (type(exc).__name__, exc), traceback=traceback.format_exc())
    _write_json(job["result"], result)
    exit_blender_process(0)


if __name__ == "__main__":
    main()
