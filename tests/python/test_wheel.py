"""The wheel the Blender extension bundles is self-contained: built here, checked by
auditwheel against the manylinux policy, installed into a fresh virtual environment with
no Debian library path, and rendering."""

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
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-build-isolation", "--no-deps",
                    "-Cbuild-dir=build/wheel", "-w", str(dist), "."], cwd=ROOT, check=True, capture_output=True)
    wheel = next(dist.glob("volpath-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert any(n.startswith("volpath/_core") for n in names) and "volpath/__init__.py" in names
    show = subprocess.run([sys.executable, "-m", "auditwheel", "show", str(wheel)], capture_output=True, text=True)
    assert show.returncode == 0, show.stderr
    # auditwheel names the manylinux tag the wheel satisfies (Debian 12's glibc gives
    # manylinux_2_36) and the only system libraries it references.
    text = " ".join(show.stdout.split())
    assert re.search(r'platform tag: "manylinux_2_\d+_x86_64"', text), text
    assert set(re.findall(r"(lib[\w+-]+\.so[.\d]*) with versions", text)) <= {"libc.so.6", "libm.so.6"}, text

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    subprocess.run([str(py), "-m", "pip", "install", "-q", str(wheel)], check=True, capture_output=True)
    env = {k: v for k, v in os.environ.items() if k not in ("LD_LIBRARY_PATH", "PYTHONPATH")}
    script = ("import json, volpath, numpy as np\n"
              "s = volpath.load_string(open('s.xml').read())\n"
              "img = volpath.render(s, spp=4)\n"
              "print(json.dumps({'file': volpath._core.__file__, 'mean': float(img.mean())}))\n")
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>'
        '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>'
        '<shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter>'
        '<transform name="to_world"><translate z="5"/></transform></shape></scene>')
    r = subprocess.run([str(py), "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["file"].startswith(str(venv)) and out["mean"] > 0
