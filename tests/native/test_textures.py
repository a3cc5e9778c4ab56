"""Textures: lookups against a reference written here, texture coordinates as Mitsuba
puts them on each shape, and BSDF parameters driven by textures."""

import re

import numpy as np
import pytest

import scenes as S
import volpath
from volpath import _core, _probes
from volpath.meshes import write_ply
from volpath.xml_writer import write_scene


def _srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _reference_lookup(texels, uv, bilinear, wrap):
    """Bilinear (texel centres at half-integers) or nearest lookup, written independently of
    the native one: v = 0 is row 0."""
    h, w, _ = texels.shape

    def index(i, n):
        if wrap == "repeat":
            return np.mod(i, n)
        if wrap == "clamp":
            return np.clip(i, 0, n - 1)
        j = np.mod(i, 2 * n)
        return np.where(j < n, j, 2 * n - 1 - j)

    x, y = uv[:, 0] * w, uv[:, 1] * h
    if not bilinear:
        return texels[index(np.floor(y).astype(int), h), index(np.floor(x).astype(int), w)]
    x0, y0 = np.floor(x - 0.5).astype(int), np.floor(y - 0.5).astype(int)
    ax, ay = (x - 0.5 - x0)[:, None], (y - 0.5 - y0)[:, None]

    def t(i, j):
        return texels[index(j, h), index(i, w)]

    return (t(x0, y0) * (1 - ax) + t(x0 + 1, y0) * ax) * (1 - ay) + (
        t(x0, y0 + 1) * (1 - ax) + t(x0 + 1, y0 + 1) * ax
    ) * ay


@pytest.mark.parametrize("wrap", ["repeat", "mirror", "clamp"])
@pytest.mark.parametrize("bilinear", [True, False])
def test_bitmap_lookups_match_a_reference(wrap, bilinear):
    """8-bit sRGB, 8-bit raw and float texels, one and three channels, at coordinates far
    outside [0, 1]: the native lookup agrees with the reference to rounding."""
    rng = np.random.default_rng(3)
    uv = rng.uniform(-2.5, 3.5, (500, 2))
    native = _core.Scene()
    bytes3 = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    floats1 = rng.random((4, 3, 1), dtype=np.float32) * 4
    cases = [
        (bytes3, True, _srgb_to_linear(bytes3 / 255.0)),
        (bytes3, False, bytes3 / 255.0),
        (floats1, False, np.repeat(floats1.astype(np.float64), 3, axis=2)),
    ]
    for texels, srgb, linear in cases:
        t = native.add_texture_bitmap(texels, srgb, bilinear, wrap)
        got = _probes.texture_eval(native, t, uv)
        assert np.allclose(got, _reference_lookup(linear, uv, bilinear, wrap), rtol=1e-6, atol=1e-7)


def test_to_uv_and_the_checkerboard():
    """Mitsuba's checkerboard: color0 where u and v (fractional parts) are both above or
    both below 1/2; to_uv maps coordinates before the lookup (here u' = 2u, v' = v + 0.5)."""
    native = _core.Scene()
    to_uv = np.array([[2.0, 0, 0], [0, 1, 0.5], [0, 0, 1]])
    t = native.add_texture_checkerboard((0.9, 0.8, 0.7), (0.1, 0.2, 0.3), to_uv)
    uv = np.array([[0.1, 0.1], [0.1, 0.6], [0.3, 0.6], [0.3, 0.1], [-0.4, 2.1]])
    # after to_uv: (0.2, 0.6) (0.2, 1.1) (0.6, 1.1) (0.6, 0.6) (-0.8, 2.6)
    expected = np.array([[0.1, 0.2, 0.3], [0.9, 0.8, 0.7], [0.1, 0.2, 0.3], [0.9, 0.8, 0.7], [0.1, 0.2, 0.3]])
    assert np.allclose(_probes.texture_eval(native, t, uv), expected)


def _uv_at(xml, origins, dirs):
    scene = volpath.load_string(S.scene(S.camera(res=4), xml))
    return _probes.surface_uv(scene.native, np.asarray(origins, float), np.asarray(dirs, float))


