"""Run by test_wheel.py in a Python with bpy: which TBB and Embree each side maps
(/proc/self/maps), the thread count, and a hash of the HAIRBSDF render's pixels.
    python tbb_probe.py SCENE.blend OUT.exr bpy_first|hairbsdf_first THREADS
Prints one JSON line after '@@'."""

import hashlib
import json
import os
import sys


def native_libs():
    found = set()
    with open("/proc/self/maps") as f:
        for line in f:
            parts = line.split()
            if len(parts) >= 6 and ("tbb" in parts[5] or "embree" in parts[5]):
                found.add(parts[5])
    return sorted(found)


def state():
    return dict(libs=native_libs(), threads=len(os.listdir("/proc/self/task")))


def main():
    blend, exr, order, threads = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    out = {}
    if order == "hairbsdf_first":
        import hairbsdf._render  # noqa: F401  (TBB and Embree before bpy)
        out["after_hairbsdf_import"] = state()
    import bpy
    out["after_bpy_import"] = state()
    import hairbsdf.blender
    hairbsdf.blender.register()
    bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
    s = bpy.context.scene
    s.cycles.seed, s.cycles.samples, s.cycles.device = 0, 8, "CPU"
    s.render.threads_mode, s.render.threads = "FIXED", threads
    s.render.engine = "HAIRBSDF"
    s.hairbsdf.threads = threads
    ims = s.render.image_settings
    ims.file_format, ims.color_depth, ims.color_mode = "OPEN_EXR", "32", "RGBA"
    s.render.filepath = exr
    bpy.ops.render.render(write_still=True)
    out["after_hairbsdf_render"] = state()
    s.render.engine, s.render.filepath = "CYCLES", exr + ".cycles.exr"
    bpy.ops.render.render(write_still=True)
    out["after_cycles_render"] = state()
    import numpy as np
    import OpenImageIO as oiio
    for key, path in (("hairbsdf_pixels", exr), ("cycles_pixels", exr + ".cycles.exr")):
        px = np.asarray(oiio.ImageBuf(path).get_pixels(oiio.FLOAT))
        out[key] = hashlib.sha256(px.tobytes()).hexdigest()[:16]
    out["hairbsdf_file"] = hairbsdf.__file__
    print("@@" + json.dumps(out), flush=True)
    os._exit(0)  # the bpy module can hang at exit with classes registered


if __name__ == "__main__":
    main()
