#!/usr/bin/env python3
"""Side by side: Cycles and the HAIRBSDF engine on one hair scene, in bpy 4.5 and in Blender 3.4.

    .venv/bin/python lab/engine_side_by_side.py [--spp 64] [--size 240x160] [--out DIR]
                                                    [--png docs/images/engine_side_by_side.png]

The scene (blender_tests/scenes/hair_scenes.py: showcase_scene) is particle hair with
interpolated children and a Curves object made by geometry nodes over a ground plane, lit by
a sun, a point light, an area light and a uniform world.

  * bpy 4.5 (this interpreter, the pip module): builds the scene, renders it with Cycles and
    with HAIRBSDF (hairbsdf.blender.register()) in one process;
  * Blender 3.4 (`blender -b`): builds the same scene and saves a 3.4 .blend, then renders
    that file from the command line, `blender -b showcase_34.blend -E CYCLES|HAIRBSDF -o ...
    -F OPEN_EXR -f 1`, with the add-on installed by scripts/install_blender_addon into a
    temporary user configuration (BLENDER_USER_CONFIG / BLENDER_USER_SCRIPTS).

The linear EXRs are shown with the Standard view transform (sRGB OETF, exposure 0) in a
2 x 3 grid (Cycles | HAIRBSDF | |difference| x 4), written to --png; the image means and
render times are printed and written to DIR/side_by_side.json. All renders use 2 threads,
CPU. About 2 minutes on 2 cores at the defaults.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENES = os.path.join(ROOT, "blender_tests", "scenes")
LIBRARY = os.path.join(ROOT, "plugin", "hairbsdf", "compare", "scenes")  # fiber_gonio, which hair_scenes imports
SITE = os.path.join(ROOT, "build", "blender_site", "current")


# ----------------------------------------------------------------------------- inside Blender

def _blender_part(argv):
    """Runs inside bpy 4.5 (part 'bpy') or Blender 3.4 (part 'build34')."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--part", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--size", required=True)
    a = ap.parse_args(argv)
    sys.path[:0] = [SCENES, LIBRARY]
    import bpy
    import fiber_gonio as fg
    import hair_scenes as hs

    w, h = (int(v) for v in a.size.split("x"))
    scene = hs.showcase_scene(width=w, height=h, spp=a.spp)
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 2
    out = {"version": bpy.app.version_string}
    if a.part == "build34":
        path = os.path.join(a.out, "showcase_34.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        out["blend"] = path
    else:
        import hairbsdf.blender
        from hairbsdf.blender import engine
        hairbsdf.blender.register()
        scene.hairbsdf.threads = 2
        for eng in ("CYCLES", "HAIRBSDF"):
            scene.render.engine = eng
            scene.render.filepath = os.path.join(a.out, f"bpy45_{eng}.exr")
            t = time.perf_counter()
            bpy.ops.render.render(write_still=True)
            out[eng] = {"seconds": time.perf_counter() - t, "exr": scene.render.filepath}
            if eng == "HAIRBSDF":
                out[eng]["status"] = engine.LAST_RENDER.get("status")
                out[eng]["warnings"] = engine.LAST_RENDER.get("warnings")
                out[eng]["engine_render_seconds"] = engine.LAST_RENDER.get("render_seconds")
                out[eng]["export_seconds"] = engine.LAST_RENDER.get("export_seconds")
    with open(os.path.join(a.out, f"part_{a.part}.json"), "w") as f:
        json.dump(out, f, indent=1)
    del fg
    from hairbsdf.compare.blender_job import exit_blender_process
    exit_blender_process(0)


# ----------------------------------------------------------------------------- driver

def _run(cmd, env=None, timeout=900):
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout, cwd=ROOT)
    secs = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit(f"failed ({r.returncode}): {' '.join(cmd)}\n{(r.stdout + r.stderr)[-4000:]}")
    return r, secs


def _blender_time(stdout):
    """Blender's own render time: the last 'Time: mm:ss.cc' line of `blender -b ... -f 1`."""
    times = re.findall(r"Time: (\d+):(\d+\.\d+)", stdout)
    if not times:
        return None
    m, s = times[-1]
    return int(m) * 60 + float(s)


def _read_exr(path):
    import OpenImageIO as oiio
    import numpy as np

    inp = oiio.ImageInput.open(path)
    if inp is None:
        sys.exit(f"cannot read {path}: {oiio.geterror()}")
    spec = inp.spec()
    px = inp.read_image(0, 0, 0, spec.nchannels, "float")
    inp.close()
    return np.asarray(px, dtype=np.float64).reshape(spec.height, spec.width, spec.nchannels)[..., :3]


