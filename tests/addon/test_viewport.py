"""The Rendered viewport without a display: the viewport's sensor, what each kind of change
rebuilds, progressive passes, and how soon a change or closing stops the work."""

import math
import time
from types import SimpleNamespace

import numpy as np
from blender_scenes import bpy, depsgraph, small_scene

from addon import viewport
from addon.export import camera, export_scene


def perspective(fov_x, width, height, near=0.1, far=100.0):
    """OpenGL's projection, as Blender's region_data.window_matrix holds it."""
    P = np.zeros((4, 4))
    P[0, 0] = 1 / math.tan(fov_x / 2)
    P[1, 1] = P[0, 0] * width / height
    P[2, 2], P[2, 3], P[3, 2] = -(far + near) / (far - near), -2 * far * near / (far - near), -1
    return P


def test_the_viewport_through_the_camera_is_the_camera(blank):
    small_scene(blank)
    cam = blank.camera
    cam.data.sensor_fit = "HORIZONTAL"
    fov = 2 * math.atan(cam.data.sensor_width / (2 * cam.data.lens))
    view = np.linalg.inv(np.array(cam.matrix_world))
    sensor = camera.from_view(view, perspective(fov, 48, 32), 48, 32, 0.1, 100)
    assert np.allclose(sensor["to_world"], camera.to_world(cam))
    assert sensor["fov"] == pytest_approx(math.degrees(fov)) and sensor["fov_axis"] == "x"
    assert "shift_x" not in sensor
    off = perspective(fov, 48, 32)
    off[0, 2] = 0.2  # an off-centre frustum: the camera view's framing
    assert camera.from_view(view, off, 48, 32, 0.1, 100)["shift_x"] == pytest_approx(
        0.2 * math.tan(fov / 2) / (2 * math.tan(fov / 2))
    )


def pytest_approx(x):
    import pytest

    return pytest.approx(x, rel=1e-9)


def update(obj, geometry=False, transform=True, shading=False):
    return SimpleNamespace(
        id=obj, is_updated_geometry=geometry, is_updated_transform=transform, is_updated_shading=shading
    )


def test_changes_are_sorted_by_what_they_rebuild(blank):
    small_scene(blank)
    sun = next(o for o in blank.objects if o.type == "LIGHT" and o.data.type == "SUN")
    area = next(o for o in blank.objects if o.type == "LIGHT" and o.data.type == "AREA")
    sphere = next(o for o in blank.objects if o.type == "MESH" and o.name.startswith("Sphere"))
    assert viewport.classify([]) == ("none", set())
    assert viewport.classify([update(sun)]) == ("suns", set())
    assert viewport.classify([update(sun), update(area)]) == ("scene", set())
    assert viewport.classify([update(sphere, geometry=True)]) == ("scene", {sphere.name})
    assert viewport.classify([update(sun, shading=True)]) == ("scene", set())  # its colour or strength


def test_entries_that_export_the_same_are_kept():
    # Scene.update tells a changed entry by identity: an entry equal by content to the
    # previous export's is replaced by it; anything else (new values, another dtype, an
    # object without value equality, such as a grid, unless it is the same) is not.
    grid = object()
    old = {
        "mesh": {"type": "mesh", "positions": np.zeros((3, 3)), "indices": np.arange(3, dtype=np.uint32)},
        "lamp": {"type": "point", "position": [0.0, 0.0, 1.0]},
        "fog": {"type": "heterogeneous", "density": grid},
    }
    new = {
        "mesh": {"type": "mesh", "positions": np.zeros((3, 3)), "indices": np.arange(3, dtype=np.uint32)},
        "lamp": {"type": "point", "position": [0.0, 0.0, 2.0]},
        "fog": {"type": "heterogeneous", "density": grid},
        "new": {"type": "constant"},
    }
    kept = viewport.kept_unchanged(old, new)
    assert kept["mesh"] is old["mesh"] and kept["fog"] is old["fog"]
    assert kept["lamp"] is new["lamp"] and kept["new"] is new["new"]
    new["mesh"]["indices"] = np.arange(3, dtype=np.int64)
    new["fog"]["density"] = object()
    kept = viewport.kept_unchanged(old, new)
    assert kept["mesh"] is new["mesh"] and kept["fog"] is new["fog"]


def wait_for(render, samples, after=0, timeout=60):
    """The first image of at least `samples` samples published after version `after`."""
    start = time.monotonic()
    while time.monotonic() - start < timeout:
        version, image, taken = render.image()
        if render.error:
            raise AssertionError(render.error)
        if image is not None and version > after and taken >= samples:
            return image, taken
        time.sleep(0.02)
    raise AssertionError("no pass in time")


