"""Render the fibre-goniometer cases with Cycles and write the per-pixel samples
to an .npz file.

Runs inside Blender 3.4 or 4.x:
    blender -b --factory-startup --python-exit-code 1 --python render_cases.py -- --out f.npz --cases small
or with the bpy module:
    .venv/bin/python render_cases.py --out f.npz --cases small
or imported (``render_to_npz(...)``) from a process that has ``bpy``.

npz contents (N = all kept pixels of all cases, concatenated):
    case     (N,)   int32    index into meta["cases"]
    wo, wi   (N, 3) float64  view / light direction in Cycles' fibre frame
                             (X = tangent root->tip, Y = normalize(X x wo), Z = X x Y)
    h        (N,)   float64  offset across the fibre, h = s / r (README.md)
    rgb      (N, 3) float64  pixel value / sun strength
    row, col (N,)   int16    pixel (row 0 = bottom of the image)
    h_probe  (N,)   float64  h measured from a Geometry>Position emission render
                             (NaN when probes are off)
    meta     ()     str      JSON: blender version, tilt, scene constants, cases, checks
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

import bpy  # noqa: E402,F401  (fail early outside Blender)
import numpy as np  # noqa: E402

import cases as case_defs  # noqa: E402
import fiber_gonio as fg  # noqa: E402

POSITION_OFFSET = (1.0, 1.0, 1.0)  # keeps the emitted position positive


class Rig:
    """The scene: strand, camera, sun, hair material and probe materials."""

    def __init__(self, scene_cfg, strand_method="geometry_nodes", threads=2):
        self.cfg = dict(scene_cfg)
        c = self.cfg
        fg.reset_scene()
        self.scene = fg.setup_render(width=c["width"], height=c["height"], spp=c["spp"],
                                     seed=c["seed"], threads=threads,
                                     filter_width=c["filter_width"],
                                     pixel_filter=c["pixel_filter"])
        self.scene.render.film_transparent = True  # alpha = coverage
        self.strand = fg.make_strand(length=c["length"], radius=c["radius"],
                                     n_points=c["n_points"], method=strand_method)
        self.camera = fg.make_camera()
        self.sun = fg.make_sun()
        self.hair_mat = fg.make_hair_material()
        self.pos_mat = fg.make_emission_probe_material("position", offset=POSITION_OFFSET)
        self.info_mat = fg.make_emission_probe_material("hairinfo")
        fg.assign_material(self.strand, self.hair_mat)
        self.pixel = 2.0 * c["radius"] / c["pixels_across"]
        self.image_height = c["height"] * self.pixel
        self.tmpdir = tempfile.mkdtemp(prefix="fiber_gonio_")
        self.n_renders = 0

    def close(self):
        shutil.rmtree(self.tmpdir, ignore_errors=True)

    # geometry ---------------------------------------------------------------
    def set_geometry(self, case):
        wo = fg.view_direction(case["theta_o"], case["psi"])
        wi = fg.light_direction(wo, case["theta_i"], case["dphi"])
        fg.place_camera(self.camera, wo, self.image_height, distance=self.cfg["camera_distance"])
        fg.place_sun(self.sun, wi, case["sun_strength"])
        return wo, wi

    def row_h(self):
        """h of every image row (row 0 = bottom): h = s / r."""
        s = np.array(fg.pixel_offsets(self.cfg["width"], self.cfg["height"], self.image_height))
        return s / self.cfg["radius"]

    # rendering --------------------------------------------------------------
    def render(self, mat=None):
        if mat is not None:
            fg.assign_material(self.strand, mat)
        path = os.path.join(self.tmpdir, "r%05d.exr" % self.n_renders)
        self.n_renders += 1
        fg.render_exr(path, self.scene)
        px, (w, h) = fg.read_exr_rgba(path)
        os.remove(path)
        assert (w, h) == (self.cfg["width"], self.cfg["height"]), (w, h)
        return np.asarray(px, dtype=np.float64)

    def probe_h(self, wo):
        """h measured from the emitted hit position: -dot(P - C, Y) / r."""
        px = self.render(self.pos_mat)
        fg.assign_material(self.strand, self.hair_mat)
        P = px[..., :3] - np.array(POSITION_OFFSET)
        X, Y, Z = (np.array(v) for v in fg.cycles_frame(wo))
        C = np.outer(P.reshape(-1, 3) @ X, X).reshape(P.shape)  # axis is the world x axis
        return -((P - C) @ Y) / self.cfg["radius"], px[..., 3]

    def hair_info(self):
        px = self.render(self.info_mat)
        fg.assign_material(self.strand, self.hair_mat)
        return px


def _frame_coords(v, wo):
    X, Y, Z = fg.cycles_frame(wo)
    return [fg._dot(v, X), fg._dot(v, Y), fg._dot(v, Z)]


def render_case(rig, case, probe=True):
    """Render one case; returns a dict of per-pixel arrays."""
    wo, wi = rig.set_geometry(case)
    fg.set_hair_params(rig.hair_mat, case["params"])
    px = rig.render(rig.hair_mat)
    hrow = rig.row_h()
    H, W = px.shape[:2]
    hh = np.broadcast_to(hrow[:, None], (H, W))
    keep = np.abs(hh) <= rig.cfg["h_max"]
    alpha = px[..., 3]
    if not np.all(alpha[keep] > 0.9999):
        raise RuntimeError("case %s: strand does not cover |h| <= %g (alpha min %g)"
                           % (case["name"], rig.cfg["h_max"], alpha[keep].min()))
    # pixels well outside the strand must be empty
    outside = np.abs(hh) >= 1.0 + 2.0 * rig.pixel / rig.cfg["radius"]
    if np.any(alpha[outside] > 0.0):
        raise RuntimeError("case %s: coverage outside the strand" % case["name"])
    rows, cols = np.nonzero(keep)
    n = rows.size
    out = dict(
        wo=np.tile(_frame_coords(wo, wo), (n, 1)),
        wi=np.tile(_frame_coords(wi, wo), (n, 1)),
        h=hh[rows, cols].astype(np.float64),
        rgb=px[rows, cols, :3] / case["sun_strength"],
        row=rows.astype(np.int16), col=cols.astype(np.int16),
        h_probe=np.full(n, np.nan),
    )
    if probe:
        hp, _ = rig.probe_h(wo)
        out["h_probe"] = hp[rows, cols]
    return out


EDGE_SHIFT_PX = 0.3   # the alpha check moves the camera by this fraction of a pixel across the strand
EDGE_ALPHA_SPP = 16


def edge_alpha_check(scene, camera, pixel, render):
    """Does the pixel filter sample the pixel centre? The check relies on it (README, "Why 1 spp
    with a narrow Blackman-Harris filter"), and a Blender that ignores the setting (another
    property name, a BOX filter that is always 1 px wide) would spread the samples over the
    pixel. The strand's edges lie on pixel boundaries; this moves the camera by EDGE_SHIFT_PX
    of a pixel across the strand and renders EDGE_ALPHA_SPP samples with the scene's filter:
    sampled at the centre, every edge pixel is empty or covered (alpha 0 or 1, up to the rare
    far filter sample); spread over the pixel, the two edge rows get alpha 0.3 and 0.7.
    `render()` returns the RGBA pixels (row 0 = bottom). Returns the facts for meta['checks']."""
    cy = scene.cycles
    saved_spp = cy.samples
    m = camera.matrix_world.copy()
    up = m.to_3x3().col[1].normalized()  # the image's up axis Yc in world space
    shifted = m.copy()
    shifted.translation = m.translation + up * (EDGE_SHIFT_PX * pixel)
    camera.matrix_world = shifted
    cy.samples = EDGE_ALPHA_SPP
    try:
        px = render()
    finally:
        camera.matrix_world = m
        cy.samples = saved_spp
    alpha = np.asarray(px, dtype=np.float64)[..., 3]
    row_max = alpha.max(axis=1)
    covered = np.nonzero(row_max > 0.0)[0]
    edge_rows = [int(covered[0]), int(covered[-1])] if covered.size else []
    return dict(edge_alpha_spp=EDGE_ALPHA_SPP, edge_alpha_shift_px=EDGE_SHIFT_PX,
                edge_alpha_filter=[cy.pixel_filter_type, float(cy.filter_width)],
                edge_alpha_rows=edge_rows,
                edge_alpha_values=[[float(a) for a in alpha[r]] for r in edge_rows],
                edge_alpha_max_fraction=float(np.max(np.minimum(alpha, 1.0 - alpha))),
                edge_alpha_rows_covered=int(np.sum(alpha.min(axis=1) >= 0.5)))


def run_checks(rig, case):
    """One-off facts measured on this Blender (stored in meta['checks'])."""
    checks = {}
    sc = rig.scene
    wo, wi = rig.set_geometry(case)
    fg.set_hair_params(rig.hair_mat, case["params"])
    base = rig.render(rig.hair_mat)
    keep = np.abs(rig.row_h()) <= rig.cfg["h_max"]  # rows
    b = base[keep, :, :3]

    def rel(a):
        return float(np.max(np.abs(a[keep, :, :3] - b)) / max(np.max(np.abs(b)), 1e-30))

    # 1. pixel is linear in the sun strength
    s0 = rig.sun.data.energy
    rig.sun.data.energy = 2.0 * s0
    checks["strength_x2_max_rel_dev"] = float(np.max(np.abs(rig.render()[keep, :, :3] - 2.0 * b))
                                              / max(np.max(np.abs(2.0 * b)), 1e-30))
    rig.sun.data.energy = s0
    # 2. bounce limits do not matter for direct light from the sun
    cy = sc.cycles
    saved = {k: getattr(cy, k) for k in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                                          "transmission_bounces", "transparent_max_bounces")}
    for k in saved:
        setattr(cy, k, 12)
    checks["bounces12_max_rel_dev"] = rel(rig.render())
    for k, v in saved.items():
        setattr(cy, k, v)
    checks["max_bounces0_nonzero"] = bool(np.max(b) > 0.0)
    # 3. light tree (4.x)
    if hasattr(cy, "use_light_tree"):
        lt = cy.use_light_tree
        cy.use_light_tree = not lt
        checks["light_tree_toggled_max_rel_dev"] = rel(rig.render())
        cy.use_light_tree = lt
    # 4. 16 spp (the filter is sampled away from the pixel centre for some samples)
    spp, pf, fw = cy.samples, cy.pixel_filter_type, cy.filter_width
    cy.samples = 16
    checks["spp16_bh001_max_rel_dev"] = rel(rig.render())
    cy.pixel_filter_type, cy.filter_width = "BOX", 0.01
    checks["spp16_box001_max_rel_dev"] = rel(rig.render())
    cy.samples, cy.pixel_filter_type, cy.filter_width = spp, pf, fw
    # 4b. the filter samples the pixel centre: the strand's edge pixels are empty or covered
    checks.update(edge_alpha_check(sc, rig.camera, rig.pixel, rig.render))
    # 5. Hair Info of the strand: Random (curve 0), Is Strand
    info = rig.hair_info()
    checks["hair_info_random"] = [float(info[keep, :, 0].min()), float(info[keep, :, 0].max())]
    checks["hair_info_is_strand"] = [float(info[keep, :, 1].min()), float(info[keep, :, 1].max())]
    # 6. evaluated geometry
    pos, rad, ncurves = fg.evaluated_strand_points(rig.strand)
    checks["n_curves"] = ncurves
    checks["n_points"] = len(pos)
    checks["radius_minmax"] = [min(rad), max(rad)]
    checks["points_straight_on_x"] = bool(all(abs(p[1]) < 1e-7 and abs(p[2]) < 1e-7 for p in pos)
                                          and all(pos[k + 1][0] > pos[k][0] for k in range(len(pos) - 1)))
    return checks


def render_to_npz(out_path, which="small", case_filter=None, probe=True, checks=True,
                  strand_method="geometry_nodes", threads=2, scene_overrides=None, verbose=True):
    cfg = dict(case_defs.SCENE)
    cfg.update(scene_overrides or {})
    case_list = case_defs.get_cases(which)
    if case_filter:
        case_list = [c for c in case_list if case_filter in c["name"]]
    t0 = time.time()
    rig = Rig(cfg, strand_method=strand_method, threads=threads)
    try:
        meta_checks = run_checks(rig, case_list[0]) if checks else {}
        parts = []
        for k, case in enumerate(case_list):
            t = time.time()
            d = render_case(rig, case, probe=probe)
            d["case"] = np.full(d["h"].shape, k, dtype=np.int32)
            parts.append(d)
            if verbose:
                print("[render_cases] %3d/%d %-45s %4d px  max %.4g  %.2fs"
                      % (k + 1, len(case_list), case["name"], d["h"].size,
                         float(np.max(d["rgb"])), time.time() - t), flush=True)
    finally:
        rig.close()
    arrays = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    meta = dict(
        blender_version=list(fg.blender_version()),
        blender_version_string=fg.blender_version_string(),
        tilt=fg.default_tilt_convention(),
        has_model_enum=fg.has_hair_model_enum(),
        case_set=which, case_filter=case_filter, strand_method=strand_method,
        scene=cfg, cases=case_list, checks=meta_checks,
        pixel_size=rig.pixel, n_renders=rig.n_renders,
        render_seconds=time.time() - t0,
        rgb_is="pixel / sun strength",
    )
    arrays["meta"] = np.array(json.dumps(meta))
    tmp = "%s.%d.tmp.npz" % (out_path, os.getpid())
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, out_path)
    if verbose:
        print("[render_cases] wrote %s (%d cases, %d pixels, %d renders, %.1fs)"
              % (out_path, len(case_list), arrays["h"].size, rig.n_renders, time.time() - t0),
              flush=True)
    return out_path


def _parse(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--cases", default="small", choices=sorted(case_defs.CASE_SETS))
    ap.add_argument("--filter", default=None, help="only cases whose name contains this")
    ap.add_argument("--no-probe", action="store_true", help="skip the position-probe renders")
    ap.add_argument("--no-checks", action="store_true")
    ap.add_argument("--strand-method", default="geometry_nodes",
                    choices=["geometry_nodes", "add_curves"])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--spp", type=int, default=None)
    ap.add_argument("--pixel-filter", default=None)
    ap.add_argument("--filter-width", type=float, default=None)
    return ap.parse_args(argv)


def main(argv=None):
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    a = _parse(argv)
    over = {}
    if a.spp is not None:
        over["spp"] = a.spp
    if a.pixel_filter is not None:
        over["pixel_filter"] = a.pixel_filter
    if a.filter_width is not None:
        over["filter_width"] = a.filter_width
    render_to_npz(os.path.abspath(a.out), a.cases, a.filter, probe=not a.no_probe,
                  checks=not a.no_checks, strand_method=a.strand_method, threads=a.threads,
                  scene_overrides=over)


if __name__ == "__main__":
    main()
