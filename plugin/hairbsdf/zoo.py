"""The model zoo (issue 7): classic and real-time hair models behind the common closure
interface. Formulas, defaults and their sources: docs/models.md. Every constructor works with no
arguments; out-of-range parameters raise ValueError naming the parameter and the allowed range.

The parameter names, defaults and ranges live in one table per model, beside its C++ Params struct
(bsdf_core/include/hairbsdf/params/<model>.h); `model_schema(name)` returns it and
`make_model(name, params)` builds a model from named values, as the renderer's `hair_model`
closure and the Blender engine's material override do."""

from __future__ import annotations

import math

from . import _core
from . import _validate as check
from .closure import Closure


def zoo_model_names() -> list[str]:
    """The zoo's model names: kajiya_kay, epic, scheuermann, marschner, deon, yan_fur."""
    return list(_core.zoo_model_names())


def zoo_models() -> list[tuple[str, str, str]]:
    """(name, title, one-line summary) per zoo model, from the models' tables (Blender's override menu)."""
    return [tuple(m) for m in _core.zoo_models()]


def model_schema(model: str, path: str | None = None) -> list[dict]:
    """The parameters of a zoo model, or of the plugin at `path` (model "plugin"): dicts with
    name, type ("float", "rgb", "choice", "bool"), default, min, max, choices, optional and
    description. ValueError for an unknown model."""
    if not isinstance(model, str):
        raise TypeError(f"model: expected a string, got {type(model).__name__}")
    if model == "plugin" and not isinstance(path, str):
        raise TypeError("path: the plugin model needs the path of the plugin library")
    return _core.model_schema(model, path or "")


def make_model(model: str, params: dict | None = None, *, path: str | None = None) -> Closure:
    """A zoo model (or, with model="plugin", the plugin at `path`) from a dict of named
    parameters; missing ones take their defaults (model_schema). Values: a number, an RGB
    triple (or a number for grey), a choice's name, a bool."""
    params = dict(params or {})
    if model == "plugin" and not isinstance(path, str):
        raise TypeError("path: the plugin model needs the path of the plugin library")
    core = _core.make_model(model, params, path or "")
    args = ", ".join(f"{k}={v!r}" for k, v in params.items())
    return Closure(core, f"make_model({model!r}, {{{args}}}" + (f", path={path!r})" if path else ")"))


def _defaults(model: str) -> dict:
    return {p["name"]: p["default"] for p in _core.model_schema(model, "") if not p["optional"]}


# --- Kajiya-Kay 1989 ----------------------------------------------------------------------------
KAJIYA_KAY_DEFAULTS = _defaults("kajiya_kay")


def kajiya_kay_hair(*, diffuse=KAJIYA_KAY_DEFAULTS["diffuse"], specular=KAJIYA_KAY_DEFAULTS["specular"],
                    exponent: float = KAJIYA_KAY_DEFAULTS["exponent"]) -> Closure:
    """Kajiya and Kay 1989 (§2.4): diffuse K_d sin(t, l) plus specular K_s cos^p(e, e'),
    normalised so that `diffuse` is the diffuse albedo and `specular` the specular albedo at
    normal view (docs/models.md §1).

    diffuse, specular: RGB (or grey) in [0, 1] with diffuse + specular <= 1 per channel
    (defaults 0.5, 0.5); exponent: p in [0, 10000] (default 60, a lobe about 7.4 degrees wide).
    Lobes: eval_lobes index 0 = specular, 3 = diffuse.
    """
    kd, ks, p = check.color("diffuse", diffuse), check.color("specular", specular), check.real("exponent", exponent)
    core = _core.make_model("kajiya_kay", {"diffuse": kd, "specular": ks, "exponent": p})
    return Closure(core, f"kajiya_kay_hair(diffuse={kd}, specular={ks}, exponent={p:g})")


# --- Epic / Unreal 2016 (Karis) -----------------------------------------------------------------
EPIC_DEFAULTS = _defaults("epic")


