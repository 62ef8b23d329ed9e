"""Mean weight of Cycles' Huang sampler against the directional albedo of the Huang eval.

Cycles' Huang sampler reports pdf 1 and a weight that estimates the traced path's energy. This
script measures how far the mean of that weight is from the integral of the eval (estimated with
Cycles' unbiased stochastic eval over uniform directions), per aspect ratio and view elevation,
in the far field. A ratio above 1 means BSDF-sampled bounces in Cycles carry more light than the
eval implies (docs/huang.md §10, the reason the engine uses Cycles' sampler).

    .venv/bin/python lab/huang_sampler_bias.py                 # the table in docs/huang.md
    .venv/bin/python lab/huang_sampler_bias.py --samples 100000 --aspect 0.5
"""

import argparse

import numpy as np

import hairbsdf


def measure(aspect, theta, samples, rng):
    inputs = dict(parametrization="melanin", melanin=0.3, melanin_redness=0.5, roughness=0.3, ior=1.55,
                  offset=0.0349066, aspect_ratio=aspect)
    cycles = hairbsdf.principled_hair(model="huang", sampler="cycles", **inputs)
    angle = rng.uniform(0, 2 * np.pi, samples)
    normal = np.stack([np.zeros(samples), np.cos(angle), np.sin(angle)], axis=1)  # random ellipse orientation
    wo = np.tile([np.sin(theta), 0.0, np.cos(theta)], (samples, 1))
    h = rng.uniform(-1, 1, samples)
    s = cycles.sample(wo, h, rng.random((samples, 3)), normal=normal)
    weight = np.where(np.isfinite(s.weight), s.weight, 0.0)
    z = rng.uniform(-1, 1, samples)
    phi = rng.uniform(0, 2 * np.pi, samples)
    wi = np.stack([z, np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi)], axis=1)
    albedo = cycles.cycles_estimate(wo, wi, h, samples=1, seed=3, normal=normal).sum(axis=1) * 4 * np.pi
    return weight.mean(0), weight.std(0) / np.sqrt(samples), albedo.mean(0), albedo.std(0) / np.sqrt(samples)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=400_000, metavar="N", help="samples per case (default 400000)")
    ap.add_argument("--aspect", type=float, action="append", metavar="B",
                    help="aspect ratio; repeat for several (default 0.5 and 1)")
    ap.add_argument("--theta", type=float, action="append", metavar="RAD",
                    help="view elevation in radians; repeat for several (default 0, 0.4, 0.9)")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    print("aspect  theta  mean sampler weight (RGB)  albedo of the eval (RGB)  ratio")
    for aspect in a.aspect or (0.5, 1.0):
        for theta in a.theta or (0.0, 0.4, 0.9):
            w, w_err, e, e_err = measure(aspect, theta, a.samples, rng)
            fmt = lambda v: " ".join("%.4f" % x for x in v)  # noqa: E731
            print(f"{aspect:6.2f} {theta:6.2f}  {fmt(w)} (+-{w_err.max():.4f})  {fmt(e)} (+-{e_err.max():.4f})  "
                  f"{fmt(w / e)}", flush=True)


if __name__ == "__main__":
    main()
