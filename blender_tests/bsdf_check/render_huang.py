"""Render the Huang fibre-goniometer cases with Cycles (bpy 4.5) and write an .npz file.

    .venv/bin/python render_huang.py --out f.npz --cases near|far [--seed N]

The scene is fiber_gonio.py's (one straight Catmull-Rom strand along world +x, orthographic
camera, delta sun, direct light only) with the Huang model, a Set Curve Normal node (mode Free)
for the elliptical cases, transparent bounces allowed (hits outside the projected ellipse are
transparent in Cycles) and many samples: Huang's eval is stochastic in Cycles, so every pixel
averages `spp` evaluations and every image row (near field) or the whole row of pixels (far
field) averages `width` independent pixels. See README_huang.md.

npz contents (one entry per kept row, near; per case, far):
    case (N,) int32, wo, wi, normal (N, 3) in Cycles' fibre frame (X = tangent, Y = normalize(X x wo)),
    h (N,), rgb (N, 3) = mean of pixel / (sun strength x alpha), sem (N, 3) standard error over the
    columns, alpha (N,), pixel_coverage (N,), near_field (N,) bool, meta (JSON string).
"""

import argparse
import json
import os
import shutil
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(os.path.dirname(os.path.dirname(HERE)), "plugin", "hairbsdf", "compare", "scenes")
for _p in (HERE, SCENES):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import bpy  # noqa: E402,F401
import numpy as np  # noqa: E402

import fiber_gonio as fg  # noqa: E402
import huang_cases  # noqa: E402

# Far field: pixels this close to one that misses the strand (its end) are not used.
END_MARGIN_PX = 2

HUANG_SOCKETS = {"aspect_ratio": "Aspect Ratio", "reflection": "Reflection", "transmission": "Transmission",
                 "secondary_reflection": "Secondary Reflection"}


def add_curve_normal_node(strand):
    """A Set Curve Normal (Free) node before Realize Instances in the strand's node tree; returns it."""
    ng = strand.modifiers[0].node_group
    realize = next(n for n in ng.nodes if n.bl_idname == "GeometryNodeRealizeInstances")
    link = realize.inputs["Geometry"].links[0]
    src = link.from_socket
    ng.links.remove(link)
    node = ng.nodes.new("GeometryNodeSetCurveNormal")
    fg.set_node_mode(node, "mode", "FREE")
    ng.links.new(src, node.inputs["Curve"])
    ng.links.new(node.outputs["Curve"], realize.inputs["Geometry"])
    return node


def set_huang_params(mat, params):
    p = dict(params)
    p["model"] = "HUANG"
    hair = fg.set_hair_params(mat, p)
    for key, sock in HUANG_SOCKETS.items():
        if key in p:
            fg.node_input(hair, sock).default_value = p[key]
    return hair


def frame_coords(v, wo):
    X, Y, Z = fg.cycles_frame(wo)
    return [fg._dot(v, X), fg._dot(v, Y), fg._dot(v, Z)]


