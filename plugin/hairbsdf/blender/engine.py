"""The render engine HAIRBSDF ("hairbsdf").

render(depsgraph): export the evaluated scene (export_scene), call hairbsdf.render.render
(imported lazily, so a missing or broken native renderer is an error message, not a failed
add-on), and write the Combined pass and the passes the view layer asks for (passes.py).  Progress, stats and cancellation go through
update_progress / update_stats / test_break; every failure is reported with
report({'ERROR'}) and never escapes into Blender.

Debugging and tests:
  HAIRBSDF_DUMP_SCENE=path.npz   also write the exported SceneDesc (export_scene.save_scene)
  HAIRBSDF_EXPORT_ONLY=1         export (and dump) only; no pixels are written
  HAIRBSDF_REPORT_FILE=path.json append one JSON line per render: warnings, errors, stats
  HAIRBSDF_RENDER_MODULE=name    import render() from this module instead of hairbsdf.render
LAST_RENDER (module attribute) holds the same dictionary for in-process callers.
"""

from __future__ import annotations

import json
import os

import numpy as np
import threading
import time
import traceback

import bpy

from . import passes
from .export_scene import ExportError, engine_settings, export_scene, save_scene
from .ui import ENGINE_ID
# Material / world / light previews (Properties editor thumbnails): samples per pixel.
PREVIEW_SAMPLES = 32
LAST_RENDER: dict = {}
# Set from any thread to stop the running render as Esc would (background mode and the
# bpy module have no Esc); cleared when a render starts.
CANCEL_EVENT = threading.Event()


def request_cancel() -> None:
    CANCEL_EVENT.set()


def _load_renderer():
    """hairbsdf.render.render (or the module named by $HAIRBSDF_RENDER_MODULE, for tests),
    or ImportError with a message for the user."""
    import importlib

    name = os.environ.get("HAIRBSDF_RENDER_MODULE") or "hairbsdf.render"
    try:
        module = importlib.import_module(name)
        if name == "hairbsdf.render":
            importlib.import_module("hairbsdf._render")  # the native part, loaded lazily
    except ImportError as exc:
        raise ImportError(
            f"the hairbsdf renderer ({name} / hairbsdf._render) is not available in this build ({exc}); "
            "run scripts/setup to build and stage it") from exc
    fn = getattr(module, "render", None)
    if fn is None:
        raise ImportError(f"{name} has no render() function; rebuild with scripts/setup")
    return fn


