#!/usr/bin/env python3
"""Measures the numbers docs/principled_hair.md quotes: how far Cycles' approximations
(`accuracy="cycles"`) are from exact special functions, the energy they lose, how far
Cycles' sampler is from the pdf it reports, and what the Blender 3.4 tilt and MaterialX's
theta_i tilt do to normalisation. Prints Markdown tables.

    .venv/bin/python lab/measure_chiang.py
"""

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "plugin" / "tests"))

import hairbsdf  # noqa: E402
from hairbsdf import materialx, testing  # noqa: E402
from reference import chiang_reference as ref  # noqa: E402

DEG = np.pi / 180


def unit(theta_deg, phi_deg=0.0):
    t, p = theta_deg * DEG, phi_deg * DEG
    return np.array([np.sin(t), np.cos(t) * np.cos(p), np.cos(t) * np.sin(p)])


def sphere_grid(n_theta=721, n_phi=1440):
    theta = np.linspace(-np.pi / 2, np.pi / 2, n_theta)[1:-1]
    phi = np.linspace(-np.pi, np.pi, n_phi + 1)[:-1]
    T, P = np.meshgrid(theta, phi, indexing="ij")
    wi = np.stack([np.sin(T), np.cos(T) * np.cos(P), np.cos(T) * np.sin(P)], -1).reshape(-1, 3)
    dw = (np.cos(T) * (theta[1] - theta[0]) * (phi[1] - phi[0])).ravel()
    return wi, dw


def cycles_vs_exact(rng, n=200_000):
    print("\n### `cycles` against `exact` accuracy (random directions and h, default colour)\n")
    print("| roughness | median rel. diff | p99 | max |")
    print("|---|---|---|---|")
    wo, wi = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    h = rng.uniform(-1, 1, n)
    for beta in (0.1, 0.2, 0.3, 0.5, 0.8, 1.0):
        a = hairbsdf.principled_hair(roughness=beta).eval(wo, wi, h)
        b = hairbsdf.principled_hair(roughness=beta, accuracy="exact").eval(wo, wi, h)
        mask = b > 1e-3 * b.max()
        rel = np.abs(a - b)[mask] / b[mask]
        print(f"| {beta} | {np.median(rel):.2e} | {np.percentile(rel, 99):.2e} | {rel.max():.2e} |")


def furnace_deficit():
    print("\n### White furnace (sigma_a = 0, Offset 2°, radial roughness 0.3), directional albedo by quadrature\n")
    print("| roughness | θo | h | cycles | exact |")
    print("|---|---|---|---|---|")
    for beta in (0.1, 0.2, 0.3, 0.5, 0.7, 1.0):
        for theta_o, h in ((0, 0.0), (45, 0.5), (80, -0.9)):
            vals = []
            for accuracy in ("cycles", "exact"):
                c = hairbsdf.principled_hair(parametrization="absorption", absorption_coefficient=0.0, roughness=beta,
                                             accuracy=accuracy)
                vals.append(c.albedo(unit(theta_o), h)[0, 0])
            print(f"| {beta} | {theta_o}° | {h} | {vals[0]:.5f} | {vals[1]:.6f} |")


def sampler_mismatch():
    print("\n### Cycles' sampler against the pdf it reports (tilt 4.2): ∫|reported − true| dω\n")
    print("| coat | roughness | accuracy | L1 |")
    print("|---|---|---|---|")
    wi, dw = sphere_grid()
    wo, h = unit(-20, 10), 0.3
    for coat in (0.0, 0.3, 0.6):
        for beta in (0.2, 0.3, 0.6):
            for accuracy in ("cycles", "exact"):
                closure = hairbsdf.principled_hair(roughness=beta, coat=coat, accuracy=accuracy)
                params = ref.principled_hair_params(roughness=beta, coat=coat)
                true = ref.chiang_sampling_density(params, np.broadcast_to(wo, wi.shape), wi, h)
                l1 = float(np.sum(np.abs(closure.pdf(wo, wi, h) - true) * dw))
                print(f"| {coat} | {beta} | {accuracy} | {l1:.2e} |")


def tilt_normalisation():
    print("\n### θi tilt (Blender 3.4–4.1, MaterialX): ∫pdf dω and albedo (sigma_a = 0, exact)\n")
    print("| model | offset | θo | h | ∫pdf | albedo |")
    print("|---|---|---|---|---|---|")
    for offset_deg in (2.0, 4.0, -5.0):
        for theta_o, h in ((-35, 0.3), (60, -0.7)):
            c = hairbsdf.principled_hair(parametrization="absorption", absorption_coefficient=0.0, tilt="3.4",
                                         accuracy="exact", offset=offset_deg * DEG)
            print(f"| Principled, tilt 3.4 | {offset_deg}° | {theta_o}° | {h} | "
                  f"{testing.pdf_integral(c, unit(theta_o), h):.5f} | {c.albedo(unit(theta_o), h)[0, 0]:.5f} |")
            m = materialx.chiang_hair_bsdf(cuticle_angle=0.5 + offset_deg / 180.0)
            print(f"| MaterialX chiang_hair_bsdf | {offset_deg}° | {theta_o}° | {h} | "
                  f"{testing.pdf_integral(m, unit(theta_o), h):.5f} | {m.albedo(unit(theta_o), h)[0, 0]:.5f} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    cycles_vs_exact(rng)
    furnace_deficit()
    sampler_mismatch()
    tilt_normalisation()


if __name__ == "__main__":
    main()
