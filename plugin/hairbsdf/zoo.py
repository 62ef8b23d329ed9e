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

