"""The Python API: determinism, cancellation, EXR I/O and the command line."""

import os
import re
import subprocess
import sys
import time

import numpy as np
import pytest

import scenes as S
import volpath

SCENE = S.scene(
    S.camera(res=40, spp=8),
    S.homogeneous("m", "2, 1, 0.5", "0.9, 0.8, 0.7", g=0.5),
    S.medium_sphere("m"),
    S.floor(),
    S.area_light_above(),
    S.point_light(),
    S.constant_env("0.1, 0.1, 0.1"),
)


@pytest.mark.parametrize("tracer", volpath.TRACERS)
def test_same_seed_same_image_whatever_the_thread_count(tracer):
    scene = volpath.load_string(SCENE)
    one = volpath.render(scene, tracer=tracer, seed=5, threads=1)
    two = volpath.render(scene, tracer=tracer, seed=5, threads=2)
    many = volpath.render(scene, tracer=tracer, seed=5, threads=7)
    assert one.dtype == np.float32 and one.shape == (40, 40, 3)
    assert np.array_equal(one, two) and np.array_equal(one, many)
    assert not np.array_equal(one, volpath.render(scene, tracer=tracer, seed=6, threads=2))


def test_progress_callback_can_cancel_quickly():
    scene = volpath.load_string(
        S.scene(S.camera(res=256, spp=4096), S.homogeneous("m", "5", "0.99"), S.medium_sphere("m"), S.constant_env())
    )
    calls = []

    def progress(fraction):
        calls.append(fraction)
        return len(calls) < 3

    start = time.perf_counter()
    with pytest.raises(volpath.RenderCancelled) as e:
        volpath.render(scene, progress=progress, threads=2)
    assert time.perf_counter() - start < 1.5
    assert e.value.image.shape == (256, 256, 3)
    assert all(0 <= f <= 1 for f in calls)


def test_progress_reaches_one():
    scene = volpath.load_string(SCENE)
    seen = []
    volpath.render(scene, spp=2, progress=lambda f: seen.append(f))
    assert seen[-1] == 1.0
    assert scene.last_render["nonfinite_samples"] == 0 and scene.last_render["seconds"] > 0


def test_bad_render_arguments():
    scene = volpath.load_string(SCENE)
    with pytest.raises(ValueError, match="unknown tracer"):
        volpath.render(scene, tracer="magic")
    with pytest.raises(ValueError, match="spp"):
        volpath.render(scene, spp=0)


def test_exr_round_trip(tmp_path):
    img = np.random.default_rng(0).random((7, 9, 3)).astype(np.float32)
    volpath.write_exr(
        tmp_path / "a.exr", img, metadata={"frame": 3, "spp": 16.0, "tracer": "nee_mis", "sun": (0.0, 0.5, -1.0)}
    )
    back, meta = volpath.read_exr(tmp_path / "a.exr", metadata=True)
    assert np.array_equal(back, img)
    assert meta["frame"] == 3 and meta["tracer"] == "nee_mis" and np.allclose(meta["sun"], (0, 0.5, -1))
    volpath.write_exr(tmp_path / "h.exr", img, half=True)
    assert np.allclose(volpath.read_exr(tmp_path / "h.exr"), img, atol=1e-3)
    assert not [p for p in os.listdir(tmp_path) if ".tmp" in p]
    (tmp_path / "broken.exr").write_bytes(b"not an exr")
    with pytest.raises(ValueError, match="not a readable EXR"):
        volpath.read_exr(tmp_path / "broken.exr")


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "volpath", *args], capture_output=True, text=True, cwd=cwd)


def test_cli_render_and_info(tmp_path):
    (tmp_path / "s.xml").write_text(SCENE.replace("<integrator", '<default name="res" value="8"/><integrator'))
    out = tmp_path / "o.exr"
    r = run_cli(
        "render", str(tmp_path / "s.xml"), "-o", str(out), "--spp", "2", "--tracer", "nee_mis", "--threads", "1"
    )
    assert r.returncode == 0, r.stderr
    assert "non-finite samples" in r.stdout and out.exists()
    image, meta = volpath.read_exr(out, metadata=True)
    assert image.shape == (40, 40, 3) and meta["tracer"] == "nee_mis" and meta["spp"] == 2
    r = run_cli("info", str(tmp_path / "s.xml"))
    assert r.returncode == 0 and "homogeneous" in r.stdout and "optical thickness" in r.stdout
    assert re.search(r"bsdfs +\d+", r.stdout) and re.search(r"memory +[\d.]+ MiB: shapes", r.stdout), r.stdout
    r = run_cli("render", str(tmp_path / "missing.xml"), "-o", str(out))
    assert r.returncode == 2 and "not found" in r.stderr
    r = run_cli("render", str(tmp_path / "s.xml"), "-o", str(out), "--spp", "0")
    assert r.returncode == 2 and "--spp" in r.stderr


