"""The wheel the Blender extension bundles is self-contained: built here, repaired by
auditwheel (which grafts the OpenVDB reader's libraries beside it) under the manylinux
policy, installed into a fresh virtual environment with no Debian library path, rendering
and reading a .vdb file. The renderer itself, volpath._core, needs nothing but libc."""

import json
import os
import re
import subprocess
import sys
import zipfile

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.xdist_group("native-build")  # shares build/wheel with the extension test
def test_wheel_is_self_contained_and_renders(tmp_path):
    dist = tmp_path / "dist"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "-q",
            "--no-build-isolation",
            "--no-deps",
            "-Cbuild-dir=build/wheel",
            "-Ccmake.define.VOLPATH_PROBES=OFF",  # as `make wheel` builds it
            "-w",
            str(dist),
            ".",
        ],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    raw = next(dist.glob("volpath-*.whl"))
    names = zipfile.ZipFile(raw).namelist()
    assert any(n.startswith("volpath/_core") for n in names) and "volpath/__init__.py" in names
    assert not any(n.startswith("volpath/_probes") for n in names)  # the tests' module stays out
    core = next(n for n in names if n.startswith("volpath/_core"))
    zipfile.ZipFile(raw).extract(core, tmp_path / "raw")
    needed = subprocess.run(["readelf", "-d", str(tmp_path / "raw" / core)], capture_output=True, text=True).stdout
    assert set(re.findall(r"NEEDED.*\[(.+)\]", needed)) <= {"libc.so.6", "libm.so.6", "ld-linux-x86-64.so.2"}, needed
    repair = subprocess.run(
        [sys.executable, "-m", "auditwheel", "repair", "-w", str(tmp_path / "repaired"), str(raw)],
        capture_output=True,
        text=True,
        env={**os.environ, "PATH": os.path.dirname(sys.executable) + os.pathsep + os.environ["PATH"]},
    )
    assert repair.returncode == 0, repair.stderr
    # Debian 12's glibc gives manylinux_2_36.
    wheel = next((tmp_path / "repaired").glob("volpath-*.whl"))
    assert re.search(r"-manylinux_2_\d+_x86_64\.whl$", wheel.name), wheel.name

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "-q", str(wheel)], check=True, capture_output=True)
    env = {k: v for k, v in os.environ.items() if k not in ("LD_LIBRARY_PATH", "PYTHONPATH")}
    write_vdb = (
        "import sys, numpy as np, bpy; sys.path.insert(0, 'tests'); from blender_scenes import write_vdb; "
        f"write_vdb({str(tmp_path / 'cloud.vdb')!r}, np.ones((4, 4, 4)))"
    )
    subprocess.run([sys.executable, "-c", write_vdb], cwd=ROOT, check=True, capture_output=True)
    script = (
        "import json, volpath, numpy as np\n"
        "s = volpath.load_string(open('s.xml').read())\n"
        "img = volpath.render(s, spp=4)\n"
        "g = volpath.VolumeGrid.from_file('cloud.vdb')\n"
        "print(json.dumps({'file': volpath._core.__file__, 'mean': float(img.mean()), 'vdb': g.max()}))\n"
    )
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>'
        '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>'
        '<shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter>'
        '<transform name="to_world"><translate z="5"/></transform></shape></scene>'
    )
    r = subprocess.run([str(py), "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["file"].startswith(str(venv)) and out["mean"] > 0 and out["vdb"] == 1.0
