"""The Huang far-field model against brute-force path tracing through an explicit rough dielectric
fibre (reference/huang_bruteforce.py): per lobe (R, TT, TRT) the L1 distance between the
scattered energy per direction bin and the model's value integrated over the bins, relative to the
lobe's energy (issue 6: <= 2 %). The model side is the deterministic eval with the converged h
integral (accuracy="converged": the brute force integrates over the width exactly, Cycles' Simpson
rule does not, docs/huang.md §5). The CI case is small; the grid is marked slow."""

import numpy as np
import pytest

import hairbsdf
from reference import huang_bruteforce as bf

LOBES = {"R": 0, "TT": 1, "TRT": 2}


def local_frame(wo, normal=None):
    t = np.array([1.0, 0.0, 0.0])
    if normal is None:
        x = np.cross(t, wo)
    else:
        x = np.cross(t, np.cross(normal, t))
    x /= np.linalg.norm(x)
    z = np.cross(x, t)
    return x, t, z


def compare(roughness, offset, aspect, theta_o_deg, rays, bins=(12, 24), trt_points=1024, seed=0, ior=1.55,
            sigma=(0.3, 0.3, 0.3)):
    wo = np.array([np.sin(np.radians(theta_o_deg)), 0.0, np.cos(np.radians(theta_o_deg))])
    normal = np.array([0.0, 0.6, 0.8]) if aspect != 1.0 else None
    x, y, z = local_frame(wo, normal)
    I = np.array([wo @ x, wo @ y, wo @ z])
    c = hairbsdf.principled_hair(model="huang", parametrization="absorption", absorption_coefficient=sigma,
                                 roughness=roughness, offset=offset, ior=ior, aspect_ratio=aspect,
                                 accuracy="converged", tolerance=1e-2, trt_points=trt_points)
    tables = tuple(hairbsdf._core.huang_table())
    b = min(aspect, 1.0 / aspect)
    traced, n = bf.trace(I, max(roughness, 0.001), ior, np.array(sigma), tilt=-offset, b=b, n=rays,
                         rng=np.random.default_rng(seed), tables=tables)
    nt, npb = bins
    # Model: 2 x 2 Gauss-Legendre points per bin in (sin theta, phi).
    gx = np.array([-1, 1]) / np.sqrt(3.0)
    st = (-1 + 2 * (np.arange(nt)[:, None] + 0.5 + 0.5 * gx[None, :]) / nt).ravel()
    ph = (-np.pi + 2 * np.pi * (np.arange(npb)[:, None] + 0.5 + 0.5 * gx[None, :]) / npb).ravel()
    S, P = np.meshgrid(st, ph, indexing="ij")
    ct = np.sqrt(1 - S ** 2)
    dl = np.stack([ct * np.sin(P), S, ct * np.cos(P)], -1).reshape(-1, 3)   # local frame
    wi = dl[:, :1] * x + dl[:, 1:2] * y + dl[:, 2:3] * z
    kw = {} if normal is None else {"normal": normal}
    model = c.eval_lobes(wo, wi, 0.0, **kw)[:, :3, 1]
    cell = (2.0 / nt) * (2 * np.pi / npb)
    model = model.reshape(nt, 2, npb, 2, 3).mean(axis=(1, 3)) * cell
    out = {}
    for name, k in LOBES.items():
        d, w = traced[name]
        ti = np.clip(((d[:, 1] + 1) / 2 * nt).astype(int), 0, nt - 1)
        pj = np.clip(((np.arctan2(d[:, 0], d[:, 2]) + np.pi) / (2 * np.pi) * npb).astype(int), 0, npb - 1)
        hist = np.zeros((nt, npb))
        np.add.at(hist, (ti, pj), w[:, 1])
        hist /= n
        m = model[:, :, k]
        energy = m.sum()
        out[name] = dict(l1=float(np.abs(hist - m).sum() / energy), energy_model=float(energy),
                         energy_traced=float(hist.sum()))
    return out


def test_bruteforce_cylinder_small():
    """One circular configuration without tilt, 1.5e6 rays: TT within 2 %; R and TRT within 6 %
    (their histograms hold 5 % and 3 % of the rays: Monte Carlo noise ~3 %)."""
    r = compare(0.3, 0.0, 1.0, 25.0, rays=1_500_000, bins=(10, 20), trt_points=256)
    print(r)
    assert r["TT"]["l1"] <= 0.02, r
    for name in ("R", "TRT"):
        assert r[name]["l1"] <= 0.06, (name, r)
        assert abs(r[name]["energy_model"] / r[name]["energy_traced"] - 1) <= 0.03, (name, r)


@pytest.mark.slow
@pytest.mark.parametrize("roughness,offset,aspect", [(0.1, 0.0, 1.0), (0.3, 0.0, 1.0), (0.5, 0.0, 1.0),
                                                      (0.3, -0.0349, 1.0), (0.3, 0.0, 0.8), (0.3, -0.0349, 0.8)])
def test_bruteforce_cylinder_grid(roughness, offset, aspect):
    """TT <= 2 %. R and TRT are reported (docs/huang.md §8): without tilt they agree to the
    histogram noise (~2-3 %); with a cuticle tilt the model's projected-area factor 1/(wo . n)
    (geometric normal) differs from the traced 1/(wo . m) (mesonormal) by cos t + tan theta tan t /
    cos gamma, a few % in R."""
    r = compare(roughness, offset, aspect, 25.0, rays=4_000_000, bins=(16, 32), trt_points=4096)
    print(roughness, offset, aspect, r)
    assert r["TT"]["l1"] <= 0.02, r
    for name in ("R", "TRT"):
        assert r[name]["l1"] <= 0.08, (name, r)
