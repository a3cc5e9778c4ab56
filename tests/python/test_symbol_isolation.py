"""The native module renders the same inside Blender's symbol scope as in a clean process,
and depends on nothing outside the manylinux allow-list.

Blender's executable exports the C symbols of its libraries (Embree 4, TBB, OpenVDB,
OpenEXR, ...). Loading the bpy wheel's compiled module with RTLD_GLOBAL reproduces that
scope in a plain Python process (importing bpy does not: Python loads it RTLD_LOCAL).
"""

import glob
import os
import subprocess
import sys
import textwrap

import numpy as np

import scenes as S

bpy_spec = None
try:
    import importlib.util

    bpy_spec = importlib.util.find_spec("bpy")
except (ImportError, ValueError):
    pass

# Shared libraries every manylinux platform provides (PEP 600 allow-list, the subset a C++
# module can need).
MANYLINUX_LIBS = {
    "libc.so.6",
    "libm.so.6",
    "libpthread.so.0",
    "libdl.so.2",
    "librt.so.1",
    "libgcc_s.so.1",
    "libstdc++.so.6",
    "ld-linux-x86-64.so.2",
    "libutil.so.1",
}

SCRIPT = textwrap.dedent("""
    import ctypes, sys
    import numpy as np
    if sys.argv[1] == "blender":
        lib = ctypes.CDLL(sys.argv[2], mode=ctypes.RTLD_GLOBAL)
        # The scope really holds Blender's Embree 4 now.
        assert hasattr(ctypes.CDLL(None), "rtcIntersect1"), "Embree's symbols are not global"
    import volpath
    scene = volpath.load_string(open(sys.argv[3]).read(), base_dir=sys.argv[4])
    np.save(sys.argv[5], volpath.render(scene, spp=4, seed=11, threads=2))
""")


def bpy_module():
    if bpy_spec is None or not bpy_spec.submodule_search_locations:
        return None
    found = glob.glob(os.path.join(bpy_spec.submodule_search_locations[0], "__init__*.so"))
    return found[0] if found else None


def test_module_needs_only_manylinux_libraries():
    from volpath import _core

    out = subprocess.run(["readelf", "-d", _core.__file__], capture_output=True, text=True, check=True).stdout
    needed = {line.split("[")[1].rstrip("]") for line in out.splitlines() if "(NEEDED)" in line}
    assert needed and needed <= MANYLINUX_LIBS, needed - MANYLINUX_LIBS


def test_render_inside_blenders_symbol_scope_is_identical(tmp_path):
    """Meshes, spheres, a .vol grid and a .vdb cloud (written by Blender's OpenVDB 12)."""
    from blender_scenes import write_vdb

    from volpath.grids import write_vol
    from volpath.meshes import write_ply

    write_vol(tmp_path / "g.vol", np.random.default_rng(2).uniform(0, 3, (8, 8, 8, 3)))
    write_vdb(tmp_path / "cloud.vdb", np.random.default_rng(3).uniform(0, 4, (6, 6, 6)), voxel_size=0.1)
    p = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [0, 0, 1]], float)
    write_ply(tmp_path / "pyramid.ply", p, [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [0, 2, 1], [0, 3, 2]])
    xml = S.scene(
        S.camera(res=24, spp=4),
        '<shape type="ply"><string name="filename" value="pyramid.ply"/>'
        '<transform name="to_world"><translate x="0.8" y="-0.5"/></transform></shape>',
        '<shape type="sphere"><point name="center" value="-1, 0.5, 0"/><float name="radius" value="0.6"/></shape>',
        '<medium type="heterogeneous" id="m"><volume type="gridvolume" name="sigma_t">'
        '<string name="filename" value="g.vol"/><transform name="to_world"><translate value="-0.5"/></transform>'
        '</volume><rgb name="albedo" value="0.9, 0.7, 0.5"/></medium>',
        S.medium_cube("m", 0.5),
        '<medium type="heterogeneous" id="cloud"><volume type="vdbvolume" name="density">'
        '<string name="filename" value="cloud.vdb"/><transform name="to_world"><translate x="-1.6" y="-1"/>'
        '</transform></volume><float name="albedo" value="0.95"/></medium>',
        '<shape type="cube"><bsdf type="null"/><ref name="interior" id="cloud"/><transform name="to_world"><scale value="0.5"/>'
        '<translate x="-1.4" y="-0.8"/></transform></shape>',
        S.floor(),
        S.area_light_above(),
        S.constant_env("0.2, 0.2, 0.2"),
    )
    (tmp_path / "s.xml").write_text(xml)
    (tmp_path / "run.py").write_text(SCRIPT)
    assert bpy_module(), "the bpy wheel (requirements.txt) is missing"
    images = {}
    for mode in ("clean", "blender"):
        out = tmp_path / f"{mode}.npy"
        r = subprocess.run(
            [
                sys.executable,
                str(tmp_path / "run.py"),
                mode,
                bpy_module(),
                str(tmp_path / "s.xml"),
                str(tmp_path),
                str(out),
            ],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert r.returncode == 0, r.stderr[-2000:]
        images[mode] = np.load(out)
    assert images["clean"].max() > 0
    assert np.array_equal(images["clean"], images["blender"])
