"""One bench_hair render with hairbsdf.render, for profilers (docs/benchmarks.md, Engine II and III).

    perf record -g .venv/bin/python lab/profile_render.py [--samples 16] [--threads 1] [--scene NAME | --npz F]
    perf report --no-children --sort dso,symbol

--modules build/profile/plugin renders with the profiling build's native modules (symbols and line
tables; lab/README.md, "A profiling build") instead of the installed, stripped ones.
"""

import argparse
import importlib.util
import os
import sys

from render_args import add_render_arguments, use_native_modules

# The scene lives with the render-unit tests (not in the package): load that file by path.
UNIT_CASES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "blender_tests", "render_units", "unit_cases.py")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_render_arguments(ap, samples_default=16)
    ap.add_argument("--scene", default="bench_hair", help="a unit_cases.py scene (default bench_hair)")
    ap.add_argument("--npz", default="", help="render a dumped SceneDesc (.npz, e.g. from "
                    "lab/render_identity/dump_scenes.py) at --samples instead of --scene")
    ap.add_argument("--camera-ray-stream", action="store_true",
                    help="integrator.camera_ray_stream: camera rays as one Embree stream per tile row")
    ap.add_argument("--per-pixel", action="store_true",
                    help="integrator.wavefront off: the per-pixel loop (default: the wavefront path tracer)")
    ap.add_argument("--one-by-one", action="store_true",
                    help="integrator.wavefront_streams off (the wavefront's rays traced one by one)")
    ap.add_argument("--scalar-shading", action="store_true",
                    help="integrator.wavefront_kernels off (every hit of the wavefront on the scalar double path)")
    ap.add_argument("--curve-intersector", help="the scene's curve_intersector (EMBREE, SWEEP, AUTO; default the scene's)")
    ap.add_argument("--repeat", type=int, default=1, help="render this many times (default 1)")
    a = ap.parse_args()
    if a.samples < 1 or a.threads < 1 or a.repeat < 1:
        ap.error("--samples, --threads and --repeat must be positive")
    if (a.one_by_one or a.scalar_shading) and a.per_pixel:
        ap.error("--one-by-one and --scalar-shading: not with --per-pixel (they set the wavefront's options)")
    if a.modules:
        use_native_modules(a.modules, ap)
    from hairbsdf.render import render
    if a.npz:
        from hairbsdf.scene_file import load_scene
        desc, name = load_scene(a.npz)[0], os.path.basename(a.npz)
        desc["integrator"]["samples"] = a.samples
    else:
        spec = importlib.util.spec_from_file_location("unit_cases", UNIT_CASES)
        cases = sys.modules["unit_cases"] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(cases)
        desc, name = cases.scene_desc(cases.case(a.scene), samples=a.samples), a.scene
    desc["integrator"]["camera_ray_stream"] = a.camera_ray_stream
    desc["integrator"]["wavefront"] = not a.per_pixel
    if a.one_by_one:
        desc["integrator"]["wavefront_streams"] = False
    if a.scalar_shading:
        desc["integrator"]["wavefront_kernels"] = False
    if a.curve_intersector:
        desc["curve_intersector"] = a.curve_intersector
    for _ in range(a.repeat):
        out = render(desc, threads=a.threads)
        print(f"{name}, {a.samples} spp, {a.threads} thread(s), camera_ray_stream {a.camera_ray_stream}, "
              f"wavefront {not a.per_pixel}{' one by one' if a.one_by_one else ''}"
              f"{' scalar shading' if a.scalar_shading else ''}"
              f"{', curve_intersector ' + a.curve_intersector if a.curve_intersector else ''}: "
              f"{out['stats']['seconds']:.2f} s, {out['stats']['rays']} rays, "
              f"{out['stats'].get('kernel_hits', 0)} kernel hits, mean {out['combined'][..., :3].mean():.6f}"
              + (f", modules from {a.modules}" if a.modules else ""),
              flush=True)


if __name__ == "__main__":
    main()
