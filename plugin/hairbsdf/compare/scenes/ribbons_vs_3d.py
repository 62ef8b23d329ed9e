"""ribbons_vs_3d: thick wavy strands seen from close by; the variant picks the curve shape
(RIBBONS = Rounded Ribbons, THICK = 3D Curves, THICK_LINEAR = Linear 3D Curves, Blender 5.x).  An area light in front and a sun behind."""

import scene_lib as lib

MATERIAL = dict(parametrization="COLOR", color=(0.35, 0.2, 0.1), roughness=0.25, radial_roughness=0.3, coat=0.1,
                ior=1.55, offset=0.0349066)


def build(scene, cfg):
    shape = (cfg.get("variant") or "THICK").upper()  # THICK_LINEAR: 5.0+, refused from the catalog
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        curve_shape=shape, subdivisions=3, osl=cfg.get("osl", False))
    lib.set_world(scene, (0.04, 0.04, 0.05), 1.0)
    r = lib.rng(9)
    lines = []
    for k in range(40):
        x = -0.25 + 0.5 * (k + r.uniform(0.2, 0.8)) / 40
        lines.append(lib.wavy_strand((x, r.uniform(-0.05, 0.05), 0.35), (0.1, 0, -1), 0.7, 14, r, wave=0.05,
                                     wave_axis=(1, 0.5, 0)))
    mat = lib.hair_material("RibbonHair", MATERIAL)
    lib.curves_from_polylines(scene, "Strands", lines, 0.008, mat)
    lib.perspective_camera(scene, (0.25, -1.1, 0.1), (0.0, 0.0, 0.0), lens=50.0)
    lib.area_light(scene, (-0.8, -1.0, 0.8), (0.0, 0.0, 0.0), energy=30.0, size=0.5)
    lib.sun_light(scene, (0.2, 1.0, 0.3), 2.0, angle_deg=2.0)
    return dict(shape=shape, strands=len(lines))
