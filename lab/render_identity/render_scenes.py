"""Renders the dumped scenes (and variants: Filter Glossy, a zoo hair_model, emission, lobe passes)
with the running Python's hairbsdf and saves the images; compare with compare.py.

    python lab/render_identity/render_scenes.py SCENES OUT [--wavefront | --wavefront-one-by-one] [VARIANT ...]

Without a flag the scenes render through the per-pixel loop (integrator.wavefront off, whatever the dump says),
whose images a change to the shading code must keep bit for bit.
--wavefront renders with integrator.wavefront (rays as Embree streams, one-closure Chiang materials through the
float32 batch kernels: the per-pixel engine's images at float rounding); --wavefront-one-by-one also sets
wavefront_streams and wavefront_kernels off (its images must be bit-identical)."""
import copy, glob, os, sys
import numpy as np
from hairbsdf.blender.export_scene import load_scene
from hairbsdf.render import render
src, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)
def variants(name, desc):
    yield name, desc
    if name.startswith(("swatch", "mixed", "huang_ellipse", "furnace")):
        d = copy.deepcopy(desc); d["integrator"]["filter_glossy"] = 1.0
        d["integrator"]["max_bounces"] = max(4, d["integrator"].get("max_bounces", 4))
        yield name + "+blur", d
    if name.startswith("swatch"):
        d = copy.deepcopy(desc)
        d["materials"][0]["closures"] = [{"type": "hair_model", "weight": (0.7, 0.7, 0.7), "model": "epic", "params": {}},
                                         {"type": "diffuse", "weight": (0.3, 0.3, 0.3), "color": (0.8, 0.5, 0.2)},
                                         {"type": "emission", "weight": (1, 1, 1), "color": (0.1, 0.2, 0.3), "strength": 0.5}]
        yield name + "+model", d
        d = copy.deepcopy(desc); d["materials"][0]["closures"][0]["model"] = "HUANG"
        d["materials"][0]["closures"].append(dict(d["materials"][0]["closures"][0], model="CHIANG", weight=(0.3, 0.2, 0.1)))
        d["integrator"]["filter_glossy"] = 1.0; d["integrator"]["samples"] = 2
        yield name + "+huang+chiang+blur", d
        d = copy.deepcopy(desc); d["materials"][0]["closures"][0]["model"] = "HUANG"
        d["integrator"]["huang_sampler"] = "mixture"; d["integrator"]["samples"] = 2
        yield name + "+huang_mixture", d
        d = copy.deepcopy(desc); d["integrator"]["passes"] = ["hair_lobes"]
        yield name + "+lobes", d
options = {"--wavefront": {"wavefront": True}, "--wavefront-one-by-one": {"wavefront": True, "wavefront_streams": False,
                                                                            "wavefront_kernels": False}}
integrator = {"wavefront": False}
integrator.update({k: v for a in sys.argv[3:] for k, v in options.get(a, {}).items()})
only = [a for a in sys.argv[3:] if a not in options]
for path in sorted(glob.glob(os.path.join(src, "*.npz"))):
    name = os.path.basename(path)[:-4]
    for vname, desc in variants(name, load_scene(path)[0]):
        if only and vname not in only: continue
        desc["integrator"].update(integrator)
        try:
            r = render(desc, threads=2)
        except Exception as e:
            print(vname, "ERROR", e); continue
        arrays = {k: v for k, v in r.items() if isinstance(v, np.ndarray)}
        np.savez(os.path.join(out, vname + ".npz"), **arrays)
        print(vname, {k: float(v.mean()) for k, v in arrays.items()}, "%.1fs" % r["stats"]["seconds"], flush=True)
