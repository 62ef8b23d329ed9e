"""Case sets of the Huang BSDF check against Cycles 4.5 (see README_huang.md).

Pure Python (no numpy, no bpy): imported by render_huang.py inside bpy and by
test_huang_check.py. Angles in degrees, node inputs in hairbsdf's snake_case keys plus
``parametrization`` (Blender's enum spelling); ``normal`` is the curve normal in world space
(the strand runs along world +x), used by the elliptical cases.
"""

# Every node input is set for every case (a socket keeps its value from the previous case
# otherwise): Blender 4.5's defaults, then the material's own values.
DEFAULTS = dict(color=(0.017513, 0.005763, 0.002059), melanin=0.8, melanin_redness=1.0, tint=(1.0, 1.0, 1.0),
                absorption_coefficient=(0.245531, 0.52, 1.365), roughness=0.3, radial_roughness=0.3, coat=0.0,
                ior=1.55, offset=0.0349066, random_color=0.0, random_roughness=0.0, aspect_ratio=0.85,
                reflection=1.0, transmission=1.0, secondary_reflection=1.0)

MATERIALS = {
    # Blender's default colour, default roughness, 2 deg offset, circular.
    "default": dict(parametrization="COLOR", color=(0.017513, 0.005763, 0.002059), roughness=0.3,
                    ior=1.55, offset=0.0349066, aspect_ratio=1.0),
    # Nearly clear fibre: strong TT and TRT.
    "clear": dict(parametrization="ABSORPTION", absorption_coefficient=(0.04, 0.09, 0.2), roughness=0.25,
                  ior=1.55, offset=0.05, aspect_ratio=1.0),
    # Smooth blond melanin, other IOR, negative offset, random roughness (curve 0's hash).
    "smooth": dict(parametrization="MELANIN", melanin=0.35, melanin_redness=0.6, tint=(1.0, 1.0, 1.0),
                   roughness=0.12, ior=1.6, offset=-0.03, random_roughness=0.3, aspect_ratio=1.0),
    # Rough, IOR 1.4, lobe factors.
    "rough_factors": dict(parametrization="ABSORPTION", absorption_coefficient=(0.2, 0.5, 1.1), roughness=0.6,
                          ior=1.4, offset=0.02, reflection=0.8, transmission=1.2, secondary_reflection=0.5,
                          aspect_ratio=1.0),
    # Elliptical, curve normal tilted in the cross-section plane.
    "ellipse": dict(parametrization="ABSORPTION", absorption_coefficient=(0.1, 0.25, 0.6), roughness=0.3,
                    ior=1.55, offset=0.035, aspect_ratio=0.7, normal=(0.0, 0.6, 0.8)),
    # Aspect ratio > 1 (Cycles inverts it and keeps the major axis on the normal).
    "ellipse_inv": dict(parametrization="COLOR", color=(0.6, 0.4, 0.25), roughness=0.35, ior=1.55,
                        offset=0.035, aspect_ratio=1.4, normal=(0.0, 1.0, 0.0)),
}

GEOMETRIES = [  # (theta_o, theta_i, dphi)
    (-40, 25, 140), (0, -20, 176), (30, -25, 55), (30, -50, -115), (-40, 50, 95), (0, 10, 12),
    (30, -30, 171), (-40, 35, -160), (0, -60, 140), (30, 20, -35),
]

SUN_STRENGTHS = (1.0, 3.0, 0.5)


def _cases(materials, geometries, prefix):
    out = []
    k = 0
    for gi, (to, ti, dp) in enumerate(geometries):
        for mi, mat in enumerate(materials):
            if (gi + mi) % 2:  # a checkerboard of the product keeps the set small
                continue
            out.append(dict(name="%s_%s_to%+g_ti%+g_dp%+g" % (prefix, mat, to, ti, dp), theta_o=to, theta_i=ti,
                            dphi=dp, psi=(70.0 + 47.0 * k) % 360.0, material=mat,
                            params=dict(DEFAULTS, **MATERIALS[mat]),
                            sun_strength=SUN_STRENGTHS[k % 3]))
            k += 1
    return out


def near_cases():
    return _cases(["default", "clear", "smooth", "rough_factors", "ellipse", "ellipse_inv"], GEOMETRIES[:6], "near")


def far_cases():
    return _cases(["default", "clear", "smooth", "rough_factors", "ellipse", "ellipse_inv"], GEOMETRIES[4:], "far")


CASE_SETS = {"near": near_cases, "far": far_cases}

# Scenes (CI size: one seed of both sets renders in about 2 min on 2 cores; docs/huang.md section 8's
# multi-seed measurements were made at 512 and 8192 spp). Near field: camera rays, pixel_coverage = 0.5 dP / r = 1 / pixels_across.
NEAR = dict(radius=0.05, length=1.0, n_points=9, width=96, height=72, pixels_across=60.0, spp=256,
            pixel_filter="BLACKMAN_HARRIS", filter_width=0.01, seed=0, camera_distance=0.25, h_max=0.97)
# Far field: pixels three radii tall (pixel_coverage 1.5 > the projected radius): one row of pixels
# along the strand, each an independent estimate of the h-independent far-field value.
FAR = dict(radius=0.005, length=1.0, n_points=9, width=48, height=4, pixel_size_in_radii=3.0, spp=4096,
           pixel_filter="BLACKMAN_HARRIS", filter_width=0.01, seed=0, camera_distance=0.25)


def get_cases(which):
    try:
        return CASE_SETS[which]()
    except KeyError:
        raise ValueError("unknown case set %r (choose from %s)" % (which, sorted(CASE_SETS)))
