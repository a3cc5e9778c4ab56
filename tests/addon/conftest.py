import pytest

pytest.importorskip("bpy", reason="the add-on tests need the bpy module (requirements.txt)")

from blender_scenes import blank_scene  # noqa: E402


@pytest.fixture
def blank():
    return blank_scene()
