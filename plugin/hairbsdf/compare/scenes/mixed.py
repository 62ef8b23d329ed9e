"""mixed: a diffuse mesh scalp (half sphere) with two particle-hair systems:
  * Mix Shader (Fac 0.35) of Principled Hair (melanin) and Hair BSDF (Reflection);
  * Add Shader of Principled Hair (colour) and Hair BSDF (Transmission).
An area light and a dim world."""

import scene_lib as lib


def build(scene, cfg):
    w, h = cfg["res"]
    lib.parity_settings(scene, width=w, height=h, spp=cfg["spp"], seed=cfg["seed"], threads=cfg.get("threads", 0),
                        curve_shape="THICK", subdivisions=3, osl=cfg.get("osl", False))
    lib.set_world(scene, (0.06, 0.06, 0.07), 1.0)
    scalp = lib.uv_sphere(scene, "Scalp", 0.3, segments=32, rings=16, hemisphere=True)
    scalp.data.materials.append(lib.diffuse_material("Skin", (0.6, 0.4, 0.3)))
    scalp.data.materials.append(lib.mix_hair_material(
        "MixHair", 0.35,
        dict(parametrization="MELANIN", melanin=0.4, melanin_redness=0.4, tint=(1.0, 1.0, 1.0), roughness=0.3,
             radial_roughness=0.3, coat=0.0, ior=1.55, offset=0.0349066),
        dict(component="Reflection", color=(0.8, 0.6, 0.4), offset_deg=0.0, roughness_u=0.1, roughness_v=1.0)))
    scalp.data.materials.append(lib.add_hair_material(
        "AddHair",
        dict(parametrization="COLOR", color=(0.2, 0.1, 0.05), roughness=0.35, radial_roughness=0.3, coat=0.0,
             ior=1.55, offset=0.0349066),
        dict(component="Transmission", color=(0.3, 0.2, 0.1), offset_deg=0.0, roughness_u=0.2, roughness_v=1.0)))
    lib.particle_hair(scene, scalp, "HairMix", count=600, length=0.15, seed=3, material_slot=2, radius=0.002,
                      tip_radius=0.0005, render_step=3, random_factor=0.05)
    lib.particle_hair(scene, scalp, "HairAdd", count=300, length=0.12, seed=4, material_slot=3, radius=0.002,
                      tip_radius=0.0005, render_step=3, random_factor=0.05)
    lib.perspective_camera(scene, (0.0, -1.4, 0.5), (0.0, 0.0, 0.12), lens=50.0)
    lib.area_light(scene, (1.0, -1.0, 1.2), (0.0, 0.0, 0.1), energy=40.0, size=0.6)
    return dict(systems=["HairMix: Mix(0.35, Principled, Hair Reflection)",
                         "HairAdd: Add(Principled, Hair Transmission)"])