def test_texture_coordinates_on_each_shape(tmp_path):
    """Where Mitsuba 3.9 puts (u, v) (values read from it): an OBJ's vt with v flipped, a
    PLY's u, v as stored, a sphere's longitude and polar angle, a rectangle's corners, a
    cube's faces (the analytic box and the emitting cube's mesh alike), and a mesh's
    barycentrics where it has no coordinates."""
    (tmp_path / "quad.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0.1 0.2\nvt 0.9 0.2\nvt 0.9 0.8\nvt 0.1 0.8\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
    )
    quad = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    write_ply(tmp_path / "quad.ply", quad, [[0, 1, 2], [0, 2, 3]], uvs=[[0.1, 0.2], [0.9, 0.2], [0.9, 0.8], [0.1, 0.8]])
    write_ply(tmp_path / "bare.ply", quad, [[0, 1, 2], [0, 2, 3]])
    down = [[0.25, 0.25, 1]], [[0, 0, -1]]
    for name, expected in (("quad.obj", [0.3, 0.65]), ("quad.ply", [0.3, 0.35]), ("bare.ply", [0.0, 0.25])):
        uv = _uv_at(f'<shape type="{name[-3:]}"><string name="filename" value="{tmp_path / name}"/></shape>', *down)
        assert np.allclose(uv, [expected], atol=1e-6), name
    d = np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0.01]])
    uv = _uv_at('<shape type="sphere"/>', 3 * d, -d)
    assert np.allclose(uv, [[0, 0.5], [0.25, 0.5], [0.5, 0.496817]], atol=1e-5)
    assert np.allclose(_uv_at('<shape type="rectangle"/>', [[0.5, 0, 3]], [[0, 0, -1]]), [[0.75, 0.5]])
    origins, dirs = [], []
    for axis in range(3):
        for sign in (1, -1):
            for a, b in ((0.5, 0.0), (0.0, 0.5)):
                o, dd = np.zeros(3), np.zeros(3)
                o[axis], dd[axis] = 3 * sign, -sign
                o[(axis + 1) % 3], o[(axis + 2) % 3] = a, b
                origins.append(o), dirs.append(dd)
    mitsuba = [
        [[0.75, 0.5], [0.5, 0.25]],
        [[0.75, 0.5], [0.5, 0.75]],
        [[0.5, 0.25], [0.25, 0.5]],
        [[0.75, 0.5], [0.5, 0.75]],
        [[0.5, 0.75], [0.75, 0.5]],
        [[0.5, 0.75], [0.25, 0.5]],
    ]
    box = _uv_at('<shape type="cube"/>', origins, dirs)
    mesh = _uv_at('<shape type="cube"><emitter type="area"/></shape>', origins, dirs)
    assert np.allclose(box, np.reshape(mitsuba, (-1, 2)), atol=1e-9)
    assert np.allclose(mesh, box, atol=1e-9)


def _furnace_plane(bsdf):
    """A one-sided plane filling the view under a unit environment: each pixel sees the
    BSDF's albedo for light from the upper hemisphere, exactly the reflectance for a
    diffuse one."""
    return S.scene(
        S.camera(res=16, fov=30, spp=64),
        f'<shape type="rectangle"><transform name="to_world"><scale value="2"/></transform>{bsdf}</shape>',
        S.constant_env("1, 1, 1"),
    )


