"""The model zoo (issue 7): classic and real-time hair models behind the common closure
interface. Formulas, defaults and their sources: docs/models.md. Every constructor works with no
arguments; out-of-range parameters raise ValueError naming the parameter and the allowed range."""

from __future__ import annotations

import math

from . import _core
from . import _validate as check
from .closure import Closure

# --- Kajiya-Kay 1989 ----------------------------------------------------------------------------
KAJIYA_KAY_DEFAULTS = {"diffuse": (0.5, 0.5, 0.5), "specular": (0.5, 0.5, 0.5), "exponent": 60.0}
KAJIYA_KAY_MAX_EXPONENT = 10_000.0


def kajiya_kay_hair(*, diffuse=KAJIYA_KAY_DEFAULTS["diffuse"], specular=KAJIYA_KAY_DEFAULTS["specular"],
                    exponent: float = KAJIYA_KAY_DEFAULTS["exponent"]) -> Closure:
    """Kajiya and Kay 1989 (§2.4): diffuse K_d sin(t, l) plus specular K_s cos^p(e, e'),
    normalised so that `diffuse` is the diffuse albedo and `specular` the specular albedo at
    normal view (docs/models.md §1).

    diffuse, specular: RGB (or grey) in [0, 1] with diffuse + specular <= 1 per channel
    (defaults 0.5, 0.5); exponent: p in [0, 10000] (default 60, a lobe about 7.4 degrees wide).
    Lobes: eval_lobes index 0 = specular, 3 = diffuse.
    """
    kd = check.color_in_range("diffuse", diffuse, 0.0, 1.0)
    ks = check.color_in_range("specular", specular, 0.0, 1.0)
    if any(a + b > 1.0 + 1e-12 for a, b in zip(kd, ks)):
        raise ValueError(f"diffuse + specular = {tuple(a + b for a, b in zip(kd, ks))} is out of range; "
                         "each channel of the sum must lie in [0, 1] (energy bound)")
    p = check.in_range("exponent", exponent, 0.0, KAJIYA_KAY_MAX_EXPONENT)
    core = _core.kajiya_kay(kd, ks, p)
    return Closure(core, f"kajiya_kay_hair(diffuse={kd}, specular={ks}, exponent={p:g})")


# --- Epic / Unreal 2016 (Karis) -----------------------------------------------------------------
EPIC_DEFAULTS = {"base_color": (0.017513, 0.005763, 0.002059), "specular": 0.5, "scatter": 0.0,
                 "roughness": 0.35, "shift": 0.035, "variant": "direct"}
EPIC_VARIANTS = {"direct": 0, "environment": 1}


def epic_hair(*, base_color=EPIC_DEFAULTS["base_color"], specular: float = EPIC_DEFAULTS["specular"],
              scatter: float = EPIC_DEFAULTS["scatter"], roughness: float = EPIC_DEFAULTS["roughness"],
              shift: float = EPIC_DEFAULTS["shift"], variant: str = EPIC_DEFAULTS["variant"]) -> Closure:
    """Epic / Unreal 2016 real-time hair (Karis's SIGGRAPH 2016 course notes; docs/models.md §2).

    base_color: C, RGB in [0, 1] (default: Blender's Principled Hair colour, a dark brown);
    specular: [0, 1], scales R by specular / 0.5 (default 0.5 = R as published);
    scatter: [0, 1], scales the multiple-scattering fake (default 0: single fibre only);
    roughness: [0, 1], beta_R = roughness^2, beta_TT = beta_R / 2, beta_TRT = 2 beta_R (default 0.35);
    shift: [-0.25, 0.25], alpha_R = -2 shift, alpha_TT = shift, alpha_TRT = 4 shift, in sin theta
           (default 0.035, about Marschner's / Blender's 2 degree cuticle tilt);
    variant: "direct" (default) or "environment" (R x saturate(wi.wr + 1), no TT, every beta + 0.2).
    The multiple-scattering term reads the per-sample `shadow=` input of eval / pdf / sample
    (the light's visibility through the hair volume, default 1).
    Lobes: R, TT, TRT, and the multiple-scattering term in slot 3.
    """
    c = check.color_in_range("base_color", base_color, 0.0, 1.0)
    spec = check.in_range("specular", specular, 0.0, 1.0)
    scat = check.in_range("scatter", scatter, 0.0, 1.0)
    rough = check.in_range("roughness", roughness, 0.0, 1.0)
    sh = check.in_range("shift", shift, -0.25, 0.25)
    check.choice("variant", variant, EPIC_VARIANTS)
    core = _core.epic(c, spec / 0.5, scat, rough, sh, EPIC_VARIANTS[variant])
    return Closure(core, f"epic_hair(base_color={c}, specular={spec:g}, scatter={scat:g}, roughness={rough:g}, "
                         f"shift={sh:g}, variant={variant!r})")


