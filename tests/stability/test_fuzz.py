"""Hostile input: mutated scene files and grid files raise volpath.SceneError (naming the
file), never another exception, a crash or a hang. CI runs a few thousand cases;
`make fuzz` runs many more (FUZZ_EXAMPLES)."""

import os
import re
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import scenes as S
import volpath
from volpath.grids import write_vol

EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "600"))
SETTINGS = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)

SEEDS = [
    S.scene(
        S.camera(res=4, spp=1),
        S.homogeneous("m", "1, 2, 3", "0.5, 0.9, 1", g=0.3),
        S.medium_sphere("m"),
        S.floor(),
        S.area_light_above(),
        S.point_light(),
        S.constant_env(),
    ),
    S.scene(
        S.camera(res=4, spp=1),
        '<medium type="heterogeneous" id="m"><volume type="gridvolume" name="sigma_t">'
        '<string name="filename" value="g.vol"/></volume><rgb name="albedo" value="0.5"/></medium>',
        S.medium_cube("m"),
        '<emitter type="directional"><vector name="direction" value="0,-1,0"/></emitter>',
    ),
    S.scene(
        S.camera(res=4, spp=1, extra='<float name="far_clip" value="1e9"/>'),
        '<medium type="atmosphere" id="air"><float name="mie_g" value="0.7"/></medium>'.replace("mie_g", "g"),
        '<emitter type="sun"><float name="elevation" value="3"/></emitter>',
    ),
    open(os.path.join(os.path.dirname(__file__), "..", "python", "test_loader.py"))
    .read()
    .split('LAJOLLA = """')[1]
    .split('"""')[0],
]
TOKENS = [
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e400",
    "1e-320",
    "",
    "abc",
    "1,2",
    "99999999",
    "-0",
    "$x",
    "1e6",
    "0x10",
    "  ",
    "<",
    "&amp;",
    "true",
    "0.5 0.5",
]


def mutate(text, data):
    kind = data.draw(st.sampled_from(["value", "delete", "duplicate", "tag", "attr", "truncate"]))
    values = list(re.finditer(r'(value|x|y|z|origin|target|up|angle|type|name|id|filename)="([^"]*)"', text))
    if kind == "value" and values:
        m = data.draw(st.sampled_from(values))
        token = data.draw(st.sampled_from(TOKENS))
        return text[: m.start(2)] + token + text[m.end(2) :]
    if kind in ("delete", "duplicate"):
        a = data.draw(st.integers(0, len(text)))
        b = data.draw(st.integers(a, min(len(text), a + 80)))
        return text[:a] + text[b:] if kind == "delete" else text[:b] + text[a:b] + text[b:]
    tags = list(re.finditer(r"<(\w+)", text))
    if kind == "tag" and tags:
        m = data.draw(st.sampled_from(tags))
        new = data.draw(
            st.sampled_from(["float", "rgb", "shape", "medium", "ref", "scene", "integer", "foo", "include"])
        )
        return text[: m.start(1)] + new + text[m.end(1) :]
    if kind == "attr" and values:
        m = data.draw(st.sampled_from(values))
        new = data.draw(st.sampled_from(["value", "name", "id", "type", "bogus"]))
        return text[: m.start(1)] + new + text[m.end(1) :]
    return text[: data.draw(st.integers(0, len(text)))]


@pytest.fixture(scope="module")
def grid_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    write_vol(d / "g.vol", np.random.default_rng(0).uniform(0, 2, (4, 4, 4)))
    return d


@SETTINGS
@given(data=st.data())
def test_mutated_scenes(grid_dir, data):
    text = data.draw(st.sampled_from(SEEDS))
    for _ in range(data.draw(st.integers(1, 3))):
        text = mutate(text, data)
    try:
        scene = volpath.load_string(text, base_dir=str(grid_dir))
    except volpath.SceneError as e:
        assert str(e)  # a message, naming where
        return
    if scene.width * scene.height <= 64:
        image = volpath.render(scene, spp=1, threads=1, max_depth=8, tracer="null_scattering")
        assert np.all(np.isfinite(image)) and image.min() >= 0


