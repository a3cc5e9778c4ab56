"""The native OBJ and PLY readers (native/src/io/mesh_files.cpp): what each format says
becomes the same arrays, and bad files name the file and line."""

import numpy as np
import pytest

from volpath import SceneError
from volpath.meshes import load_mesh, write_ply

QUAD = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)


def test_obj_corners_uvs_normals_and_negative_indices(tmp_path):
    path = tmp_path / "m.obj"
    path.write_text(
        "# a quad and a triangle sharing corners\n"
        "o quad\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\ns off\nusemtl grey\n"
        "f 1/1/1 2/2/1 3/3/1 4/4/1\n"
        "f -4/-4/-1 -2/-2/-1 -1/-1/-1\n"
        "f 1/2/1 2/2/1 3/3/1\n"
    )
    m = load_mesh(str(path))
    # The second face's corners are the first's (one vertex each); the third's first corner
    # pairs vertex 1 with another vt: a fifth vertex.
    assert m.triangles.tolist() == [[0, 1, 2], [0, 2, 3], [0, 2, 3], [4, 1, 2]]
    assert np.array_equal(m.positions, np.vstack([QUAD, QUAD[:1]]))
    assert np.array_equal(m.uvs, [[0, 1], [1, 1], [1, 0], [0, 0], [1, 1]])  # v flipped
    assert np.array_equal(m.normals, np.tile([0.0, 0, 1], (5, 1)))
    assert m.triangles.dtype == np.uint32 and m.positions.dtype == np.float64


def test_obj_without_texture_coordinates_on_some_corners_has_no_uvs(tmp_path):
    path = tmp_path / "m.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.5\nf 1/1 2 3\n")
    m = load_mesh(str(path))
    assert m.uvs is None and m.normals is None and m.triangles.tolist() == [[0, 1, 2]]


def _ascii_ply(path, faces="4 0 1 2 3\n3 0 2 3\n"):
    path.write_text(
        "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 4\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n"
        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "-1 -1 0 0 0 1 0 0\n1 -1 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n-1 1 0 0 0 1 0 1\n" + faces
    )
    return path


def test_ascii_ply_reads_normals_uvs_and_polygons(tmp_path):
    m = load_mesh(str(_ascii_ply(tmp_path / "m.ply")))
    assert np.array_equal(m.positions, QUAD)
    assert np.array_equal(m.normals, np.tile([0.0, 0, 1], (4, 1)))
    assert np.array_equal(m.uvs, [[0, 0], [1, 0], [1, 1], [0, 1]])
    assert m.triangles.tolist() == [[0, 1, 2], [0, 2, 3], [0, 2, 3]]


def test_binary_ply_round_trip_of_the_exporters_writer(tmp_path):
    rng = np.random.default_rng(3)
    positions = rng.normal(size=(500, 3)).astype(np.float32)
    triangles = rng.integers(0, 500, size=(900, 3))
    normals = rng.normal(size=(500, 3)).astype(np.float32)
    uvs = rng.random((500, 2)).astype(np.float32)
    write_ply(tmp_path / "m.ply", positions, triangles, normals, uvs)
    m = load_mesh(str(tmp_path / "m.ply"))
    assert np.array_equal(m.positions, positions) and np.array_equal(m.triangles, triangles)
    assert np.array_equal(m.normals, normals) and np.array_equal(m.uvs, uvs)


BAD = {
    "obj letters": ("m.obj", "v 0 0 0\nv 1 x 0\n", r"m\.obj:2: malformed 'v' line \(expected numbers\)"),
    "obj short vertex": ("m.obj", "v 0 0\n", r"m\.obj:1: malformed 'v'"),
    "obj missing vertex": ("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n", r"m\.obj:5: face refers to a missing"),
    "obj missing normal": ("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n", r"m\.obj:4: face refers"),
    "obj index zero": ("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", r"m\.obj:4: face refers"),
    "obj two corners": ("m.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", r"m\.obj:3: a face needs at least 3 vertices"),
    "obj no faces": ("m.obj", "v 0 0 0\n", r"m\.obj: the mesh has no triangles"),
    "ply magic": ("m.ply", "plx\nend_header\n", r"m\.ply: not a PLY file"),
    "ply format": ("m.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", r"unknown PLY format"),
    "ply type": (
        "m.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
        r"m\.ply:4: unknown type of property 'x'",
    ),
    "ply no z": (
        "m.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
        r"needs properties x, y and z",
    ),
    "ply no faces": (
        "m.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
        "end_header\n0 0 0\n",
        r"needs 'vertex' and 'face' elements",
    ),
    "ply out of range": (
        "m.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        r"a face refers to a vertex that does not exist \(vertices: 3\)",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_mesh_file_names_the_file_and_line(tmp_path, case):
    name, text, pattern = BAD[case]
    (tmp_path / name).write_text(text)
    with pytest.raises(SceneError, match=pattern):
        load_mesh(str(tmp_path / name))


def test_ascii_ply_error_names_the_line_of_the_bad_number(tmp_path):
    path = _ascii_ply(tmp_path / "m.ply", faces="4 0 1 2 3\n3 0 two 3\n")
    with pytest.raises(SceneError, match=r"m\.ply:21: malformed number 'two' in element 'face'"):
        load_mesh(str(path))


def test_truncated_binary_ply_says_where_it_ends(tmp_path):
    write_ply(tmp_path / "m.ply", QUAD, [[0, 1, 2], [0, 2, 3]])
    data = (tmp_path / "m.ply").read_bytes()
    (tmp_path / "m.ply").write_bytes(data[:-5])
    with pytest.raises(SceneError, match=r"m\.ply: the file ends inside element 'face'"):
        load_mesh(str(tmp_path / "m.ply"))