# --- Scheuermann (ATI) 2004 ---------------------------------------------------------------------
SCHEUERMANN_DEFAULTS = {
    "primary_color": (0.5, 0.5, 0.5), "secondary_color": (0.5, 0.35, 0.2),
    "primary_exponent": 240.0, "secondary_exponent": 60.0,
    "primary_shift": 0.0349208, "secondary_shift": -0.0699268,  # tan 2 deg, -tan 4 deg
    "shift_texture": 0.5, "noise": 1.0,
}


def scheuermann_hair(*, primary_color=SCHEUERMANN_DEFAULTS["primary_color"],
                     secondary_color=SCHEUERMANN_DEFAULTS["secondary_color"],
                     primary_exponent: float = SCHEUERMANN_DEFAULTS["primary_exponent"],
                     secondary_exponent: float = SCHEUERMANN_DEFAULTS["secondary_exponent"],
                     primary_shift: float = SCHEUERMANN_DEFAULTS["primary_shift"],
                     secondary_shift: float = SCHEUERMANN_DEFAULTS["secondary_shift"],
                     shift_texture: float = SCHEUERMANN_DEFAULTS["shift_texture"],
                     noise: float = SCHEUERMANN_DEFAULTS["noise"]) -> Closure:
    """Scheuermann (ATI) 2004: two Kajiya-Kay specular lobes on shifted tangents (docs/models.md §3).

    primary_color, secondary_color: RGB in [0, 1], primary + secondary <= 1 per channel (each colour
    bounds its lobe's albedo); primary_exponent, secondary_exponent: [0, 10000] (defaults 240, 60:
    light-space widths about Marschner's beta_R and 2 beta_R); primary_shift, secondary_shift:
    [-1, 1], tangent shifts along the normal (defaults tan 2 deg and -tan 4 deg, Principled Hair's R
    and TRT at its 2 degree offset); shift_texture: [0, 1], the shift texture value, 0.5 = none;
    noise: [0, 1], the noise texture value masking the secondary lobe (default 1).
    Lobes: eval_lobes index 0 = primary, 2 = secondary.
    """
    c1 = check.color_in_range("primary_color", primary_color, 0.0, 1.0)
    c2 = check.color_in_range("secondary_color", secondary_color, 0.0, 1.0)
    if any(a + b > 1.0 + 1e-12 for a, b in zip(c1, c2)):
        raise ValueError(f"primary_color + secondary_color = {tuple(a + b for a, b in zip(c1, c2))} is out of range; "
                         "each channel of the sum must lie in [0, 1] (energy bound)")
    p1 = check.in_range("primary_exponent", primary_exponent, 0.0, 10_000.0)
    p2 = check.in_range("secondary_exponent", secondary_exponent, 0.0, 10_000.0)
    s1 = check.in_range("primary_shift", primary_shift, -1.0, 1.0)
    s2 = check.in_range("secondary_shift", secondary_shift, -1.0, 1.0)
    st = check.in_range("shift_texture", shift_texture, 0.0, 1.0)
    nz = check.in_range("noise", noise, 0.0, 1.0)
    core = _core.scheuermann(c1, c2, p1, p2, s1, s2, st, nz)
    return Closure(core, f"scheuermann_hair(primary_color={c1}, secondary_color={c2}, primary_exponent={p1:g}, "
                         f"secondary_exponent={p2:g}, primary_shift={s1:g}, secondary_shift={s2:g}, "
                         f"shift_texture={st:g}, noise={nz:g})")


# --- Marschner 2003 -----------------------------------------------------------------------------
MARSCHNER_DEFAULTS = {
    "sigma_a": (0.245531, 0.52, 1.365), "eta": 1.55, "eccentricity": 0.9, "alpha_r": -0.1309, "beta_r": 0.1309,
    "glint_scale": 0.5, "caustic_width": 0.2618, "caustic_fade": 0.3, "caustic_limit": 0.5,
}


