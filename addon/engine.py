"""The Volpath render engine: F12 and animation renders through the exporter and
volpath.render, tiles shown as they finish, Esc honoured within a fraction of a second."""

import time

import bpy
import numpy as np

from .export import ExportError, camera, export_scene


class VolpathRenderEngine(bpy.types.RenderEngine):
    bl_idname = "VOLPATH"
    bl_label = "Volpath"
    bl_use_preview = False
    # The viewport has no Volpath preview: Material Preview and Rendered shading use EEVEE.
    bl_use_eevee_viewport = True

    def render(self, depsgraph):
        import volpath
        from volpath.adaptive import describe
        from volpath.render import resolve_tracer

        scene = depsgraph.scene
        settings = scene.volpath
        try:
            exported = export_scene(depsgraph)
            for message in exported.warnings:
                self.report({"WARNING"}, f"Volpath: {message}")
            for message in exported.notes:
                self.report({"INFO"}, f"Volpath: {message}")
            vp_scene = volpath.load_dict(exported.scene, source=f"{scene.name} (frame {scene.frame_current})")
            tracer, auto = resolve_tracer(vp_scene, settings.tracer, settings.tolerance, vp_scene.max_depth)
        except (ExportError, volpath.SceneError, ValueError) as e:
            self.report({"ERROR"}, f"Volpath: {e}")
            return
        if auto is not None:
            self.report({"INFO"}, f"Volpath: tracer '{tracer}' ({'; '.join(auto['reasons'])})")
        width, height = camera.resolution(scene.render)
        image = np.zeros((height, width, 3), np.float32)
        result = self.begin_result(0, 0, width, height)
        start = last_shown = time.monotonic()
        target = settings.adaptive_threshold if settings.use_adaptive_sampling else None
        samples = f"{settings.spp} spp" if target is None else f"up to {settings.spp} spp"
        adaptive = {}  # the latest error estimate, with a noise threshold

        def progress(fraction):
            nonlocal last_shown
            if self.test_break():
                return False
            now = time.monotonic()
            elapsed = now - start
            remaining = elapsed * (1 - fraction) / fraction if fraction > 0 else float("nan")
            self.update_progress(fraction)
            left = (
                f", {describe(adaptive)}" if adaptive else (f", about {remaining:.0f} s left" if fraction > 0 else "")
            )
            self.update_stats("", f"Volpath | {samples} | {tracer} | {elapsed:.1f} s{left}")
            if now - last_shown > 0.5:
                _show(result, image)
                self.update_result(result)
                last_shown = now
            return True

        try:
            volpath.render(
                vp_scene,
                spp=settings.spp,
                seed=settings.seed,
                threads=settings.threads or None,
                tracer=tracer,
                progress=progress,
                out=image,
                target_error=target,
                status=adaptive.update,
                denoise=settings.use_denoising,
            )
        except volpath.RenderCancelled:
            _show(result, image)
            self.end_result(result, cancel=True)
            return
        except Exception as e:  # a render error must reach the report, never take Blender down
            self.report({"ERROR"}, f"Volpath: render failed ({e})")
            self.end_result(result, cancel=True)
            return
        _show(result, image)
        self.end_result(result)
        stats = vp_scene.last_render
        if stats["nonfinite_samples"]:
            self.report({"WARNING"}, f"Volpath: {stats['nonfinite_samples']} non-finite samples discarded")
        if target is not None:
            samples = f"error {100 * stats['error']:.2g} %, {stats['spp_min']}-{stats['spp_max']} spp"
        self.update_stats("", f"Volpath | {samples} | {tracer} | {stats['seconds']:.1f} s")


def _show(result, image):
    """Our rows run top to bottom, Blender's bottom to top; alpha is 1."""
    height, width, _ = image.shape
    rgba = np.ones((height, width, 4), np.float32)
    rgba[..., :3] = image[::-1]
    result.layers[0].passes["Combined"].rect.foreach_set(rgba.ravel())


def register():
    bpy.utils.register_class(VolpathRenderEngine)


def unregister():
    bpy.utils.unregister_class(VolpathRenderEngine)