def epic_hair(*, base_color=EPIC_DEFAULTS["base_color"], specular: float = EPIC_DEFAULTS["specular"],
              scatter: float = EPIC_DEFAULTS["scatter"], roughness: float = EPIC_DEFAULTS["roughness"],
              shift: float = EPIC_DEFAULTS["shift"], variant: str = EPIC_DEFAULTS["variant"],
              energy: str = EPIC_DEFAULTS["energy"]) -> Closure:
    """Epic / Unreal 2016 real-time hair (Karis's SIGGRAPH 2016 course notes; docs/models.md §2).

    base_color: C, RGB in [0, 1] (default: Blender's Principled Hair colour, a dark brown);
    specular: [0, 1], scales R by specular / 0.5 (default 0.5 = R as published);
    scatter: [0, 1], scales the multiple-scattering fake (default 0: single fibre only);
    roughness: [0, 1], beta_R = roughness^2, beta_TT = beta_R / 2, beta_TRT = 2 beta_R (default 0.35);
    shift: [-0.25, 0.25], alpha_R = -2 shift, alpha_TT = shift, alpha_TRT = 4 shift, in sin theta
           (default 0.035, about Marschner's / Blender's 2 degree cuticle tilt);
    variant: "direct" (default) or "environment" (R x saturate(wi.wr + 1), no TT, every beta + 0.2);
    energy: "bounded" (default: eval divided per channel by max(1, the model's albedo at this view and
            shadow), so no view creates energy) or "published" (the notes' model exactly).
    The multiple-scattering term reads the per-sample `shadow=` input of eval / pdf / sample
    (the light's visibility through the hair volume, default 1).
    Lobes: R, TT, TRT, and the multiple-scattering term in slot 3.
    """
    c, spec, scat = check.color("base_color", base_color), check.real("specular", specular), check.real("scatter", scatter)
    rough, sh = check.real("roughness", roughness), check.real("shift", shift)
    if not isinstance(variant, str):
        raise TypeError(f"variant: expected a string, got {variant!r}")
    if not isinstance(energy, str):
        raise TypeError(f"energy: expected a string, got {energy!r}")
    core = _core.make_model("epic", {"base_color": c, "specular": spec, "scatter": scat, "roughness": rough,
                                     "shift": sh, "variant": variant, "energy": energy})
    return Closure(core, f"epic_hair(base_color={c}, specular={spec:g}, scatter={scat:g}, roughness={rough:g}, "
                         f"shift={sh:g}, variant={variant!r}, energy={energy!r})")


# --- Scheuermann (ATI) 2004 ---------------------------------------------------------------------
SCHEUERMANN_DEFAULTS = _defaults("scheuermann")


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
    c1, c2 = check.color("primary_color", primary_color), check.color("secondary_color", secondary_color)
    p1, p2 = check.real("primary_exponent", primary_exponent), check.real("secondary_exponent", secondary_exponent)
    s1, s2 = check.real("primary_shift", primary_shift), check.real("secondary_shift", secondary_shift)
    st, nz = check.real("shift_texture", shift_texture), check.real("noise", noise)
    core = _core.make_model("scheuermann", {
        "primary_color": c1, "secondary_color": c2, "primary_exponent": p1, "secondary_exponent": p2,
        "primary_shift": s1, "secondary_shift": s2, "shift_texture": st, "noise": nz})
    return Closure(core, f"scheuermann_hair(primary_color={c1}, secondary_color={c2}, primary_exponent={p1:g}, "
                         f"secondary_exponent={p2:g}, primary_shift={s1:g}, secondary_shift={s2:g}, "
                         f"shift_texture={st:g}, noise={nz:g})")


# --- Marschner 2003 -----------------------------------------------------------------------------
MARSCHNER_DEFAULTS = _defaults("marschner")


