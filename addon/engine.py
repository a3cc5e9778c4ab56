"""The Volpath render engine: F12 and animation renders through the exporter and
volpath.render, tiles shown as they finish, Esc honoured within a fraction of a second;
besides Combined, the view layer's Depth and Denoising Albedo / Normal passes."""

import time

import bpy
import numpy as np

from .export import ExportError, camera, export_scene, motion


class VolpathRenderEngine(bpy.types.RenderEngine):
    bl_idname = "VOLPATH"
    bl_label = "Volpath"
    bl_use_preview = False
    # Material Preview uses EEVEE; Rendered shading, Volpath (view_update / view_draw).
    bl_use_eevee_viewport = True

    def view_update(self, context, depsgraph):
        _viewport_update(self, context, depsgraph)

    def view_draw(self, context, depsgraph):
        _viewport_draw(self, context, depsgraph)

    def __del__(self):
        state = getattr(self, "_viewport", None)
        if state is not None:
            state["render"].stop()

    def update_render_passes(self, scene=None, renderlayer=None):
        for name, channels, ids, kind in _passes(renderlayer):
            self.register_pass(scene, renderlayer, name, channels, ids, kind)

    def render(self, depsgraph):
        import volpath
        from volpath.adaptive import describe
        from volpath.render import resolve_tracer

        scene = depsgraph.scene
        settings = scene.volpath
        try:
            exported = _export_blurred(self, depsgraph)
            for message in exported.warnings:
                self.report({"WARNING"}, f"Volpath: {message}")
            for message in exported.notes:
                self.report({"INFO"}, f"Volpath: {message}")
            vp_scene = volpath.load_dict(exported.scene, source=f"{scene.name} (frame {scene.frame_current})")
            for message in vp_scene.summary["warnings"]:  # e.g. a VDB's negative voxels, clamped
                self.report({"WARNING"}, f"Volpath: {message}")
            tracer, auto = resolve_tracer(vp_scene, settings.tracer, settings.tolerance, vp_scene.max_depth)
        except (ExportError, volpath.SceneError, ValueError) as e:
            self.report({"ERROR"}, f"Volpath: {e}")
            return
        if auto is not None:
            self.report({"INFO"}, f"Volpath: tracer '{tracer}' ({'; '.join(auto['reasons'])})")
        width, height = camera.resolution(scene.render)
        image = np.zeros((height, width, 3), np.float32)
        result = self.begin_result(0, 0, width, height, layer=depsgraph.view_layer.name)
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

        want_aovs = len(_passes(depsgraph.view_layer)) > 1
        try:
            rendered = volpath.render(
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
                aovs=want_aovs,
            )
        except volpath.RenderCancelled:
            _show(result, image)
            self.end_result(result, cancel=True)
            return
        except Exception as e:  # a render error must reach the report, never take Blender down
            self.report({"ERROR"}, f"Volpath: render failed ({e})")
            self.end_result(result, cancel=True)
            return
        image, aovs = rendered if want_aovs else (rendered, {})
        _show(result, image, aovs)
        self.end_result(result)
        stats = vp_scene.last_render
        if stats["nonfinite_samples"]:
            self.report({"WARNING"}, f"Volpath: {stats['nonfinite_samples']} non-finite samples discarded")
        if target is not None:
            samples = f"error {100 * stats['error']:.2g} %, {stats['spp_min']}-{stats['spp_max']} spp"
        self.update_stats("", f"Volpath | {samples} | {tracer} | {stats['seconds']:.1f} s")


def _export_blurred(engine, depsgraph):
    """The scene at the render's frame, with the motion keys its Motion Blur settings ask for
    (the engine evaluating the shutter's sub-frames)."""

    def depsgraph_at(frame, subframe):
        engine.frame_set(frame, subframe=subframe)
        return depsgraph

    scene = depsgraph.scene
    blur = motion.sample(scene, depsgraph_at, scene.frame_current)
    exported = export_scene(depsgraph, instanced=blur.instanced() if blur else ())
    motion.attach(exported, blur)
    return exported


