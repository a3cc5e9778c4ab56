"""OpenVDB volumes: files written by Blender 5.0's OpenVDB 12 read by volpath._vdb (Debian's
OpenVDB 10) into the sparse brick layout, with the same values and placement; sequences;
bad files raise SceneError naming the file and the grid."""

import numpy as np
import pytest
from blender_scenes import write_vdb

import scenes as S
import volpath
from volpath.xml_reader import read_xml


def cloud(shape=(10, 12, 14), seed=1):
    """A random blob inside a zero border, indexed [x, y, z] as Blender's module takes it."""
    d = np.zeros(shape, np.float32)
    d[2:-2, 3:-3, 4:-2] = np.random.default_rng(seed).uniform(0.1, 2.0, (shape[0] - 4, shape[1] - 6, shape[2] - 6))
    return d


def translate(v):
    m = np.eye(4)
    m[:3, 3] = v
    return m


def vdb_to_world(grid):
    """World position of the centre of every voxel of a VolumeGrid, (z, y, x, 3)."""
    z, y, x, _ = grid.shape
    idx = np.stack(np.meshgrid(np.arange(z), np.arange(y), np.arange(x), indexing="ij")[::-1], -1)
    unit = (idx + 0.5) / np.array([x, y, z])
    return unit @ grid.to_world[:3, :3].T + grid.to_world[:3, 3]


def test_blender_written_vdb_loads_with_the_same_values_and_places(tmp_path):
    density = cloud()
    path = write_vdb(tmp_path / "cloud.vdb", density, voxel_size=0.1, origin_index=(3, -5, 0))
    grid = volpath.VolumeGrid.from_file(path, "density")
    values, centres = grid.numpy()[..., 0], vdb_to_world(grid)
    # A VDB voxel ijk sits at ijk * voxel_size; the array's [x, y, z] at ijk = origin + (x, y, z).
    ijk = np.rint(centres / 0.1).astype(int) - np.array([3, -5, 0])
    assert np.allclose(centres, (ijk + [3, -5, 0]) * 0.1, atol=1e-12)
    inside = np.all((ijk >= 0) & (ijk < density.shape), axis=-1)
    expected = np.where(inside, density[tuple(np.clip(ijk, 0, np.array(density.shape) - 1).transpose(3, 0, 1, 2))], 0)
    assert np.array_equal(values, expected)
    assert np.count_nonzero(values) == np.count_nonzero(density)


def test_a_volume_saved_by_blender_loads_with_the_same_values(tmp_path):
    import bpy

    density = cloud(seed=2)
    write_vdb(tmp_path / "in.vdb", density, voxel_size=0.25)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.object.volume_import(filepath=str(tmp_path / "in.vdb"))
    volume = bpy.context.object.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    volume.grids.load()
    assert volume.grids.save(str(tmp_path / "saved.vdb"))
    a = volpath.VolumeGrid.from_file(tmp_path / "in.vdb")
    b = volpath.VolumeGrid.from_file(tmp_path / "saved.vdb")
    assert np.array_equal(a.numpy(), b.numpy()) and np.allclose(a.to_world, b.to_world)


def test_vdb_numpy_render_round_trip(tmp_path):
    """A .vdb cloud renders bit for bit as the same voxels handed over from numpy."""
    path = write_vdb(tmp_path / "cloud.vdb", cloud(), voxel_size=0.15)
    grid = volpath.VolumeGrid.from_file(path)
    place = '<transform name="to_world"><translate value="-1, -1, -1"/></transform>'

    xml = S.scene(
        S.camera(res=12, spp=8),
        '<medium type="heterogeneous" id="m"><volume type="vdbvolume" name="density">'
        f'<string name="filename" value="cloud.vdb"/>{place}</volume>'
        '<float name="albedo" value="0.8"/><float name="scale" value="4"/></medium>',
        S.medium_cube("m", half=3),
        S.constant_env(),
    )
    from_file = volpath.render(volpath.load_string(xml, base_dir=str(tmp_path)), seed=3)
    d = read_xml(xml, "<string>", {})
    d["m"]["density"] = volpath.VolumeGrid.from_numpy(grid.numpy(), translate(-1) @ grid.to_world)
    from_numpy = volpath.render(volpath.load_dict(d), seed=3)
    assert from_file.mean() > 0 and np.array_equal(from_file, from_numpy)


def test_colour_grid_and_sequence_frames(tmp_path):
    from addon.export.volumes import _openvdb

    vdb = _openvdb()
    for frame in (1, 2):
        g = vdb.Vec3SGrid()
        g.name = "albedo"
        g.copyFromArray(np.full((4, 4, 4, 3), [0.2, 0.5, 0.1 * frame], np.float32))
        vdb.write(str(tmp_path / f"smoke_{frame:04d}.vdb"), grids=[g])
    grid = volpath.VolumeGrid.from_file(tmp_path / "smoke_####.vdb", "albedo", frame=2)
    assert grid.channels == 3 and np.allclose(grid.max(), 0.5)
    assert np.allclose(grid.numpy()[grid.numpy()[..., 0] > 0], [0.2, 0.5, 0.2])
    with pytest.raises(volpath.SceneError, match="smoke_0003.vdb: volume file not found"):
        volpath.VolumeGrid.from_file(tmp_path / "smoke_####.vdb", "albedo", frame=3)
    with pytest.raises(volpath.SceneError, match="no 'frame'"):
        volpath.VolumeGrid.from_file(tmp_path / "smoke_####.vdb", "albedo")


