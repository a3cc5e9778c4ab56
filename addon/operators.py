"""Operators: export the scene as a Volpath scene directory; render the animation to a
video through the sunrise pipeline, in the background, with progress and cancel."""

import os
import threading
import time

import bpy
from bpy.props import StringProperty


class VOLPATH_OT_export_scene(bpy.types.Operator):
    """Write the scene as scene.xml with its meshes and volumes (renders with `python -m volpath render`)"""

    bl_idname = "volpath.export_scene"
    bl_label = "Export Volpath Scene"
    directory: StringProperty(subtype="DIR_PATH")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        from .export import ExportError, export_scene, write_directory

        if not self.directory:
            self.report({"ERROR"}, "no directory given")
            return {"CANCELLED"}
        try:
            exported = export_scene(context.evaluated_depsgraph_get())
            path = write_directory(exported, bpy.path.abspath(self.directory))
        except (ExportError, OSError) as e:
            self.report({"ERROR"}, f"Volpath: {e}")
            return {"CANCELLED"}
        for message in exported.warnings:
            self.report({"WARNING"}, f"Volpath: {message}")
        self.report({"INFO"}, f"Volpath scene written to {os.path.abspath(path)}")
        return {"FINISHED"}


class VideoJob:
    """The pipeline run behind the operator: exported in Blender's main thread, rendered
    in a background thread (frames in worker processes or on Dask), polled by a timer."""

    def __init__(self, scene):
        from pipeline.run import Options, Run

        from .export.animation import export_animation, frame_list

        s = scene.volpath
        self.out_dir = bpy.path.abspath(s.video_directory)
        self.frames = frame_list(scene, step=s.video_step)
        options = Options(
            spp=s.spp,
            target_error=s.adaptive_threshold if s.use_adaptive_sampling else 0.0,
            denoise=s.use_denoising,
            tracer=s.tracer,
            workers=s.video_workers,
            threads=s.threads,
            scheduler=s.video_scheduler.strip(),
            resume=s.video_resume,
            fps=s.video_fps,
            exposure="auto",
            video_name=f"{bpy.path.clean_name(scene.name)}.mp4",
        )
        self.cancel = threading.Event()
        self.done = self.total = 0
        self.started = time.monotonic()
        options.check()  # before the export, which may take a while
        animation_dir = os.path.join(self.out_dir, "scene")
        self.warnings = export_animation(scene, self.frames, animation_dir)
        self.run = Run(animation_dir, self.out_dir, self.frames, options, progress=self._progress, cancel=self.cancel)
        self.summary = self.error = None
        self.thread = threading.Thread(target=self._work, name="volpath-video", daemon=True)
        self.thread.start()

    def _progress(self, done, total, status):
        self.done, self.total = done, total

    def _work(self):
        try:
            self.summary = self.run.execute()
        except Exception as e:  # reported by the operator, in Blender's main thread
            self.error = f"{type(e).__name__}: {e}"

    @property
    def finished(self):
        return not self.thread.is_alive()

    def status_text(self):
        total = self.total or len(self.frames)
        elapsed = time.monotonic() - self.started
        eta = f", about {elapsed * (total - self.done) / self.done:.0f} s left" if self.done else ""
        return f"Volpath video: {self.done}/{total} frames{eta} (Esc to cancel)"

    def report(self, operator):
        """The end of the run in Blender's report; returns the operator's result."""
        for w in self.warnings:
            operator.report({"WARNING"}, f"Volpath: {w}")
        if self.error:
            operator.report({"ERROR"}, f"Volpath video failed: {self.error}")
            return {"CANCELLED"}
        for f in self.run.failed():
            operator.report({"ERROR"}, f"Volpath: frame {f} failed: {self.run.status[f]['error']}")
        kept = sum(1 for s in self.run.status.values() if s["status"] in ("rendered", "kept"))
        if self.cancel.is_set():
            operator.report(
                {"WARNING"},
                f"Volpath video cancelled: {kept} frames kept in {self.out_dir} (run again with Resume to finish)",
            )
            return {"CANCELLED"}
        video = self.summary.get("video") if self.summary else None
        operator.report(
            {"INFO"}, f"Volpath video: {video} ({kept} frames); Open Output Folder in the Animation to Video panel"
        )
        bpy.context.window_manager.volpath_last_output = self.out_dir
        self._show_last_frame()
        return {"FINISHED"}

    def _show_last_frame(self):
        from pipeline.run import exr_path

        finished = [f for f in self.frames if self.run.status.get(f, {}).get("status") in ("rendered", "kept")]
        if not finished:
            return
        image = bpy.data.images.load(exr_path(self.out_dir, finished[-1]), check_existing=True)
        image.reload()
        for window in getattr(bpy.context.window_manager, "windows", []):
            for area in window.screen.areas:
                if area.type == "IMAGE_EDITOR":
                    area.spaces.active.image = image
                    return


class VOLPATH_OT_render_video(bpy.types.Operator):
    """Render the frame range to EXR frames and a video with the sunrise pipeline (runs in the background)"""

    bl_idname = "volpath.render_video"
    bl_label = "Render Animation to Video"

    _job = None
    _timer = None

    def execute(self, context):
        # Without a window (blender -b, the bpy module) there is no event loop to poll
        # from: run the same job and wait for it.
        job = self._start(context)
        if job is None:
            return {"CANCELLED"}
        while not job.finished:
            time.sleep(0.1)
        return job.report(self)

    def invoke(self, context, event):
        if context.window is None:
            return self.execute(context)
        self._job = self._start(context)
        if self._job is None:
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, len(self._job.frames))
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC":
            job.cancel.set()
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        context.window_manager.progress_update(job.done)
        context.workspace.status_text_set(
            job.status_text() if not job.cancel.is_set() else "Volpath video: cancelling (finished frames are kept)"
        )
        if not job.finished:
            return {"PASS_THROUGH"}
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        return job.report(self)

    def _start(self, context):
        from .export import ExportError

        try:
            return VideoJob(context.scene)
        except (ExportError, ValueError, OSError) as e:
            self.report({"ERROR"}, f"Volpath: {e}")
            return None


class VOLPATH_OT_open_output(bpy.types.Operator):
    """Open the folder of the last video in the file browser of the system"""

    bl_idname = "volpath.open_output"
    bl_label = "Open Output Folder"

    @classmethod
    def poll(cls, context):
        return bool(context.window_manager.volpath_last_output)

    def execute(self, context):
        bpy.ops.wm.path_open(filepath=context.window_manager.volpath_last_output)
        return {"FINISHED"}


CLASSES = (VOLPATH_OT_export_scene, VOLPATH_OT_render_video, VOLPATH_OT_open_output)


def register():
    bpy.types.WindowManager.volpath_last_output = StringProperty(name="Last Video Folder", subtype="DIR_PATH")
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
    del bpy.types.WindowManager.volpath_last_output
