"""Volume objects: VDB files written by Blender's openvdb become heterogeneous media."""

import numpy as np
import pytest
from blender_scenes import (
    add_camera,
    add_volume,
    bpy,
    depsgraph,
    render_f12,
    set_background,
    volume_material,
    write_vdb,
)

import volpath
from addon.export import ExportError, export_scene, write_directory
from addon.export.convert import BLENDER_TO_SCENE


def _cloud():
    x, y, z = np.meshgrid(*(np.arange(12),) * 3, indexing="ij")
    return np.clip(1 - np.sqrt((x - 5.5) ** 2 + (y - 5.5) ** 2 + (z - 5.5) ** 2) / 6, 0, None).astype(np.float32)


def test_vdb_values_and_placement(blank, tmp_path):
    density = _cloud()
    add_volume(
        write_vdb(tmp_path / "cloud.vdb", density, voxel_size=0.1, origin_index=(3, 0, 0)),
        volume_material("smoke", density=4.0, color=(0.9, 0.8, 0.7)),
        location=(1, 2, 3),
    )
    add_camera(blank)
    d = export_scene(depsgraph()).scene
    cloud = d["cloud"]
    medium = cloud["interior"]
    grid = medium["density"]  # a volpath.VolumeGrid, read sparse
    assert medium["scale"] == pytest.approx(4.0)
    assert medium["albedo"]["value"] == pytest.approx([0.9, 0.8, 0.7])
    # Every voxel of the grid, by its centre in the scene: back in Blender's object space,
    # a VDB voxel ijk sits at ijk * voxel_size; the array's [x, y, z] is ijk - (3, 0, 0).
    z, y, x, _ = grid.shape
    idx = np.stack(np.meshgrid(np.arange(z), np.arange(y), np.arange(x), indexing="ij")[::-1], -1)
    centres = ((idx + 0.5) / [x, y, z]) @ grid.to_world[:3, :3].T + grid.to_world[:3, 3]
    blender = centres @ np.linalg.inv(BLENDER_TO_SCENE[:3, :3]).T - [1, 2, 3]
    ijk = np.rint(blender / 0.1).astype(int) - [3, 0, 0]
    assert np.allclose(blender, (ijk + [3, 0, 0]) * 0.1, atol=1e-6)
    inside = np.all((ijk >= 0) & (ijk < density.shape), axis=-1)
    clipped = np.clip(ijk, 0, np.array(density.shape) - 1)
    expected = np.where(inside, density[clipped[..., 0], clipped[..., 1], clipped[..., 2]], 0)
    assert np.array_equal(grid.numpy()[..., 0], expected)
    assert np.count_nonzero(grid.numpy()) == np.count_nonzero(density)


def test_vdb_scene_f12_equals_directory_render(blank, tmp_path):
    add_volume(
        write_vdb(tmp_path / "cloud.vdb", _cloud() * 5), volume_material("smoke", density=3.0, color=(0.95,) * 3)
    )
    add_camera(blank, location=(0.6, -3, 0.6), rotation=(np.pi / 2, 0, 0))
    set_background(blank, (1, 1, 1))
    blank.volpath.tracer = "null_scattering"
    f12 = render_f12(blank, tmp_path / "f12.exr")
    path = write_directory(export_scene(depsgraph()), tmp_path / "scene")
    assert (tmp_path / "scene" / "volumes" / "cloud.vdb").is_file()  # a copy: the directory stands alone
    assert 'type="vdbvolume"' in open(path).read()
    again = volpath.render(volpath.load_file(path), seed=0, tracer="null_scattering")
    assert np.array_equal(f12, again)
    # The cloud is visible: the centre (8x8 pixels at 4 spp) is darker than the corners'
    # open sky, which is 1.
    assert again[12:20, 20:28].mean() < 0.9 and again[0, 0].mean() == pytest.approx(1.0)


def test_missing_vdb_is_a_clear_error(blank, tmp_path, capfd):
    path = write_vdb(tmp_path / "gone.vdb", _cloud())
    volume = add_volume(path, volume_material("smoke"))
    add_camera(blank)
    path.unlink()
    volume.data.grids.unload()
    with pytest.raises(ExportError, match=r"volume 'gone': VDB file '.*gone\.vdb' not found"):
        export_scene(depsgraph())
    render_result = tmp_path / "f12.exr"
    with pytest.raises(RuntimeError):
        render_f12(blank, render_result)  # Blender refuses to save a failed render ...
    out = capfd.readouterr()
    assert "Volpath: volume 'gone': VDB file" in out.out + out.err  # ... and the report says why


def puff_sequence(directory):
    """A two-frame VDB sequence of a cloud (three times denser at frame 2), imported."""
    base = _cloud()
    for frame, scale in ((1, 1.0), (2, 3.0)):
        write_vdb(directory / f"puff_{frame:04d}.vdb", base * scale)
    bpy.ops.object.volume_import(
        filepath=str(directory / "puff_0001.vdb"),
        directory=str(directory),
        files=[{"name": "puff_0001.vdb"}, {"name": "puff_0002.vdb"}],
    )


def test_vdb_sequence_follows_the_frame(blank, tmp_path):
    puff_sequence(tmp_path)
    volume = bpy.context.object
    volume.data.materials.append(volume_material("smoke"))
    assert volume.data.is_sequence
    add_camera(blank)
    peaks = []
    for frame in (1, 2):
        blank.frame_set(frame)
        exported = export_scene(depsgraph())
        assert exported.sequences == {volume.name: volume.name}
        peaks.append(exported.scene[volume.name]["interior"]["density"].max())
    assert peaks[1] == pytest.approx(3 * peaks[0])


