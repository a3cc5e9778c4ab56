"""A scene dictionary back to Mitsuba-style XML, with its meshes as PLY, its textures'
texels as PNG (8-bit) or EXR, and its grids as .vdb files (copies of the files they were
read from, else written sparse; see write_volume for the grids that stay a dense .vol).

The inverse of xml_reader.py for what the Blender exporter produces: ``write_scene(d,
directory)`` writes ``scene.xml`` next to ``meshes/``, ``textures/`` and ``volumes/`` so
that ``volpath.load_file`` gives the same native scene as ``volpath.load_dict(d)`` (floats
are written with ``repr``, which round-trips exactly; meshes and grids are float32 either
way, texels keep their bits).
"""

import hashlib
import os
import shutil
from xml.sax.saxutils import quoteattr

import numpy as np

from . import vdb
from .grids import write_vol
from .images import write_image
from .meshes import write_ply
from .plugins import kind_of
from .volume import VolumeGrid


def write_scene(d, directory, filename="scene.xml", by_content=False):
    """Write the scene dictionary ``d`` into ``directory``; returns the XML file's path.
    ``by_content``: meshes' and texels' files are named by what they hold, and written only
    where no file of that name is there yet, so that scenes written side by side (an
    animation's frames) share the files that stay the same."""
    return write_entries(scene_entries(d, directory, by_content), directory, filename)


def scene_entries(d, directory, by_content=False, digests=None):
    """{key: XML text} of the scene dictionary's top-level entries, their files written
    into ``directory`` (see write_scene). With ``by_content``, equal texts say the same.
    ``digests``: a dictionary kept between calls, where the content digests of arrays that
    stay the same objects (an animation's unchanged meshes) are computed once."""
    os.makedirs(directory, exist_ok=True)
    writer = _Writer(directory, by_content, {} if digests is None else digests)
    return {
        key: "\n".join(writer.entry(key, value, 1, top=True))
        for key, value in d.items()
        if key != "type" and not key.startswith("__")
    }


def write_entries(entries, directory, filename):
    """A scene file of XML entries (scene_entries'), written whole or not at all; its path."""
    path = os.path.join(directory, filename)
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write("\n".join(['<scene version="3.0.0">', *entries.values(), "</scene>"]) + "\n")
    os.replace(tmp, path)
    return path


def write_volume(volume, directory, name_for, grid):
    """Write the VolumeGrid `volume` beside a scene in `directory`, at the relative path
    name_for(extension), and return the volume plugin that reads it back: a copy of the
    .vdb it was read from, else a sparse .vdb holding it as `grid`. A .vdb grid fades to 0
    beyond its active voxels where a grid's lookups clamp at its border; a grid whose
    outermost voxels are not all 0 (and any grid, in builds without the OpenVDB module)
    is written as a dense .vol, which clamps the same way."""
    if volume.vdb:
        path, vdb_grid, to_world = volume.vdb
        rel = name_for("vdb")
        shutil.copyfile(path, os.path.join(directory, rel))
        return {"type": "vdbvolume", "filename": rel, "grid": vdb_grid, "to_world": to_world}
    if vdb.available() and _border_is_zero(volume):
        rel = name_for("vdb")
        volume.save(os.path.join(directory, rel), grid)  # placed by the file's transform
        return {"type": "vdbvolume", "filename": rel, "grid": grid, "to_world": np.eye(4)}
    rel = name_for("vol")
    write_vol(os.path.join(directory, rel), volume.numpy())
    return {"type": "gridvolume", "filename": rel, "to_world": volume.to_world}


