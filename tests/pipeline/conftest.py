import pytest

pytest.importorskip("bpy", reason="the pipeline tests need the bpy module (requirements.txt)")
