"""Compares two folders of images from render_scenes.py: bit-identical, or the largest
difference per image relative to the image's mean.

    python lab/render_identity/compare.py BEFORE AFTER
"""
import glob
import os
import sys

import numpy as np

before, after = sys.argv[1], sys.argv[2]
worst = 0.0
for path in sorted(glob.glob(os.path.join(before, "*.npz"))):
    name = os.path.basename(path)
    other = os.path.join(after, name)
    if not os.path.exists(other):
        print(f"{name}: missing in {after}")
        worst = np.inf
        continue
    a, b = np.load(path), np.load(other)
    for key in a.files:
        x, y = a[key].astype(np.float64), b[key].astype(np.float64)
        if np.array_equal(x, y):
            print(f"{name} {key}: bit-identical")
            continue
        rel = np.max(np.abs(x - y)) / max(np.mean(np.abs(x)), 1e-30)
        worst = max(worst, rel)
        print(f"{name} {key}: {np.sum(x != y)} of {x.size} values differ, max |diff| / mean {rel:.3g}")
sys.exit(0 if worst == 0 else 1)