def load_grid_file(grid_dir, name, raw, volume="gridvolume"):
    """Load a scene whose medium reads the grid file `name` holding `raw`: it loads, or
    raises a SceneError that names the file."""
    (grid_dir / name).write_bytes(raw)
    xml = S.scene(
        S.camera(res=2, spp=1),
        f'<medium type="heterogeneous" id="m"><volume type="{volume}" '
        f'name="sigma_t"><string name="filename" value="{name}"/></volume></medium>',
        S.medium_cube("m"),
    )
    try:
        volpath.load_string(xml, base_dir=str(grid_dir))
    except volpath.SceneError as e:
        assert name in str(e)


@SETTINGS
@given(
    header=st.binary(min_size=0, max_size=60),
    values=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), max_size=20),
)
def test_hostile_vol_files(grid_dir, header, values):
    load_grid_file(grid_dir, "hostile.vol", header + struct.pack(f"<{len(values)}f", *values))


@SETTINGS
@given(
    dims=st.tuples(st.integers(-5, 1 << 30), st.integers(-5, 1 << 20), st.integers(-5, 1 << 20)),
    channels=st.integers(-1, 5),
    version=st.integers(0, 255),
    encoding=st.integers(-2, 4),
    extra=st.integers(0, 64),
)
def test_vol_headers_checked_before_allocating(grid_dir, dims, channels, version, encoding, extra):
    load_grid_file(
        grid_dir,
        "header.vol",
        b"VOL"
        + bytes([version])
        + struct.pack("<5i", encoding, *dims, channels)
        + struct.pack("<6f", 0, 0, 0, 1, 1, 1)
        + b"\0" * (4 * extra),
    )


@pytest.fixture(scope="module")
def vdb_bytes(tmp_path_factory):
    """A small cloud written by Blender's OpenVDB (leaves, a tile-free tree, blosc-free)."""
    from blender_scenes import write_vdb

    d = np.zeros((20, 20, 20), np.float32)
    d[3:17, 2:15, 4:18] = np.random.default_rng(0).uniform(0, 1, (14, 13, 14))
    return write_vdb(tmp_path_factory.mktemp("vdb") / "c.vdb", d).read_bytes()


@pytest.fixture
def quick_vdb_timeout(monkeypatch):
    """OpenVDB can loop on a hostile file until the reader's timeout: a short one here."""
    from volpath import vdb

    monkeypatch.setattr(vdb, "TIMEOUT", 2.0)


# Each case starts a reader process (~0.1 s): a sixth of the examples of the other fuzzers.
@settings(SETTINGS, max_examples=max(EXAMPLES // 6, 1))
@given(data=st.data())
def test_hostile_vdb_files(grid_dir, vdb_bytes, quick_vdb_timeout, data):
    """Truncations, flipped bytes, overwritten sizes and spliced runs of a real file."""
    raw = bytearray(vdb_bytes)
    for _ in range(data.draw(st.integers(1, 3))):
        kind = data.draw(st.sampled_from(["truncate", "flip", "int", "splice"]))
        at = data.draw(st.integers(0, max(len(raw) - 1, 0)))
        if kind == "truncate":
            del raw[at:]
        elif kind == "flip" and raw:
            raw[at] ^= 1 << data.draw(st.integers(0, 7))
        elif kind == "int":
            raw[at : at + 4] = struct.pack("<i", data.draw(st.sampled_from([-1, 0, 1 << 30, -(1 << 31), 7, 4096])))
        else:
            b = data.draw(st.integers(at, min(len(raw), at + 64)))
            raw[at:at] = raw[at:b]
    load_grid_file(grid_dir, "hostile.vdb", bytes(raw), volume="vdbvolume")
