"""Peak memory and time of the HAIRBSDF engine on a big groom: n_side x n_side Curves strands
with `keys` keys each (1000 x 1000 x 16 = 1M strands, 16M keys), made by geometry nodes.

Used by blender_tests/test_engine_million_strands.py and lab/bench_engine.py. Runs
inside bpy 4.5 or Blender 3.4 (Linux: /proc/self/status, /proc/self/clear_refs).

Memory is the process's resident set: after Blender has evaluated the scene, the peak
counter (VmHWM) is reset (`echo 5 > /proc/self/clear_refs`) and each phase reports its peak
above the resident set before it:
  export_peak_bytes  export_scene alone (the SceneDesc arrays and the exporter's temporaries)
  engine_peak_bytes  bpy.ops.render.render with HAIRBSDF: export + hairbsdf.render (BVH and
                     renderer buffers) + writing the image
and the renderer's own account, stats["peak_memory_bytes"] (Embree's allocations at their
peak + the renderer's buffers).
"""

import os
import time

import bpy

import hair_scenes as hs


def _status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    return 0


def rss():
    return _status("VmRSS")


def reset_peak():
    """Reset VmHWM to the current resident set; False where the kernel does not allow it."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def peak():
    return _status("VmHWM")


def build_groom(n_side=1000, keys=16, width=32, height=24):
    scene = hs.reset(width=width, height=height, spp=1)
    mat = hs.hair_material("Hair", parametrization="MELANIN", melanin=0.5, roughness=0.3)
    hs.curves_grid("Groom", nx=n_side, ny=n_side, size=4.0, n_points=keys, length=0.3, radius=0.001,
                   material=mat)
    hs.make_camera(location=(0.0, -6.0, 2.0), target=(0.0, 0.0, 0.0))
    hs.make_light("SUN", energy=3.0)
    scene.render.engine = "HAIRBSDF"
    scene.hairbsdf.threads = 2
    return scene


def measure(n_side=1000, keys=16, render=True, out_path=None):
    """Builds the groom, exports it, renders it with the engine; returns the numbers."""
    import hairbsdf.blender
    from hairbsdf.blender import engine
    from hairbsdf.blender.export_scene import export_scene

    hairbsdf.blender.register()
    res = {"blender": bpy.app.version_string, "strands": n_side * n_side, "keys_per_strand": keys}
    scene = build_groom(n_side, keys)
    t = time.perf_counter()
    dg = bpy.context.evaluated_depsgraph_get()
    res["depsgraph_seconds"] = time.perf_counter() - t
    res["blender_peak_bytes"] = peak()  # Blender's own: the scene and its evaluation
    res["peak_reset"] = reset_peak()
    base = rss()
    res["base_rss_bytes"] = base
    t = time.perf_counter()
    desc, rep = export_scene(dg, render=True)
    res["export_seconds"] = time.perf_counter() - t
    res["export_peak_bytes"] = peak() - base
    res["exported_strands"] = int(desc["curves"]["curve_random"].size)
    res["exported_keys"] = int(desc["curves"]["points"].shape[0])
    res["scene_desc_bytes"] = int(sum(a.nbytes for a in desc["curves"].values()))
    del desc, rep
    if not render:
        return res
    reset_peak()
    base = rss()
    scene.render.filepath = out_path or os.path.join(bpy.app.tempdir or "/tmp", "hairbsdf_million.exr")
    t = time.perf_counter()
    bpy.ops.render.render(write_still=out_path is not None)
    res["render_op_seconds"] = time.perf_counter() - t
    res["engine_peak_bytes"] = peak() - base
    last = dict(engine.LAST_RENDER)
    stats = last.get("stats") or {}
    res.update(status=last.get("status"), errors=last.get("errors"), warnings=last.get("warnings"),
               engine_export_seconds=last.get("export_seconds"), render_seconds=last.get("render_seconds"),
               build_seconds=stats.get("build_seconds"), renderer_peak_bytes=stats.get("peak_memory_bytes"),
               samples=stats.get("samples"), nan_count=stats.get("nan_count"))
    return res
