"""The model zoo (issue 7): classic and real-time hair models behind the common closure
interface. Formulas, defaults and their sources: docs/models.md. Every constructor works with no
arguments; out-of-range parameters raise ValueError naming the parameter and the allowed range.

The parameter names, defaults and ranges live in one table per model, beside its C++ Params struct
(bsdf_core/include/hairbsdf/params/<model>.h); `model_schema(name)` returns it and
`make_model(name, params)` builds a model from named values, as the renderer's `hair_model`
closure and the Blender engine's material override do."""

from __future__ import annotations

from . import _core
from . import _validate as check
from ._param_docs import with_parameters
from .closure import Closure


def zoo_model_names() -> list[str]:
    """The zoo's model names: kajiya_kay, epic, scheuermann, marschner, deon, yan_fur."""
    return list(_core.zoo_model_names())

PLUGIN_MODEL = _core.PLUGIN_MODEL  # the model name that loads a plugin library (`path`)


def zoo_models() -> list[tuple[str, str, str]]:
    """(name, title, one-line summary) per zoo model, from the models' tables (Blender's override menu)."""
    return [tuple(m) for m in _core.zoo_models()]


def model_schema(model: str, path: str | None = None) -> list[dict]:
    """The parameters of a zoo model, or of the plugin at `path` (model "plugin"): dicts with
    name, type ("float", "rgb", "choice", "bool"), default, min, max, choices, optional and
    description. ValueError for an unknown model."""
    if not isinstance(model, str):
        raise TypeError(f"model: expected a string, got {type(model).__name__}")
    if model == PLUGIN_MODEL and not isinstance(path, str):
        raise TypeError("path: the plugin model needs the path of the plugin library")
    return _core.model_schema(model, path or "")


def make_model(model: str, params: dict | None = None, *, path: str | None = None) -> Closure:
    """A zoo model (or, with model="plugin", the plugin at `path`) from a dict of named
    parameters; missing ones take their defaults (model_schema). Values: a number, an RGB
    triple (or a number for grey), a choice's name, a bool."""
    params = dict(params or {})
    if model == PLUGIN_MODEL and not isinstance(path, str):
        raise TypeError("path: the plugin model needs the path of the plugin library")
    core = _core.make_model(model, params, path or "")
    args = ", ".join(f"{k}={v!r}" for k, v in params.items())
    return Closure(core, f"make_model({model!r}, {{{args}}}" + (f", path={path!r})" if path else ")"))


def _defaults(model: str) -> dict:
    return {p["name"]: p["default"] for p in _core.model_schema(model, "") if not p["optional"]}


def _table_parameters(model: str):
    """Appends the model's generated Parameters block to the function's docstring."""
    return with_parameters(_core.model_schema(model, ""), f"bsdf_core/include/hairbsdf/params/{model}.h")


# --- Kajiya-Kay 1989 ----------------------------------------------------------------------------
KAJIYA_KAY_DEFAULTS = _defaults("kajiya_kay")


@_table_parameters("kajiya_kay")
def kajiya_kay_hair(*, diffuse=KAJIYA_KAY_DEFAULTS["diffuse"], specular=KAJIYA_KAY_DEFAULTS["specular"],
                    exponent: float = KAJIYA_KAY_DEFAULTS["exponent"]) -> Closure:
    """Kajiya and Kay 1989 (§2.4): diffuse K_d sin(t, l) plus specular K_s cos^p(e, e'),
    normalised so that `diffuse` is the diffuse albedo and `specular` the specular albedo at
    normal view (docs/models.md §1).

    diffuse + specular must not exceed 1 in any channel; the lobe is about 1/sqrt(exponent) wide.
    Lobes: eval_lobes index 0 = specular, 3 = diffuse.
    """
    kd, ks, p = check.color("diffuse", diffuse), check.color("specular", specular), check.real("exponent", exponent)
    core = _core.make_model("kajiya_kay", {"diffuse": kd, "specular": ks, "exponent": p})
    return Closure(core, f"kajiya_kay_hair(diffuse={kd}, specular={ks}, exponent={p:g})")


