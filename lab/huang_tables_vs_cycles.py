"""Compare our generated Huang E_glass tables (hairbsdf._core.huang_table) with the tables compiled
into a Blender build (diagnostic only: nothing is copied; docs/huang.md §3, docs/blender5.md).

Cycles stores its glass albedo tables as float arrays in the binary. This script finds each of our
two tables there by a pattern of 12 entries (tolerance 1e-3), then reports the largest difference over
the whole table. Run with the venv whose bpy you want to inspect:

    .venv-bpy5/bin/python lab/huang_tables_vs_cycles.py 5.x   # bpy 5.3's bpy/__init__.so
    .venv/bin/python lab/huang_tables_vs_cycles.py 4.x        # bpy 4.5's
"""
import importlib.metadata
import importlib.util
import sys

import numpy as np

import hairbsdf
from hairbsdf.principled import HUANG_GLASS_ALBEDO_TABLES


def find_table(blob: np.ndarray, ours: np.ndarray, tolerance: float = 1e-3):
    """Offsets in `blob` (float32) where `ours` (n, n, n) seems to start."""
    n = ours.shape[0]
    probes = [(k, j, i) for i in (n // 2 - 2, n // 2, n // 2 + 2) for j in (n * 3 // 8, n * 5 // 8)
              for k in (n * 5 // 16, n // 2)]
    offsets = [(k * n + j) * n + i for k, j, i in probes]
    first = offsets[0]
    np.seterr(invalid="ignore")  # the binary's bytes read as floats include NaNs
    candidates = np.nonzero(np.abs(blob[: blob.size - n ** 3] - ours[probes[0]]) < tolerance)[0]
    for off, probe in zip(offsets[1:], probes[1:]):
        candidates = candidates[np.abs(blob[candidates + off - first] - ours[probe]) < tolerance]
    return [int(c) - first for c in candidates]


def main(argv):
    if len(argv) != 2 or argv[1] not in HUANG_GLASS_ALBEDO_TABLES:
        print(f"usage: {argv[0]} {{{'|'.join(HUANG_GLASS_ALBEDO_TABLES)}}}", file=sys.stderr)
        return 2
    spec = importlib.util.find_spec("bpy")  # the extension module itself; importing bpy is not needed
    if spec is None or not spec.origin:
        print("no bpy module in this Python", file=sys.stderr)
        return 2
    so = spec.origin
    blob = np.memmap(so, dtype=np.float32, mode="r")
    tables = hairbsdf._core.huang_table(HUANG_GLASS_ALBEDO_TABLES[argv[1]])
    print(f"{so} (bpy {importlib.metadata.version('bpy')}), our {argv[1]} tables {tables.shape}")
    status = 0
    for which, name in enumerate(("eta >= 1", "eta < 1")):
        ours = tables[which]
        found = find_table(blob, ours)
        if len(found) != 1:
            print(f"  {name}: {len(found)} matches of the pattern (expected 1)")
            status = 1
            continue
        theirs = np.asarray(blob[found[0]: found[0] + ours.size], dtype=np.float64).reshape(ours.shape)
        diff = np.abs(theirs - ours)
        worst = np.unravel_index(np.argmax(diff), diff.shape)
        print(f"  {name}: at float {found[0]}; |ours - Cycles'| max {diff.max():.2e} at [z, y, x] = {[int(i) for i in worst]}"
              f" ({ours[worst]:.6f} vs {theirs[worst]:.6f}), p99 {np.quantile(diff, 0.99):.2e},"
              f" median {np.median(diff):.2e}")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv))
