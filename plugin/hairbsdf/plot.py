"""`hairbsdf plot`: per-lobe polar plots, (theta_i, delta_phi) heat maps and directional albedo
of a model spec; and the target-versus-fit polar figure of `hairbsdf fit` (docs/fit.md).

matplotlib is imported here only, lazily, with the Agg backend: `import hairbsdf` never needs it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from . import gonio
from ._deps import require
from ._validate import huang_tolerance_range
from .gonio import H_NODES
from .closure import YAN_FUR_LOBES
from .principled import DEFAULT_MODEL
from .spec import SpecError, build, format_spec, parse_spec

RGB_COLOURS = ("#d62728", "#2ca02c", "#1f77b4")
LOBE_COLOURS = {"R": "#1f77b4", "TT": "#d62728", "TRT": "#2ca02c", "TRRT+": "#9467bd", "TTs": "#ff7f0e",
                "TRTs": "#8c564b", "total": "black"}
DEFAULT_THETA_O = (0.0, 30.0, 60.0)
DEFAULT_RESOLUTION = 96
# Huang (principled_hair(model="huang")) costs about a millisecond a row where Chiang costs
# microseconds: its plots use a coarser heat map, fewer polar points and a looser tolerance
# (docs/huang.md §4), unless --resolution / --tolerance say otherwise.
HUANG_RESOLUTION = 32
HUANG_SLICE_POINTS = 181
HUANG_PLOT_TOLERANCE = 0.1


def pyplot():
    """matplotlib.pyplot with the Agg backend (no display needed)."""
    matplotlib = require("matplotlib", "tools", "hairbsdf plot / fit")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


# --- Slices -----------------------------------------------------------------------------------------
# phi_o = 0 throughout: wo = (sin theta_o, cos theta_o, 0).

def longitudinal_slice(closure, theta_o, count=361, h_count=H_NODES, h_dependent=False, **eval_kw):
    """Directions in the plane of the fibre axis and the view: wi = (cos t, sin t, 0), t in
    [0, 2 pi] (t = 0 the tip, 90 deg towards the viewer's side: delta_phi = 0, 270 deg the far
    side: delta_phi = pi). Returns t and the lobes (count, 4, 3)."""
    t = np.linspace(0.0, 2 * np.pi, count)
    wi = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=1)
    wo = gonio.direction(theta_o, 0.0)
    return t, gonio.far_field_lobes(closure, np.broadcast_to(wo, wi.shape), wi, h_count, h_dependent, **eval_kw)


def azimuthal_slice(closure, theta_o, count=361, h_count=H_NODES, h_dependent=False, **eval_kw):
    """Directions on the specular cone theta_i = -theta_o against delta_phi in [-pi, pi]."""
    phi = np.linspace(-np.pi, np.pi, count)
    wi = gonio.direction(-theta_o, phi)
    wo = gonio.direction(theta_o, 0.0)
    return phi, gonio.far_field_lobes(closure, np.broadcast_to(wo, wi.shape), wi, h_count, h_dependent, **eval_kw)


def luminance(rgb):
    return np.asarray(rgb) @ gonio.REC709


# --- Figures -----------------------------------------------------------------------------------------

def _spec_closure(text):
    name, kwargs = parse_spec(text)
    return build(text), gonio.depends_on_h(name, kwargs), format_spec(name, kwargs)


def is_huang(spec: str) -> bool:
    """Whether a spec is principled_hair(model="huang") (the expensive model: coarser plot defaults)."""
    name, kwargs = parse_spec(spec)
    return name == "principled_hair" and str(kwargs.get("model", DEFAULT_MODEL)).lower() == "huang"


def _polar_axes(plt, rows, title):
    fig, axes = plt.subplots(rows, 2, subplot_kw={"projection": "polar"}, figsize=(9, 4.3 * rows + 1.2),
                             squeeze=False)
    fig.subplots_adjust(left=0.06, right=0.84, top=1 - 1.5 / (4.3 * rows + 1.2), bottom=0.03, hspace=0.45,
                        wspace=0.35)
    fig.suptitle(_wrap(title), fontsize=9)
    return fig, axes


def _wrap(title: str, width: int = 105) -> str:
    """Long specs broken over lines (a title wider than the figure is cut off)."""
    import textwrap
    return "\n".join(textwrap.fill(line, width, subsequent_indent="    ") for line in title.split("\n"))


def _label_axes(ax_long, ax_azi, theta_o_deg):
    ax_long.set_title(f"longitudinal plane, θo = {theta_o_deg:g}°\n(0° tip, 90° Δφ=0, 270° Δφ=π)", fontsize=8)
    ax_azi.set_title(f"azimuth Δφ on the cone θi = −θo, θo = {theta_o_deg:g}°", fontsize=8)
    for ax in (ax_long, ax_azi):
        ax.tick_params(labelsize=6)


def _view_arrow(ax, theta_o):
    # wo in the longitudinal plane is at t = atan2(cos theta_o, sin theta_o)
    t = np.arctan2(np.cos(theta_o), np.sin(theta_o))
    ax.annotate("", xy=(t, ax.get_rmax() * 0.95), xytext=(0, 0),
                arrowprops={"arrowstyle": "->", "color": "grey", "lw": 0.8})


def fit_comparison_figure(target: str, fitted: str, path, *, h_count=H_NODES, theta_o_deg=DEFAULT_THETA_O, title=None):
    """Polar plots of the target (solid) and the fit (dashed), per RGB channel, in the longitudinal
    plane and on the specular cone, for each theta_o. Returns the path written."""
    plt = pyplot()
    tgt, tgt_h, tgt_text = _spec_closure(target)
    fit_c, fit_h, fit_text = _spec_closure(fitted)
    fig, axes = _polar_axes(plt, len(theta_o_deg), title or f"target {tgt_text}\nfit {fit_text}")
    for row, deg in enumerate(theta_o_deg):
        to = np.radians(deg)
        for col, slicer in enumerate((longitudinal_slice, azimuthal_slice)):
            ax = axes[row, col]
            x, a = slicer(tgt, to, h_count=h_count, h_dependent=tgt_h)
            _, b = slicer(fit_c, to, h_count=h_count, h_dependent=fit_h)
            for c, colour in enumerate(RGB_COLOURS):
                ax.plot(x, a.sum(axis=1)[:, c], color=colour, lw=1.2, label="target" if c == 0 else None)
                ax.plot(x, b.sum(axis=1)[:, c], color=colour, lw=1.2, ls="--", label="fit" if c == 0 else None)
            if col == 0:
                _view_arrow(ax, to)
        _label_axes(axes[row, 0], axes[row, 1], deg)
    axes[0, 1].legend(loc="upper right", bbox_to_anchor=(1.35, 1.1), fontsize=7,
                      title="RGB: solid target, dashed fit", title_fontsize=7)
    return _save(fig, plt, path)


def lobe_polar_figure(spec: str, path, *, h_count=H_NODES, theta_o_deg=DEFAULT_THETA_O, count=361, **eval_kw):
    """Per-lobe polar plots (luminance) and the total, longitudinal plane and specular cone;
    `count` directions per slice, eval_kw (e.g. tolerance=) passed to eval_lobes."""
    plt = pyplot()
    closure, h_dep, text = _spec_closure(spec)
    fig, axes = _polar_axes(plt, len(theta_o_deg), f"{text}\nper-lobe luminance (Rec. 709), h-averaged" if h_dep
                            else f"{text}\nper-lobe luminance (Rec. 709)")
    for row, deg in enumerate(theta_o_deg):
        to = np.radians(deg)
        for col, slicer in enumerate((longitudinal_slice, azimuthal_slice)):
            ax = axes[row, col]
            x, lobes = slicer(closure, to, count=count, h_count=h_count, h_dependent=h_dep, **eval_kw)
            lum = luminance(lobes)  # (n, 4), (n, 6) for yan_fur
            for p, lobe in enumerate(YAN_FUR_LOBES[:lum.shape[1]]):
                if np.any(lum[:, p] > 0):
                    ax.plot(x, lum[:, p], color=LOBE_COLOURS[lobe], lw=1.0, label=lobe)
            ax.plot(x, lum.sum(axis=1), color="black", lw=1.4, ls=":", label="total")
            if col == 0:
                _view_arrow(ax, to)
        _label_axes(axes[row, 0], axes[row, 1], deg)
    axes[0, 1].legend(loc="upper right", bbox_to_anchor=(1.35, 1.1), fontsize=7)
    return _save(fig, plt, path)


def heatmap_figure(spec: str, path, *, h_count=H_NODES, theta_o_deg=DEFAULT_THETA_O, resolution=DEFAULT_RESOLUTION,
                   **eval_kw):
    """(theta_i, delta_phi) maps of each lobe's luminance and the total (rows) for each theta_o
    (columns), log colour scale over 4 decades below each row's maximum."""
    plt = pyplot()
    from matplotlib.colors import LogNorm
    closure, h_dep, text = _spec_closure(spec)
    ti = np.linspace(-np.pi / 2, np.pi / 2, resolution)
    dp = np.linspace(-np.pi, np.pi, 2 * resolution)
    TI, DP = np.meshgrid(ti, dp, indexing="ij")
    wi = gonio.direction(TI.ravel(), DP.ravel())
    maps = []
    for deg in theta_o_deg:
        wo = np.broadcast_to(gonio.direction(np.radians(deg), 0.0), wi.shape)
        lum = luminance(gonio.far_field_lobes(closure, wo, wi, h_count, h_dep, **eval_kw))
        maps.append(np.concatenate([lum, lum.sum(axis=1, keepdims=True)], axis=1).reshape(*TI.shape, lum.shape[1] + 1))
    names = (*YAN_FUR_LOBES[:maps[0].shape[-1] - 1], "total")
    fig, axes = plt.subplots(len(names), len(theta_o_deg), figsize=(3.2 * len(theta_o_deg) + 1.2, 2.2 * len(names)),
                             squeeze=False)
    fig.subplots_adjust(left=0.08, right=0.86, top=0.92, bottom=0.05, hspace=0.45, wspace=0.25)
    fig.suptitle(_wrap(f"{text}\nluminance over (Δφ, θi), log scale"), fontsize=9)
    extent = (-180, 180, -90, 90)
    for r, lobe in enumerate(names):
        vmax = max(float(m[..., r].max()) for m in maps)
        for c, deg in enumerate(theta_o_deg):
            ax = axes[r, c]
            if vmax <= 0:
                ax.text(0.5, 0.5, f"{lobe}: zero", ha="center", va="center", transform=ax.transAxes)
                ax.set_xticks([]), ax.set_yticks([])
                continue
            data = np.maximum(maps[c][..., r], vmax * 1e-4)
            im = ax.imshow(data, origin="lower", extent=extent, aspect="auto", cmap="magma",
                           norm=LogNorm(vmin=vmax * 1e-4, vmax=vmax))
            ax.set_title(f"{lobe}, θo = {deg:g}°", fontsize=8)
            ax.tick_params(labelsize=6)
            if r == 4:
                ax.set_xlabel("Δφ (deg)", fontsize=7)
            if c == 0:
                ax.set_ylabel("θi (deg)", fontsize=7)
        if vmax > 0:  # one colour bar per row, beside its last map
            box = axes[r, -1].get_position()
            bar = fig.colorbar(im, cax=fig.add_axes([0.88, box.y0, 0.015, box.height]))
            bar.ax.tick_params(labelsize=6)
    return _save(fig, plt, path)


