"""The model zoo (issue 7): classic and real-time hair models behind the common closure
interface. Formulas, defaults and their sources: docs/models.md. Every constructor works with no
arguments; out-of-range parameters raise ValueError naming the parameter and the allowed range."""

from __future__ import annotations

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
