"""The comparison harness's scene library: metadata only (no bpy), read by
``hairbsdf.compare`` outside Blender and by ``build_scene.py`` inside it.

Each entry:
  module       builder module in this folder; it has ``build(scene, cfg) -> info dict``
  kind         "deterministic": noise-free renders (1 spp at the pixel centre, delta light),
               compared per pixel by relative error; "noisy": Monte Carlo renders over several
               seeds, compared with the Welch test and the image-mean bias
  model        the hair model the scene exercises ("chiang", "huang")
  min_blender  oldest Blender that can build it ((4, 0, 0) for 4.x-only features)
  variants     None, or names of variants that are compared separately (e.g. curve shapes)
  variant_min_blender  optional {variant: oldest Blender} for variants newer than the scene
  image_mean   True: also gate |image mean / Cycles' image mean - 1| (the furnace)
  cycles_defaults  True: the scene keeps Cycles' default Filter Glossy, Clamp Indirect and Light
               Threshold on purpose (the report lists them as parity warnings)
  deliberate_settings  {setting: value} the builder sets away from parity on purpose (the report
               lists them as parity warnings; test_harness_scenes checks them)
  ci / full    default sizes: res (W, H), spp per render, seeds (independent renders per engine)
  title, description  for the report and --list-scenes
"""

DEFAULT_SCENE = "swatch"

