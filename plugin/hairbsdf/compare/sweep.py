"""`hairbsdf compare --sweep sweep.toml`: one scene, several axes of values, their product as
cases (docs/cluster.md, "Sweeps", is the schema's documentation).

    scene = "fiber_gonio:front"            # a library scene[:variant], or a .blend (relative to this file)
    blender = ["bpy", "bpy5"]              # optional axis: Blender versions, as --blender takes them
    heatmap = ["melanin", "roughness"]     # optional: the heat map's two axes (default: the first two)

    [[axis]]
    name = "melanin"                       # optional: defaults to the input's or setting's name
    material = "*"                         # optional: a material's name, "*" (default) every one with the node
    node = "Principled Hair BSDF"          # a node's name, label or type
    input = "Melanin"                      # the node's input socket
    values = [0.1, 0.5, 0.9]               # or range = {start = 0.1, stop = 0.9, num = 5} (or step = 0.2)

    [[axis]]
    setting = "cycles.samples"             # a render setting: a dotted path from the scene
    values = [1, 4]

    [[axis]]
    setting = "hairbsdf.wavefront"         # our engine's own settings (hairbsdf.*): set on our renders only
    values = [0, 1]                        # (a bool setting takes 0 / 1)

Blender sets each value after it opens the scene (blender_job.apply_overrides); the scene is built
once. A bad file raises SweepError naming the key.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import io
import itertools
import math
import os
import tomllib
from pathlib import Path

TOP_KEYS = ("scene", "blender", "heatmap", "axis", "title")
AXIS_KEYS = ("name", "material", "node", "input", "setting", "values", "range")
RANGE_KEYS = ("start", "stop", "num", "step")


class SweepError(ValueError):
    pass


@dataclasses.dataclass
class Axis:
    name: str
    values: list
    target: dict  # {material, node, input} or {setting}

    def override(self, value):
        return dict(self.target, key="axis %s" % self.name, value=value)


@dataclasses.dataclass
class Sweep:
    path: str
    scene: str
    axes: list
    blender: list | None
    heatmap: tuple
    title: str

    @property
    def size(self):
        return math.prod(len(a.values) for a in self.axes)

    def points(self):
        """Every point of the product: [{axis name: value}]."""
        return [dict(zip([a.name for a in self.axes], vals)) for vals in itertools.product(*[a.values for a in self.axes])]

    def as_dict(self):
        return dict(file=self.path, scene=self.scene, title=self.title, blender=self.blender,
                    heatmap=list(self.heatmap), axes=[dict(name=a.name, values=a.values, **a.target) for a in self.axes])


def _num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _values(where, ax):
    if ("values" in ax) == ("range" in ax):
        raise SweepError("%s: give exactly one of values = [...] or range = {start, stop, num|step}" % where)
    if "values" in ax:
        vals = ax["values"]
        if not isinstance(vals, list) or not vals:
            raise SweepError("%s.values: must be a non-empty list, not %r" % (where, vals))
        for v in vals:
            if not (_num(v) or isinstance(v, str) or (isinstance(v, list) and all(_num(x) for x in v))):
                raise SweepError("%s.values: %r is not a number, a string or a list of numbers (a colour)" % (where, v))
        return vals
    r = ax["range"]
    if not isinstance(r, dict):
        raise SweepError("%s.range: must be a table {start, stop, num} or {start, stop, step}, not %r" % (where, r))
    for k in r:
        if k not in RANGE_KEYS:
            raise SweepError("%s.range.%s: unknown key (allowed: %s)" % (where, k, ", ".join(RANGE_KEYS)))
    for k in ("start", "stop"):
        if not _num(r.get(k)):
            raise SweepError("%s.range.%s: a number is required" % (where, k))
    a, b = float(r["start"]), float(r["stop"])
    if ("num" in r) == ("step" in r):
        raise SweepError("%s.range: give exactly one of num (points, both ends included) or step" % where)
    if "num" in r:
        n = r["num"]
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise SweepError("%s.range.num: an integer >= 1 is required, not %r" % (where, n))
        return [a] if n == 1 else [round(a + (b - a) * i / (n - 1), 12) for i in range(n)]
    st = r["step"]
    if not _num(st) or st <= 0:
        raise SweepError("%s.range.step: a number > 0 is required, not %r" % (where, st))
    n = int(math.floor((b - a) / st + 1e-9)) + 1
    if n < 1:
        raise SweepError("%s.range: stop must not be below start" % where)
    return [round(a + i * st, 12) for i in range(n)]


def load(path):
    """Parses and checks a sweep file. Raises SweepError("FILE: KEY: what is wrong")."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise SweepError("%s: cannot read it: %s" % (path, exc)) from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepError("%s: not valid TOML: %s" % (path, exc)) from None
    try:
        return _parse(path, data)
    except SweepError as exc:
        raise SweepError("%s: %s" % (path, exc)) from None


