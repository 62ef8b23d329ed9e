"""MaterialX hair: the `chiang_hair_bsdf` closure, its support nodes, the `simple_hair_default`
node graph, and the MDL `SimpleHairBase` material of the MaterialX proposal.

Names and defaults are MaterialX 1.39's nodedefs (checked against the `materialx` wheel by
the tests). Semantics follow the specification; docs/materialx.md lists where the GLSL,
OSL and MDL backends differ and the slips in the proposal's MDL text.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import _core
from . import _validate as check
from .closure import Closure

# ND_chiang_hair_bsdf defaults (roughness pairs: (longitudinal variance v, azimuthal scale s)).
CHIANG_HAIR_BSDF_DEFAULTS = {
    "tint_R": (1.0, 1.0, 1.0),
    "tint_TT": (1.0, 1.0, 1.0),
    "tint_TRT": (1.0, 1.0, 1.0),
    "ior": 1.55,
    "roughness_R": (0.1, 0.1),
    "roughness_TT": (0.05, 0.05),
    "roughness_TRT": (0.2, 0.2),
    "cuticle_angle": 0.5,
    "absorption_coefficient": (0.0, 0.0, 0.0),
}
CHIANG_HAIR_ROUGHNESS_DEFAULTS = {"longitudinal": 0.1, "azimuthal": 0.2, "scale_TT": 0.5, "scale_TRT": 2.0}
CHIANG_HAIR_ABSORPTION_FROM_COLOR_DEFAULTS = {"color": (1.0, 1.0, 1.0), "azimuthal_roughness": 0.2}
DEON_HAIR_ABSORPTION_FROM_MELANIN_DEFAULTS = {
    "melanin_concentration": 0.25,
    "melanin_redness": 0.5,
    "eumelanin_color": (0.657704, 0.498077, 0.254107),
    "pheomelanin_color": (0.829444, 0.67032, 0.349938),
}


def _pair(name, value):
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected a vector2 (v, s) of numbers, got {value!r}") from exc
    if arr.shape != (2,):
        raise ValueError(f"{name}: expected a vector2 (v, s), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be finite")
    if np.any(arr < 0):
        raise ValueError(f"{name}: (v, s) must be >= 0 (MaterialX range [0, inf))")
    return (float(arr[0]), float(arr[1]))


def chiang_hair_bsdf(*, glsl_compat: bool = False, **inputs) -> Closure:
    """MaterialX `chiang_hair_bsdf`: sum over R, TT, TRT, TRRT+ of tint * A_p * M_p * N_p.

    Keywords are the nodedef's input names: tint_R, tint_TT, tint_TRT (color3), ior,
    roughness_R, roughness_TT, roughness_TRT (vector2 (v, s); s without sqrt(pi/8)),
    cuticle_angle (in [0, 1], 0.5 = no tilt, mapped to (c - 0.5) * pi radians), and
    absorption_coefficient (vector3). `normal` and `curve_direction` come from the fibre
    frame (`h` and `x`). `glsl_compat=True` multiplies by the GLSL backend's extra 1/pi.
    """
    check.keywords("chiang_hair_bsdf", inputs, CHIANG_HAIR_BSDF_DEFAULTS)
    v = dict(CHIANG_HAIR_BSDF_DEFAULTS)
    for key, value in inputs.items():
        if key.startswith("roughness_"):
            v[key] = _pair(key, value)
        elif key in ("ior", "cuticle_angle"):
            v[key] = check.real(key, value)
        else:
            v[key] = check.color(key, value)
    core = _core.materialx_chiang([v["tint_R"], v["tint_TT"], v["tint_TRT"]], v["ior"],
                                  [v["roughness_R"], v["roughness_TT"], v["roughness_TRT"]], v["cuticle_angle"],
                                  v["absorption_coefficient"])
    shown = ", ".join(f"{k}={val!r}" for k, val in inputs.items())
    closure = Closure(core, f"chiang_hair_bsdf({shown})")
    return closure * (1.0 / math.pi) if glsl_compat else closure


class ChiangHairRoughness(NamedTuple):
    roughness_R: tuple
    roughness_TT: tuple
    roughness_TRT: tuple


def chiang_hair_roughness(longitudinal: float = 0.1, azimuthal: float = 0.2, scale_TT: float = 0.5,
                          scale_TRT: float = 2.0) -> ChiangHairRoughness:
    """MaterialX `chiang_hair_roughness`: (v, s) per lobe from artist roughness (Chiang 2016
    eqs. 7-8, s without sqrt(pi/8)); TT and TRT scale only v, by scale**2."""
    r = _core.materialx_roughness(check.real("longitudinal", longitudinal), check.real("azimuthal", azimuthal),
                                  check.real("scale_TT", scale_TT), check.real("scale_TRT", scale_TRT))
    return ChiangHairRoughness(*(tuple(x) for x in r))


def chiang_hair_absorption_from_color(color=(1.0, 1.0, 1.0), azimuthal_roughness: float = 0.2) -> np.ndarray:
    """MaterialX `chiang_hair_absorption_from_color`: Chiang 2016 eq. 9, colour clamped to [0.001, 1]."""
    return np.array(_core.materialx_absorption_from_color(check.color("color", color),
                                                          check.real("azimuthal_roughness", azimuthal_roughness)))


def deon_hair_absorption_from_melanin(melanin_concentration: float = 0.25, melanin_redness: float = 0.5,
                                      eumelanin_color=(0.657704, 0.498077, 0.254107),
                                      pheomelanin_color=(0.829444, 0.67032, 0.349938)) -> np.ndarray:
    """MaterialX `deon_hair_absorption_from_melanin`: q = -ln(max(1 - c, 1e-4)),
    sigma = max(q(1 - r)(-ln E) + q r (-ln P), 0) with d'Eon's pigment colours E and P."""
    return np.array(_core.materialx_absorption_from_melanin(
        check.real("melanin_concentration", melanin_concentration), check.real("melanin_redness", melanin_redness),
        check.color("eumelanin_color", eumelanin_color), check.color("pheomelanin_color", pheomelanin_color)))


# Interface of the `simple_hair` node graph (resources/Materials/Examples/SimpleHair).
SIMPLE_HAIR_DEFAULTS = {
    "melaninConcentration": 0.5,
    "melaninRedness": 0.5,
    "melaninMix": 1.0,
    "baseColor": (1.0, 1.0, 1.0),
    "longitudinalRoughness": 0.1,
    "azimuthalRoughness": 0.1,
    "cuticleAngle": 0.5,
    "tint_R": (1.0, 1.0, 1.0),
    "tint_TT": (1.0, 1.0, 1.0),
    "tint_TRT": (1.0, 1.0, 1.0),
    "ior": 1.55,
}


def simple_hair_default(**inputs) -> Closure:
    """The MaterialX `simple_hair_default` material: melanin and colour absorptions blended
    by melaninMix, `chiang_hair_roughness` feeding all three lobes, no diffuse. As in the
    graph, the colour helper keeps its default azimuthal roughness 0.2 (it is not wired)."""
    check.keywords("simple_hair_default", inputs, SIMPLE_HAIR_DEFAULTS)
    v = dict(SIMPLE_HAIR_DEFAULTS)
    v.update(inputs)
    melanin = deon_hair_absorption_from_melanin(v["melaninConcentration"], v["melaninRedness"])
    color = chiang_hair_absorption_from_color(v["baseColor"])
    mix = check.real("melaninMix", v["melaninMix"])
    absorption = mix * melanin + (1.0 - mix) * color
    r = chiang_hair_roughness(v["longitudinalRoughness"], v["azimuthalRoughness"])
    return chiang_hair_bsdf(tint_R=v["tint_R"], tint_TT=v["tint_TT"], tint_TRT=v["tint_TRT"], ior=v["ior"],
                            roughness_R=r.roughness_R, roughness_TT=r.roughness_TT, roughness_TRT=r.roughness_TRT,
                            cuticle_angle=v["cuticleAngle"], absorption_coefficient=tuple(absorption))


def simple_hair_base(*, base_color_weight: float = 1.0, base_color=(1.0, 1.0, 1.0),
                     melanin_concentration: float = 1.0, melanin_redness: float = 0.5,
                     specular_reflection_roughness: float = 0.1,
                     specular_reflection_anisotropic_roughness: bool = False,
                     specular_reflection_azimuthal_roughness: float = 0.2, specular_reflection_ior: float = 1.55,
                     specular_reflection_shift: float = 0.5, tint_R=(1.0, 1.0, 1.0), tint_TT=(1.0, 1.0, 1.0),
                     tint_TRT=(1.0, 1.0, 1.0)) -> Closure:
    """The MDL `SimpleHairBase` material of the MaterialX hair proposal, as it was meant
    (docs/materialx.md §7 lists the slips in its text and how each is read here):
    s comes from the azimuthal fit of the (isotropic or azimuthal) roughness, TT/TRT scale
    only v (by 1/4 and 4), the shift maps to (shift - 0.5) * pi, the melanin absorption is
    used when base_color is white with weight 1 (else the colour absorption), and the IOR
    is kept above 1 + 1e-5. Defaults are the proposal's."""
    roughness = check.real("specular_reflection_roughness", specular_reflection_roughness)
    azimuthal = (check.real("specular_reflection_azimuthal_roughness", specular_reflection_azimuthal_roughness)
                 if specular_reflection_anisotropic_roughness else roughness)
    r = chiang_hair_roughness(roughness, azimuthal, 0.5, 2.0)
    color = check.color("base_color", base_color)
    weight = check.real("base_color_weight", base_color_weight)
    if color == (1.0, 1.0, 1.0) and weight == 1.0:
        absorption = deon_hair_absorption_from_melanin(melanin_concentration, melanin_redness)
    else:
        absorption = chiang_hair_absorption_from_color(tuple(weight * c for c in color), azimuthal)
    return chiang_hair_bsdf(tint_R=tint_R, tint_TT=tint_TT, tint_TRT=tint_TRT,
                            ior=max(check.real("specular_reflection_ior", specular_reflection_ior), 1.0 + 1e-5),
                            roughness_R=r.roughness_R, roughness_TT=r.roughness_TT, roughness_TRT=r.roughness_TRT,
                            cuticle_angle=check.real("specular_reflection_shift", specular_reflection_shift),
                            absorption_coefficient=tuple(absorption))
