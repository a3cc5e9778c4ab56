"""The extension as a user gets it: `make extension` builds the zip with Blender's own
tool, Blender installs it into an empty user directory, and F12 renders through it with
the wheel inside (not the development checkout)."""

import json
import os
import subprocess
import sys
import textwrap

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

SCRIPT = textwrap.dedent("""
    import json, os, sys
    os.environ["BLENDER_USER_RESOURCES"] = sys.argv[2]
    # Hide the development checkout: only the extension may provide Volpath.
    sys.meta_path = [f for f in sys.meta_path if "editable" not in repr(f).lower()]
    sys.path = [p for p in sys.path if os.path.abspath(p or ".") != sys.argv[3]]
    import bpy
    from bl_pkg import bl_extension_cli as cli
    assert cli.cli_extension_handler(["install-file", sys.argv[1], "--repo", "user_default", "--enable"]) == 0
    import addon_utils
    addon_utils.enable("bl_ext.user_default.volpath", default_set=True)
    import volpath
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("bl_ext.user_default.volpath", default_set=True)
    scene = bpy.context.scene
    scene.render.engine = "VOLPATH"
    scene.render.resolution_x, scene.render.resolution_y = 16, 16
    scene.volpath.spp = 2
    bpy.ops.mesh.primitive_plane_add(size=4)
    bpy.ops.object.light_add(type="SUN")
    bpy.ops.object.camera_add(location=(0, 0, 5))
    scene.camera = bpy.context.object
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = os.path.join(sys.argv[2], "f12.exr")
    bpy.ops.render.render(write_still=True)
    image = volpath.read_exr(scene.render.filepath)
    from bl_ext.user_default.volpath.addon.export.animation import frame_list
    import pipeline.run  # what the video operator imports
    print(json.dumps({"volpath": volpath.__file__, "pipeline": pipeline.run.__file__,
                      "frames": frame_list(scene), "mean": float(image[..., :3].mean())}))
""")


@pytest.mark.xdist_group("native-build")  # shares build/wheel with the wheel test
def test_extension_installs_and_renders(tmp_path):
    build = subprocess.run(["make", "extension"], cwd=ROOT, capture_output=True, text=True)
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    zips = [f for f in os.listdir(os.path.join(ROOT, "dist")) if f.endswith(".zip")]
    assert zips == ["volpath-0.1.0-linux_x64.zip"]
    user = tmp_path / "user"
    user.mkdir()
    r = subprocess.run(
        [sys.executable, "-c", SCRIPT, os.path.join(ROOT, "dist", zips[0]), str(user), ROOT],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["volpath"].startswith(str(user / "extensions"))  # the bundled wheel
    assert out["pipeline"].startswith(str(user / "extensions")) and out["frames"] == list(range(1, 251))
    assert out["mean"] > 0
