"""Render an exported animation's frames in parallel, then make the pictures and the video.

Output directory::

    scene/                    the exported animation (scene.xml, meshes/, volumes/, animation.json)
    frames/frame_0001.exr     linear radiance + metadata (frame, sun direction, spp, tracer, seconds, version)
    png/00000.png ...         tone-mapped, numbered in video order
    contact_sheet.png  sunrise.mp4  summary.json

Frames are written atomically as they finish and summary.json is rewritten after each,
so a run killed at any moment loses at most the frames in flight; ``resume`` keeps every
frame whose EXR reads back valid. A failed frame is retried once, then reported, while
the others go on.
"""

import concurrent.futures as cf
import contextlib
import json
import multiprocessing
import os
import sys
import threading
import time
import types
from dataclasses import asdict, dataclass

import numpy as np

import volpath

from . import video
from .frames import film_shape, pack, read_animation, render_frame


@dataclass
class Options:
    spp: int = 16  # samples per pixel, or the cap with target_error
    target_error: float = 0.0  # > 0: each frame to this display error (volpath.render's target_error)
    denoise: bool = False  # Intel Open Image Denoise on each frame (volpath.render's denoise)
    tracer: str = "auto"
    workers: int = 0  # local processes (0: one per core)
    threads: int = 0  # threads per frame (0: cores / workers locally, 1 on Dask)
    scheduler: str = ""  # Dask distributed scheduler address ("": this machine)
    resume: bool = False
    fps: int = 24
    exposure: object = 0.0  # stops, or "auto" (video.auto_exposure)
    video_name: str = "sunrise.mp4"

    def check(self):
        if self.spp < 1:
            raise ValueError(f"spp must be at least 1, got {self.spp}")
        if not 0 <= self.target_error < 1:
            raise ValueError(f"target_error must be a display error in (0, 1) (0: off), got {self.target_error}")
        if self.tracer != "auto" and self.tracer not in volpath.TRACERS:
            raise ValueError(f"unknown tracer '{self.tracer}' (expected auto or one of: {', '.join(volpath.TRACERS)})")
        if self.workers < 0 or self.threads < 0:
            raise ValueError("workers and threads must not be negative")
        if self.exposure != "auto" and not isinstance(self.exposure, (int, float)):
            raise ValueError(f"exposure must be a number of stops or 'auto', got {self.exposure!r}")
        if not 1 <= self.fps <= 240:
            raise ValueError(f"fps must be in 1..240, got {self.fps}")


def exr_path(out_dir, frame):
    return os.path.join(out_dir, "frames", f"frame_{frame:04d}.exr")


def valid_frame(path, frame, shape, options):
    """Whether an EXR on disk is this frame, finished, at this size and spp or target error
    (resume keeps these)."""
    try:
        image, meta = volpath.read_exr(path, metadata=True)
    except (OSError, ValueError):
        return False
    if bool(meta.get("denoised", 0)) != options.denoise:
        return False
    if options.target_error:  # EXR metadata holds it as float32
        same = meta.get("spp_cap") == options.spp and np.float32(meta.get("target_error", 0)) == np.float32(
            options.target_error
        )
    else:
        same = meta.get("spp") == options.spp and "target_error" not in meta
    return meta.get("frame") == frame and same and image.shape == shape and np.all(np.isfinite(image))


