"""Render the legacy Hair BSDF (ShaderNodeBsdfHair) fibre-goniometer cases with Cycles and write
an .npz file in render_cases.py's format (case, wo, wi, h, rgb, row, col, meta).

Runs inside Blender 3.4 or 4.x:
    blender -b --factory-startup --python-exit-code 1 --python render_cycles_hair.py -- --out f.npz
or with the bpy module:
    .venv/bin/python render_cycles_hair.py --out f.npz

The scene is fiber_gonio.py's (one straight thick Catmull-Rom strand, orthographic camera, delta
sun, direct light only, 1 spp at the pixel centre), as in README.md; only the material differs.
Cycles' eval of this closure is deterministic, so every pixel is sun strength x eval(wo, wi, h)
with the Color folded in.

Cases (CASES below): both components, the node defaults, rough / smooth / offset variants, views
theta_o in {-40, 0, 30} and lights on the near (reflection) and far (transmission) side, with
|dphi| chosen so that the shading-normal split crosses the strand for some of them.
"""

import argparse
import json
import os
import sys
import tempfile
import time
import shutil

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(os.path.dirname(os.path.dirname(HERE)), "plugin", "hairbsdf", "compare", "scenes")
for _p in (HERE, SCENES):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import bpy  # noqa: E402,F401
import numpy as np  # noqa: E402

import cases as case_defs  # noqa: E402
import fiber_gonio as fg  # noqa: E402
from render_cases import edge_alpha_check  # noqa: E402

# Node inputs (Offset in radians) per material; component as Blender's enum ('Reflection' | 'Transmission').
MATERIALS = {
    "refl_default": dict(component="Reflection", color=(0.8, 0.8, 0.8), offset=0.0, roughness_u=0.1,
                         roughness_v=1.0),
    "refl_offset_narrow": dict(component="Reflection", color=(0.9, 0.6, 0.3), offset=0.12, roughness_u=0.25,
                               roughness_v=0.35),
    "trans_default": dict(component="Transmission", color=(0.8, 0.8, 0.8), offset=0.0, roughness_u=0.1,
                          roughness_v=1.0),
    "trans_offset_rough": dict(component="Transmission", color=(0.3, 0.7, 0.5), offset=-0.2, roughness_u=0.4,
                               roughness_v=0.3),
}
THETA_O = (-40.0, 0.0, 30.0)
# (theta_i, dphi): near side (|dphi| < 90) for reflection, far side for transmission; 55 and 140
# degrees put the normal split inside the strand (the N test changes sign at h = -cos dphi ...).
LIGHTS = {"Reflection": ((-35.0, 20.0), (20.0, 55.0), (45.0, -70.0), (-10.0, 110.0)),
          "Transmission": ((-30.0, 160.0), (25.0, -140.0), (50.0, 105.0), (0.0, 70.0))}


def get_cases():
    out = []
    k = 0
    for mname, params in MATERIALS.items():
        for theta_o in THETA_O:
            for theta_i, dphi in LIGHTS[params["component"]]:
                out.append(dict(name="%s/to%+g/ti%+g/dp%+g" % (mname, theta_o, theta_i, dphi), material=mname,
                                params=params, theta_o=theta_o, theta_i=theta_i, dphi=dphi,
                                psi=(37.0 * k) % 360.0, sun_strength=1.0))
                k += 1
    return out


def make_material():
    mat = bpy.data.materials.new("LegacyHair")
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    hair = nt.nodes.new("ShaderNodeBsdfHair")
    hair.name = "Hair"
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    if hasattr(out, "target"):
        out.target = "ALL"
    nt.links.new(hair.outputs[0], out.inputs["Surface"])
    return mat


def set_params(mat, p):
    hair = mat.node_tree.nodes["Hair"]
    hair.component = p["component"]
    hair.inputs["Color"].default_value = tuple(p["color"]) + (1.0,)
    hair.inputs["Offset"].default_value = p["offset"]
    fg.node_input(hair, "RoughnessU").default_value = p["roughness_u"]
    fg.node_input(hair, "RoughnessV").default_value = p["roughness_v"]


def frame_coords(v, wo):
    X, Y, Z = fg.cycles_frame(wo)
    return [fg._dot(v, X), fg._dot(v, Y), fg._dot(v, Z)]


def node_defaults():
    """The node's defaults in this Blender (recorded in meta; the Python constructor's defaults)."""
    mat = make_material()
    hair = mat.node_tree.nodes["Hair"]
    d = dict(component=hair.component, color=list(hair.inputs["Color"].default_value)[:3],
             offset=float(hair.inputs["Offset"].default_value),
             roughness_u=float(fg.node_input(hair, "RoughnessU").default_value),
             roughness_v=float(fg.node_input(hair, "RoughnessV").default_value))
    bpy.data.materials.remove(mat)
    return d


