"""Principled Hair inputs -> the Kajiya-Kay example plugin's parameters, for
`hairbsdf compare --model plugin:PATH:examples/plugins/kajiya_kay/mapping.py` (docs/plugins.md,
"Compare it with Cycles"). It runs inside Blender's Python (3.4's or bpy 4.5's): standard
library only.

`inputs` holds one Principled Hair node's values as the exporter reads them: the keys of the
principled_hair `inputs` in docs/scene_desc.md (color, melanin, melanin_redness, tint,
absorption_coefficient, roughness, radial_roughness, coat, ior, offset, random_color,
random_roughness, random (None: per-strand Hair Info > Random)), plus `model` (CHIANG | HUANG)
and `parametrization` (COLOR | MELANIN | ABSORPTION). Colours are (r, g, b) tuples.

Kajiya-Kay has no absorption and no lobes through the fibre, so this is an approximation:
  color    the fibre colour: as given (COLOR), or from the absorption sigma_a through the
           inverse of Chiang 2016 eq. 9, C = exp(-sqrt(sigma_a) P(radial_roughness)), the mapping
           Principled Hair's Direct Coloring uses (MELANIN: sigma_a from Cycles' pigments, times
           the Tint);
  exponent the specular cone's width 1/sqrt(p) = Principled Hair's R width sqrt(v),
           v = (0.726 r + 0.812 r^2 + 3.7 r^20)^2 (r = Roughness), so p = 1/v;
  specular_color, specular: white and the plugin's default weight 0.3 (Principled Hair's R is
           an uncoloured Fresnel reflection).
"""

import math

EUMELANIN = (0.506, 0.841, 1.653)    # Cycles' pigment absorption per unit melanin
PHEOMELANIN = (0.343, 0.733, 1.924)


def _albedo_scale(beta_n):  # Chiang 2016 eq. 9 denominator
    x = beta_n
    return 5.969 - 0.215 * x + 2.532 * x ** 2 - 10.73 * x ** 3 + 5.574 * x ** 4 + 0.245 * x ** 5


def _color_from_absorption(sigma_a, radial_roughness):
    p = _albedo_scale(radial_roughness)
    return tuple(min(max(math.exp(-math.sqrt(max(s, 0.0)) * p), 0.0), 1.0) for s in sigma_a)


def _fibre_color(inputs):
    par = inputs.get("parametrization", "COLOR")
    radial = float(inputs.get("radial_roughness", 0.3))
    if par == "ABSORPTION":
        return _color_from_absorption(inputs.get("absorption_coefficient", (0.245531, 0.52, 1.365)), radial)
    if par == "MELANIN":
        q = -math.log(max(1.0 - float(inputs.get("melanin", 0.8)), 1e-4))
        red = float(inputs.get("melanin_redness", 1.0))
        sigma = tuple(q * (1 - red) * e + q * red * h for e, h in zip(EUMELANIN, PHEOMELANIN))
        tint = inputs.get("tint", (1.0, 1.0, 1.0))  # its absorption adds: approximately a product
        return tuple(c * t for c, t in zip(_color_from_absorption(sigma, radial), tint))
    return tuple(min(max(float(c), 0.0), 1.0) for c in inputs.get("color", (0.017513, 0.005763, 0.002059)))


def map_inputs(inputs):
    r = float(inputs.get("roughness", 0.3))
    v = (0.726 * r + 0.812 * r * r + 3.7 * r ** 20) ** 2
    exponent = min(max(1.0 / max(v, 1e-12), 1.0), 10000.0)
    return {"color": _fibre_color(inputs), "specular_color": (1.0, 1.0, 1.0), "specular": 0.3,
            "exponent": exponent}