def marschner_hair(*, sigma_a=MARSCHNER_DEFAULTS["sigma_a"], eta: float = MARSCHNER_DEFAULTS["eta"],
                   eccentricity: float = MARSCHNER_DEFAULTS["eccentricity"],
                   alpha_r: float = MARSCHNER_DEFAULTS["alpha_r"], beta_r: float = MARSCHNER_DEFAULTS["beta_r"],
                   glint_scale: float = MARSCHNER_DEFAULTS["glint_scale"],
                   caustic_width: float = MARSCHNER_DEFAULTS["caustic_width"],
                   caustic_fade: float = MARSCHNER_DEFAULTS["caustic_fade"],
                   caustic_limit: float = MARSCHNER_DEFAULTS["caustic_limit"],
                   energy: str = MARSCHNER_DEFAULTS["energy"]) -> Closure:
    """Marschner et al. 2003 (docs/models.md §4); angles in radians, defaults from Table 1.

    sigma_a: absorption, RGB >= 0 (<= 1e4; default Blender's Principled Hair absorption);
    eta: [1.1, 3] (1.55); eccentricity: a in [0.5, 1] (0.9); alpha_r: R shift in [-0.35, 0.35]
    (-7.5 deg; alpha_TT = -alpha_r/2, alpha_TRT = -3 alpha_r/2); beta_r: R width in [0.005, 0.7]
    (7.5 deg; beta_TT = beta_r/2, beta_TRT = 2 beta_r); glint_scale: k_G in [0, 5] (0.5);
    caustic_width: w_c in [0.01, 0.7] (15 deg); caustic_fade: Delta eta* in [0, 1] (0.3);
    caustic_limit: Delta h_M in [0, 1] (0.5);
    energy: "bounded" (default: eval divided per channel by max(1, the model's albedo at this view
    and cross-section orientation), so no view creates energy) or "published" (the paper's model).
    The cross-section's major axis is the per-sample `normal=` (zero: the view-dependent frame).
    """
    s = check.color("sigma_a", sigma_a)
    reals = {"eta": eta, "eccentricity": eccentricity, "alpha_r": alpha_r, "beta_r": beta_r, "glint_scale": glint_scale,
             "caustic_width": caustic_width, "caustic_fade": caustic_fade, "caustic_limit": caustic_limit}
    if not isinstance(energy, str):
        raise TypeError(f"energy: expected a string, got {energy!r}")
    core = _core.make_model("marschner", {"sigma_a": s, **{k: check.real(k, v) for k, v in reals.items()},
                                          "energy": energy})
    return Closure(core, f"marschner_hair(sigma_a={s}, eta={eta:g}, eccentricity={eccentricity:g}, alpha_r={alpha_r:g}, "
                         f"beta_r={beta_r:g}, glint_scale={glint_scale:g}, caustic_width={caustic_width:g}, "
                         f"caustic_fade={caustic_fade:g}, caustic_limit={caustic_limit:g}, energy={energy!r})")


# --- d'Eon 2011 ---------------------------------------------------------------------------------
DEON_DEFAULTS = {**_defaults("deon"), "sigma_a": None}


def deon_hair(*, melanin: float = DEON_DEFAULTS["melanin"], melanin_redness: float = DEON_DEFAULTS["melanin_redness"],
              sigma_a=None, pigments: str = DEON_DEFAULTS["pigments"], eta: float = DEON_DEFAULTS["eta"],
              roughness: float = DEON_DEFAULTS["roughness"], tilt: float = DEON_DEFAULTS["tilt"],
              tabulated: bool = DEON_DEFAULTS["tabulated"]) -> Closure:
    """d'Eon et al. 2011 energy-conserving hair with the Gaussian-detector azimuthal term (docs/models.md §5).

    Colour: melanin, melanin_redness in [0, 1] (defaults 0.8, 1.0 as Principled Hair) with
    pigments="cycles" (default) or "deon" (seed 004's constants), or sigma_a (RGB >= 0) directly;
    eta: [1.1, 3]; roughness: beta_R in [0.02, 1] radians (default 7.5 deg; TT x1/2, TRT x2; the M
    variance is beta^2 and the detector's sd beta); tilt: cuticle tilt in [-0.2, 0.2] rad (2 deg);
    tabulated: tables over (|sin theta_o|, phi) (default) or direct quadrature.
    Lobes: R, TT, TRT, TRRT+ (residual, so that sigma_a = 0 conserves energy).
    """
    if not isinstance(tabulated, bool):
        raise TypeError("tabulated: expected True or False")
    if not isinstance(pigments, str):
        raise TypeError(f"pigments: expected a string, got {pigments!r}")
    params = {"melanin": check.real("melanin", melanin), "melanin_redness": check.real("melanin_redness", melanin_redness),
              "pigments": pigments, "eta": check.real("eta", eta), "roughness": check.real("roughness", roughness),
              "tilt": check.real("tilt", tilt), "tabulated": tabulated}
    if sigma_a is not None:
        params["sigma_a"] = check.color("sigma_a", sigma_a)
    core = _core.make_model("deon", params)
    (s,) = [tuple(d["sigma_a"]) for d in core.model_params()]
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