def _standard(img):
    """Blender's Standard view transform at exposure 0: the sRGB OETF, clipped to [0, 1]."""
    import numpy as np

    x = np.clip(img, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def main():
    if "--part" in sys.argv:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
        return _blender_part(argv)
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", default="240x160")
    ap.add_argument("--out", default=os.path.join(ROOT, "build", "side_by_side"))
    ap.add_argument("--png", default=os.path.join(ROOT, "docs", "images", "engine_side_by_side.png"))
    ap.add_argument("--blender", default=os.environ.get("BLENDER") or shutil.which("blender") or "blender")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    t_start = time.perf_counter()
    me = os.path.abspath(__file__)
    common = ["--spp", str(a.spp), "--size", a.size, "--out", a.out]
    summary = {"spp": a.spp, "size": a.size, "threads": 2}

    # bpy 4.5, in one process: Cycles and HAIRBSDF.
    _run([sys.executable, me, "--part", "bpy", *common])
    with open(os.path.join(a.out, "part_bpy.json")) as f:
        p45 = json.load(f)
    if p45["HAIRBSDF"].get("status") != "ok":
        sys.exit(f"HAIRBSDF in bpy 4.5 did not render: {p45['HAIRBSDF']}")
    summary["bpy"] = p45

    # Blender 3.4: build and save, install the add-on in a temporary user configuration, render
    # the .blend from the command line with both engines.
    _run([a.blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", me, "--",
          "--part", "build34", *common])
    with open(os.path.join(a.out, "part_build34.json")) as f:
        p34 = json.load(f)
    user = tempfile.mkdtemp(prefix="hairbsdf_side_by_side_")
    env = dict(os.environ, BLENDER_USER_CONFIG=os.path.join(user, "config"),
               BLENDER_USER_SCRIPTS=os.path.join(user, "scripts"),
               BLENDER_USER_RESOURCES=os.path.join(user, "resources"))
    try:
        _run([os.path.join(ROOT, "scripts", "install_blender_addon"), a.blender], env=env)
        for eng in ("CYCLES", "HAIRBSDF"):
            prefix = os.path.join(a.out, f"b34_{eng}_")
            r, wall = _run([a.blender, "-b", p34["blend"], "-E", eng, "-t", "2", "-o", prefix + "#",
                            "-F", "OPEN_EXR", "-f", "1"], env=env)
            if eng == "HAIRBSDF" and ("hairbsdf: " in r.stdout and "ERROR" in r.stdout):
                sys.exit("HAIRBSDF in Blender 3.4 reported an error:\n" + r.stdout[-3000:])
            p34[eng] = {"seconds": _blender_time(r.stdout), "wall_seconds_with_startup": wall,
                        "exr": prefix + "1.exr"}
    finally:
        shutil.rmtree(user, ignore_errors=True)
    summary["blender34"] = p34

    # Means and the grid.
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    rows = [("bpy 4.5 (pip module, in process)", p45), ("Blender 3.4 (blender -b, add-on)", p34)]
    fig, axes = plt.subplots(2, 3, figsize=(12, 5.9), dpi=100)
    for r_i, (label, part) in enumerate(rows):
        cy, ours = _read_exr(part["CYCLES"]["exr"]), _read_exr(part["HAIRBSDF"]["exr"])
        part["CYCLES"]["mean_rgb"] = cy.mean(axis=(0, 1)).tolist()
        part["HAIRBSDF"]["mean_rgb"] = ours.mean(axis=(0, 1)).tolist()
        part["mean_ratio"] = float(ours.mean() / cy.mean())
        # noise of the mean difference: both renders are independent, pixels nearly so
        d = (ours - cy).mean(axis=2)
        part["mean_ratio_sigma"] = float(d.std() / np.sqrt(d.size) / cy.mean())
        for c_i, (title, img) in enumerate((("Cycles", _standard(cy)), ("HAIRBSDF", _standard(ours)),
                                            ("|HAIRBSDF - Cycles| x 4", np.clip(4 * np.abs(ours - cy), 0, 1)))):
            ax = axes[r_i, c_i]
            ax.imshow(img, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if c_i < 2:
                eng = "CYCLES" if c_i == 0 else "HAIRBSDF"
                title += f"  mean {np.mean(part[eng]['mean_rgb']):.4f}, {part[eng]['seconds']:.1f} s"
            ax.set_title(title, fontsize=9)
            if c_i == 0:
                ax.set_ylabel(f"{label}\n{part['version']}", fontsize=9)
    fig.suptitle(f"Particle hair with children + Curves; sun, point, area, world; {a.size} px, {a.spp} spp, "
                 "2 threads, Standard view transform", fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(a.png)), exist_ok=True)
    fig.savefig(a.png)
    summary["total_seconds"] = time.perf_counter() - t_start
    with open(os.path.join(a.out, "side_by_side.json"), "w") as f:
        json.dump(summary, f, indent=1)
    for label, part in rows:
        c, o = part["CYCLES"], part["HAIRBSDF"]
        print(f"{label} {part['version']}: mean Cycles {np.mean(c['mean_rgb']):.5f} HAIRBSDF "
              f"{np.mean(o['mean_rgb']):.5f} (ratio {part['mean_ratio']:.4f} +- {part['mean_ratio_sigma']:.4f}); "
              f"time Cycles {c['seconds']:.2f} s "
              f"HAIRBSDF {o['seconds']:.2f} s")
    print(f"wrote {a.png} and {os.path.join(a.out, 'side_by_side.json')} in {summary['total_seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
