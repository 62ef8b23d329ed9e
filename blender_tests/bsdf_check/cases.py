"""Case grid of the BSDF-level check against real Cycles.

Pure Python (no numpy, no bpy): imported by render_cases.py inside Blender and by
test_bsdf_check.py in the venv.

A case = one render = (view direction, light direction, sun strength, node inputs).
Angles in degrees; node inputs use the snake_case keys of
``hairbsdf.principled_hair`` plus ``parametrization`` in Blender's enum spelling.

Geometry grid: theta_o in {-40, 0, 30}, theta_i in {-60, -20, 0, 25, 50} and
dphi = phi_i - phi_o in DPHI_FULL (never 0 or 180 exactly: no sun exactly
behind the camera or exactly behind the strand).  psi (the azimuth of the
camera around the strand axis in world space) varies between cases; the model
must not depend on it, so it also checks the frame construction.
"""

THETA_O = (-40.0, 0.0, 30.0)
THETA_I = (-60.0, -20.0, 0.0, 25.0, 50.0)
# dphi spread around the fibre: forward scattering near 180 deg (backlit TT),
# side lighting, and near-retro reflection (sun close to the camera, but never
# exactly behind it).
DPHI_FULL = (12.0, 55.0, 95.0, 140.0, 171.0, 178.5, -35.0, -115.0, -160.0)
DPHI_SMALL = (55.0, 140.0, 176.0, -115.0)

# Node inputs. Offset in radians.  random_color only acts in the MELANIN mode
# (docs/cycles.md §2.3); the others still set it to check that it is ignored.
MATERIALS = {
    # Direct coloring, Blender default colour, default roughness, 2 deg offset.
    "color_default": dict(
        parametrization="COLOR", color=(0.017513, 0.005763, 0.002059),
        roughness=0.3, radial_roughness=0.3, coat=0.0, ior=1.55, offset=0.0349066,
        random_color=0.0, random_roughness=0.0),
    # Direct coloring, light blond, coat, random roughness, negative offset.
    "color_blond_coat": dict(
        parametrization="COLOR", color=(0.62, 0.45, 0.28),
        roughness=0.45, radial_roughness=0.65, coat=0.4, ior=1.55, offset=-0.05,
        random_color=0.7, random_roughness=0.35),
    # Melanin with tint, random colour and random roughness, low roughness.
    "melanin_tint_random": dict(
        parametrization="MELANIN", melanin=0.35, melanin_redness=0.6, tint=(0.9, 0.7, 0.8),
        roughness=0.2, radial_roughness=0.25, coat=0.0, ior=1.55, offset=0.05,
        random_color=0.5, random_roughness=0.4),
    # Dark melanin, other IOR, coat.
    "melanin_dark_ior17": dict(
        parametrization="MELANIN", melanin=0.85, melanin_redness=0.2, tint=(1.0, 1.0, 1.0),
        roughness=0.4, radial_roughness=0.5, coat=0.15, ior=1.7, offset=0.02,
        random_color=0.3, random_roughness=0.0),
    # Absorption, very rough, strong coat, IOR 1.4.
    "absorption_rough_coat": dict(
        parametrization="ABSORPTION", absorption_coefficient=(0.2, 0.5, 1.1),
        roughness=0.8, radial_roughness=0.8, coat=0.8, ior=1.4, offset=-0.03,
        random_color=0.0, random_roughness=0.2),
    # Absorption, nearly transparent fibre: strong TT/TRT, offset -> visible tilt.
    "absorption_clear": dict(
        parametrization="ABSORPTION", absorption_coefficient=(0.04, 0.09, 0.2),
        roughness=0.25, radial_roughness=0.35, coat=0.0, ior=1.55, offset=0.05,
        random_color=0.0, random_roughness=0.0),
    # Direct coloring, bright, smooth radial / rough longitudinal, IOR 1.3.
    "color_bright_ior13": dict(
        parametrization="COLOR", color=(0.85, 0.8, 0.7),
        roughness=0.6, radial_roughness=0.2, coat=0.3, ior=1.3, offset=-0.04,
        random_color=0.0, random_roughness=0.5),
}

SUN_STRENGTHS = (1.0, 3.0, 0.5)


def _case(name, theta_o, theta_i, dphi, psi, material, strength):
    return dict(name=name, theta_o=theta_o, theta_i=theta_i, dphi=dphi, psi=psi,
                material=material, params=dict(MATERIALS[material]),
                sun_strength=strength)


def full_cases():
    """Every material on every (theta_o, theta_i, dphi) of the full grid."""
    out = []
    k = 0
    for material in MATERIALS:
        for to in THETA_O:
            for ti in THETA_I:
                for dp in DPHI_FULL:
                    psi = (70.0 + 47.0 * k) % 360.0
                    strength = SUN_STRENGTHS[k % len(SUN_STRENGTHS)]
                    name = "%s_to%+g_ti%+g_dp%+g" % (material, to, ti, dp)
                    out.append(_case(name, to, ti, dp, psi, material, strength))
                    k += 1
    return out


def small_cases():
    """CI set: every (theta_o, theta_i) pair with the 4 azimuths of DPHI_SMALL,
    materials assigned round-robin so each material sees several geometries
    (60 renders)."""
    out = []
    mats = list(MATERIALS)
    k = 0
    for to in THETA_O:
        for ti in THETA_I:
            for dp in DPHI_SMALL:
                material = mats[k % len(mats)]
                psi = (70.0 + 47.0 * k) % 360.0
                strength = SUN_STRENGTHS[k % len(SUN_STRENGTHS)]
                name = "%s_to%+g_ti%+g_dp%+g" % (material, to, ti, dp)
                out.append(_case(name, to, ti, dp, psi, material, strength))
                k += 1
    return out


CASE_SETS = {"small": small_cases, "full": full_cases}

# Scene constants shared by every case.
SCENE = dict(
    radius=0.05,          # strand radius (world units)
    length=1.0,           # strand length; the frame is ~0.003 long along it
    n_points=9,           # keys of the straight Catmull-Rom strand
    width=4,              # image width in pixels (along the strand)
    height=160,           # image height in pixels (across the strand)
    pixels_across=120.0,  # pixels across the strand diameter
    spp=1,                # see README: sample 0 is at the pixel centre
    pixel_filter="BLACKMAN_HARRIS",
    filter_width=0.01,
    seed=0,
    camera_distance=0.25,  # close: float32 ray origins limit the precision of h (README)
    h_max=0.97,           # drop pixels with |h| > h_max
)


def get_cases(which):
    try:
        return CASE_SETS[which]()
    except KeyError:
        raise ValueError("unknown case set %r (choose from %s)" % (which, sorted(CASE_SETS)))