def marschner_hair(*, sigma_a=MARSCHNER_DEFAULTS["sigma_a"], eta: float = MARSCHNER_DEFAULTS["eta"],
                   eccentricity: float = MARSCHNER_DEFAULTS["eccentricity"],
                   alpha_r: float = MARSCHNER_DEFAULTS["alpha_r"], beta_r: float = MARSCHNER_DEFAULTS["beta_r"],
                   glint_scale: float = MARSCHNER_DEFAULTS["glint_scale"],
                   caustic_width: float = MARSCHNER_DEFAULTS["caustic_width"],
                   caustic_fade: float = MARSCHNER_DEFAULTS["caustic_fade"],
                   caustic_limit: float = MARSCHNER_DEFAULTS["caustic_limit"]) -> Closure:
    """Marschner et al. 2003 (docs/models.md §4); angles in radians, defaults from Table 1.

    sigma_a: absorption, RGB >= 0 (<= 1e4; default Blender's Principled Hair absorption);
    eta: [1.1, 3] (1.55); eccentricity: a in [0.5, 1] (0.9); alpha_r: R shift in [-0.35, 0.35]
    (-7.5 deg; alpha_TT = -alpha_r/2, alpha_TRT = -3 alpha_r/2); beta_r: R width in [0.005, 0.7]
    (7.5 deg; beta_TT = beta_r/2, beta_TRT = 2 beta_r); glint_scale: k_G in [0, 5] (0.5);
    caustic_width: w_c in [0.01, 0.7] (15 deg); caustic_fade: Delta eta* in [0, 1] (0.3);
    caustic_limit: Delta h_M in [0, 1] (0.5).
    The cross-section's major axis is the per-sample `normal=` (zero: the view-dependent frame).
    """
    s = check.color("sigma_a", sigma_a)
    if any(x < 0 or x > 1e4 for x in s):
        raise ValueError(f"sigma_a={sigma_a!r} is out of range; every channel must lie in [0, 10000]")
    core = _core.marschner(
        s, check.in_range("eta", eta, 1.1, 3.0), check.in_range("eccentricity", eccentricity, 0.5, 1.0),
        check.in_range("alpha_r", alpha_r, -0.35, 0.35), check.in_range("beta_r", beta_r, 0.005, 0.7),
        check.in_range("glint_scale", glint_scale, 0.0, 5.0), check.in_range("caustic_width", caustic_width, 0.01, 0.7),
        check.in_range("caustic_fade", caustic_fade, 0.0, 1.0), check.in_range("caustic_limit", caustic_limit, 0.0, 1.0))
    return Closure(core, f"marschner_hair(sigma_a={s}, eta={eta:g}, eccentricity={eccentricity:g}, alpha_r={alpha_r:g}, "
                         f"beta_r={beta_r:g}, glint_scale={glint_scale:g}, caustic_width={caustic_width:g}, "
                         f"caustic_fade={caustic_fade:g}, caustic_limit={caustic_limit:g})")


# --- d'Eon 2011 ---------------------------------------------------------------------------------
# Pigment absorption (per unit concentration and diameter): seed 004 (d'Eon's constants) and
# Cycles' (the same mapping Principled Hair uses, hairbsdf.absorption_from_melanin).
DEON_EUMELANIN = (0.419, 0.697, 1.37)
DEON_PHEOMELANIN = (0.187, 0.4, 1.05)
DEON_DEFAULTS = {"melanin": 0.8, "melanin_redness": 1.0, "sigma_a": None, "pigments": "cycles", "eta": 1.55,
                 "roughness": 0.1309, "tilt": 0.0349066, "tabulated": True}


def deon_absorption(melanin: float, melanin_redness: float, pigments: str = "cycles") -> tuple[float, float, float]:
    """sigma_a from melanin and redness: Cycles' concentration mapping
    (q = -ln(max(1 - melanin, 1e-4)), eumelanin q (1 - r), pheomelanin q r) with Cycles' or d'Eon's
    (seed 004) pigment constants."""
    import math
    from .principled import absorption_from_melanin
    m = check.in_range("melanin", melanin, 0.0, 1.0)
    r = check.in_range("melanin_redness", melanin_redness, 0.0, 1.0)
    check.choice("pigments", pigments, ("cycles", "deon"))
    if pigments == "cycles":
        return tuple(absorption_from_melanin(m, r))
    q = -math.log(max(1.0 - m, 1e-4))
    return tuple(q * (1 - r) * e + q * r * p for e, p in zip(DEON_EUMELANIN, DEON_PHEOMELANIN))