def test_sparse_storage_follows_the_active_voxels():
    """A 128^3 box with a small ball: only bricks holding it are stored."""
    n = 128
    x = (np.arange(n) + 0.5) / n - 0.5
    ball = ((x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2) < 0.1**2).astype(np.float32)
    grid = volpath.VolumeGrid.from_numpy(ball)
    assert np.array_equal(grid.numpy()[..., 0], ball)
    assert grid.nbytes < 0.05 * grid.dense_nbytes
    # Lookups agree with a dense trilinear reference at random points.
    rng = np.random.default_rng(4)
    for p in rng.uniform(0.3, 0.7, (200, 3)):
        c = np.clip(p * n - 0.5, 0, n - 1)
        i0 = np.minimum(c.astype(int), n - 1)
        i1, w = np.minimum(i0 + 1, n - 1), c - i0
        ref = 0.0
        for corner in range(8):
            b = [(corner >> a) & 1 for a in range(3)]
            ix = [i1[a] if b[a] else i0[a] for a in range(3)]
            ref += ball[ix[2], ix[1], ix[0]] * np.prod([w[a] if b[a] else 1 - w[a] for a in range(3)])
        assert abs(grid.native.lookup(tuple(p))[0] - ref) < 1e-6


@pytest.mark.parametrize("channels", [1, 3])
def test_lookups_match_a_dense_trilinear_reference(channels):
    """Random values in a 21 x 13 x 17 grid (odd sizes: partial bricks at the far borders)
    with a quarter of its bricks empty: lookups at random points, the borders included,
    equal trilinear interpolation of the dense array, whether the eight voxels share one
    brick (the fast path) or not."""
    rng = np.random.default_rng(channels)
    dense = rng.uniform(0, 5, (17, 13, 21, channels)).astype(np.float32)  # (z, y, x, c)
    dense[:8, :8, 8:16] = 0  # an empty brick
    grid = volpath.VolumeGrid.from_numpy(dense)
    n = np.array([21, 13, 17])
    for p in np.concatenate([rng.uniform(0, 1, (300, 3)), rng.choice([0.0, 1.0], (20, 3))]):
        c = np.clip(p * n - 0.5, 0, n - 1)
        i0 = np.minimum(c.astype(int), n - 1)
        i1, w = np.minimum(i0 + 1, n - 1), c - i0
        ref = np.zeros(channels)
        for corner in range(8):
            b = [(corner >> a) & 1 for a in range(3)]
            ix = [i1[a] if b[a] else i0[a] for a in range(3)]
            ref += dense[ix[2], ix[1], ix[0]] * np.prod([w[a] if b[a] else 1 - w[a] for a in range(3)])
        got = np.array(grid.native.lookup(tuple(p)))
        assert np.allclose(got, np.broadcast_to(ref, 3), rtol=1e-5, atol=1e-5), (p, got, ref)


@pytest.mark.parametrize(
    "damage, message",
    [
        ("truncated", "grid 'density': .+"),
        ("missing grid", "grid 'smoke': no grid named 'smoke' \\(the file has 'density'\\)"),
        ("nan", "grid 'density' contains NaN or infinite values"),
        ("not a file", "grid 'density': .+"),
    ],
)
def test_bad_vdb_files_raise_scene_errors_naming_file_and_grid(tmp_path, damage, message):
    density = cloud()
    path = write_vdb(tmp_path / "bad.vdb", density)
    if damage == "nan":  # copyFromArray drops NaN: set it through an accessor
        from addon.export.volumes import _openvdb

        vdb = _openvdb()
        grid = vdb.read(str(path), "density")
        grid.getAccessor().setValueOn((5, 6, 7), float("nan"))
        vdb.write(str(path), grids=[grid])
    if damage == "truncated":
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    if damage == "not a file":
        path.write_bytes(b"definitely not OpenVDB" * 10)
    xml = S.scene(
        S.camera(res=4, spp=1),
        '<medium type="heterogeneous" id="m"><volume type="vdbvolume" name="density">'
        f'<string name="filename" value="bad.vdb"/><string name="grid" value="{"smoke" if damage == "missing grid" else "density"}"/>'
        "</volume></medium>",
        S.medium_cube("m"),
    )
    with pytest.raises(volpath.SceneError, match=f"<string>:\\d+: .*bad.vdb: {message}") as e:
        volpath.load_string(xml, base_dir=str(tmp_path))
    assert str(tmp_path / "bad.vdb") in str(e.value)