def _viewport_update(engine, context, depsgraph):
    """Export what the change needs (viewport.py says what) and restart the viewport's
    rendering; the session lives on the engine, which Blender keeps per viewport."""
    from . import viewport
    from .export import drop_meshes, lights

    state = getattr(engine, "_viewport", None)
    kind, geometry = viewport.classify(depsgraph.updates) if state is not None else ("scene", set())
    if state is None:
        state = engine._viewport = {"meshes": {}, "sensor": None, "scene": None, "suns": {}}
        state["render"] = viewport.ViewportRender(depsgraph.scene.volpath.spp, seed=depsgraph.scene.volpath.seed)
    if kind == "scene":
        drop_meshes(state["meshes"], [bpy.data.objects[n] for n in geometry if n in bpy.data.objects])
        exported = export_scene(depsgraph, state["meshes"])
        state["scene"], state["suns"] = viewport.kept_unchanged(state["scene"], exported.scene), exported.suns
        suns = None
    elif kind == "suns":
        objects = depsgraph.scene.objects
        suns = {k: lights.sun_direction(objects[n].evaluated_get(depsgraph)) for k, n in state["suns"].items()}
    else:
        return
    state["sensor"] = _view_sensor(context, depsgraph)
    state["render"].show(viewport.with_view(state["scene"], state["sensor"], suns))


def _view_sensor(context, depsgraph):
    space, region = context.space_data, context.region
    return camera.from_view(
        context.region_data.view_matrix,
        context.region_data.window_matrix,
        region.width,
        region.height,
        space.clip_start,
        space.clip_end,
    )


def _viewport_draw(engine, context, depsgraph):
    """The latest pass as a texture over the region, in the scene's view transform; a new
    view (orbit, zoom, resize) restarts the rendering first."""
    import gpu
    from gpu_extras.presets import draw_texture_2d

    from . import viewport

    state = getattr(engine, "_viewport", None)
    if state is None or state["scene"] is None:
        return
    try:
        sensor = _view_sensor(context, depsgraph)
    except ValueError:  # an orthographic view
        return
    if not viewport.same(sensor, state["sensor"]):
        state["sensor"] = sensor
        state["render"].show(viewport.with_view(state["scene"], sensor))
    _, rgba, samples = state["render"].image()
    if rgba is None:
        return
    height, width, _ = rgba.shape
    pixels = gpu.types.Buffer("FLOAT", width * height * 4, np.ascontiguousarray(rgba[::-1]).ravel())
    texture = gpu.types.GPUTexture((width, height), format="RGBA16F", data=pixels)
    gpu.state.blend_set("ALPHA_PREMULT")
    engine.bind_display_space_shader(depsgraph.scene)
    draw_texture_2d(texture, (0, 0), context.region.width, context.region.height)
    engine.unbind_display_space_shader()
    gpu.state.blend_set("NONE")
    error = state["render"].error
    engine.update_stats("", f"Volpath | {error}" if error else f"Volpath | {samples} spp")
    if samples < state["render"].max_samples and not error:
        engine.tag_redraw()  # draw again while passes come in


def _passes(layer):
    """(name, channels, channel ids, type) of the passes the view layer asks for."""
    passes = [("Combined", 4, "RGBA", "COLOR")]
    if layer is not None and layer.use_pass_z:
        passes.append(("Depth", 1, "Z", "VALUE"))
    if layer is not None and layer.volpath.denoising_data:
        passes += [("Denoising Normal", 3, "XYZ", "VECTOR"), ("Denoising Albedo", 3, "RGB", "COLOR")]
    return passes


# Blender's passes from volpath.render's aovs; Depth where nothing is hit as Cycles writes it.
_AOVS = {
    "Depth": ("depth", lambda a: np.minimum(a, 1e10)),
    "Denoising Normal": ("normal", None),
    "Denoising Albedo": ("albedo", None),
}


def _show(result, image, aovs=None):
    """Combined (alpha 1) and, at the end, the other passes; our rows run top to bottom,
    Blender's bottom to top."""
    height, width, _ = image.shape
    rgba = np.ones((height, width, 4), np.float32)
    rgba[..., :3] = image[::-1]
    passes = result.layers[0].passes
    passes["Combined"].rect.foreach_set(rgba.ravel())
    for name, (key, convert) in _AOVS.items():
        if aovs and name in passes:
            values = aovs[key] if convert is None else convert(aovs[key])
            passes[name].rect.foreach_set(np.ascontiguousarray(values[::-1], np.float32).ravel())


def register():
    bpy.utils.register_class(VolpathRenderEngine)


def unregister():
    bpy.utils.unregister_class(VolpathRenderEngine)