def render_to_npz(out_path, which, threads=2, verbose=True, seed=None):
    cfg = dict(huang_cases.NEAR if which == "near" else huang_cases.FAR)
    if seed is not None:  # independent renders of the same set, averaged by test_huang_check.py
        cfg["seed"] = int(seed)
    cases = huang_cases.get_cases(which)
    t0 = time.time()
    fg.reset_scene()
    scene = fg.setup_render(width=cfg["width"], height=cfg["height"], spp=cfg["spp"], seed=cfg["seed"],
                            threads=threads, filter_width=cfg["filter_width"], pixel_filter=cfg["pixel_filter"])
    scene.render.film_transparent = True
    scene.cycles.transparent_max_bounces = 8  # hits outside the projected ellipse continue
    strand = fg.make_strand(length=cfg["length"], radius=cfg["radius"], n_points=cfg["n_points"])
    normal_node = add_curve_normal_node(strand)
    camera, sun = fg.make_camera(), fg.make_sun()
    mat = fg.make_hair_material()
    fg.assign_material(strand, mat)
    r = cfg["radius"]
    if which == "near":
        pixel = 2.0 * r / cfg["pixels_across"]
    else:
        pixel = cfg["pixel_size_in_radii"] * r
    image_height = cfg["height"] * pixel
    coverage = 0.5 * pixel / r
    # Far field: Blender renders at least 4 rows; the camera moves up by half a pixel so that the
    # centre of row 1 (rows counted from the bottom) passes through the strand axis.
    far_row = 1
    tmp = tempfile.mkdtemp(prefix="huang_gonio_")
    parts = []
    try:
        for k, case in enumerate(cases):
            t = time.time()
            wo = fg.view_direction(case["theta_o"], case["psi"])
            wi = fg.light_direction(wo, case["theta_i"], case["dphi"])
            fg.place_camera(camera, wo, image_height, distance=cfg["camera_distance"])
            if which == "far":
                from mathutils import Vector
                camera.location = camera.location + Vector(fg.camera_axes(wo)[1]) * (0.5 * pixel)
            fg.place_sun(sun, wi, case["sun_strength"])
            normal = case["params"].get("normal", (0.0, 0.0, 1.0))
            normal_node.inputs["Normal"].default_value = normal
            set_huang_params(mat, {k2: v for k2, v in case["params"].items() if k2 != "normal"})
            path = os.path.join(tmp, "r%04d.exr" % k)
            fg.render_exr(path, scene)
            px, (w, h) = fg.read_exr_rgba(path)
            px = np.asarray(px, dtype=np.float64)
            os.remove(path)
            alpha = px[..., 3]
            rgb = px[..., :3] / case["sun_strength"]
            with np.errstate(invalid="ignore", divide="ignore"):
                unpremul = np.where(alpha[..., None] > 0, rgb / alpha[..., None], 0.0)
            if which == "near":
                s = np.array(fg.pixel_offsets(cfg["width"], cfg["height"], image_height))
                hrow = s / r
                keep = (np.abs(hrow) <= cfg["h_max"]) & np.all(alpha > 0.9999, axis=1)
                rows = np.nonzero(keep)[0]
                mean = unpremul[rows].mean(axis=1)
                sem = unpremul[rows].std(axis=1, ddof=1) / np.sqrt(cfg["width"])
                hs = hrow[rows]
                al = alpha[rows].mean(axis=1)
            else:
                # Pixels within END_MARGIN_PX of a pixel that misses the strand see its end, which
                # shades differently (at theta_o = -40 deg the end pixel is 20-30 % off and moved
                # the row's mean by 0.5-0.7 %): they are dropped.
                hit = alpha[far_row] > 0.5
                near_end = np.convolve((~hit).astype(int), np.ones(2 * END_MARGIN_PX + 1, int), mode="same") > 0
                ok = hit & ~near_end
                assert ok.sum() >= cfg["width"] // 2, "far field: only %d pixels away from the strand's ends" % ok.sum()
                mean = unpremul[far_row, ok].mean(axis=0)[None]
                sem = (unpremul[far_row, ok].std(axis=0, ddof=1) / np.sqrt(ok.sum()))[None]
                hs = np.zeros(1)
                al = alpha[far_row].mean()[None]
                others = np.delete(alpha, far_row, axis=0)
                assert np.all(others == 0), "far field: a row other than %d hit the strand" % far_row
            n = len(hs)
            parts.append(dict(case=np.full(n, k, np.int32), wo=np.tile(frame_coords(wo, wo), (n, 1)),
                              wi=np.tile(frame_coords(wi, wo), (n, 1)),
                              normal=np.tile(frame_coords(normal, wo), (n, 1)), h=hs, rgb=mean, sem=sem, alpha=al,
                              pixel_coverage=np.full(n, coverage), near_field=np.full(n, which == "near")))
            if verbose:
                print("[render_huang] %2d/%d %-40s %3d rows  max %.4g  %.1fs" % (k + 1, len(cases), case["name"], n,
                                                                              float(np.max(mean)), time.time() - t),
                      flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    arrays = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    meta = dict(blender_version_string=fg.blender_version_string(), case_set=which, scene=cfg, cases=cases,
                render_seconds=time.time() - t0, rgb_is="mean of pixel / (sun strength x alpha)")
    arrays["meta"] = np.array(json.dumps(meta))
    tmpout = "%s.%d.tmp.npz" % (out_path, os.getpid())
    np.savez_compressed(tmpout, **arrays)
    os.replace(tmpout, out_path)
    if verbose:
        print("[render_huang] wrote %s (%d cases, %.1fs)" % (out_path, len(cases), time.time() - t0), flush=True)
    return out_path


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--cases", default="near", choices=sorted(huang_cases.CASE_SETS))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, help="Cycles seed (default: the case set's, 0)")
    a = ap.parse_args(argv if argv is not None else sys.argv[1:])
    render_to_npz(os.path.abspath(a.out), a.cases, threads=a.threads, seed=a.seed)


if __name__ == "__main__":
    main()