def test_a_textured_diffuse_plane_shows_its_texels(tmp_path):
    """A 2 x 2 nearest-filtered sRGB PNG on a diffuse plane: each quarter of the image
    renders the linear value of its texel (mean of the quarter, 5 s.e.). v = 0 is the
    texture's top row and the rectangle's bottom edge, so the image's upper half shows the
    texture's second row."""
    from PIL import Image

    texels = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [128, 128, 128]]], np.uint8)
    Image.fromarray(texels).save(tmp_path / "tex.png")
    bitmap = f'<texture type="bitmap" name="reflectance"><string name="filename" value="{tmp_path / "tex.png"}"/>'
    bitmap += '<string name="filter_type" value="nearest"/></texture>'
    image = volpath.render(volpath.load_string(_furnace_plane(f'<bsdf type="diffuse">{bitmap}</bsdf>')), seed=4)
    linear = _srgb_to_linear(texels / 255.0)
    for (i, j), texel in {(0, 0): (1, 0), (0, 1): (1, 1), (1, 0): (0, 0), (1, 1): (0, 1)}.items():
        q = image[i * 8 : (i + 1) * 8, j * 8 : (j + 1) * 8].reshape(-1, 3)
        se = q.std(0) / np.sqrt(len(q))
        assert np.all(np.abs(q.mean(0) - linear[texel]) <= 5 * se + 1e-3), ((i, j), q.mean(0), linear[texel])


def _scene_dict(bsdf):
    return {
        "type": "scene",
        "integrator": {"type": "volpath"},
        "sensor": {
            "type": "perspective",
            "fov": 40.0,
            "to_world": np.array([[-1.0, 0, 0, 0], [0, 1, 0, 0.3], [0, 0, -1, 4], [0, 0, 0, 1]]),
            "film": {"type": "hdrfilm", "width": 12, "height": 12},
            "sampler": {"type": "independent", "sample_count": 8},
        },
        "ball": {"type": "sphere", "bsdf": bsdf},
        "floor": {
            "type": "rectangle",
            "to_world": np.array([[3.0, 0, 0, 0], [0, 0, 3, -1], [0, -3, 0, 0], [0, 0, 0, 1]]),
            "bsdf": {"type": "diffuse"},
        },
        "sun": {"type": "directional", "direction": [0.3, -1.0, -0.2], "irradiance": 3.0},
        "sky": {"type": "constant", "radiance": 0.2},
    }


def _flat(value, channels=3):
    """A bitmap whose every texel is `value`: linear floats, looked up to exactly `value`."""
    return {"type": "bitmap", "data": np.full((3, 5, channels), value, np.float32)}


@pytest.mark.parametrize(
    "constant, textured",
    [
        ({"type": "diffuse", "reflectance": 0.25}, {"type": "diffuse", "reflectance": _flat(0.25)}),
        (
            {"type": "roughplastic", "diffuse_reflectance": 0.5, "specular_reflectance": 0.75, "alpha": 0.125},
            {
                "type": "roughplastic",
                "diffuse_reflectance": _flat(0.5),
                "specular_reflectance": _flat(0.75),
                "alpha": _flat(0.125, 1),
            },
        ),
        (
            {"type": "principled", "base_color": 0.5, "roughness": 0.5},
            {"type": "principled", "base_color": _flat(0.5), "roughness": _flat(0.5, 1)},
        ),
        (
            {"type": "principled", "base_color": 0.5, "metallic": 0.25, "roughness": 0.5},
            {"type": "principled", "base_color": 0.5, "metallic": _flat(0.25, 1), "roughness": _flat(0.5, 1)},
        ),
        (
            {"type": "roughconductor", "distribution": "ggx", "specular_reflectance": 0.5, "alpha": 0.25},
            {"type": "roughconductor", "distribution": "ggx", "specular_reflectance": _flat(0.5), "alpha": _flat(0.25)},
        ),
        (
            {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.25},
            {"type": "roughdielectric", "distribution": "ggx", "alpha": _flat(0.25, 1)},
        ),
    ],
    ids=["diffuse", "roughplastic", "principled", "principled metallic", "roughconductor", "roughdielectric"],
)
def test_a_uniform_texture_renders_the_bits_of_its_constant(constant, textured):
    """Every parameter a texture can drive, given by a texture of one value (exact in
    float32), renders the same bits as the constant: the binding puts the value where
    the constant goes (principled: roughness squared, metallic the blend's weight)."""
    a = volpath.render(volpath.load_dict(_scene_dict(constant)), seed=2)
    b = volpath.render(volpath.load_dict(_scene_dict(textured)), seed=2)
    assert np.array_equal(a, b)