def _parse(path, data):
    for k in data:
        if k not in TOP_KEYS:
            raise SweepError("%s: unknown key (allowed: %s)" % (k, ", ".join(TOP_KEYS)))
    scene = data.get("scene")
    if not isinstance(scene, str) or not scene:
        raise SweepError("scene: required, a library scene name (NAME or NAME:VARIANT) or a .blend file")
    if scene.endswith(".blend"):
        scene = str((path.parent / scene).resolve())
        if not os.path.exists(scene):
            raise SweepError("scene: no such .blend file: %s" % scene)
    blender = data.get("blender")
    if blender is not None and (not isinstance(blender, list) or not blender
                                or not all(isinstance(b, str) and b for b in blender)):
        raise SweepError("blender: must be a non-empty list of --blender values (bpy, bpy5, a path), not %r"
                         % (blender,))
    axes_in = data.get("axis")
    if not isinstance(axes_in, list) or not axes_in or not all(isinstance(a, dict) for a in axes_in):
        raise SweepError("axis: at least one [[axis]] table is required")
    axes = []
    for i, ax in enumerate(axes_in):
        where = "axis[%d]" % i
        for k in ax:
            if k not in AXIS_KEYS:
                raise SweepError("%s.%s: unknown key (allowed: %s)" % (where, k, ", ".join(AXIS_KEYS)))
        if "setting" in ax:
            for k in ("material", "node", "input"):
                if k in ax:
                    raise SweepError("%s.%s: an axis sets a render setting or a node input, not both" % (where, k))
            if not isinstance(ax["setting"], str) or not ax["setting"].strip(". "):
                raise SweepError("%s.setting: a dotted path from the scene is required, e.g. cycles.samples" % where)
            target = dict(setting=ax["setting"])
            default_name = ax["setting"].split(".")[-1]
        else:
            for k in ("node", "input"):
                if not isinstance(ax.get(k), str) or not ax[k]:
                    raise SweepError("%s.%s: required (a string), or give setting = \"...\" instead" % (where, k))
            mat = ax.get("material", "*")
            if not isinstance(mat, str) or not mat:
                raise SweepError("%s.material: a material's name or \"*\" is required, not %r" % (where, mat))
            target = dict(material=mat, node=ax["node"], input=ax["input"])
            default_name = ax["input"].lower().replace(" ", "_")
        name = ax.get("name", default_name)
        if not isinstance(name, str) or not name:
            raise SweepError("%s.name: a non-empty string is required" % where)
        if name in [a.name for a in axes] or name == "blender":
            raise SweepError("%s.name: %r is used twice (name the axes apart)" % (where, name))
        axes.append(Axis(name, _values(where, ax), target))
    names = [a.name for a in axes] + (["blender"] if blender else [])
    heat = data.get("heatmap", names[:2])
    if not isinstance(heat, list) or len(heat) != 2 or len(set(heat)) != 2 or not all(h in names for h in heat):
        if "heatmap" in data:
            raise SweepError("heatmap: two different axis names are required (axes: %s), not %r"
                             % (", ".join(names), heat))
        heat = names[:2] if len(names) >= 2 else names[:1] * 2
    title = data.get("title", "sweep " + path.stem)
    if not isinstance(title, str):
        raise SweepError("title: a string is required")
    return Sweep(str(path), scene, axes, blender, tuple(heat), title)


def fmt_value(v):
    if isinstance(v, float):
        return "%g" % v
    if isinstance(v, list):
        return "(" + ",".join(fmt_value(x) for x in v) + ")"
    return str(v)


def expand(sweep, base_cases):
    """The sweep's cases: each base case (the scene in each Blender, per variant) at every point."""
    out = []
    for c in base_cases:
        for pt in sweep.points():
            tag = "[%s]" % ",".join("%s=%s" % (k, fmt_value(v)) for k, v in pt.items())
            name, _, label = c.id.partition("@")
            overrides = [a.override(pt[a.name]) for a in sweep.axes]
            out.append(dataclasses.replace(c, id="%s%s@%s" % (name, tag, label), sweep_point=dict(pt),
                                           overrides=overrides))
    return sorted(out, key=lambda c: c.id)


# --------------------------------------------------------------------------- the sweep view

def image_bias(out_dir, case):
    """Signed relative bias of the image means, ours / Cycles − 1, from the case's mean EXRs."""
    import numpy as np

    from . import metrics
    d = Path(out_dir) / "cases" / case["dir"]
    try:
        ref = metrics.load_image(str(d / "cycles_mean.exr"))
        test = metrics.load_image(str(d / "hairbsdf_mean.exr"))
    except Exception:
        return None
    m = float(ref[..., :3].mean(dtype=np.float64))
    return float(test[..., :3].mean(dtype=np.float64)) / m - 1.0 if m else None


