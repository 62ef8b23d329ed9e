"""furnace: a slab of non-absorbing hair (absorption coefficient 0) in a uniform white world.

Three layers of straight strands along X fill an orthographic view along +Y.  With sigma_a = 0
the only energy lost is what Cycles' model loses (truncated Bessel series) and what leaves the
32-bounce budget, so the image mean must equal Cycles' own image mean."""

import scene_lib as lib

LAYERS = 3
PER_LAYER = 90
RADIUS = 0.006
MATERIAL = dict(parametrization="ABSORPTION", absorption_coefficient=(0.0, 0.0, 0.0), roughness=0.3,
                radial_roughness=0.3, coat=0.0, ior=1.55, offset=0.0349066)


def build(scene, cfg):
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        bounces=dict(max_bounces=32, diffuse_bounces=4, glossy_bounces=32,
                                     transmission_bounces=32, volume_bounces=0, transparent_max_bounces=8),
                        curve_shape="THICK", subdivisions=3, osl=cfg.get("osl", False))
    lib.set_world(scene, (1.0, 1.0, 1.0), 1.0)
    r = lib.rng(11)
    lines = []
    spacing = 1.2 / PER_LAYER
    for layer in range(LAYERS):
        y = -0.04 + 0.04 * layer
        for k in range(PER_LAYER):
            z = -0.6 + (k + 0.5 + layer / LAYERS) * spacing
            z0, z1 = z + r.uniform(-0.2, 0.2) * spacing, z + r.uniform(-0.2, 0.2) * spacing
            y0, y1 = y + r.uniform(-0.008, 0.008), y + r.uniform(-0.008, 0.008)
            n = 8
            lines.append([(-0.8 + 1.6 * i / (n - 1), y0 + (y1 - y0) * i / (n - 1), z0 + (z1 - z0) * i / (n - 1))
                          for i in range(n)])
    mat = lib.hair_material("FurnaceHair", MATERIAL)
    lib.curves_from_polylines(scene, "FurnaceSlab", lines, RADIUS, mat)
    lib.ortho_camera(scene, (0.0, -3.0, 0.0), (0.0, 0.0, 0.0), ortho_scale=0.9)
    return dict(strands=len(lines), material=MATERIAL, world=1.0)