def test_fire_blackbody_and_emission_become_radiance(blank, tmp_path):
    """A VDB with density and temperature grids (as Blender's fire), rendered in Cycles'
    terms: Principled Volume emission over sigma_a, and blackbody radiance from
    Temperature x the temperature grid."""
    from addon.export.volumes import _openvdb
    from volpath.blackbody import blackbody_rgb

    vdb = _openvdb()
    density, temperature = vdb.FloatGrid(), vdb.FloatGrid()
    density.name, temperature.name = "density", "temperature"
    d = np.zeros((6, 6, 6), np.float32)
    d[1:5, 1:5, 1:5] = 2.0
    t = np.zeros((8, 8, 8), np.float32)  # a larger active box than the density's
    t[:, :, :] = 1.5
    density.copyFromArray(d)
    temperature.copyFromArray(t)
    for g in (density, temperature):
        g.transform = vdb.createLinearTransform(voxelSize=0.1)
    vdb.write(str(tmp_path / "fire.vdb"), grids=[density, temperature])
    m = volume_material("fire", density=1.0, color=(0.2, 0.2, 0.2))
    pv = m.node_tree.nodes["Principled Volume"]
    pv.inputs["Blackbody Intensity"].default_value = 1.0
    pv.inputs["Temperature"].default_value = 1000.0  # kelvin per unit of the grid
    pv.inputs["Emission Strength"].default_value = 0.8
    pv.inputs["Emission Color"].default_value = (1.0, 0.5, 0.0, 1.0)
    add_volume(tmp_path / "fire.vdb", m)
    add_camera(blank)
    interior = export_scene(depsgraph()).scene["fire"]["interior"]
    # The radiance grid lies on the density's voxels (same bricks and placement).
    radiance, density = interior["radiance"], interior["density"]
    assert radiance.shape[:3] == density.shape[:3] and np.allclose(radiance.to_world, density.to_world)
    assert np.array_equal(radiance.native.brick_index, density.native.brick_index)
    sigma_a = 2.0 * 0.8  # density x (1 - colour)
    expected = np.array([0.8, 0.4, 0.0]) / sigma_a + blackbody_rgb(1500.0)
    dense = density.numpy()[..., 0]
    assert np.count_nonzero(dense) == 64
    assert np.allclose(radiance.numpy()[dense > 0], expected, rtol=1e-5)
    scene = volpath.load_dict(export_scene(depsgraph()).scene)
    assert scene.summary["media"][0]["emissive"]


def test_emitting_volume_is_stored_sparse(blank, tmp_path):
    """Two small fires 190 voxels apart: the density and its radiance keep only the bricks
    around them (OpenVDB leaves), not the 200^3 box between them (96 MB of radiance dense),
    in memory and in an exported directory."""
    from addon.export.volumes import _openvdb

    vdb = _openvdb()
    density = vdb.FloatGrid()
    density.name = "density"
    blob = np.full((4, 4, 4), 3.0, np.float32)
    density.copyFromArray(blob, ijk=(0, 0, 0))
    density.copyFromArray(blob, ijk=(190, 190, 190))
    density.transform = vdb.createLinearTransform(voxelSize=0.01)
    vdb.write(str(tmp_path / "fires.vdb"), grids=[density])
    m = volume_material("fires", density=1.0, color=(0.5, 0.5, 0.5))
    m.node_tree.nodes["Principled Volume"].inputs["Emission Strength"].default_value = 2.0
    add_volume(tmp_path / "fires.vdb", m)
    add_camera(blank)
    interior = export_scene(depsgraph()).scene["fires"]["interior"]
    radiance = interior["radiance"]
    assert min(radiance.shape[:3]) >= 194  # the two fires and the space between
    assert radiance.nbytes < 0.01 * radiance.dense_nbytes, (radiance.nbytes, radiance.dense_nbytes)
    assert radiance.max() == pytest.approx(2.0 / (3.0 * 0.5), rel=1e-5)  # emission / sigma_a
    # Sparse on disk too: the exported directory holds the radiance as a .vdb of its own.
    path = write_directory(export_scene(depsgraph()), tmp_path / "scene")
    written = tmp_path / "scene" / "volumes" / "radiance.vdb"
    assert written.stat().st_size < 1e6  # dense: 96 MB
    assert volpath.VolumeGrid.from_file(written, "radiance").max() == pytest.approx(radiance.max(), rel=1e-6)
    assert volpath.load_file(path).summary["media"][0]["emissive"]


def test_a_vdb_sequence_and_a_moving_object_reach_the_video_as_f12_renders_them(blank, tmp_path):
    """A VDB sequence beside a cube keyframed across the floor: per frame the sequence's grids
    (animation.json) and the cube's instance (the frame's updates) both apply, and each
    pipeline frame is the bits of the scene exported afresh at that frame."""
    import json

    from addon.export.animation import export_animation
    from pipeline.frames import render_frame

    puff_sequence(tmp_path)
    bpy.context.object.data.materials.append(volume_material("smoke"))
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(-1, 0, 0))
    cube = bpy.context.object
    for frame, x in ((1, -1.0), (2, 1.0)):
        cube.location.x = x
        cube.keyframe_insert("location", frame=frame)
    bpy.ops.object.light_add(type="SUN")
    add_camera(blank)
    anim = tmp_path / "anim"
    export_animation(blank, [1, 2], str(anim))
    animation = json.loads((anim / "animation.json").read_text())
    assert "volumes" in animation["frames"][1] and "updates" in animation["frames"][1]
    for f in (1, 2):
        image, _ = render_frame(str(anim), f, 4, threads=1)
        blank.frame_set(f)
        fresh = write_directory(export_scene(depsgraph(), instanced=animation["instanced"]), tmp_path / f"f{f}")
        assert np.array_equal(image, volpath.render(volpath.load_file(fresh), spp=4, seed=f, threads=2)), f
