"""The sunrise pipeline end to end on a tiny animation: both entry points, resume after a
kill, Dask against the local pool, a failing frame, bad options."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import faults
import numpy as np
import pytest
from blender_scenes import ROOT, bpy, tiny_animation

import volpath

FRAMES = 4


def cli(*args, env=None, **kw):
    return subprocess.run(
        [sys.executable, "-m", "addon.sunrise", *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
        **kw,
    )


def frames_on_disk(out):
    return sorted(os.listdir(out / "frames"))


def test_python_entry_point_makes_frames_metadata_and_video(tmp_path):
    from pipeline.video import count_frames

    blend = tiny_animation(tmp_path / "tiny.blend")
    out = tmp_path / "out"
    r = cli("--blend", blend, "--out", out, "--workers", 2)
    assert r.returncode == 0, r.stderr[-3000:]
    assert frames_on_disk(out) == [f"frame_{f:04d}.exr" for f in range(1, FRAMES + 1)]
    suns = []
    for f in range(1, FRAMES + 1):
        image, meta = volpath.read_exr(out / "frames" / f"frame_{f:04d}.exr", metadata=True)
        assert image.shape == (36, 64, 3) and np.all(np.isfinite(image)) and image.mean() > 0
        assert meta["frame"] == f and meta["spp"] == 4 and meta["tracer"] in volpath.TRACERS
        assert meta["volpath_version"] == volpath.__version__ and meta["seconds"] > 0
        suns.append(meta["sun_direction"])
    assert not np.allclose(suns[0], suns[-1], atol=1e-3)  # the keyframed sun moved
    assert count_frames(str(out / "sunrise.mp4")) == FRAMES
    summary = json.loads((out / "summary.json").read_text())
    assert [summary["frames"][str(f)]["status"] for f in range(1, FRAMES + 1)] == ["rendered"] * FRAMES
    assert summary["video_frames"] == FRAMES and (out / "contact_sheet.png").exists()
    assert summary["animated"] == []  # its sun and camera are updated frame by frame: nothing else


def test_frames_to_a_target_error_report_it_and_resume_by_it(tmp_path):
    # Every frame to the same display error: each frame's EXR and summary.json say what it
    # achieved and with how many samples; a resume keeps frames of the same target and cap
    # and renders again those of another.
    blend = tiny_animation(tmp_path / "tiny.blend", frames=2)
    out = tmp_path / "out"
    r = cli("--blend", blend, "--out", out, "--target-error", 0.01, "--spp", 64, "--workers", 1)
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["options"]["target_error"] == 0.01
    for f in (1, 2):
        _, meta = volpath.read_exr(out / "frames" / f"frame_{f:04d}.exr", metadata=True)
        assert meta["target_error"] == pytest.approx(0.01) and meta["spp_cap"] == 64 and meta["spp"] <= 64
        status = summary["frames"][str(f)]
        assert status["error"] == pytest.approx(meta["error"], abs=1e-5) and status["spp_mean"] == pytest.approx(
            meta["spp_mean"], abs=0.06
        )
    r = cli("--blend", blend, "--out", out, "--target-error", 0.01, "--spp", 64, "--resume", "--workers", 1)
    assert [s["status"] for s in json.loads((out / "summary.json").read_text())["frames"].values()] == ["kept"] * 2
    r = cli("--blend", blend, "--out", out, "--target-error", 0.02, "--spp", 64, "--resume", "--workers", 1)
    assert [s["status"] for s in json.loads((out / "summary.json").read_text())["frames"].values()] == ["rendered"] * 2
    r = cli("--blend", blend, "--out", out, "--target-error", 1.5)
    assert r.returncode == 2 and "display error" in r.stderr


def test_denoised_frames_say_so_and_resume_by_it(tmp_path):
    blend = tiny_animation(tmp_path / "tiny.blend", frames=2)
    out = tmp_path / "out"
    r = cli("--blend", blend, "--out", out, "--denoise", "--workers", 1)
    assert r.returncode == 0, r.stderr[-3000:]
    assert [volpath.read_exr(out / "frames" / f"frame_{f:04d}.exr", metadata=True)[1]["denoised"] for f in (1, 2)] == [
        1,
        1,
    ]
    cli("--blend", blend, "--out", out, "--denoise", "--resume", "--workers", 1)
    assert [s["status"] for s in json.loads((out / "summary.json").read_text())["frames"].values()] == ["kept"] * 2
    cli("--blend", blend, "--out", out, "--no-denoise", "--resume", "--workers", 1)
    assert [s["status"] for s in json.loads((out / "summary.json").read_text())["frames"].values()] == ["rendered"] * 2


def test_blender_entry_point(tmp_path):
    """`blender -b tiny.blend --python addon/sunrise.py -- ...`: Blender runs the file as
    __main__ with the .blend open and its own arguments before `--` (simulated with the
    bpy module: no Blender executable is installed here)."""
    blend = tiny_animation(tmp_path / "tiny.blend", frames=2)
    out = tmp_path / "out"
    script = textwrap.dedent(f"""
        import runpy, sys
        import bpy
        bpy.ops.wm.open_mainfile(filepath={str(blend)!r})
        sys.argv = ["blender", "-b", {str(blend)!r}, "--python", "addon/sunrise.py", "--",
                    "--out", {str(out)!r}, "--res", "32x18", "--spp", "2"]
        runpy.run_path("addon/sunrise.py", run_name="__main__")
    """)
    r = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    assert frames_on_disk(out) == ["frame_0001.exr", "frame_0002.exr"]
    assert volpath.read_exr(out / "frames" / "frame_0001.exr").shape == (18, 32, 3)


def test_kill_then_resume_renders_only_what_is_missing(tmp_path):
    blend = tiny_animation(tmp_path / "tiny.blend", frames=8, spp=64, sky=True)
    out = tmp_path / "out"
    p = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "addon.sunrise",
            "--blend",
            str(blend),
            "--out",
            str(out),
            "--workers",
            "1",
            "--threads",
            "1",
        ],
        cwd=ROOT,
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.time() + 120
    while time.time() < deadline and not (out / "frames" / "frame_0002.exr").exists():
        time.sleep(0.05)
    os.killpg(p.pid, signal.SIGKILL)
    p.wait()
    kept = {
        name: (out / "frames" / name).stat().st_mtime_ns
        for name in frames_on_disk(out)
        if name.endswith(".exr") and not name.endswith(".tmp.exr")
    }
    assert 2 <= len(kept) < 8, kept  # killed midway
    r = cli("--blend", blend, "--out", out, "--resume", "--workers", 2)
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())["frames"]
    for name, mtime in kept.items():
        frame = int(name[6:10])
        assert summary[str(frame)]["status"] == "kept"
        assert (out / "frames" / name).stat().st_mtime_ns == mtime  # untouched
    rendered = [f for f, s in summary.items() if s["status"] == "rendered"]
    assert len(rendered) == 8 - len(kept)
    assert [n for n in frames_on_disk(out) if n.endswith(".exr")] == [f"frame_{f:04d}.exr" for f in range(1, 9)]


def test_dask_cluster_gives_the_same_bits_as_the_local_pool(tmp_path):
    """With more animated than the sun: the box keyframed across the floor and its colour,
    which workers apply to their scenes in place. summary.json and the contact sheet's
    caption name them."""
    from distributed import LocalCluster

    from addon.export.animation import export_animation
    from pipeline.run import Options, Run, exr_path

    tiny_animation(tmp_path / "tiny.blend", frames=3)
    scene = bpy.context.scene
    box = scene.objects["Cube"]
    colour = box.material_slots[0].material.node_tree.nodes["Principled BSDF"].inputs["Base Color"]
    for frame, x, rgba in ((1, -2.0, (0.8, 0.3, 0.1, 1)), (3, 2.0, (0.1, 0.3, 0.8, 1))):
        box.location.x, colour.default_value = x, rgba
        box.keyframe_insert("location", frame=frame)
        colour.keyframe_insert("default_value", frame=frame)
    animation = tmp_path / "scene"
    export_animation(scene, [1, 2, 3], str(animation))
    local = Run(str(animation), str(tmp_path / "local"), [1, 2, 3], Options(spp=4, workers=2), progress=lambda *a: None)
    local.render()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        dask = Run(
            str(animation),
            str(tmp_path / "dask"),
            [1, 2, 3],
            Options(spp=4, scheduler=cluster.scheduler_address),
            progress=lambda *a: None,
        )
        dask.render()
    for f in (1, 2, 3):
        a = volpath.read_exr(exr_path(str(tmp_path / "local"), f))
        b = volpath.read_exr(exr_path(str(tmp_path / "dask"), f))
        assert np.array_equal(a, b)
    assert all(s["status"] == "rendered" for s in dask.status.values())
    summary = local.make_video()
    assert {a["what"] for a in summary["animated"]} == {"mesh 'Cube'", "material 'box'"}
    png = (tmp_path / "local" / "contact_sheet.png").read_bytes()
    assert int.from_bytes(png[20:24], "big") > 36  # the frames' row and the caption under it


def test_a_failing_frame_is_retried_reported_and_the_rest_completes(tmp_path):
    from pipeline.video import count_frames

    blend = tiny_animation(tmp_path / "tiny.blend")
    out = tmp_path / "out"
    r = cli("--blend", blend, "--out", out, env=faults.environment([2]))
    assert r.returncode == 1
    assert "frame 2 failed: RuntimeError: frame 2: failure injected" in r.stdout
    summary = json.loads((out / "summary.json").read_text())["frames"]
    assert summary["2"]["status"] == "failed" and summary["2"]["attempts"] == 2
    assert all(summary[str(f)]["status"] == "rendered" for f in (1, 3, 4))
    assert count_frames(str(out / "sunrise.mp4")) == 3


@pytest.mark.parametrize(
    "args, message",
    [
        (["--frames", "5-1"], "the range ends before it starts"),
        (["--res", "0x5"], "expected WIDTHxHEIGHT"),
        (["--tracer", "bogus"], "unknown tracer 'bogus'"),
        (["--spp", "0"], "--spp: 0: must be at least 1"),
        (["--exposure", "bright"], "expected a number of stops or 'auto'"),
        (["--blend", "/nonexistent.blend"], "no such .blend file"),
    ],
)
def test_bad_options_get_a_clear_message(tmp_path, args, message):
    r = cli("--out", tmp_path / "out", *args)
    assert r.returncode == 2
    assert message in r.stderr


def test_resume_rerenders_frames_of_another_size_or_spp(tmp_path):
    blend = tiny_animation(tmp_path / "tiny.blend", frames=2)
    out = tmp_path / "out"
    assert cli("--blend", blend, "--out", out, "--spp", 2).returncode == 0
    r = cli("--blend", blend, "--out", out, "--spp", 2, "--resume", "--res", "32x18")
    assert r.returncode == 0, r.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())["frames"]
    assert [s["status"] for s in summary.values()] == ["rendered", "rendered"]
    r = cli("--blend", blend, "--out", out, "--spp", 2, "--resume", "--res", "32x18")
    summary = json.loads((out / "summary.json").read_text())["frames"]
    assert [s["status"] for s in summary.values()] == ["kept", "kept"]
    assert volpath.read_exr(out / "frames" / "frame_0001.exr").shape == (18, 32, 3)


def test_vdb_sequence_changes_with_the_frame(tmp_path):
    """A two-file VDB sequence: each pipeline frame renders that frame's grid (a copy of
    its .vdb, read sparse), the same bits as rendering the scene exported at that frame."""
    from blender_scenes import add_camera, blank_scene, set_background, volume_material, write_vdb

    from addon.export import export_scene
    from addon.export.animation import export_animation
    from pipeline.frames import render_frame

    scene = blank_scene()
    x, y, z = np.meshgrid(*(np.arange(8),) * 3, indexing="ij")
    base = np.clip(1 - np.sqrt((x - 3.5) ** 2 + (y - 3.5) ** 2 + (z - 3.5) ** 2) / 4, 0, None).astype(np.float32)
    for frame, scale in ((1, 1.0), (2, 4.0)):
        write_vdb(tmp_path / f"puff_{frame:04d}.vdb", base * scale)
    bpy.ops.object.volume_import(
        filepath=str(tmp_path / "puff_0001.vdb"),
        directory=str(tmp_path),
        files=[{"name": "puff_0001.vdb"}, {"name": "puff_0002.vdb"}],
    )
    bpy.context.object.data.materials.append(volume_material("smoke", density=20.0))
    add_camera(scene, location=(0.4, -3, 0.4), rotation=(np.pi / 2, 0, 0))
    set_background(scene, (1, 1, 1))
    scene.volpath.tracer = "null_scattering"
    export_animation(scene, [1, 2], str(tmp_path / "anim"))
    copies = sorted(os.listdir(tmp_path / "anim" / "volumes"))
    per_frame = [c for c in copies if c.endswith(("_density_0001.vdb", "_density_0002.vdb"))]
    assert len(per_frame) == 2 and not [c for c in copies if c.endswith(".vol")], copies
    images = []
    for frame in (1, 2):
        image, _ = render_frame(str(tmp_path / "anim"), frame, 4, "null_scattering")
        scene.frame_set(frame)
        direct = volpath.render(
            volpath.load_dict(export_scene(bpy.context.evaluated_depsgraph_get()).scene),
            spp=4,
            seed=frame,
            tracer="null_scattering",
        )
        assert np.array_equal(image, direct), frame
        images.append(image)
    # Four times denser: darker over the whole image (measured 0.93 and 0.89; the noise of a
    # mean over the puff's pixels at 4 spp is ~0.005). One pixel is too coarse under a white
    # sky: its few paths through the puff find the sky or not at all.
    assert images[1].mean() < images[0].mean()


def test_a_worker_builds_the_scene_once_and_each_frame_is_the_bits_of_a_fresh_load(tmp_path):
    """render_frame keeps a worker's scene and moves its sun and camera from frame to frame
    (Scene.update); a frame is the same bits as the frame rendered by a fresh worker."""
    from addon.export.animation import export_animation
    from pipeline import frames

    tiny_animation(frames=3, sky=True)
    export_animation(bpy.context.scene, [1, 2, 3], str(tmp_path / "anim"))
    kept = []
    for frame in (1, 2, 3):
        image, _ = frames.render_frame(str(tmp_path / "anim"), frame, 2, "null_scattering")
        kept.append(frames._scenes[str(tmp_path / "anim")])
        frames._scenes.clear()
        fresh, _ = frames.render_frame(str(tmp_path / "anim"), frame, 2, "null_scattering")
        assert np.array_equal(image, fresh), frame
        frames._scenes[str(tmp_path / "anim")] = kept[-1]
    assert kept[0] is kept[1] is kept[2]


def test_workers_do_not_run_the_callers_script_again(tmp_path):
    """A script that imports bpy and runs the pipeline at its top level, with no __main__
    guard, its workers' Python without bpy (as Blender's bundled Python spawns them): the
    pool's spawn workers render frames without running the script again (issue #35)."""
    from addon.export.animation import export_animation

    tiny_animation(frames=2)
    export_animation(bpy.context.scene, [1, 2], str(tmp_path / "anim"))
    script, runs, no_bpy = tmp_path / "render.py", tmp_path / "runs.txt", tmp_path / "no_bpy"
    no_bpy.mkdir()
    (no_bpy / "sitecustomize.py").write_text(
        textwrap.dedent("""
        import sys

        class NoBpy:
            def find_spec(self, name, path=None, target=None):
                if name.partition(".")[0] == "bpy":
                    raise ImportError("no bpy in a frame worker")

        sys.meta_path.insert(0, NoBpy())
    """)
    )
    script.write_text(
        textwrap.dedent(f"""
        import os, sys
        import bpy
        sys.path.insert(0, {ROOT!r})
        os.environ["PYTHONPATH"] = {str(no_bpy)!r}  # the workers' Python has no bpy
        with open({str(runs)!r}, "a") as f:
            f.write("run\\n")
        from pipeline.run import Options, Run
        run = Run({str(tmp_path / "anim")!r}, {str(tmp_path / "out")!r}, [1, 2], Options(spp=1, workers=2),
                  progress=lambda *a: None)
        run.render()
        assert not run.failed(), run.status
    """)
    )
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    assert runs.read_text() == "run\n"
    assert frames_on_disk(tmp_path / "out") == ["frame_0001.exr", "frame_0002.exr"]