def _coord(case, axis):
    if axis == "blender":
        return case["blender"]["label"]
    return fmt_value(case["sweep_point"][axis])


def _axis_values(sweep, cases, axis):
    if axis == "blender":
        return list(dict.fromkeys(c["blender"]["label"] for c in cases))
    (ax,) = [a for a in sweep.axes if a.name == axis]
    return [fmt_value(v) for v in ax.values]


def sweep_view(out_dir, cases, sweep):
    """Writes sweep.html (a verdict matrix per slice of the other axes, and the bias heat map over
    sweep.heatmap) and returns report.json's runs[].sweep."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from .report import _anchor, _badge

    cases = [c for c in cases if c.get("sweep_point") is not None]
    for c in cases:
        c["sweep_bias"] = image_bias(out_dir, c)
    ax_x, ax_y = sweep.heatmap
    xs, ys = _axis_values(sweep, cases, ax_x), _axis_values(sweep, cases, ax_y)
    others = [a.name for a in sweep.axes if a.name not in (ax_x, ax_y)]
    if "blender" not in (ax_x, ax_y):
        others.append("blender")
    slices = {}
    for c in cases:
        key = tuple((o, _coord(c, o)) for o in others) + (("variant", c.get("variant") or ""),)
        slices.setdefault(key, {})[(_coord(c, ax_x), _coord(c, ax_y))] = c
    parts, images, matrix = [], [], []
    for key, cells in slices.items():
        label = ", ".join("%s = %s" % kv for kv in key if kv[1]) or "all"
        rows = ["<h2>%s</h2><table><tr><th>%s \\ %s</th>%s</tr>" % (
            html.escape(label), html.escape(ax_y), html.escape(ax_x),
            "".join("<th>%s</th>" % html.escape(x) for x in xs))]
        grid = np.full((len(ys), len(xs)), np.nan)
        for iy, y in enumerate(ys):
            tds = []
            for ix, x in enumerate(xs):
                c = cells.get((x, y))
                if c is None:
                    tds.append("<td>&ndash;</td>")
                    continue
                b = c.get("sweep_bias")
                if b is not None:
                    grid[iy, ix] = b
                tds.append("<td>%s<br><span class=\"cell-note\">%s</span></td>" % (
                    _badge(c["status"], "index.html#" + _anchor(c)), "bias %+.2e" % b if b is not None else ""))
                matrix.append(dict(slice=label, x=x, y=y, id=c["id"], status=c["status"], bias=b))
            rows.append("<tr><th>%s</th>%s</tr>" % (html.escape(y), "".join(tds)))
        rows.append("</table>")
        fig, axp = plt.subplots(figsize=(1.2 + 0.8 * len(xs), 1.0 + 0.6 * len(ys)), dpi=100)
        lim = float(np.nanmax(np.abs(grid))) if np.isfinite(grid).any() else 1.0
        im = axp.imshow(grid, cmap="RdBu_r", vmin=-lim or -1, vmax=lim or 1, origin="lower", aspect="auto")
        axp.set_xticks(range(len(xs)), xs, rotation=45)
        axp.set_yticks(range(len(ys)), ys)
        axp.set_xlabel(ax_x)
        axp.set_ylabel(ax_y)
        axp.set_title("bias (ours / Cycles - 1): %s" % label, fontsize=9)
        fig.colorbar(im, ax=axp)
        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png")
        plt.close(fig)
        png = "sweep_heatmap_%d.png" % len(images)
        (Path(out_dir) / png).write_bytes(buf.getvalue())
        images.append(png)
        rows.append('<p><img alt="bias heat map" src="data:image/png;base64,%s"></p>'
                    % base64.b64encode(buf.getvalue()).decode())
        parts.append("\n".join(rows))
    page = ("<!doctype html><html><head><meta charset=\"utf-8\"><title>%s</title><style>%s</style></head><body>"
            "<h1>%s</h1><p>%s: %d points over %s; verdict per case (a click opens it in the report), and the "
            "image-mean bias of ours against Cycles as a heat map over %s × %s.</p>%s</body></html>") % (
        html.escape(sweep.title), _css(), html.escape(sweep.title), html.escape(os.path.basename(sweep.path)),
        len(cases), html.escape(", ".join([a.name for a in sweep.axes] + (["blender"] if sweep.blender else []))),
        html.escape(ax_x), html.escape(ax_y), "\n".join(parts))
    tmp = Path(out_dir) / "sweep.html.tmp"
    tmp.write_text(page)
    os.replace(tmp, Path(out_dir) / "sweep.html")
    return dict(sweep.as_dict(), page="sweep.html", heatmaps=images, matrix=matrix)


def _css():
    from .report import TEMPLATES
    return (TEMPLATES / "report.css").read_text()