class HairBsdfRenderEngine(bpy.types.RenderEngine):
    bl_idname = ENGINE_ID
    bl_label = "hairbsdf"
    bl_use_preview = True  # material previews render with this engine (PREVIEW_SAMPLES spp)
    bl_use_postprocess = True
    bl_use_shading_nodes_custom = False  # keep Cycles' shader node editor
    bl_use_eevee_viewport = True

    # Blender 4.4+ documents __init__(*args, **kwargs) -> super().__init__ and __del__ ->
    # super().__del__(); 3.4's bpy_struct has no __del__ (checked on Blender 3.4).
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._messages = []

    def __del__(self):
        parent_del = getattr(super(), "__del__", None)
        if parent_del is not None:
            try:
                parent_del()
            except Exception:  # pragma: no cover - interpreter shutdown
                pass

    # ------------------------------------------------------------------ helpers
    def _cancelled(self) -> bool:
        if CANCEL_EVENT.is_set():
            return True
        return bool(self.test_break())

    def _log(self, level, message):
        self._messages.append((level, message))
        try:
            self.report({level}, "hairbsdf: " + message)
        except Exception:  # pragma: no cover
            print(f"hairbsdf {level}: {message}")

    def _finish(self, info):
        info["messages"] = [list(m) for m in self._messages]
        LAST_RENDER.clear()
        LAST_RENDER.update(info)
        path = os.environ.get("HAIRBSDF_REPORT_FILE")
        if path:
            try:
                with open(path, "a") as f:
                    f.write(json.dumps(info, default=str) + "\n")
            except OSError as exc:  # pragma: no cover
                print(f"hairbsdf: cannot write {path}: {exc}")

    def update_render_passes(self, scene=None, renderlayer=None):
        try:
            passes.register_passes(self, scene, renderlayer)
        except Exception as exc:  # pragma: no cover - never fail Blender's pass sync
            print(f"hairbsdf: update_render_passes failed: {exc}")

    # ------------------------------------------------------------------ render
    def render(self, depsgraph):
        info = {"status": "started", "warnings": [], "errors": []}
        self._messages = []
        CANCEL_EVENT.clear()
        try:
            self._render(depsgraph, info)
        except KeyboardInterrupt:
            info["status"] = "cancelled"
            self._log("INFO", "render cancelled")
        except Exception as exc:  # never let an exception reach Blender
            info["status"] = "error"
            msg = f"{type(exc).__name__}: {exc}" if not isinstance(exc, ExportError) else str(exc)
            info["errors"].append(msg)
            info["traceback"] = traceback.format_exc()
            self._log("ERROR", msg)
            try:
                self.error_set("hairbsdf: " + msg)
            except Exception:  # pragma: no cover - older Blender
                pass
        finally:
            self._finish(info)

    def _render(self, depsgraph, info):
        scene = depsgraph.scene
        settings = engine_settings(scene)
        t0 = time.perf_counter()
        self.update_stats("", "hairbsdf: exporting scene")
        desc, rep = export_scene(depsgraph, render=True, settings=settings, cancel=self._cancelled)
        if self.is_preview:
            desc["integrator"]["samples"] = min(int(desc["integrator"]["samples"]), PREVIEW_SAMPLES)
            desc["integrator"]["passes"] = []
            info["preview"] = True
        t_export = time.perf_counter() - t0
        info.update(export=rep.as_dict(), export_seconds=t_export, counts=dict(rep.counts))
        for w in rep.all_warnings():
            info["warnings"].append(w)
            if not self.is_preview:  # the preview scenes' own materials would only add noise
                self._log("WARNING", w)
        dump = os.environ.get("HAIRBSDF_DUMP_SCENE")
        if dump:
            save_scene(dump, desc, extra={"report": rep.as_dict()})
        if os.environ.get("HAIRBSDF_EXPORT_ONLY"):
            info["status"] = "exported"
            return
        if self._cancelled():
            raise KeyboardInterrupt

        render_fn = _load_renderer()
        width, height = desc["camera"]["resolution"]
        n_samples = int(desc["integrator"]["samples"])
        mem_mb = _scene_bytes(desc) / (1024.0 * 1024.0)
        started = time.perf_counter()
        state = {"last": 0.0}

        def progress(*args, **kwargs):
            try:  # an exception here would reach the renderer and stop the render
                frac, done = _progress_fraction(args, kwargs, n_samples)
                now = time.perf_counter()
                if now - state["last"] < 0.1 and frac < 1.0:
                    return
                state["last"] = now
                self.update_progress(frac)
                spent = now - started
                self.update_stats(f"Mem: {mem_mb:.1f} MB",
                                  f"hairbsdf | Sample {done}/{n_samples} | Time {spent:.1f} s")
                self.update_memory_stats(memory_used=mem_mb, memory_peak=mem_mb)  # 4.x: keywords only
            except Exception as exc:  # pragma: no cover
                print(f"hairbsdf: progress update failed: {exc}")

        cancel = self._cancelled

        threads = settings["threads"] or (scene.render.threads if scene.render.threads_mode == "FIXED" else 0)
        self.update_stats(f"Mem: {mem_mb:.1f} MB", "hairbsdf | rendering")
        result = render_fn(desc, progress=progress, cancel=cancel, threads=int(threads))
        stats = dict(result.get("stats", {}) or {})
        info["render_seconds"] = time.perf_counter() - started
        info["stats"] = {k: v for k, v in stats.items() if k != "warnings"}
        for w in stats.get("warnings", []) or []:
            info["warnings"].append(str(w))
            self._log("WARNING", str(w))
        cancelled = bool(stats.get("cancelled")) or self._cancelled()
        combined = result.get("combined")
        if combined is None:
            if cancelled:
                info["status"] = "cancelled"
                return
            raise RuntimeError("the renderer returned no 'combined' image")
        # A cancelled render still shows the samples done so far, as Cycles does.
        extra = passes.blender_passes(desc["integrator"].get("passes", []))
        self._write_result(depsgraph, combined, result, extra, width, height)
        if cancelled:
            info["status"] = "cancelled"
            self._log("INFO", "render cancelled after %s samples" % stats.get("samples", "?"))
            return
        self.update_progress(1.0)
        info["image_mean"] = float(np.asarray(combined)[..., :3].mean())
        info["status"] = "ok"

    def _write_result(self, depsgraph, img, images, extra, width, height):
        """Combined plus the `extra` passes (passes.blender_passes) from the renderer's `images`."""
        import numpy as np

        img = np.asarray(img, dtype=np.float32)
        if img.shape != (height, width, 4):
            raise RuntimeError(f"the renderer returned an image of shape {img.shape}, expected "
                               f"{(height, width, 4)}")
        layer_name = depsgraph.view_layer.name if depsgraph.view_layer else ""
        for _, label, channels, chan_id, _kind in extra:
            try:
                self.add_pass(label, channels, chan_id, layer=layer_name)
            except Exception as exc:  # pragma: no cover - e.g. a pass Blender already made
                print(f"hairbsdf: add_pass {label}: {exc}")
        result = self.begin_result(0, 0, width, height, layer=layer_name)
        try:
            if result is None or not len(result.layers):
                raise RuntimeError("Blender gave no render layer to write the image to")
            layer = result.layers[0]
            # Blender's rect row 0 is the bottom row; the renderer's row 0 is the top.
            write_rect(layer.passes["Combined"], np.ascontiguousarray(img[::-1]).reshape(-1), width * height)
            for key, label, channels, _chan_id, _kind in extra:
                data = images.get(key)
                target = layer.passes.find_pass(label, "") if hasattr(layer.passes, "find_pass") else None
                if target is None:
                    target = next((p for p in layer.passes if p.name == label), None)
                if data is None or target is None:
                    self._log("WARNING", f"pass '{label}' could not be written")
                    continue
                flat = np.ascontiguousarray(np.asarray(data, dtype=np.float32)[::-1]).reshape(-1)
                write_rect(target, flat, width * height)
        finally:
            if result is not None:
                self.end_result(result)