def test_progressive_passes_and_what_a_change_rebuilds(blank):
    small_scene(blank)
    exported = export_scene(depsgraph())
    sun_key = next(iter(exported.suns))
    view = np.linalg.inv(np.array(blank.camera.matrix_world))
    sensor = camera.from_view(view, perspective(0.8, 40, 30), 40, 30, 0.1, 100)
    render = viewport.ViewportRender(max_samples=3, threads=2)
    try:
        render.show(viewport.with_view(exported.scene, sensor))
        image, taken = wait_for(render, 3)
        assert image.shape == (30, 40, 4) and np.all(np.isfinite(image)) and render.loads == 1
        # Orbiting: a new sensor, of another size; the loaded scene is updated, not rebuilt.
        view[:3, 3] += (0.3, 0.1, 0)
        sensor = camera.from_view(view, perspective(0.8, 32, 24), 32, 24, 0.1, 100)
        before = render.image()[0]
        render.show(viewport.with_view(exported.scene, sensor))
        image, _ = wait_for(render, 1, before)
        assert image.shape == (24, 32, 4) and render.loads == 1
        # A Sun lamp turned: its direction replaced, still no rebuild.
        before = render.image()[0]
        render.show(viewport.with_view(exported.scene, sensor, {sun_key: (0.3, -1.0, 0.2)}))
        wait_for(render, 1, before)
        assert render.loads == 1
        # A Sun's strength: the scene exported again, its other entries kept as they were
        # (compared by content: these meshes are not from the cache), so still an update.
        sun = next(o for o in blank.objects if o.type == "LIGHT" and o.data.type == "SUN")
        sun.data.energy *= 2
        again = viewport.kept_unchanged(exported.scene, export_scene(depsgraph()).scene)
        assert [k for k in again if again[k] is not exported.scene[k]] == [sun_key]
        before = render.image()[0]
        render.show(viewport.with_view(again, sensor))
        wait_for(render, 1, before)
        assert render.loads == 1
        # Anything else: the scene exported again and built (waited for by the count of
        # loads: a pass of the old scene may still publish until show() is called).
        bpy.ops.mesh.primitive_cube_add(size=0.5, location=(-2, 0, 0.25))
        render.show(viewport.with_view(export_scene(depsgraph()).scene, sensor))
        start = time.monotonic()
        while render.loads < 2 and time.monotonic() - start < 60:
            time.sleep(0.02)
        assert render.loads == 2
        time.sleep(0.2)
        assert render.error is None
    finally:
        render.stop()


def test_closing_the_viewport_stops_a_pass_in_flight(blank):
    """A pass of a dense fog at 256x256 takes seconds; stop() returns within one second
    (the renderer checks for cancel about twenty times a second; the bound leaves room
    for a loaded CI machine)."""
    small_scene(blank)
    for obj in blank.objects:
        if obj.type == "MESH" and obj.name.startswith("Cube"):
            obj.scale = (6, 6, 6)
    exported = export_scene(depsgraph())
    view = np.linalg.inv(np.array(blank.camera.matrix_world))
    sensor = camera.from_view(view, perspective(0.8, 256, 256), 256, 256, 0.1, 100)
    render = viewport.ViewportRender(max_samples=64, threads=1)
    render.show(viewport.with_view(exported.scene, sensor))
    wait_for(render, 0)  # the quick image is there; full-resolution passes run
    start = time.monotonic()
    render.stop()
    assert time.monotonic() - start < 1.0


def test_the_engine_starts_the_viewport_from_the_view_it_is_given(blank):
    """engine.view_update's work with a stand-in engine and viewport (no display here): the
    scene is exported once, seen through the region's matrices at the region's size."""
    from addon import engine as engine_module

    small_scene(blank)
    view = np.linalg.inv(np.array(blank.camera.matrix_world))
    region_data = SimpleNamespace(view_matrix=view, window_matrix=perspective(0.8, 36, 20))
    context = SimpleNamespace(
        region=SimpleNamespace(width=36, height=20),
        region_data=region_data,
        space_data=SimpleNamespace(clip_start=0.1, clip_end=100.0),
    )
    stand_in = SimpleNamespace()
    engine_module._viewport_update(stand_in, context, depsgraph())
    try:
        state = stand_in._viewport
        image, _ = wait_for(state["render"], 1)
        assert image.shape == (20, 36, 4) and state["render"].loads == 1 and state["meshes"]
        assert np.allclose(state["sensor"]["to_world"], camera.to_world(blank.camera))
    finally:
        stand_in._viewport["render"].stop()