def albedo_figure(spec: str, path, *, h_count=8, count=25, **eval_kw):
    """Directional albedo (RGB, the integral of eval over wi) against theta_o, h-averaged where the
    model depends on h (the albedo is smooth in h: 8 nodes suffice). Quadrature at half the default
    density (panels_per_scale=0.5: within 1e-3 of the default on Principled Hair and Epic)."""
    plt = pyplot()
    closure, h_dep, text = _spec_closure(spec)
    theta = np.linspace(-np.pi / 2 * 0.98, np.pi / 2 * 0.98, count)
    wo = gonio.direction(theta, 0.0)
    if h_dep:
        nodes, weights = gonio.h_nodes(h_count)
        albedo = sum(w * closure.albedo(wo, float(h), panels_per_scale=0.5, **eval_kw) for h, w in zip(nodes, weights))
    else:
        albedo = closure.albedo(wo, 0.0, panels_per_scale=0.5, **eval_kw)
    fig, ax = plt.subplots(figsize=(6, 3.6), constrained_layout=True)
    for c, (colour, name) in enumerate(zip(RGB_COLOURS, "RGB")):
        ax.plot(np.degrees(theta), albedo[:, c], color=colour, marker=".", lw=1, label=name)
    ax.set_xlabel("θo (deg)")
    ax.set_ylabel("directional albedo")
    ax.set_xlim(-90, 90)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(_wrap(text + ("\nh-averaged" if h_dep else ""), 90), fontsize=8)
    return _save(fig, plt, path)