def test_temperature_grid_emits_blackbody_light(tmp_path):
    """A fire: a density and a temperature grid in one file (each placed by the file); the
    hot voxels glow red, the corners of the image, missing the fire, stay black."""
    from addon.export.volumes import _openvdb

    vdb = _openvdb()
    grids = []
    for name, value in (("density", 2.0), ("temperature", 3000.0)):
        g = vdb.FloatGrid()
        g.name = name
        g.copyFromArray(np.full((4, 4, 4), value, np.float32), ijk=(-2, -2, -2))
        g.transform = vdb.createLinearTransform(voxelSize=0.25)
        grids.append(g)
    vdb.write(str(tmp_path / "fire.vdb"), grids=grids)
    volume = (
        '<volume type="vdbvolume" name="{0}"><string name="filename" value="fire.vdb"/>'
        '<string name="grid" value="{0}"/></volume>'
    )
    xml = S.scene(
        S.camera(res=8, spp=8),
        f'<medium type="heterogeneous" id="m">{volume.format("density")}'
        f'<float name="albedo" value="0"/>{volume.format("temperature")}'
        '<float name="blackbody_scale" value="1e-6"/></medium>',
        S.medium_cube("m", half=1.1),
    )
    img = volpath.render(volpath.load_string(xml, base_dir=str(tmp_path)), seed=1)
    assert img[4, 4, 0] > img[4, 4, 2] > 0  # 3000 K is red
    assert np.all(img[0, 0] == 0)


def values_at(grid, points):
    """A VolumeGrid's stored values at world points (..., 3), by the voxel that holds them
    (0 outside the grid)."""
    z, y, x, c = grid.shape
    unit = (points - grid.to_world[:3, 3]) @ np.linalg.inv(grid.to_world[:3, :3]).T
    idx = np.floor(unit * np.array([x, y, z])).astype(int)
    inside = np.all((idx >= 0) & (idx < np.array([x, y, z])), axis=-1)
    idx = np.where(inside[..., None], idx, 0)
    return np.where(inside[..., None], grid.numpy()[idx[..., 2], idx[..., 1], idx[..., 0]], 0)


@pytest.mark.parametrize("channels", [1, 3])
def test_a_volume_grid_saves_as_a_sparse_vdb(tmp_path, channels):
    """VolumeGrid.save writes a .vdb holding only the non-zero voxels, which from_file
    reads back with the same value at every voxel centre, though over a box of its own
    (the active voxels and a margin), including blocks that touch the array's border."""
    rng = np.random.default_rng(3)
    data = np.zeros((20, 30, 40, channels), np.float32)
    data[2:6, 20:29, 1:9] = rng.uniform(0.1, 2.0, (4, 9, 8, channels))
    data[15:20, 0:3, 30:40] = rng.uniform(0.1, 2.0, (5, 3, 10, channels))
    rotation = np.eye(4)
    rotation[:2, :2] = [[0.6, -0.8], [0.8, 0.6]]
    grid = volpath.VolumeGrid.from_numpy(data, translate((1.0, -2.0, 3.0)) @ rotation @ np.diag([4.0, 3.0, 2.0, 1.0]))
    grid.save(tmp_path / "g.vdb", "radiance")
    back = volpath.VolumeGrid.from_file(tmp_path / "g.vdb", "radiance")
    assert back.channels == channels and back.nbytes < grid.dense_nbytes / 4
    assert np.allclose(values_at(back, vdb_to_world(grid)), data, rtol=0, atol=0)


@pytest.mark.parametrize("border", ["zero", "non-zero"])
def test_a_volume_grid_in_a_dictionary_writes_back_as_xml(tmp_path, border):
    """xml_writer writes a VolumeGrid as a sparse .vdb placed by its own transform when its
    outermost voxels are 0 (the scene read back has the same extinction everywhere, to
    rounding), else as a dense .vol, whose lookups clamp at the border as the grid's do
    (the same render, bit for bit)."""
    from volpath import _probes
    from volpath.xml_writer import write_scene

    xml = S.scene(
        S.camera(res=8, spp=4),
        '<medium type="heterogeneous" id="m"><float name="density" value="1"/></medium>',
        S.medium_cube("m"),
        S.constant_env(),
    )
    d = read_xml(xml, "<string>", {})
    to_world = np.diag([2.0, 2.0, 2.0, 1.0]) @ translate(-0.5)
    data = np.random.default_rng(1).random((5, 6, 7))
    if border == "zero":
        data = np.pad(data, 1)
    d["m"]["density"] = volpath.VolumeGrid.from_numpy(data, to_world)
    path = write_scene(d, tmp_path)
    direct, written = volpath.load_dict(d), volpath.load_file(path)
    if border == "non-zero":
        assert (tmp_path / "volumes" / "density.vol").is_file()
        assert np.array_equal(volpath.render(direct, seed=1), volpath.render(written, seed=1))
        return
    assert 'type="vdbvolume"' in open(path).read() and (tmp_path / "volumes" / "density.vdb").is_file()
    points = np.random.default_rng(2).uniform(-1.2, 1.2, (2000, 3))
    assert np.allclose(
        _probes.medium_sigma_t(written.native, 0, points),
        _probes.medium_sigma_t(direct.native, 0, points),
        rtol=1e-5,
        atol=1e-6,
    )
    assert volpath.render(written, seed=1).mean() > 0
