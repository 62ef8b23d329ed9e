"""Speed of hairbsdf.render against Cycles on one scene at equal samples, 2 threads.

    .venv/bin/python blender_tests/render_units/bench_vs_cycles.py [case] [samples] [repeats]

Default: the `bench_hair` case of unit_cases.py (1500 strands over a plane, 160 x 160 px,
sun + world, Blender's default bounce budgets), 32 samples, 2 repeats. Cycles' time is
bpy.ops.render.render (scene sync and BVH build included), ours is stats["seconds"] (BVH
build included). Renders alternate, so a busy machine slows both alike.
"""

import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import unit_cases as C  # noqa: E402


def main():
    name = sys.argv[1] if len(sys.argv) > 1 else "bench_hair"
    spp = int(sys.argv[2]) if len(sys.argv) > 2 else 32
    repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    from hairbsdf.render import render

    out = os.path.join("/tmp", f"hairbsdf_bench_{os.getpid()}.npz")
    for _ in range(repeats):
        subprocess.run([sys.executable, os.path.join(HERE, "cycles_render.py"), "--out", out, "--cases", name,
                        "--samples", str(spp), "--threads", "2"], cwd=HERE, check=True, capture_output=True)
        d = np.load(out)
        t_cycles = json.loads(str(d["meta"]))["seconds"][name]
        ref = d["img_" + name][..., :3]
        o = render(C.scene_desc(C.case(name), samples=spp), threads=2)
        ours = o["combined"][..., :3]
        print(f"{name} {spp} spp, 2 threads: Cycles {t_cycles:.2f} s, ours {o['stats']['seconds']:.2f} s "
              f"(ratio {o['stats']['seconds'] / t_cycles:.2f}); image means ours {ours.mean():.5f} "
              f"Cycles {ref.mean():.5f}", flush=True)
    os.remove(out)


if __name__ == "__main__":
    main()