# --- Epic / Unreal 2016 (Karis) -----------------------------------------------------------------
EPIC_DEFAULTS = _defaults("epic")


@_table_parameters("epic")
def epic_hair(*, base_color=EPIC_DEFAULTS["base_color"], specular: float = EPIC_DEFAULTS["specular"],
              scatter: float = EPIC_DEFAULTS["scatter"], roughness: float = EPIC_DEFAULTS["roughness"],
              shift: float = EPIC_DEFAULTS["shift"], variant: str = EPIC_DEFAULTS["variant"],
              energy: str = EPIC_DEFAULTS["energy"]) -> Closure:
    """Epic / Unreal 2016 real-time hair (Karis's SIGGRAPH 2016 course notes; docs/models.md §2).

    base_color's default is Blender's Principled Hair colour, a dark brown; shift's is about
    Marschner's / Blender's 2 degree cuticle tilt. variant "environment": R x saturate(wi.wr + 1),
    no TT, every beta + 0.2. energy "bounded": eval divided per channel by max(1, the model's albedo
    at this view and shadow); "published": the notes' model exactly.
    The multiple-scattering term reads the per-sample `shadow=` input of eval / pdf / sample
    (the light's visibility through the hair volume; 1 when not given).
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


@_table_parameters("scheuermann")
def scheuermann_hair(*, primary_color=SCHEUERMANN_DEFAULTS["primary_color"],
                     secondary_color=SCHEUERMANN_DEFAULTS["secondary_color"],
                     primary_exponent: float = SCHEUERMANN_DEFAULTS["primary_exponent"],
                     secondary_exponent: float = SCHEUERMANN_DEFAULTS["secondary_exponent"],
                     primary_shift: float = SCHEUERMANN_DEFAULTS["primary_shift"],
                     secondary_shift: float = SCHEUERMANN_DEFAULTS["secondary_shift"],
                     shift_texture: float = SCHEUERMANN_DEFAULTS["shift_texture"],
                     noise: float = SCHEUERMANN_DEFAULTS["noise"]) -> Closure:
    """Scheuermann (ATI) 2004: two Kajiya-Kay specular lobes on shifted tangents (docs/models.md §3).

    Each colour bounds its lobe's albedo, and primary + secondary must not exceed 1 in any channel.
    The default exponents give light-space widths about Marschner's beta_R and 2 beta_R; the shifts
    move the tangents along the normal, by default Principled Hair's R and TRT at its 2 degree offset.
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


