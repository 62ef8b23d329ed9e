"""Per-scene thresholds: built-in floors (issue 5's parity thresholds) that a TOML file may
tighten but never loosen.

TOML layout (hairbsdf/compare/thresholds.toml, shipped in the package):

    [defaults]            # every scene
    mean_bias_rel = 0.005
    [scenes.furnace]      # one scene (all its variants), or "scenes.ribbons_vs_3d:RIBBONS"
    image_mean_rel = 0.004
    pending = "why"       # rendered and measured, gates reported but not enforced
    pending_blender = {"3.4" = "why"}   # the same, only for Blender versions starting so

A value looser than its floor is an error (ThresholdError), not a silent clamp.
"""

from __future__ import annotations

import os
import tomllib

# key: (floor, direction, description).  "max": the value must be <= floor (smaller is
# stricter); "min": >= floor (larger is stricter).
FLOORS = {
    "median_rel": (1e-4, "max", "fiber_gonio: median per-pixel relative error"),
    "p99_rel": (2e-3, "max", "fiber_gonio: 99th percentile of the per-pixel relative error"),
    "image_mean_rel": (5e-3, "max", "furnace: |image mean / Cycles' image mean - 1|"),
    "welch_alpha": (0.01, "min", "family-wise level of the per-pixel Welch test (Sidak-corrected)"),
    "welch_max_failures": (0, "max", "pixel-channels allowed to fail the Welch test"),
    "mean_bias_alpha": (0.01, "min", "per-case false-alarm level of the image-mean test: |z| <= t(1 - alpha/2, "
                                     "Welch df)"),
    "mean_bias_rel": (5e-3, "max", "image-mean bias bound, relative"),
    "welch_floor_rel": (1e-4, "max", "standard-error floor of the Welch test, relative to the pixel"),
    "welch_floor_abs": (1e-6, "max", "standard-error floor of the Welch test, absolute"),
}
# Informational metrics: shown with pass/fail in the report, never gating unless *_gate = true.
INFO_DEFAULTS = {
    "idiff_failthresh": 0.016,     # Blender's render tests (8-bit display-referred)
    "idiff_failpercent": 1.0,
    "idiff_gate": False,
    "flip_max": 0.1,
    "flip_gate": False,
    "psnr_min": 30.0,
    "psnr_gate": False,
    "gonio_erode": 2,
}
KNOWN = set(FLOORS) | set(INFO_DEFAULTS) | {"pending", "pending_blender", "note"}
# Keys that no longer exist, with what replaced them (an old TOML gets told, not just "unknown").
RETIRED = {
    "mean_bias_sigma": "the image-mean test's fixed |z| <= 2 became a per-case level, mean_bias_alpha (floor 0.01; "
                       "the critical |z| is t(1 - alpha/2) with the Welch degrees of freedom, docs/statistics.md); "
                       "tighten with mean_bias_alpha = 0.05 instead",
}


class ThresholdError(ValueError):
    pass


def _check(key, value, where):
    if key in RETIRED:
        raise ThresholdError("%s: '%s' was retired: %s" % (where, key, RETIRED[key]))
    if key not in KNOWN:
        raise ThresholdError("%s: unknown threshold '%s' (known: %s)" % (where, key, ", ".join(sorted(KNOWN))))
    if key == "pending_blender" and not (isinstance(value, dict) and all(isinstance(v, str) for v in value.values())):
        raise ThresholdError('%s: pending_blender must be a table {"3.4" = "reason"}' % where)
    if key in FLOORS:
        floor, direction, desc = FLOORS[key]
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise ThresholdError("%s: %s must be a number" % (where, key))
        if (direction == "max" and value > floor) or (direction == "min" and value < floor):
            raise ThresholdError("%s: %s = %r loosens the fixed floor %r (%s); thresholds may only be tightened"
                                 % (where, key, value, floor, desc))


class Thresholds:
    def __init__(self, data=None, source=None):
        self.source = source
        data = data or {}
        self.defaults = dict(data.get("defaults", {}))
        self.scenes = {k: dict(v) for k, v in data.get("scenes", {}).items()}
        for k, v in self.defaults.items():
            _check(k, v, "%s [defaults]" % (source or "thresholds"))
        for name, tab in self.scenes.items():
            for k, v in tab.items():
                _check(k, v, "%s [scenes.%s]" % (source or "thresholds", name))
        extra = set(data) - {"defaults", "scenes"}
        if extra:
            raise ThresholdError("%s: unknown tables %s" % (source or "thresholds", sorted(extra)))

    @classmethod
    def load(cls, path=None):
        """The floors alone when path is None; a path that does not exist is an error."""
        if path is None:
            return cls({}, None)
        if not os.path.isfile(path):
            raise ThresholdError("thresholds file %s does not exist" % path)
        with open(path, "rb") as f:
            return cls(tomllib.load(f), str(path))

    def for_case(self, scene, variant=None, blender_version=None):
        """Effective thresholds of one case: floors, then [defaults], [scenes.NAME], [scenes.NAME:VARIANT];
        `pending_blender` entries apply when blender_version (e.g. (3, 4, 1)) starts with their key."""
        out = {k: v[0] for k, v in FLOORS.items()}
        out.update(INFO_DEFAULTS)
        out["pending"] = None
        out.update(self.defaults)
        out.update(self.scenes.get(scene, {}))
        if variant:
            out.update(self.scenes.get("%s:%s" % (scene, variant), {}))
        by_version = out.pop("pending_blender", None) or {}
        if blender_version is not None and not out["pending"]:
            version = ".".join(str(x) for x in blender_version)
            for prefix, reason in by_version.items():
                if version == prefix or version.startswith(prefix + "."):
                    out["pending"] = reason
        return out