# --- Yan et al. 2015 fur ------------------------------------------------------------------------
YAN_FUR_DEFAULTS = _defaults("yan_fur")


def yan_fur(*, medulla_ratio: float = YAN_FUR_DEFAULTS["medulla_ratio"],
            cortex_absorption=YAN_FUR_DEFAULTS["cortex_absorption"],
            medulla_absorption: float = YAN_FUR_DEFAULTS["medulla_absorption"],
            medulla_scattering: float = YAN_FUR_DEFAULTS["medulla_scattering"],
            medulla_g: float = YAN_FUR_DEFAULTS["medulla_g"], eta: float = YAN_FUR_DEFAULTS["eta"],
            alpha: float = YAN_FUR_DEFAULTS["alpha"], roughness: float = YAN_FUR_DEFAULTS["roughness"],
            radial_roughness: float = YAN_FUR_DEFAULTS["radial_roughness"]) -> Closure:
    """Yan et al. 2015 fur, the double cylinder (docs/models.md §7). Defaults: Yan 2015's measured fit.

    medulla_ratio: kappa in [0, 0.99] (0.88); cortex_absorption: sigma_ca per unit radius, RGB in
    [0, 1e4] (0.64 grey); medulla_absorption, medulla_scattering: sigma_ma, sigma_ms per unit radius
    in [0, 10] (0.17, 1.69); medulla_g: Henyey-Greenstein asymmetry in [-0.9, 0.9] (0, isotropic);
    eta: [1.1, 3] (1.55); alpha: cuticle tilt in [-0.2, 0.2] rad, Principled Hair's Offset convention
    (5.48 deg); roughness, radial_roughness: Chiang's beta_m, beta_n in [0.01, 1] (0.2238, 0.2186:
    R's longitudinal sd 11.64 deg and the azimuthal sd 7.49 deg of the fit).
    Lobes (eval_lobes is (N, 6, 3)): R, TT, TRT, TRRT+ unscattered (Chiang's with the medulla's
    transmittance, at h), TTs and TRTs scattered in the medulla (Monte Carlo tables, built once per
    (medulla_ratio, cortex_absorption, medulla_*, eta) in the process).
    """
    s = check.color("cortex_absorption", cortex_absorption)
    reals = {"medulla_ratio": medulla_ratio, "medulla_absorption": medulla_absorption,
             "medulla_scattering": medulla_scattering, "medulla_g": medulla_g, "eta": eta, "alpha": alpha,
             "roughness": roughness, "radial_roughness": radial_roughness}
    core = _core.make_model("yan_fur", {"cortex_absorption": s, **{k: check.real(k, v) for k, v in reals.items()}})
    return Closure(core, f"yan_fur(medulla_ratio={medulla_ratio:g}, cortex_absorption={s}, "
                         f"medulla_absorption={medulla_absorption:g}, medulla_scattering={medulla_scattering:g}, "
                         f"medulla_g={medulla_g:g}, eta={eta:g}, alpha={alpha:g}, roughness={roughness:g}, "
                         f"radial_roughness={radial_roughness:g})")
