"""Refactoring guard (issue #36): the bench scenes and a sunrise frame render the same
bits as when tests/data/image_hashes.json was taken. A change that means to alter images
(a new estimator, a fixed bug) takes the hashes again and says so in its commit:

    python tests/pipeline/test_same_bits.py --update
"""

import hashlib
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HASHES = os.path.join(ROOT, "tests", "data", "image_hashes.json")
BENCH_SCENES = ("absorbing_sphere", "single_scattering", "dense_multiple", "thin_fog", "hetero_cube", "cloud")
SUNRISE_FRAME = 34

# One worker for the module: the first test may write the bench scenes' grids.
pytestmark = pytest.mark.xdist_group("bench-grids")


def digest(image):
    return hashlib.sha256(np.ascontiguousarray(image, dtype=np.float32).tobytes()).hexdigest()


def bench_scene(name):
    import volpath

    if not all(os.path.exists(os.path.join(ROOT, "bench", "scenes", g)) for g in ("hetero_cube.vol", "cloud.vdb")):
        # The bench scenes' grids are made by a script (seeded), not kept in git.
        subprocess.run([sys.executable, os.path.join(ROOT, "bench", "make_grids.py")], check=True, capture_output=True)
    scene = volpath.load_file(os.path.join(ROOT, "bench", "scenes", f"{name}.xml"), res=24)
    return volpath.render(scene, spp=2, seed=1, threads=2)


def sunrise_frame(tmp):
    """Frame 34 of the default sunrise, built by its script, exported by the pipeline's
    export, at 48x27 and 2 spp."""
    import bpy
    from blender_scenes import blank_scene

    from addon.export.animation import export_animation
    from pipeline.frames import render_frame

    blend = os.path.join(tmp, "sunrise.blend")
    subprocess.run(
        [sys.executable, os.path.join(ROOT, "scenes", "sunrise", "build.py"), blend], check=True, capture_output=True
    )
    blank_scene()  # registers the add-on, whose properties the .blend holds
    bpy.ops.wm.open_mainfile(filepath=blend)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 48, 27, 100
    export_animation(scene, [SUNRISE_FRAME], os.path.join(tmp, "anim"))
    return render_frame(os.path.join(tmp, "anim"), SUNRISE_FRAME, 2, threads=2)[0]


def current_hashes():
    hashes = {name: digest(bench_scene(name)) for name in BENCH_SCENES}
    with tempfile.TemporaryDirectory() as tmp:
        hashes["sunrise"] = digest(sunrise_frame(tmp))
    return hashes


@pytest.mark.parametrize("name", BENCH_SCENES)
def test_bench_scene_renders_the_recorded_bits(name):
    with open(HASHES, encoding="utf-8") as f:
        assert digest(bench_scene(name)) == json.load(f)[name]


def test_sunrise_frame_renders_the_recorded_bits(tmp_path):
    with open(HASHES, encoding="utf-8") as f:
        assert digest(sunrise_frame(str(tmp_path))) == json.load(f)["sunrise"]


if __name__ == "__main__":
    if sys.argv[1:] != ["--update"]:
        sys.exit(__doc__)
    sys.path[:0] = [ROOT, os.path.join(ROOT, "tests")]
    with open(HASHES, "w", encoding="utf-8") as f:
        json.dump(current_hashes(), f, indent=1)
        f.write("\n")
    print(f"wrote {HASHES}")
