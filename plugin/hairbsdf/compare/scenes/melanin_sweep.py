"""melanin_sweep: 5 x 3 small swatches, melanin 0.05..0.95 (blonde to black) across, melanin
redness 0, 0.5, 1 down; a soft sun and a dim world."""

import scene_lib as lib

MELANIN = (0.05, 0.25, 0.45, 0.7, 0.95)
REDNESS = (0.0, 0.5, 1.0)
PER_CELL = 10
POINTS = 8


def build(scene, cfg):
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        curve_shape="THICK", subdivisions=3, osl=cfg.get("osl", False))
    lib.set_world(scene, (0.05, 0.05, 0.06), 1.0)
    r = lib.rng(3)
    cells = []
    for row, red in enumerate(REDNESS):
        for col, mel in enumerate(MELANIN):
            cx, cz = (col - 2) * 0.4, (1 - row) * 0.4
            mat = lib.hair_material("Sweep_m%02d_r%02d" % (round(mel * 100), round(red * 100)),
                                    dict(parametrization="MELANIN", melanin=mel, melanin_redness=red,
                                         tint=(1.0, 1.0, 1.0), roughness=0.3, radial_roughness=0.3, coat=0.0,
                                         ior=1.55, offset=0.0349066))
            lines = []
            for k in range(PER_CELL):
                x = cx - 0.14 + 0.28 * (k + r.uniform(0.2, 0.8)) / PER_CELL
                lines.append(lib.wavy_strand((x, r.uniform(-0.02, 0.02), cz + 0.16), (0, 0, -1), 0.32, POINTS, r,
                                             wave=0.01))
            lib.curves_from_polylines(scene, "Sweep%d%d" % (row, col), lines, 0.006, mat)
            cells.append(dict(row=row, col=col, melanin=mel, redness=red))
    lib.ortho_camera(scene, (0.0, -3.0, 0.0), (0.0, 0.0, 0.0), ortho_scale=2.1)
    lib.sun_light(scene, (0.4, -0.8, 0.5), 3.0, angle_deg=3.0)
    return dict(cells=cells)
