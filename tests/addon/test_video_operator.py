"""Render Animation to Video from Blender: the same pipeline, driven by an operator."""

import json
import os

import faults
import pytest
from blender_scenes import bpy, tiny_animation

import volpath


def _settings(tmp_path, resume=False, spp=2):
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 32, 18
    s = scene.volpath
    s.spp, s.video_directory, s.video_resume, s.video_workers = spp, str(tmp_path / "video"), resume, 1
    return scene


def _exrs(tmp_path):
    return sorted(n for n in os.listdir(tmp_path / "video" / "frames") if n.endswith(".exr"))


def test_operator_renders_frames_and_video(tmp_path, capfd):
    from pipeline.video import count_frames

    tiny_animation(frames=3)
    scene = _settings(tmp_path)
    assert bpy.ops.volpath.render_video() == {"FINISHED"}
    assert _exrs(tmp_path) == ["frame_0001.exr", "frame_0002.exr", "frame_0003.exr"]
    video = tmp_path / "video" / f"{scene.name}.mp4"
    assert count_frames(str(video)) == 3
    out = capfd.readouterr().out
    assert f"Volpath video: {video} (3 frames)" in out
    assert bpy.context.window_manager.volpath_last_output == str(tmp_path / "video")
    assert any(img.filepath.endswith("frame_0003.exr") for img in bpy.data.images)  # the last frame, loaded


def test_cancel_keeps_finished_frames_and_a_second_run_renders_the_rest(tmp_path):
    from addon.operators import VideoJob

    tiny_animation(frames=3)
    scene = _settings(tmp_path, spp=3000)  # about a second per frame
    job = VideoJob(scene)
    while job.done < 1 and not job.finished:
        pass
    job.cancel.set()
    job.thread.join(60)
    kept = _exrs(tmp_path)
    assert 1 <= len(kept) < 3
    first = {n: os.stat(tmp_path / "video" / "frames" / n).st_mtime_ns for n in kept}
    scene.volpath.video_resume = True
    assert bpy.ops.volpath.render_video() == {"FINISHED"}
    summary = json.loads((tmp_path / "video" / "summary.json").read_text())["frames"]
    for name, mtime in first.items():
        assert summary[str(int(name[6:10]))]["status"] == "kept"
        assert os.stat(tmp_path / "video" / "frames" / name).st_mtime_ns == mtime
    assert sum(s["status"] == "rendered" for s in summary.values()) == 3 - len(first)
    assert _exrs(tmp_path) == ["frame_0001.exr", "frame_0002.exr", "frame_0003.exr"]


def test_a_failing_frame_is_reported(tmp_path, capfd, monkeypatch):
    tiny_animation(frames=3)
    _settings(tmp_path)
    for name, value in faults.environment([2]).items():
        monkeypatch.setenv(name, value)
    # An error in the report makes bpy.ops raise, as in Blender's own scripts.
    with pytest.raises(RuntimeError, match="Volpath: frame 2 failed: RuntimeError"):
        bpy.ops.volpath.render_video()
    assert "(2 frames)" in capfd.readouterr().out  # the video of the others
    assert _exrs(tmp_path) == ["frame_0001.exr", "frame_0003.exr"]
    assert volpath.read_exr(tmp_path / "video" / "frames" / "frame_0003.exr").shape == (18, 32, 3)