def write_rect(render_pass, flat, n_pixels):
    """Fast bulk write of a pass: Blender 4.x takes the flat floats, 3.4 one 4-float item per
    pixel (both ~20 ms for 1080p; assigning .rect instead takes ~3 s)."""
    try:
        render_pass.rect.foreach_set(flat)
        return
    except (TypeError, ValueError, RuntimeError):
        pass
    try:
        render_pass.rect.foreach_set(flat.reshape(n_pixels, -1))
    except (TypeError, ValueError, RuntimeError):
        render_pass.rect = flat.reshape(n_pixels, -1)


def _progress_fraction(args, kwargs, n_samples):
    """Accepts progress(fraction), progress(done, total), progress(dict) or keywords."""
    frac, done = 0.0, 0
    vals = list(args)
    if len(vals) == 1 and isinstance(vals[0], dict):
        kwargs = dict(vals[0], **kwargs)
        vals = []
    if "fraction" in kwargs or "progress" in kwargs:
        frac = float(kwargs.get("fraction", kwargs.get("progress", 0.0)))
    if "samples" in kwargs or "sample" in kwargs:
        done = int(kwargs.get("samples", kwargs.get("sample", 0)))
    if len(vals) >= 2:
        done, total = int(vals[0]), max(int(vals[1]), 1)
        frac = done / total
    elif len(vals) == 1:
        frac = float(vals[0])
    if frac > 1.0 and n_samples > 0 and not kwargs:  # a sample count was passed
        done, frac = int(frac), frac / n_samples
    if not done:
        done = int(round(frac * n_samples))
    return min(max(frac, 0.0), 1.0), done


def _scene_bytes(desc) -> int:
    import numpy as np

    total = 0
    stack = [desc]
    while stack:
        x = stack.pop()
        if isinstance(x, np.ndarray):
            total += x.nbytes
        elif isinstance(x, dict):
            stack.extend(x.values())
        elif isinstance(x, (list, tuple)):
            stack.extend(x)
    return total


classes = (HairBsdfRenderEngine,)