def _save(fig, plt, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# --- Command line -----------------------------------------------------------------------------------------

def build_parser(prog: str = "hairbsdf plot") -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Per-lobe polar plots, (theta_i, delta_phi) heat maps and directional albedo of a hair BSDF, "
                    "as PNG files.",
        epilog="SPEC is parsed, never evaluated: one call of principled_hair, kajiya_kay_hair, epic_hair, "
               "scheuermann_hair, marschner_hair, deon_hair or yan_fur (or a short name) with literal keyword arguments.\n\n"
               "Example:\n  hairbsdf plot \"principled_hair(melanin=0.6)\" --out out/plot\n\nDocs: docs/fit.md.")
    ap.add_argument("spec", metavar="SPEC", help="the BSDF, e.g. \"principled_hair(melanin=0.6)\" or \"epic_hair(roughness=0.3)\"")
    ap.add_argument("--out", default="out/plot", metavar="DIR", help="output directory (default out/plot)")
    ap.add_argument("--name", help="file name stem (default: the constructor name)")
    ap.add_argument("--theta-o", metavar="DEGREES", default=",".join(f"{t:g}" for t in DEFAULT_THETA_O),
                    help="view angles theta_o in degrees, comma separated (default 0,30,60)")
    ap.add_argument("--h-nodes", type=int, default=H_NODES, metavar="K",
                    help="Gauss-Legendre nodes in h for h-dependent BSDFs such as Principled Hair (default 32: "
                         "2e-4 of the far field at radial roughness 0.3; raise it for a smaller radial roughness)")
    ap.add_argument("--resolution", type=int, metavar="N",
                    help=f"heat map theta_i cells (delta_phi: twice; default {DEFAULT_RESOLUTION}; "
                         f"{HUANG_RESOLUTION} for Huang, whose rows cost ~1 ms: a coarser grid, and "
                         f"{HUANG_SLICE_POINTS} instead of 361 directions per polar slice)")
    ap.add_argument("--tolerance", type=float, metavar="T",
                    help=f"Huang only: eval and albedo tolerance relative to each row's total (default "
                         f"{HUANG_PLOT_TOLERANCE:g} in plots, docs/huang.md §4); other models have none")
    ap.add_argument("--only", choices=("polar", "heatmap", "albedo"), action="append",
                    help="write only these plots (repeatable; default all three)")
    return ap


