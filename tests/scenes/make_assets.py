"""Writes the corpus's binary assets (committed beside it): a density grid with a few
slightly negative voxels, as filtering leaves them; an 8-bit colour grid; a raw normal map
of ripples; a height map; a quad OBJ with texture coordinates.

    python tests/scenes/make_assets.py
"""

import os

import numpy as np
from PIL import Image

from volpath.grids import write_vol

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    z, y, x = np.mgrid[0:12, 0:12, 0:12] / 11.0
    density = np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) * 8) - 0.02  # edges dip below 0
    write_vol(os.path.join(HERE, "smoke.vol"), density.astype(np.float32), bbox=((-1, -1, -1), (1, 1, 1)))
    u, v = np.meshgrid(np.arange(32), np.arange(32))
    colours = np.stack([u * 8, v * 8, ((u // 4 + v // 4) % 2) * 200 + 30], axis=-1).astype(np.uint8)
    Image.fromarray(colours).save(os.path.join(HERE, "colours.png"))
    angle = np.sin(u / 32 * 4 * np.pi) * 0.5
    normals = np.stack([np.sin(angle), np.zeros_like(angle), np.cos(angle)], axis=-1)
    Image.fromarray(np.round((normals + 1) / 2 * 255).astype(np.uint8)).save(os.path.join(HERE, "ripples.png"))
    Image.fromarray(np.round((np.sin(u / 32 * 2 * np.pi) + 1) / 2 * 255).astype(np.uint8)).save(
        os.path.join(HERE, "heights.png")
    )
    with open(os.path.join(HERE, "quad.obj"), "w") as f:
        f.write("# a unit quad in the xz plane, facing +y, with texture coordinates\n")
        f.write("v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n")
        f.write("vt 0 0\nvt 2 0\nvt 2 2\nvt 0 2\nvn 0 1 0\n")
        f.write("f 1/1/1 4/4/1 3/3/1 2/2/1\n")


if __name__ == "__main__":
    main()