def test_ctrl_c_stops_the_cli_within_a_second(tmp_path):
    import select
    import signal

    (tmp_path / "slow.xml").write_text(
        S.scene(S.camera(res=256, spp=100000), S.homogeneous("m", "5", "0.99"), S.medium_sphere("m"), S.constant_env())
    )
    # As from a terminal: SIGINT handled (a shell's background job, as CI may be, inherits
    # it ignored, and Python then keeps it ignored).
    proc = subprocess.Popen(
        [sys.executable, "-m", "volpath", "render", str(tmp_path / "slow.xml"), "-o", str(tmp_path / "o.exr")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # Wait until rendering: the progress bar has appeared (a loaded CI machine may take
    # seconds just to import).
    seen = b""
    deadline = time.time() + 60
    while b"%" not in seen and time.time() < deadline and proc.poll() is None:
        if select.select([proc.stderr], [], [], 0.1)[0]:
            seen += os.read(proc.stderr.fileno(), 4096)
    assert b"%" in seen and proc.poll() is None, seen
    time.sleep(0.3)
    sent = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=10)
    assert time.perf_counter() - sent < 1.0
    assert proc.returncode == 130 and b"interrupted" in err
    assert not (tmp_path / "o.exr").exists()


def test_memory_report_counts_what_the_scene_holds():
    """scene.memory (and scene.last_render["memory"], and `volpath info`): a mesh's
    vertices and triangles under "shapes", its BVH under "bvh", a grid's stored bricks under
    "media"."""
    import volpath

    rng = np.random.default_rng(3)
    density = rng.uniform(0, 1, (16, 16, 16)).astype(np.float32)
    grid = volpath.VolumeGrid.from_numpy(density)
    positions = rng.uniform(-1, 1, (3000, 3))
    indices = np.arange(3000, dtype=np.uint32).reshape(-1, 3)
    d = {
        "type": "scene",
        "camera": {
            "type": "perspective",
            "fov": 40,
            "to_world": np.eye(4),
            "film": {"type": "hdrfilm", "width": 8, "height": 8},
        },
        "blob": {"type": "mesh", "positions": positions, "indices": indices},
        "fog": {"type": "heterogeneous", "density": grid},
        "box": {"type": "cube", "bsdf": {"type": "null"}, "interior": {"type": "ref", "id": "fog"}},
    }
    scene = volpath.load_dict(d)
    memory = scene.memory
    assert memory["shapes"] >= positions.size * 8 + indices.size * 4
    assert memory["bvh"] >= 1000 * (8 + 32 / 4)  # a reference per triangle, a 32-byte node per leaf of <= 4
    assert memory["media"] >= grid.nbytes
    assert memory["total"] == sum(v for k, v in memory.items() if k != "total")
    volpath.render(scene, spp=1)
    assert scene.last_render["memory"] == scene.memory


def test_a_point_light_edited_in_place_gives_the_bits_of_a_fresh_load():
    """Scene.update replaces a point light (the viewport's edited lamp) as it does a sun:
    moved, brighter, or hidden from shadow rays, the scene renders the bits of the same
    dictionary loaded afresh, without building its meshes again."""
    import scenes as S
    import volpath
    from volpath.xml_reader import read_xml

    d = read_xml(
        S.scene(
            S.camera(res=12, spp=2),
            S.homogeneous("m", "1, 1, 1", "0.8"),
            S.medium_sphere("m", radius=0.5),
            S.floor(),
            S.point_light(),
        ),
        "<test>",
    )
    key = next(k for k, v in d.items() if isinstance(v, dict) and v.get("type") == "point")
    scene = volpath.load_dict(d)
    before = volpath.render(scene, seed=2)
    for change in (
        {"position": np.array([1.0, 2.5, -1.0])},
        {"intensity": np.array([30.0, 20.0, 10.0])},
        {"hidden_from": "shadow"},
    ):
        d = dict(d, **{key: dict(d[key], **change)})
        assert scene.update(d)
        image = volpath.render(scene, seed=2)
        assert not np.array_equal(image, before), change  # the change shows
        assert np.array_equal(image, volpath.render(volpath.load_dict(d), seed=2)), change
        before = image


def test_a_material_and_a_world_changed_in_place_give_the_bits_of_a_fresh_load():
    """Scene.update gives a shape's BSDF new values (a keyframed material) and a constant
    world a new radiance in place: the image is a fresh load's, and the scene holds no
    BSDF more than before. A change it cannot make in place (a texture, a shape's map)
    returns False and changes nothing."""
    import scenes as S
    import volpath
    from volpath.xml_reader import read_xml

    d = read_xml(S.scene(S.camera(res=12, spp=2), S.floor(), S.point_light()), "<test>")
    d["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": [0.2, 0.2, 0.2]}}
    floor = next(k for k, v in d.items() if isinstance(v, dict) and v.get("type") == "rectangle")
    scene = volpath.load_dict(d)
    before, memory = volpath.render(scene, seed=2), scene.memory
    green = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.1, 0.7, 0.2]}}
    d = dict(d, sky={"type": "constant", "radiance": {"type": "rgb", "value": [0.6, 0.5, 0.4]}})
    d[floor] = {**{k: v for k, v in d[floor].items() if not isinstance(v, dict)}, "bsdf": green}
    assert scene.update(d)
    image = volpath.render(scene, seed=2)
    assert not np.array_equal(image, before)
    assert np.array_equal(image, volpath.render(volpath.load_dict(d), seed=2))
    assert scene.memory == memory
    textured = dict(green, reflectance={"type": "checkerboard"})
    for change in ({"bsdf": textured}, {"to_world": np.diag([2.0, 2.0, 2.0, 1.0])}):
        assert not scene.update(dict(d, **{floor: dict(d[floor], **change)}))
        assert np.array_equal(volpath.render(scene, seed=2), image)