def test_an_8_bit_texture_stays_8_bit_and_round_trips_through_xml(tmp_path):
    """A 1024 x 512 RGB 8-bit texture costs its bytes (within 1 %) in scene.memory; written
    to XML it becomes a PNG, and the scene read back renders the same bits."""
    rng = np.random.default_rng(1)
    texels = rng.integers(0, 256, (512, 1024, 3), dtype=np.uint8)
    d = _scene_dict({"type": "diffuse", "reflectance": {"type": "bitmap", "data": texels}})
    scene = volpath.load_dict(d)
    assert texels.nbytes <= scene.memory["textures"] <= 1.01 * texels.nbytes
    path = write_scene(d, tmp_path)
    assert (tmp_path / "textures" / "reflectance.png").exists()
    again = volpath.load_file(path)
    assert np.array_equal(volpath.render(scene, seed=3), volpath.render(again, seed=3))
    assert again.summary["textures"][0]["texel"] == "uint8"


@pytest.mark.parametrize(
    "texture, message",
    [
        ('<string name="filename" value="missing.png"/>', "file 'missing.png' not found"),
        (
            '<string name="filename" value="tex.png"/><string name="filter_type" value="cubic"/>',
            "'filter_type' is 'cubic'",
        ),
        (
            '<string name="filename" value="tex.png"/><string name="wrap_mode_u" value="clamp"/>'
            '<string name="wrap_mode_v" value="repeat"/>',
            "must agree",
        ),
        ('<string name="filename" value="bad.png"/>', "not a readable image"),
        ('<string name="filename" value="tex.png"/><float name="gamma" value="2.2"/>', "'gamma' is 2.2"),
    ],
)
def test_bad_bitmaps_are_errors_with_file_and_line(tmp_path, texture, message):
    from PIL import Image

    Image.fromarray(np.zeros((2, 2, 3), np.uint8)).save(tmp_path / "tex.png")
    (tmp_path / "bad.png").write_bytes(b"not a png")
    xml = S.scene(
        S.camera(res=4),
        f'<shape type="sphere"><bsdf type="diffuse">\n<texture type="bitmap" name="reflectance">{texture}'
        "</texture></bsdf></shape>",
    )
    (tmp_path / "s.xml").write_text(xml)
    with pytest.raises(volpath.SceneError, match=message) as e:
        volpath.load_file(tmp_path / "s.xml")
    assert "s.xml:" in str(e.value)


def test_mitsuba_0_5_bitmap_spellings(tmp_path):
    """uscale / uoffset and friends map onto to_uv; EWA filtering loads as bilinear with
    a warning naming the file and line."""
    from PIL import Image

    Image.fromarray(np.arange(12, dtype=np.uint8).reshape(2, 2, 3) * 20).save(tmp_path / "tex.png")
    xml = f"""<scene version="0.5.0">{S.camera(res=4)}<shape type="sphere"><bsdf type="diffuse">
    <texture type="bitmap" name="reflectance"><string name="filename" value="{tmp_path / "tex.png"}"/>
    <string name="filterType" value="ewa"/><float name="uscale" value="4"/><float name="voffset" value="0.25"/>
    <float name="maxAnisotropy" value="20"/></texture></bsdf></shape></scene>"""
    with pytest.warns(volpath.SceneWarning) as caught:
        scene = volpath.load_string(xml)
    messages = [str(w.message) for w in caught]
    assert any(re.search(r":\d+: texture 'bitmap': 'filter_type' ignored", m) for m in messages), messages
    assert any("'max_anisotropy' ignored" in m for m in messages), messages
    plain = _core.Scene()
    texture = plain.add_texture_bitmap(np.asarray(Image.open(tmp_path / "tex.png")), True)
    uv = np.random.default_rng(2).random((50, 2))
    expected = _probes.texture_eval(plain, texture, uv * [4, 1] + [0, 0.25])
    assert np.allclose(_probes.texture_eval(scene.native, 0, uv), expected)