def deon_hair(*, melanin: float = DEON_DEFAULTS["melanin"], melanin_redness: float = DEON_DEFAULTS["melanin_redness"],
              sigma_a=None, pigments: str = "cycles", eta: float = 1.55, roughness: float = 0.1309,
              tilt: float = 0.0349066, tabulated: bool = True) -> Closure:
    """d'Eon et al. 2011 energy-conserving hair with the Gaussian-detector azimuthal term (docs/models.md §5).

    Colour: melanin, melanin_redness in [0, 1] (defaults 0.8, 1.0 as Principled Hair) with
    pigments="cycles" (default) or "deon" (seed 004's constants), or sigma_a (RGB >= 0) directly;
    eta: [1.1, 3]; roughness: beta_R in [0.02, 1] radians (default 7.5 deg; TT x1/2, TRT x2; the M
    variance is beta^2 and the detector's sd beta); tilt: cuticle tilt in [-0.2, 0.2] rad (2 deg);
    tabulated: tables over (|sin theta_o|, phi) (default) or direct quadrature.
    Lobes: R, TT, TRT, TRRT+ (residual, so that sigma_a = 0 conserves energy).
    """
    if sigma_a is None:
        s = deon_absorption(melanin, melanin_redness, pigments)
    else:
        s = check.color("sigma_a", sigma_a)
        if any(x < 0 or x > 1e4 for x in s):
            raise ValueError(f"sigma_a={sigma_a!r} is out of range; every channel must lie in [0, 10000]")
    if not isinstance(tabulated, bool):
        raise TypeError("tabulated: expected True or False")
    core = _core.deon(s, check.in_range("eta", eta, 1.1, 3.0), check.in_range("roughness", roughness, 0.02, 1.0),
                      check.in_range("tilt", tilt, -0.2, 0.2), tabulated)
    return Closure(core, f"deon_hair(sigma_a={tuple(round(x, 6) for x in s)}, eta={eta:g}, roughness={roughness:g}, "
                         f"tilt={tilt:g}, tabulated={tabulated})")


# --- Cycles' legacy Hair BSDF node ----------------------------------------------------------------
# The Blender node's defaults (ShaderNodeBsdfHair): component Reflection, Color 0.8 grey, Offset 0,
# RoughnessU 0.1, RoughnessV 1.0. Offset is in radians, as Blender stores it.
CYCLES_HAIR_DEFAULTS = {"component": "reflection", "color": (0.8, 0.8, 0.8), "offset": 0.0, "roughness_u": 0.1,
                        "roughness_v": 1.0}
CYCLES_HAIR_COMPONENTS = ("reflection", "transmission")
CYCLES_HAIR_MAX_COLOR = 1e4


def cycles_hair_bsdf(*, component: str = CYCLES_HAIR_DEFAULTS["component"], color=CYCLES_HAIR_DEFAULTS["color"],
                     offset: float = CYCLES_HAIR_DEFAULTS["offset"],
                     roughness_u: float = CYCLES_HAIR_DEFAULTS["roughness_u"],
                     roughness_v: float = CYCLES_HAIR_DEFAULTS["roughness_v"]) -> Closure:
    """Cycles' legacy "Hair BSDF" node, as Cycles evaluates and samples it (docs/models.md §6).

    component: "reflection" (default) or "transmission" (case-insensitive, Blender's
    'REFLECTION' / 'TRANSMISSION' accepted); color: RGB (or grey) >= 0 (default 0.8; eval / pdf
    is this colour); offset: the node's Offset in radians, [-pi/2, pi/2] (default 0; Cycles stores
    minus it, so the lobe peaks at theta_i = -theta_o - 2 offset); roughness_u: longitudinal, roughness_v: azimuthal, [0, 1] (defaults
    0.1 and 1.0; Cycles clamps both to [0.001, 1]).
    The split between the components follows Cycles' shading normal at the hit, which depends on
    `h` (reflection where wi . N >= 0). Lobes: reflection in slot 0 (R), transmission in slot 1 (TT).
    Cycles' sampler is not its eval's density (docs/models.md §6): `sample` returns Cycles' pdf
    and weight = color, `pdf` returns eval's density.
    """
    if not isinstance(component, str):
        raise TypeError(f"component: expected a string, one of {CYCLES_HAIR_COMPONENTS}")
    comp = component.lower()
    check.choice("component", comp, CYCLES_HAIR_COMPONENTS)
    c = check.color_in_range("color", color, 0.0, CYCLES_HAIR_MAX_COLOR)
    off = check.in_range("offset", offset, -0.5 * math.pi, 0.5 * math.pi)
    ru = check.in_range("roughness_u", roughness_u, 0.0, 1.0)
    rv = check.in_range("roughness_v", roughness_v, 0.0, 1.0)
    core = _core.cycles_hair(comp == "transmission", c, off, ru, rv)
    return Closure(core, f"cycles_hair_bsdf(component={comp!r}, color={c}, offset={off:g}, roughness_u={ru:g}, "
                         f"roughness_v={rv:g})")