def main(argv=None, prog: str = "hairbsdf plot") -> int:
    ap = build_parser(prog)
    args = ap.parse_args(argv)
    try:
        name, _ = parse_spec(args.spec)
        build(args.spec)
        theta_o = tuple(float(t) for t in args.theta_o.split(","))
    except SpecError as exc:
        ap.error(str(exc))
    except ValueError:
        ap.error(f"--theta-o: expected degrees separated by commas, got {args.theta_o!r}")
    if not all(-90 < t < 90 for t in theta_o):
        ap.error("--theta-o: each angle must lie in (-90, 90) degrees")
    huang = is_huang(args.spec)
    resolution = args.resolution if args.resolution is not None else HUANG_RESOLUTION if huang else DEFAULT_RESOLUTION
    if args.h_nodes < 1 or resolution < 4:
        ap.error("--h-nodes must be >= 1 and --resolution >= 4")
    if args.tolerance is not None and not huang:
        ap.error("--tolerance: only Huang (principled_hair(model='huang')) takes a tolerance")
    eval_kw = {}
    if huang:
        tolerance = HUANG_PLOT_TOLERANCE if args.tolerance is None else args.tolerance
        lo, hi = huang_tolerance_range()
        if not lo <= tolerance <= hi:
            ap.error(f"--tolerance={tolerance:g} is out of range; allowed: [{lo:g}, {hi:g}]")
        eval_kw = dict(tolerance=tolerance)
    out, stem = Path(args.out), args.name or name
    only = set(args.only or ("polar", "heatmap", "albedo"))
    written = []
    if "polar" in only:
        written.append(lobe_polar_figure(args.spec, out / f"{stem}_polar.png", h_count=args.h_nodes,
                                         theta_o_deg=theta_o, count=HUANG_SLICE_POINTS if huang else 361,
                                         **eval_kw))
    if "heatmap" in only:
        written.append(heatmap_figure(args.spec, out / f"{stem}_heatmap.png", h_count=args.h_nodes,
                                      theta_o_deg=theta_o, resolution=resolution, **eval_kw))
    if "albedo" in only:
        written.append(albedo_figure(args.spec, out / f"{stem}_albedo.png", **eval_kw))
    for path in written:
        print(path)
    return 0
