"""swatch: 160 straight, slightly wavy strands hanging from a bar; an area light plus a dim
world; 16 bounces, so light scatters between strands.  The default scene of scripts/compare."""

import scene_lib as lib

COUNT = 160
POINTS = 12
MATERIAL = dict(parametrization="MELANIN", melanin=0.3, melanin_redness=0.5, tint=(1.0, 1.0, 1.0), roughness=0.3,
                radial_roughness=0.3, coat=0.0, ior=1.55, offset=0.0349066, random_color=0.0,
                random_roughness=0.0)


def strands():
    r = lib.rng(5)
    lines, radii = [], []
    for k in range(COUNT):
        x = -0.3 + 0.6 * (k + r.uniform(0.1, 0.9)) / COUNT
        y = r.uniform(-0.04, 0.04)
        length = 1.0 + r.uniform(-0.05, 0.05)
        pts = lib.wavy_strand((x, y, 0.5), (0, 0, -1), length, POINTS, r, wave=0.03, wave_axis=(0.3, 1, 0))
        lines.append(pts)
        radii.append([0.004 - 0.002 * i / (POINTS - 1) for i in range(POINTS)])
    return lines, radii


def build(scene, cfg):
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        curve_shape="THICK", subdivisions=3, osl=cfg.get("osl", False))
    lib.set_world(scene, (0.08, 0.09, 0.1), 1.0)
    lines, radii = strands()
    mat = lib.hair_material("SwatchHair", MATERIAL)
    lib.curves_from_polylines(scene, "Swatch", lines, radii, mat)
    lib.perspective_camera(scene, (0.0, -2.2, 0.05), (0.0, 0.0, 0.0), lens=50.0)
    lib.area_light(scene, (1.2, -1.5, 1.0), (0.0, 0.0, 0.0), energy=60.0, size=0.8)
    return dict(strands=len(lines), material=MATERIAL)