def _border_is_zero(volume):
    """Whether the outermost voxels of a VolumeGrid are all 0 (read from its bricks)."""
    index, bricks = volume.native.brick_index, volume.native.bricks  # (bz, by, bx), (n, 8, 8, 8, c)
    stored = np.argwhere(index >= 0)
    slots = index[tuple(stored.T)]
    for axis, size in enumerate(volume.shape[:3]):  # z, y, x
        for end in (0, size - 1):
            rows = slots[stored[:, axis] == end // 8]
            if np.any(np.take(bricks[rows], end % 8, axis=axis + 1)):
                return False
    return True


def _num(v):
    return repr(float(v))


class _Writer:
    def __init__(self, directory, by_content, digests):
        self.directory = directory
        self.by_content = by_content
        self.digests = digests  # id(array) -> (array, digest): the array kept, so its id is not reused
        self.files = set()

    def asset(self, folder, name, ext, arrays=()):
        """A file's path relative to the directory; by content, named after `arrays` too."""
        os.makedirs(os.path.join(self.directory, folder), exist_ok=True)
        stem = "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "asset"
        if self.by_content and arrays:
            digest = hashlib.sha256()
            for a in arrays:
                if a is not None:
                    digest.update(self.digest(a))
            return f"{folder}/{stem}_{digest.hexdigest()[:16]}.{ext}"
        rel, i = f"{folder}/{stem}.{ext}", 1
        while rel in self.files:
            rel, i = f"{folder}/{stem}_{i}.{ext}", i + 1
        self.files.add(rel)
        return rel

    def digest(self, a):
        if id(a) not in self.digests or self.digests[id(a)][0] is not a:
            c = np.ascontiguousarray(a)
            h = hashlib.sha256(f"{c.dtype}{c.shape}".encode())
            h.update(c.tobytes())
            self.digests[id(a)] = a, h.digest()
        return self.digests[id(a)][1]

    def write(self, rel, write):
        """write(path) makes the file at rel; by content, only where it is not there yet, and
        whole or not at all (a file found there later is whole)."""
        path = os.path.join(self.directory, rel)
        if not self.by_content:
            write(path)
        elif not os.path.exists(path):
            stem, ext = os.path.splitext(path)
            tmp = f"{stem}.tmp{os.getpid()}{ext}"
            write(tmp)
            os.replace(tmp, path)

    def entry(self, key, value, depth, top=False):
        pad = "    " * depth
        name = f" name={quoteattr(key)}"
        if isinstance(value, VolumeGrid):
            stem = os.path.splitext(os.path.basename(value.vdb[0]))[0] if value.vdb else key
            content = (value.bricks, value.native.brick_index)
            value = write_volume(value, self.directory, lambda ext: self.asset("volumes", stem, ext, content), key)
        if isinstance(value, dict):
            if value.get("type") == "ref":
                return [f"{pad}<ref{name if not top else ''} id={quoteattr(value['id'])}/>"]
            if value.get("type") in ("rgb", "spectrum"):
                v = np.broadcast_to(np.asarray(value["value"], dtype=np.float64), (3,))
                return [f'{pad}<rgb{name} value="{", ".join(map(_num, v))}"/>']
            return self.obj(key, value, depth, top)
        if isinstance(value, (bool, np.bool_)):
            return [f'{pad}<boolean{name} value="{str(bool(value)).lower()}"/>']
        if isinstance(value, (int, np.integer)):
            return [f'{pad}<integer{name} value="{int(value)}"/>']
        if isinstance(value, (float, np.floating)):
            return [f'{pad}<float{name} value="{_num(value)}"/>']
        if isinstance(value, str):
            return [f"{pad}<string{name} value={quoteattr(value)}/>"]
        arr = np.asarray(value, dtype=np.float64)
        if arr.shape == (3,):
            return [f'{pad}<vector{name} value="{", ".join(map(_num, arr))}"/>']
        if arr.shape == (4, 4):
            return [
                f"{pad}<transform{name}>",
                f'{pad}    <matrix value="{" ".join(map(_num, arr.ravel()))}"/>',
                f"{pad}</transform>",
            ]
        if arr.ndim == 3 and arr.shape[1:] == (4, 4):  # motion keys, evenly spaced over the shutter
            lines = [f"{pad}<animation{name}>"]
            for k, m in enumerate(arr):
                lines += [
                    f'{pad}    <transform time="{_num(k / (len(arr) - 1))}">',
                    f'{pad}        <matrix value="{" ".join(map(_num, m.ravel()))}"/>',
                    f"{pad}    </transform>",
                ]
            return [*lines, f"{pad}</animation>"]
        raise TypeError(f"cannot write '{key}' ({type(value).__name__}) as XML")

    def obj(self, key, d, depth, top):
        pad = "    " * depth
        kind = kind_of(d)
        if kind is None:
            raise TypeError(f"'{key}': unknown plugin type {d.get('type')!r}")
        d = dict(d)
        if d["type"] == "mesh":  # arrays become a PLY file (and one a motion key, deformed)
            arrays = d.pop("positions"), d.pop("indices"), d.pop("normals", None), d.pop("uvs", None)
            rel = self.asset("meshes", key, "ply", arrays)
            self.write(rel, lambda path: write_ply(path, *arrays))
            d["type"], d["filename"] = "ply", rel
            if "motion" in d:
                keys = []
                for positions in d.pop("motion"):
                    keys.append(self.asset("meshes", f"{key}_key", "ply", (positions, arrays[1])))
                    self.write(keys[-1], lambda path, p=positions: write_ply(path, p, arrays[1]))
                d["motion"] = ", ".join(keys)
        elif d["type"] in ("bitmap", "envmap") and "data" in d:  # texels become a PNG (8-bit) or an EXR
            texels = np.asarray(d.pop("data"))
            rel = self.asset("textures", key, "png" if texels.dtype == np.uint8 else "exr", (texels,))
            self.write(rel, lambda path: write_image(path, texels if texels.ndim == 3 else texels[..., None]))
            d["filename"] = rel
        elif d["type"] == "gridvolume" and "data" in d:
            data = d.pop("data")
            rel = self.asset("volumes", key, "vol", (np.asarray(data),))
            self.write(rel, lambda path: write_vol(path, data))
            d["filename"] = rel
        attrs = f" type={quoteattr(d['type'])}"
        if top:
            attrs += f" id={quoteattr(key)}"
        elif kind in ("medium", "volume", "texture"):  # the parameter they fill
            attrs += f" name={quoteattr(key)}"
        body = []
        for k, v in d.items():
            if k != "type" and not k.startswith("__"):
                body += self.entry(k, v, depth + 1)
        if not body:
            return [f"{pad}<{kind}{attrs}/>"]
        return [f"{pad}<{kind}{attrs}>", *body, f"{pad}</{kind}>"]
