"""fur_ball: particle hair on a diffuse sphere.  The hair material uses Random Color and
Random Roughness, and its Coat is driven by Hair Info > Random (times 0.6); a point light and
a dim world."""

import scene_lib as lib

MATERIAL = dict(parametrization="MELANIN", melanin=0.45, melanin_redness=0.6, tint=(1.0, 1.0, 1.0),
                roughness=0.35, radial_roughness=0.35, ior=1.55, offset=0.0349066, random_color=0.5,
                random_roughness=0.4)
COAT_FROM_RANDOM = 0.6


def build(scene, cfg):
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        curve_shape="THICK", subdivisions=3, osl=cfg.get("osl", False))
    lib.set_world(scene, (0.05, 0.05, 0.05), 1.0)
    ball = lib.uv_sphere(scene, "FurBall", 0.25, segments=32, rings=16)
    ball.data.materials.append(lib.diffuse_material("FurSkin", (0.2, 0.15, 0.1)))
    ball.data.materials.append(lib.hair_material("FurHair", MATERIAL, coat_from_hair_info=COAT_FROM_RANDOM))
    lib.particle_hair(scene, ball, "Fur", count=1500, length=0.1, seed=7, material_slot=2, radius=0.0025,
                      tip_radius=0.0005, render_step=3, random_factor=0.03)
    lib.perspective_camera(scene, (0.0, -1.3, 0.3), (0.0, 0.0, 0.0), lens=50.0)
    lib.point_light(scene, (0.8, -0.8, 0.9), energy=40.0, radius=0.1)
    return dict(strands=1500, material=MATERIAL, coat_from_hair_info=COAT_FROM_RANDOM)
