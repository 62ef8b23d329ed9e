"""The Kajiya-Kay example of kajiya_kay.cpp written in NumPy and wrapped with hairbsdf.python_bsdf:
the same formulas, sampler and pdf (docs/plugins.md), for BSDF-level work without a compiler.

    from kajiya_kay import kajiya_kay
    hair = kajiya_kay(color=(0.6, 0.4, 0.25), specular=0.3, exponent=40)
    hairbsdf.test_plugin(hair)
"""

import math

import numpy as np

import hairbsdf


def kajiya_kay(color=(0.6, 0.4, 0.25), specular_color=(1.0, 1.0, 1.0), specular=0.3, exponent=40.0):
    kd, ks = np.asarray(color, dtype=float), np.asarray(specular_color, dtype=float)
    w, p = float(specular), float(exponent)
    j = math.sqrt(math.pi) * math.exp(math.lgamma(0.5 * (p + 3)) - math.lgamma(0.5 * p + 2))  # J(p + 2)
    norm = 1.0 / (2 * math.pi * j)
    s, d = w * ks.sum(), (1 - w) * kd.sum()
    pick = s / (s + d) if s + d > 0 else -1.0  # probability of the specular lobe

    def cos_of(x):
        return np.sqrt(np.maximum(0.0, 1 - x * x))

    def cdf(x, s0, b):  # logistic
        with np.errstate(over="ignore"):
            return 1 / (1 + np.exp((s0 - x) / b))

    def scale(so):
        return cos_of(so) / math.sqrt(2 * p) + 0.5 / p

    def lobes(wo, si):
        """(N, 4, 3) values (specular as R, diffuse as TRRT+) and the pdf (N,)."""
        so = wo[:, 0]
        co, ci = cos_of(so), cos_of(si)
        cone = np.maximum(ci * co - si * so, 0.0)
        out = np.zeros((len(si), 4, 3))
        out[:, 0] = (w * cone**p * ci * norm)[:, None] * ks
        out[:, 3] = ((1 - w) * ci / math.pi**2)[:, None] * kd
        b, s0 = scale(so), -so
        e = np.exp(-np.abs(si - s0) / b)
        logistic = e / (b * (1 + e) ** 2 * (cdf(1, s0, b) - cdf(-1, s0, b)))
        pdf = pick * logistic / (2 * math.pi) + (1 - pick) * ci / math.pi**2 if pick >= 0 else np.zeros(len(si))
        return out, pdf

    def eval_(wo, wi, h):
        return lobes(wo, wi[:, 0])[0]

    def pdf_(wo, wi, h):
        return lobes(wo, wi[:, 0])[1]

    def sample_(wo, h, u):
        n = len(wo)
        spec = u[:, 2] < pick
        b, s0 = scale(wo[:, 0]), -wo[:, 0]
        lo = cdf(-1, s0, b)
        with np.errstate(divide="ignore", invalid="ignore"):
            q = lo + (u[:, 2] / pick) * (cdf(1, s0, b) - lo)
            si_spec = s0 - b * np.log(1 / q - 1)
            si_diff = np.sqrt(np.maximum(0.0, (u[:, 2] - pick) / (1 - pick))) * np.cos(2 * math.pi * u[:, 1])
        si = np.clip(np.where(spec, si_spec, si_diff), -1.0, 1.0)
        ci, phi = cos_of(si), 2 * math.pi * u[:, 0]
        wi = np.stack([si, ci * np.cos(phi), ci * np.sin(phi)], axis=1)
        values, pdf = lobes(wo, si)
        lobe = np.where(spec, 0, 3).astype(np.int32)
        ok = (pdf > 0) & (pick >= 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            weight = np.where(ok[:, None], values.sum(axis=1) / pdf[:, None], 0.0)
        return wi, weight, np.where(ok, pdf, 0.0), np.where(ok, lobe, -1).astype(np.int32)

    return hairbsdf.python_bsdf(eval=eval_, sample=sample_, pdf=pdf_, name="kajiya_kay_numpy")
