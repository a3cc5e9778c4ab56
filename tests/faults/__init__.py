"""Fault injection for tests whose work runs in other processes (see sitecustomize.py)."""

import os

HERE = os.path.dirname(os.path.abspath(__file__))


def environment(frames):
    """Environment variables under which ``frames`` fail to render in every new process."""
    path = os.pathsep.join(p for p in (HERE, os.environ.get("PYTHONPATH", "")) if p)
    return {"PYTHONPATH": path, "VOLPATH_TEST_FAIL_FRAMES": ",".join(map(str, frames))}