@_table_parameters("marschner")
def marschner_hair(*, sigma_a=MARSCHNER_DEFAULTS["sigma_a"], eta: float = MARSCHNER_DEFAULTS["eta"],
                   eccentricity: float = MARSCHNER_DEFAULTS["eccentricity"],
                   alpha_r: float = MARSCHNER_DEFAULTS["alpha_r"], beta_r: float = MARSCHNER_DEFAULTS["beta_r"],
                   glint_scale: float = MARSCHNER_DEFAULTS["glint_scale"],
                   caustic_width: float = MARSCHNER_DEFAULTS["caustic_width"],
                   caustic_fade: float = MARSCHNER_DEFAULTS["caustic_fade"],
                   caustic_limit: float = MARSCHNER_DEFAULTS["caustic_limit"],
                   energy: str = MARSCHNER_DEFAULTS["energy"]) -> Closure:
    """Marschner et al. 2003 (docs/models.md §4); angles in radians, defaults from Table 1.

    sigma_a's default is Blender's Principled Hair absorption. energy "bounded": eval divided per
    channel by max(1, the model's albedo at this view and cross-section orientation); "published":
    the paper's model.
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


@_table_parameters("deon")
def deon_hair(*, melanin: float = DEON_DEFAULTS["melanin"], melanin_redness: float = DEON_DEFAULTS["melanin_redness"],
              sigma_a=None, pigments: str = DEON_DEFAULTS["pigments"], eta: float = DEON_DEFAULTS["eta"],
              roughness: float = DEON_DEFAULTS["roughness"], tilt: float = DEON_DEFAULTS["tilt"],
              tabulated: bool = DEON_DEFAULTS["tabulated"]) -> Closure:
    """d'Eon et al. 2011 energy-conserving hair with the Gaussian-detector azimuthal term (docs/models.md §5).

    Colour: melanin and melanin_redness (Principled Hair's defaults) through the pigments' constants,
    or sigma_a directly. roughness: the M variance is beta^2 and the detector's sd beta.
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
# The node's sockets, Blender's defaults and the allowed ranges: its table (params/cycles_hair.h), which
# also checks the values (make_model).
CYCLES_HAIR_DEFAULTS = _defaults("cycles_hair")
CYCLES_HAIR_COMPONENTS = tuple(next(p["choices"] for p in _core.model_schema("cycles_hair", "")
                                    if p["name"] == "component"))


@_table_parameters("cycles_hair")
def cycles_hair_bsdf(*, component: str = CYCLES_HAIR_DEFAULTS["component"], color=CYCLES_HAIR_DEFAULTS["color"],
                     offset: float = CYCLES_HAIR_DEFAULTS["offset"],
                     roughness_u: float = CYCLES_HAIR_DEFAULTS["roughness_u"],
                     roughness_v: float = CYCLES_HAIR_DEFAULTS["roughness_v"]) -> Closure:
    """Cycles' legacy "Hair BSDF" node, as Cycles evaluates and samples it (docs/models.md §6).

    Defaults are the Blender node's; component is case-insensitive (Blender's 'REFLECTION' /
    'TRANSMISSION' accepted).
    The split between the components follows Cycles' shading normal at the hit, which depends on
    `h` (reflection where wi . N >= 0). Lobes: reflection in slot 0 (R), transmission in slot 1 (TT).
    Cycles' sampler is not its eval's density (docs/models.md §6): `sample` returns Cycles' pdf
    and weight = color, `pdf` returns eval's density.
    """
    if not isinstance(component, str):
        raise TypeError(f"component: expected a string, one of {CYCLES_HAIR_COMPONENTS}")
    comp = component.lower()
    c = check.color("color", color)
    off, ru, rv = check.real("offset", offset), check.real("roughness_u", roughness_u), check.real("roughness_v", roughness_v)
    core = _core.make_model("cycles_hair", {"component": comp, "color": c, "offset": off, "roughness_u": ru,
                                            "roughness_v": rv})
    return Closure(core, f"cycles_hair_bsdf(component={comp!r}, color={c}, offset={off:g}, roughness_u={ru:g}, "
                         f"roughness_v={rv:g})")


# --- Yan et al. 2015 fur ------------------------------------------------------------------------
YAN_FUR_DEFAULTS = _defaults("yan_fur")


@_table_parameters("yan_fur")
def yan_fur(*, medulla_ratio: float = YAN_FUR_DEFAULTS["medulla_ratio"],
            cortex_absorption=YAN_FUR_DEFAULTS["cortex_absorption"],
            medulla_absorption: float = YAN_FUR_DEFAULTS["medulla_absorption"],
            medulla_scattering: float = YAN_FUR_DEFAULTS["medulla_scattering"],
            medulla_g: float = YAN_FUR_DEFAULTS["medulla_g"], eta: float = YAN_FUR_DEFAULTS["eta"],
            alpha: float = YAN_FUR_DEFAULTS["alpha"], roughness: float = YAN_FUR_DEFAULTS["roughness"],
            radial_roughness: float = YAN_FUR_DEFAULTS["radial_roughness"]) -> Closure:
    """Yan et al. 2015 fur, the double cylinder (docs/models.md §7). Defaults: Yan 2015's measured fit.

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