def render_to_npz(out_path, threads=2, verbose=True):
    cfg = dict(case_defs.SCENE)
    cases = get_cases()
    t0 = time.time()
    fg.reset_scene()
    defaults = node_defaults()
    scene = fg.setup_render(width=cfg["width"], height=cfg["height"], spp=cfg["spp"], seed=cfg["seed"],
                            threads=threads, filter_width=cfg["filter_width"], pixel_filter=cfg["pixel_filter"])
    scene.render.film_transparent = True
    strand = fg.make_strand(length=cfg["length"], radius=cfg["radius"], n_points=cfg["n_points"])
    camera, sun = fg.make_camera(), fg.make_sun()
    mat = make_material()
    fg.assign_material(strand, mat)
    pixel = 2.0 * cfg["radius"] / cfg["pixels_across"]
    image_height = cfg["height"] * pixel
    hrow = np.array(fg.pixel_offsets(cfg["width"], cfg["height"], image_height)) / cfg["radius"]
    tmp = tempfile.mkdtemp(prefix="legacy_hair_gonio_")
    parts = []
    checks = {}
    try:
        # the filter samples the pixel centre (render_cases.edge_alpha_check), on the first case's view
        wo = fg.view_direction(cases[0]["theta_o"], cases[0]["psi"])
        fg.place_camera(camera, wo, image_height, distance=cfg["camera_distance"])

        def _render_rgba():
            path = os.path.join(tmp, "edge_alpha.exr")
            fg.render_exr(path, scene)
            px, _ = fg.read_exr_rgba(path)
            os.remove(path)
            return np.asarray(px, dtype=np.float64)
        checks.update(edge_alpha_check(scene, camera, pixel, _render_rgba))
        for k, case in enumerate(cases):
            t = time.time()
            wo = fg.view_direction(case["theta_o"], case["psi"])
            wi = fg.light_direction(wo, case["theta_i"], case["dphi"])
            fg.place_camera(camera, wo, image_height, distance=cfg["camera_distance"])
            fg.place_sun(sun, wi, case["sun_strength"])
            set_params(mat, case["params"])
            path = os.path.join(tmp, "r%04d.exr" % k)
            fg.render_exr(path, scene)
            px, (w, h) = fg.read_exr_rgba(path)
            px = np.asarray(px, dtype=np.float64)
            os.remove(path)
            hh = np.broadcast_to(hrow[:, None], (h, w))
            keep = np.abs(hh) <= cfg["h_max"]
            if not np.all(px[..., 3][keep] > 0.9999):
                raise RuntimeError("case %s: strand does not cover |h| <= %g" % (case["name"], cfg["h_max"]))
            rows, cols = np.nonzero(keep)
            n = rows.size
            parts.append(dict(case=np.full(n, k, np.int32), wo=np.tile(frame_coords(wo, wo), (n, 1)),
                              wi=np.tile(frame_coords(wi, wo), (n, 1)), h=hh[rows, cols].astype(np.float64),
                              rgb=px[rows, cols, :3] / case["sun_strength"], row=rows.astype(np.int16),
                              col=cols.astype(np.int16)))
            if verbose:
                print("[render_cycles_hair] %2d/%d %-44s max %.4g  %.2fs" % (k + 1, len(cases), case["name"],
                                                                          float(px[..., :3].max()), time.time() - t),
                      flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    arrays = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    meta = dict(blender_version=list(fg.blender_version()), blender_version_string=fg.blender_version_string(),
                tilt=fg.default_tilt_convention(), case_set="cycles_hair", scene=cfg, cases=cases,
                node_defaults=defaults, checks=checks, render_seconds=time.time() - t0, rgb_is="pixel / sun strength")
    arrays["meta"] = np.array(json.dumps(meta))
    tmpout = "%s.%d.tmp.npz" % (out_path, os.getpid())
    np.savez_compressed(tmpout, **arrays)
    os.replace(tmpout, out_path)
    if verbose:
        print("[render_cycles_hair] wrote %s (%d cases, %.1fs)" % (out_path, len(cases), time.time() - t0),
              flush=True)
    return out_path


def main(argv=None):
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--cases", default="cycles_hair", choices=["cycles_hair"])
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args(argv)
    render_to_npz(os.path.abspath(a.out), threads=a.threads)


if __name__ == "__main__":
    main()
