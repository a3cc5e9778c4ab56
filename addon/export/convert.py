"""Blender values to scene values. Blender is Z-up; Volpath's scenes are Y-up (the
atmosphere's ground, the sun's elevation). This is the only place that knows: every
matrix and direction the exporter writes goes through here."""

import numpy as np

# (x, y, z) in Blender -> (x, z, -y) in the scene: a rotation of -90 degrees about x.
BLENDER_TO_SCENE = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def matrix(m):
    """A Blender 4x4 (mathutils.Matrix or array) as a scene to_world matrix."""
    return BLENDER_TO_SCENE @ np.array(m, dtype=np.float64).reshape(4, 4)


def point(v):
    """A Blender world point as a scene point."""
    return BLENDER_TO_SCENE[:3, :3] @ np.array(v, dtype=np.float64).reshape(3)


def direction(v):
    """A Blender world direction as a scene direction (unit length)."""
    d = BLENDER_TO_SCENE[:3, :3] @ np.array(v, dtype=np.float64).reshape(3)
    return d / np.linalg.norm(d)


def rgb(v):
    return {"type": "rgb", "value": [float(c) for c in v]}
