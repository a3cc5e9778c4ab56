"""OpenVDB files, read and written in a child process.

OpenVDB (volpath._vdb, Debian's library) trusts its input: a corrupt file can corrupt the
heap of the process reading it (the fuzzer found such files). A scene file is input, so
the grid is read by a short-lived child process that hands the bricks back through a
temporary file: a bad file costs the child, never the renderer or Blender, and OpenVDB's
libraries never load into Blender's process. Writing goes the same way, in reverse.
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
    getattr(_vdb, sys.argv[2])(*sys.argv[3:])
except ImportError as e:
    sys.exit(json.dumps({"error": ".vdb files need volpath._vdb, which this build lacks "
                                  "(build it with Debian's libopenvdb-dev installed): " + str(e)}))
except (ValueError, RuntimeError, MemoryError) as e:
    sys.exit(json.dumps({"error": str(e)}))
"""


def available():
    """Whether this build has the OpenVDB module (Debian's libopenvdb-dev at build time)."""
    return _module_dir() is not None


def _module_dir():
    spec = importlib.util.find_spec("volpath._vdb")  # found, not imported (an editable install puts it apart)
    return os.path.dirname(spec.origin) if spec else None


def _run(function, args, what, timeout):
    """_vdb.function(*args) in a child process; a failure raises SceneError(what: why)."""
    module_dir = _module_dir() or os.path.dirname(os.path.abspath(__file__))
    try:
        r = subprocess.run(
            [sys.executable, "-I", "-S", "-c", _CHILD, module_dir, function, *map(str, args)],
            capture_output=True,
            text=True,
            timeout=timeout,
            env=_child_environment(),
        )
    except subprocess.TimeoutExpired:
        raise SceneError(f"{what}: took longer than {timeout:.0f} s (a corrupt file?)") from None
    if r.returncode != 0:
        try:
            message = json.loads(r.stderr.strip().splitlines()[-1])["error"]
        except (ValueError, IndexError, KeyError, TypeError):
            message = (
                f"OpenVDB failed (exit status {r.returncode}): the file is corrupt, or the child process "
                f"could not run ({r.stderr.strip()[-300:]})"
            )
        raise SceneError(f"{what}: {message}")


def read(path, grid):
    """The grid `grid` of the .vdb file `path` as a dict: res (x, y, z), origin (the index of
    voxel 0), index_to_world (4x4), brick_index (bz, by, bx), bricks (n, 8, 8, 8, c)."""
    timeout = TIMEOUT + os.path.getsize(path) / 20e6
    with tempfile.TemporaryDirectory(prefix="volpath-vdb-") as tmp:
        out = os.path.join(tmp, "grid.bin")
        _run("save", [path, grid, out], f"{path}: grid '{grid}'", timeout)
        return _load(out)


def write(path, grid, d):
    """Write the dict `d` (as read() returns) as the .vdb file `path` holding one fog-volume
    grid named `grid`: its non-zero voxels active, placed by index_to_world."""
    with tempfile.TemporaryDirectory(prefix="volpath-vdb-") as tmp:
        bricks = os.path.join(tmp, "grid.bin")
        _dump(bricks, d)
        _run("write", [bricks, grid, path], f"{path}: grid '{grid}'", TIMEOUT + os.path.getsize(bricks) / 20e6)


def _child_environment():
    """The environment without LD_PRELOAD: a preloaded sanitizer runtime (make sanitize) is
    for _core, which the child never loads, and it cannot start under the memory limit."""
    return {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}


def _dump(path, d):
    data = np.ascontiguousarray(d["bricks"], dtype="<f4")
    with open(path, "wb") as f:
        f.write(b"VPVDB1\0\0")
        np.asarray([*d["res"], *d["origin"], data.shape[-1]], "<i4").tofile(f)
        np.asarray([data.shape[0]], "<i8").tofile(f)
        np.asarray(d["index_to_world"], "<f8").reshape(16).tofile(f)
        np.ascontiguousarray(d["brick_index"], dtype="<i4").tofile(f)
        data.tofile(f)


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
    return {"res": res, "origin": origin, "index_to_world": index_to_world, "brick_index": index, "bricks": data}
