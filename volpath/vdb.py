"""OpenVDB files, read in a child process.

OpenVDB (volpath._vdb, Debian's library) trusts its input: a corrupt file can corrupt the
heap of the process reading it (the fuzzer found such files). A scene file is input, so
the grid is read by a short-lived child process that hands the bricks back through a
temporary file: a bad file costs the child, never the renderer or Blender, and OpenVDB's
libraries never load into Blender's process.
"""

import importlib.util
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

from .errors import SceneError

# A reader slower than this (seconds, plus one per 20 MB of file) is stuck on a hostile file.
TIMEOUT = 30.0
# The child imports volpath._vdb from the package directory by itself (no numpy, no package)
# and may use at most three quarters of the machine's memory: a hostile size fails there.
_CHILD = """import json, os, resource, sys
memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") * 3 // 4
resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
sys.path.insert(0, sys.argv[1])
try:
    import _vdb
    _vdb.save(*sys.argv[2:])
except ImportError as e:
    sys.exit(json.dumps({"error": "reading .vdb files needs volpath._vdb, which this build lacks "
                                  "(build it with Debian's libopenvdb-dev installed): " + str(e)}))
except (ValueError, RuntimeError, MemoryError) as e:
    sys.exit(json.dumps({"error": str(e)}))
"""


def read(path, grid):
    """The grid `grid` of the .vdb file `path` as a dict: res (x, y, z), origin (the index of
    voxel 0), index_to_world (4x4), brick_index (bz, by, bx), bricks (n, 8, 8, 8, c)."""
    what = f"{path}: grid '{grid}'"
    spec = importlib.util.find_spec("volpath._vdb")  # found, not imported (an editable install puts it apart)
    module_dir = os.path.dirname(spec.origin) if spec else os.path.dirname(os.path.abspath(__file__))
    timeout = TIMEOUT + os.path.getsize(path) / 20e6
    with tempfile.TemporaryDirectory(prefix="volpath-vdb-") as tmp:
        out = os.path.join(tmp, "grid.bin")
        try:
            r = subprocess.run([sys.executable, "-I", "-S", "-c", _CHILD, module_dir, str(path), grid, out],
                               capture_output=True, text=True, timeout=timeout, env=_child_environment())
        except subprocess.TimeoutExpired:
            raise SceneError(f"{what}: reading took longer than {timeout:.0f} s (a corrupt file?)") from None
        if r.returncode != 0:
            try:
                message = json.loads(r.stderr.strip().splitlines()[-1])["error"]
            except (ValueError, IndexError, KeyError, TypeError):
                message = (f"the reader failed (exit status {r.returncode}): the file is corrupt, or the reader "
                           f"could not run ({r.stderr.strip()[-300:]})")
            raise SceneError(f"{what}: {message}")
        return _load(out)


def _child_environment():
    """The environment without LD_PRELOAD: a preloaded sanitizer runtime (make sanitize) is
    for _core, which the child never loads, and it cannot start under the memory limit."""
    return {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}


def _load(path):
    with open(path, "rb") as f:
        if f.read(8) != b"VPVDB1\0\0":
            raise SceneError(f"{path}: not a brick file")
        ints = np.fromfile(f, "<i4", 7)
        stored = int(np.fromfile(f, "<i8", 1)[0])
        index_to_world = np.fromfile(f, "<f8", 16).reshape(4, 4)
        res, origin, channels = ints[:3], ints[3:6], int(ints[6])
        bricks = (res + 7) // 8
        index = np.fromfile(f, "<i4", int(np.prod(bricks))).reshape(bricks[::-1])
        data = np.fromfile(f, "<f4", stored * 512 * channels).reshape(stored, 8, 8, 8, channels)
    return {"res": res, "origin": origin, "index_to_world": index_to_world, "brick_index": index,
            "bricks": data}
