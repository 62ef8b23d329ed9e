"""huang_ellipse (Blender 4.x only): three swatches of the Huang model with aspect ratios
0.5, 0.8 and 1.0.  The strands run along X; the ellipse's major axis follows the curve
normal (Set Curve Normal: Z Up for the first two swatches, Minimum Twist for the third)."""

import scene_lib as lib

SWATCHES = ((0.5, "Z_UP"), (0.8, "Z_UP"), (1.0, "MINIMUM_TWIST"))


def build(scene, cfg):
    if not lib.has_model_enum():
        raise RuntimeError("huang_ellipse needs Blender 4.0+ (Principled Hair model enum)")
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        bounces=dict(glossy_bounces=16), curve_shape="THICK", subdivisions=3,
                        osl=cfg.get("osl", False))
    lib.set_world(scene, (0.05, 0.05, 0.06), 1.0)
    r = lib.rng(21)
    for k, (aspect, normal) in enumerate(SWATCHES):
        mat = lib.hair_material("Huang%d" % k, dict(model="HUANG", parametrization="MELANIN", melanin=0.3,
                                                   melanin_redness=0.5, tint=(1.0, 1.0, 1.0), roughness=0.3,
                                                   ior=1.55, offset=0.0349066, aspect_ratio=aspect))
        z0 = 0.3 - 0.3 * k
        lines = [lib.wavy_strand((-0.4, r.uniform(-0.03, 0.03), z0 + 0.2 * (j + r.uniform(0.2, 0.8)) / 20 - 0.1),
                                 (1, 0, 0), 0.8, 10, r, wave=0.02, wave_axis=(0, 0, 1)) for j in range(20)]
        lib.curves_from_polylines(scene, "HuangSwatch%d" % k, lines, 0.005, mat, curve_normal=normal)
    lib.perspective_camera(scene, (0.0, -1.8, 0.1), (0.0, 0.0, 0.0), lens=50.0)
    lib.area_light(scene, (0.8, -1.2, 1.0), (0.0, 0.0, 0.0), energy=40.0, size=0.6)
    return dict(swatches=[dict(aspect_ratio=a, normal=n) for a, n in SWATCHES])