class Run:
    """One pipeline run over an exported animation directory."""

    def __init__(self, animation_dir, out_dir, frames, options, progress=None, cancel=None):
        options.check()
        if not frames:
            raise ValueError("no frames to render")
        self.animation_dir, self.out_dir, self.frames, self.options = animation_dir, out_dir, list(frames), options
        self.progress = progress  # callable(done, total, status dict) or None for a tqdm bar
        self.cancel = cancel or threading.Event()
        self.status = {}
        self.summary_path = os.path.join(out_dir, "summary.json")
        self._animation_json = None  # animation.json, read when first needed
        os.makedirs(os.path.join(out_dir, "frames"), exist_ok=True)

    # -- bookkeeping --------------------------------------------------------------------------

    def _animation(self):
        if self._animation_json is None:
            self._animation_json = read_animation(self.animation_dir)
        return self._animation_json

    def _write_summary(self, **extra):
        summary = {
            "options": asdict(self.options),
            "frames": {str(f): self.status[f] for f in self.frames if f in self.status},
            # What the export found animated besides the camera, lamps and VDB sequences
            # (addon/export/animation.py); the contact sheet's caption says it too.
            "animated": self._animation().get("animated", []),
            **extra,
        }
        tmp = self.summary_path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(summary, f, indent=1)
        os.replace(tmp, self.summary_path)
        return summary

    def _report(self, bar):
        done = sum(1 for s in self.status.values() if s["status"] in ("rendered", "kept", "failed"))
        if bar is not None:
            bar.n = done
            bar.refresh()
        if self.progress is not None:
            self.progress(done, len(self.frames), self.status)

    # -- rendering ------------------------------------------------------------------------------
    def render(self):
        todo = []
        shape = film_shape(self.animation_dir)
        for f in self.frames:
            if self.options.resume and valid_frame(exr_path(self.out_dir, f), f, shape, self.options):
                self.status[f] = {"status": "kept"}
            else:
                todo.append(f)
        self._write_summary()
        bar = None
        if self.progress is None:
            from tqdm import tqdm

            bar = tqdm(total=len(self.frames), initial=len(self.frames) - len(todo), unit="frame", desc="frames")
        try:
            if todo:
                if self.options.scheduler:
                    self._render_dask(todo, bar)
                else:
                    self._render_local(todo, bar)
        finally:
            if bar is not None:
                bar.close()
        return self._write_summary(cancelled=self.cancel.is_set())

    def _finished(self, frame, attempt, result, error, resubmit, bar):
        if error is None:
            image, meta = result
            volpath.write_exr(exr_path(self.out_dir, frame), image, metadata=meta)
            self.status[frame] = {
                "status": "rendered",
                "seconds": round(meta["seconds"], 3),
                "spp": meta["spp"],
                "tracer": meta["tracer"],
                "attempts": attempt,
            }
            if "error" in meta:  # rendered to a target error: what it achieved, with how many samples
                self.status[frame].update(error=round(meta["error"], 5), spp_mean=round(meta["spp_mean"], 1))
        elif attempt < 2 and not self.cancel.is_set():
            self.status[frame] = {"status": "retrying", "error": error, "attempts": attempt}
            resubmit(frame, attempt + 1)
        else:
            self.status[frame] = {"status": "failed", "error": error, "attempts": attempt}
        self._write_summary()
        self._report(bar)

    def _args(self, frame, source, threads):
        o = self.options
        return source, frame, o.spp, o.tracer, None, threads, o.target_error or None, o.denoise

    def _render_local(self, todo, bar):
        cores = os.cpu_count() or 1
        workers = min(self.options.workers or cores, len(todo))
        threads = self.options.threads or max(1, cores // workers)
        source = os.path.abspath(self.animation_dir)
        # spawn: workers must not inherit Blender (or a Blender module) through fork.
        pool = cf.ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))
        try:
            pending = {}

            def submit(frame, attempt):
                with _main_hidden():  # submit may start a worker
                    pending[pool.submit(render_frame, *self._args(frame, source, threads))] = (frame, attempt)

            for f in todo:
                submit(f, 1)
            while pending:
                if self.cancel.is_set():
                    for fut in pending:
                        fut.cancel()
                    break
                done, _ = cf.wait(list(pending), timeout=0.2, return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    frame, attempt = pending.pop(fut)
                    result, error = _outcome(fut)
                    self._finished(frame, attempt, result, error, submit, bar)
        finally:
            # On cancel, frames in flight finish in the background and are dropped.
            pool.shutdown(wait=not self.cancel.is_set(), cancel_futures=True)

    def _render_dask(self, todo, bar):
        try:
            from distributed import Client, wait
        except ImportError:
            raise RuntimeError(
                "a Dask scheduler was given but dask.distributed is not installed (pip install distributed)"
            ) from None
        with Client(self.options.scheduler, timeout="20s") as client:
            # Workers may be other machines: the scene travels as bytes, frames come back as arrays.
            source = client.scatter(pack(self.animation_dir), broadcast=True)
            threads = self.options.threads or 1
            pending = {}

            def submit(frame, attempt):
                fut = client.submit(
                    render_frame,
                    *self._args(frame, source, threads),
                    pure=False,
                    key=f"volpath-frame-{frame}-{attempt}-{time.time_ns()}",
                )
                pending[fut] = (frame, attempt)

            for f in todo:
                submit(f, 1)
            while pending:
                if self.cancel.is_set():
                    client.cancel(list(pending))
                    break
                try:
                    done = wait(list(pending), timeout=0.2, return_when="FIRST_COMPLETED").done
                except TimeoutError:
                    continue
                for fut in done:
                    frame, attempt = pending.pop(fut)
                    result, error = _outcome(fut)
                    self._finished(frame, attempt, result, error, submit, bar)

    # -- pictures -------------------------------------------------------------------------------
    def make_video(self):
        """PNGs, contact sheet and MP4 from every finished frame, in frame order."""
        finished = [f for f in self.frames if self.status.get(f, {}).get("status") in ("rendered", "kept")]
        if not finished:
            return self._write_summary(cancelled=self.cancel.is_set(), video=None)
        png_dir = os.path.join(self.out_dir, "png")
        os.makedirs(png_dir, exist_ok=True)
        for name in os.listdir(png_dir):
            os.remove(os.path.join(png_dir, name))
        images = [volpath.read_exr(exr_path(self.out_dir, f)) for f in finished]
        stops = (
            video.auto_exposure(images, finished)
            if self.options.exposure == "auto"
            else [float(self.options.exposure)] * len(images)
        )
        pictures = []
        for i, (image, exposure) in enumerate(zip(images, stops)):
            picture = video.tonemap(image, exposure)
            video.write_png(os.path.join(png_dir, f"{i:05d}.png"), picture)
            pictures.append(picture)
        step = max(1, len(pictures) // 24)  # at most about 24 frames on the sheet
        labels = [self._label(f) for f in finished[::step]]
        video.write_png(
            os.path.join(self.out_dir, "contact_sheet.png"),
            video.contact_sheet(pictures[::step], labels=labels, caption=self._caption()),
        )
        mp4 = video.encode(
            os.path.join(png_dir, "%05d.png"), os.path.join(self.out_dir, self.options.video_name), fps=self.options.fps
        )
        return self._write_summary(
            cancelled=self.cancel.is_set(), video=os.path.abspath(mp4), video_frames=len(finished)
        )

    def _label(self, frame):
        """The contact sheet's words on a frame: its number, the display error it reached
        (rendered to a target) and its seconds."""
        status = self.status.get(frame, {})
        parts = [str(frame)] + ([f"{status['error']:.3f}"] if "error" in status else [])
        return " ".join(parts + ([f"{status['seconds']:.0f}s"] if "seconds" in status else []))

    def _caption(self):
        """The contact sheet's caption: what the animation animates besides the camera, the
        lamps and VDB sequences, or None."""
        animated = self._animation().get("animated", [])
        if not animated:
            return None
        return "animated: " + "; ".join(f"{a['what']} ({a['changes']} from frame {a['from_frame']})" for a in animated)

    def execute(self):
        """Render, then the pictures and the video; returns the summary."""
        self.render()
        return self.make_video()

    def failed(self):
        return [f for f in self.frames if self.status.get(f, {}).get("status") == "failed"]


@contextlib.contextmanager
def _main_hidden():
    """Spawned workers run the caller's __main__ again (multiprocessing's spawn imports it,
    by name or path), which may import Blender, render, or worse; render_frame needs none
    of it. While a worker starts, __main__ is an empty module."""
    main = sys.modules["__main__"]
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        sys.modules["__main__"] = main


def _outcome(future):
    try:
        return future.result(), None
    except Exception as e:  # a worker's failure is a frame's status, never the run's end
        return None, f"{type(e).__name__}: {e}"