SCENES = {
    "fiber_gonio": dict(
        module="fiber_gonio_grid", kind="deterministic", model="chiang", min_blender=(3, 4, 0),
        variants=["front", "back", "side"],
        ci=dict(res=(256, 192), spp=1, seeds=1), full=dict(res=(640, 480), spp=1, seeds=1),
        title="Fibre goniometer grid",
        description="12 straight strands at 4 inclinations x 3 in-plane angles, six materials, an orthographic "
                    "camera and one delta sun per variant (front-, back- and side-lit): every pixel is one BSDF "
                    "evaluation, so the render is noise-free and compared per pixel (median and p99 of the "
                    "relative error)."),
    "fiber_gonio_huang": dict(
        module="fiber_gonio_grid", kind="noisy", model="huang", min_blender=(4, 0, 0),
        variants=["huang_front", "huang_back", "huang_side"],
        ci=dict(res=(192, 144), spp=16, seeds=4), full=dict(res=(384, 288), spp=32, seeds=8),
        title="Fibre goniometer grid, Huang model",
        description="The fibre_gonio grid with four Huang materials (circular and elliptical fibres, lobe "
                    "factors), direct light from one delta sun per variant. Cycles' Huang eval is stochastic, "
                    "so the renders are compared statistically (Welch test and image-mean bias), not per pixel. "
                    "Blender 4.x only."),
    "furnace": dict(
        module="furnace", kind="noisy", model="chiang", min_blender=(3, 4, 0), variants=None, image_mean=True,
        ci=dict(res=(64, 64), spp=8, seeds=4), full=dict(res=(192, 192), spp=32, seeds=8),
        title="White furnace",
        description="A slab of non-absorbing hair (sigma_a = 0) in a uniform white world, 32 bounces: the image "
                    "mean must match Cycles' own (not 1: Cycles loses energy to its truncated Bessel series)."),
    "swatch": dict(
        module="swatch", kind="noisy", model="chiang", min_blender=(3, 4, 0), variants=None,
        ci=dict(res=(128, 96), spp=8, seeds=4), full=dict(res=(320, 240), spp=16, seeds=8),
        title="Hair swatch",
        description="160 straight, slightly wavy strands hanging from a bar, an area light plus a dim world, "
                    "16 bounces (multiple scattering between strands)."),
    "melanin_sweep": dict(
        module="melanin_sweep", kind="noisy", model="chiang", min_blender=(3, 4, 0), variants=None,
        ci=dict(res=(160, 96), spp=8, seeds=4), full=dict(res=(400, 240), spp=32, seeds=8),
        title="Melanin sweep",
        description="5 x 3 small swatches from blonde to black (melanin 0.05..0.95) and from neutral to red "
                    "(redness 0, 0.5, 1), lit by a soft sun and a dim world."),
    "fur_ball": dict(
        module="fur_ball", kind="noisy", model="chiang", min_blender=(3, 4, 0), variants=None,
        ci=dict(res=(96, 96), spp=8, seeds=4), full=dict(res=(256, 256), spp=32, seeds=16),
        title="Fur ball",
        description="Particle hair on a diffuse sphere; Random Color, Random Roughness and a Coat driven by "
                    "Hair Info > Random; a point light and a dim world."),
    "shading_network": dict(
        module="shading_network", kind="noisy", model="chiang", min_blender=(3, 4, 0), variants=None,
        ci=dict(res=(128, 96), spp=8, seeds=4), full=dict(res=(320, 240), spp=16, seeds=8),
        title="Inputs from node networks",
        description="The swatch's strands with Melanin from a B-spline ColorRamp on Hair Info > Intercept and "
                    "Roughness from a clamped Map Range on Hair Info > Random, evaluated per hit by the "
                    "engine's shading VM; an area light and a dim world."),
    "ribbons_vs_3d": dict(
        module="ribbons_vs_3d", kind="noisy", model="chiang", min_blender=(3, 4, 0),
        variants=["RIBBONS", "THICK", "THICK_LINEAR"], variant_min_blender=dict(THICK_LINEAR=(5, 0, 0)),
        # 16 CI seeds: single renders are heavy-tailed here (one seed's image mean ranges 0.96-1.04 x the
        # mean), and 4 seeds made a -2.3 % "bias" (z -4.9) that 16 seeds show to be chance (-0.26 %, z -0.5).
        ci=dict(res=(128, 96), spp=8, seeds=16), full=dict(res=(320, 240), spp=32, seeds=8),
        title="Ribbons vs 3D curves",
        description="Thick wavy strands seen from close by, rendered as Rounded Ribbons, as 3D Curves and "
                    "(Blender 5.x) as Linear 3D Curves (one variant each)."),
    "mixed": dict(
        module="mixed", kind="noisy", model="chiang", min_blender=(3, 4, 0), variants=None,
        ci=dict(res=(128, 96), spp=8, seeds=4), full=dict(res=(320, 240), spp=32, seeds=8),
        title="Mixed shaders on a scalp",
        description="A diffuse mesh scalp with two particle-hair systems: Mix Shader (Principled Hair, Hair BSDF "
                    "reflection) and Add Shader (Principled Hair, Hair BSDF transmission)."),
    "hdri_swatch": dict(
        module="hdri_swatch", kind="noisy", model="chiang", min_blender=(3, 4, 0), variants=None,
        cycles_defaults=True,
        ci=dict(res=(128, 96), spp=8, seeds=4), full=dict(res=(320, 240), spp=32, seeds=8),
        title="Swatch under an HDRI, Cycles' default settings",
        description="The swatch's strands lit only by an equirectangular environment texture (sky gradient, "
                    "ground, a soft sun blob), with Cycles' default Filter Glossy 1, Clamp Indirect 10 and "
                    "Light Threshold 0.01."),
    "huang_ellipse": dict(
        module="huang_ellipse", kind="noisy", model="huang", min_blender=(4, 0, 0), variants=None,
        ci=dict(res=(128, 96), spp=8, seeds=8), full=dict(res=(320, 240), spp=32, seeds=8),
        title="Huang model, elliptical fibres",
        description="Three swatches of the Huang model with aspect ratios 0.5, 0.8 and 1.0; the ellipse axes "
                    "follow the curve normals (Z Up and Minimum Twist). Blender 4.x only."),
    "user_scene": dict(
        module="user_scene", kind="noisy", model="chiang", min_blender=(3, 4, 0), variants=None,
        deliberate_settings={"cycles.sample_clamp_direct": 2.0, "cycles.sample_clamp_indirect": 0.5},
        ci=dict(res=(128, 96), spp=8, seeds=4), full=dict(res=(256, 192), spp=16, seeds=8),
        title="A user's scene",
        description="What users' scenes reach: particle hair on a sheared emitter, Curves under a negative "
                    "scale, a ground mesh textured through its UVs, sun, point, spot and area lights, Clamp "
                    "Direct 2 and Indirect 0.5, an HDRI world and an emissive quad."),
}
