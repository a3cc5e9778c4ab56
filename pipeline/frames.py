"""Frames of an exported animation: one scene plus, per frame, the camera, the lamps, the
grids of VDB sequences (what Blender evaluated at that frame) and the scene entries that
anything else animated changes.

An animation directory holds ``scene.xml`` (with its meshes/ and volumes/) and
``animation.json``::

    {"suns": {"<scene key>": "<Blender object>"}, "lamps": {"<scene key>": "<Blender object>"},
     "frames": [{"frame": 1, "suns": {"<Blender object>": [x, y, z]},
                 "lamps": {"<Blender object>": {emitter}}, "camera": 4x4,
                 "volumes": {"<scene key>": {"to_world": 4x4, "density": {volume}}},
                 "updates": "updates_0001.xml"}, ...],
     "animated": [{"what": "mesh 'Cube'", "changes": "placement", "from_frame": 2}, ...],
     "instanced": ["Cube"]}

``suns``: the scene's sun emitters and the Sun lamps they came from; per frame, each lamp's
direction (where its light travels, in scene coordinates) and the camera's ``to_world``
(null without a camera). ``lamps``: the point, spot and sun emitters followed frame by frame, each
frame holding the emitter as Blender evaluates the lamp there (power, colour, position,
direction). ``volumes`` only for VDB sequences: their grids at that frame, as scene-language
volumes (a ``vdbvolume``: a copy of the frame's .vdb, or an emitting volume's radiance
written sparse by volpath.xml_writer). ``animated``: what else the export found animated
(what, what changes, from which frame); a frame where any of it differs from the first
names ``updates``, a scene file holding the top-level entries of scene.xml that differ at
that frame (an instance's map, a group's deformed mesh, a shape's material, the world, a
lamp), which replace scene.xml's; or, where objects appear or vanish, ``scene``, the whole
frame's scene file. ``instanced``: the objects exported as instances of a group of their
own because they move or deform (between frames or, with motion blur, in a frame's
shutter, whose motion keys the frame's entries carry). A worker applies a frame's changes to the scene it holds
(volpath's Scene.update: in place where it can, else the frame's scene is built anew).

The Blender add-on writes the directory (``addon/export/animation.py``). ``render_frame``
is what a worker runs (a local process or a Dask worker): it needs volpath only, never
Blender. The animation arrives as a directory path or, for workers on other machines, as
the bytes of a zip of that directory.
"""

import copy
import hashlib
import io
import json
import os
import tempfile
import time
import zipfile

import numpy as np

from volpath import SceneError

ANIMATION_FILE = "animation.json"
SCENE_FILE = "scene.xml"

_cache = {}  # per worker process: animation key -> (scene dictionary, base directory, animation)
_scenes = {}  # per worker process: base directory -> the scene at the last frame rendered


def read_animation(directory):
    """The animation.json of an animation directory, checked."""
    path = os.path.join(directory, ANIMATION_FILE)
    try:
        with open(path, encoding="utf-8") as f:
            animation = json.load(f)
    except FileNotFoundError:
        raise SceneError(f"{path}: not found (export the animation first)") from None
    except json.JSONDecodeError as e:
        raise SceneError(f"{path}:{e.lineno}: malformed JSON ({e.msg})") from None
    if not isinstance(animation.get("frames"), list) or not isinstance(animation.get("suns"), dict):
        raise SceneError(f"{path}: expected 'suns' and 'frames' entries")
    return animation


def pack(directory):
    """The animation directory as zip bytes, for workers without a shared file system."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as z:
        for base, _, files in os.walk(directory):
            for name in sorted(files):
                full = os.path.join(base, name)
                z.write(full, os.path.relpath(full, directory))
    return buffer.getvalue()


def _load(source):
    """(scene dictionary, base directory, animation) for a directory or packed bytes."""
    if isinstance(source, (bytes, bytearray)):
        key = hashlib.sha256(source).hexdigest()
        if key not in _cache:
            directory = tempfile.mkdtemp(prefix=f"volpath-anim-{key[:12]}-")
            with zipfile.ZipFile(io.BytesIO(source)) as z:
                z.extractall(directory)
            _cache[key] = _read_scene(directory, SCENE_FILE), directory, read_animation(directory)
        return _cache[key]
    directory = os.path.abspath(os.fspath(source))
    path = os.path.join(directory, SCENE_FILE)
    key = (path, os.path.getmtime(path) if os.path.exists(path) else None)
    if key not in _cache:
        _cache[key] = _read_scene(directory, SCENE_FILE), directory, read_animation(directory)
    return _cache[key]


def _read_scene(directory, filename):
    """The scene dictionary of a scene file in the animation directory."""
    from volpath.xml_reader import read_xml

    path = os.path.join(directory, filename)
    if not os.path.exists(path):
        raise SceneError(f"{path}: not found")
    with open(path, encoding="utf-8") as f:
        return read_xml(f.read(), path)


def film_shape(directory):
    """(height, width, 3): the image shape of the exported animation's frames."""
    d, _, _ = _load(directory)
    film = next(v for v in d["camera"].values() if isinstance(v, dict) and v.get("type") == "hdrfilm")
    return int(film["height"]), int(film["width"]), 3


def frame_dictionary(d, animation, entry):
    """The scene dictionary at one frame: lamps, sun directions and camera from ``entry``."""
    d = copy.copy(d)  # shallow: only the entries replaced below are copied
    for key, obj_name in animation.get("lamps", {}).items():
        if key not in d:
            raise SceneError(f"animation: lamp '{key}' is not in the scene")
        if obj_name in entry.get("lamps", {}):
            lamp = entry["lamps"][obj_name]
            d[key] = {k: np.asarray(v, dtype=np.float64) if isinstance(v, list) else v for k, v in lamp.items()}
    for key, obj_name in animation["suns"].items():
        if key not in d:
            raise SceneError(f"animation: sun '{key}' is not in the scene")
        if obj_name in entry["suns"]:
            d[key] = dict(d[key], direction=np.asarray(entry["suns"][obj_name], dtype=np.float64))
    if entry.get("camera") is not None:
        d["camera"] = dict(d["camera"], to_world=np.asarray(entry["camera"], dtype=np.float64))
    for key, grids in entry.get("volumes", {}).items():  # VDB sequences: this frame's grids
        if key not in d:
            raise SceneError(f"animation: volume '{key}' is not in the scene")
        interior = dict(d[key]["interior"])
        for grid in ("density", "radiance"):
            interior.pop(grid, None)
            if grid in grids:
                interior[grid] = dict(grids[grid], to_world=np.asarray(grids[grid]["to_world"], dtype=np.float64))
        d[key] = dict(d[key], interior=interior, to_world=np.asarray(grids["to_world"], dtype=np.float64))
    return d


def _whole_frame(directory, filename):
    """A frame's own scene file, loaded (the frames' usual scene stays cached as it is)."""
    from volpath import load_dict

    return load_dict(_read_scene(directory, filename), base_dir=directory, source=os.path.join(directory, filename))


def _with_updates(d, directory, entry):
    """The scene dictionary with the frame's updates file's entries in place of its own."""
    if "updates" not in entry:
        return d
    updates = _read_scene(directory, entry["updates"])
    return {**d, **{k: v for k, v in updates.items() if k != "type" and not k.startswith("__")}}


def render_frame(source, frame, spp, tracer="auto", seed=None, threads=None, target_error=None, denoise=False):
    """Render one frame; returns (image, metadata). The seed defaults to the frame number,
    so a frame is the same bits wherever and however often it is rendered. With
    ``target_error`` the frame renders to that display error and ``spp`` is the cap;
    ``denoise`` passes it through Intel Open Image Denoise."""
    from volpath import __version__, load_dict, render

    d, directory, animation = _load(source)
    entries = [e for e in animation["frames"] if e["frame"] == frame]
    if not entries:
        raise SceneError(f"frame {frame} is not in the exported animation")
    entry = entries[0]
    start = time.perf_counter()
    built = True
    if "scene" in entry:  # exported whole: objects appear or vanish
        scene = _whole_frame(directory, entry["scene"])
    else:
        # A worker builds the scene once; the frames after it change it in place
        # (Scene.update), unless more changes than it can (a VDB sequence's grids).
        frame_d = frame_dictionary(_with_updates(d, directory, entry), animation, entry)
        scene = _scenes.get(directory)
        built = scene is None or not scene.update(frame_d)
        if built:
            scene = _scenes[directory] = load_dict(frame_d, base_dir=directory)
    scene.source = f"frame {frame}"
    image = render(
        scene,
        spp=spp,
        seed=frame if seed is None else seed,
        threads=threads,
        tracer=tracer,
        target_error=target_error,
        denoise=denoise,
    )
    stats = scene.last_render
    sun = next(iter(entry["suns"].values()), None)
    metadata = {
        "frame": int(frame),
        "spp": int(stats["spp"]),
        "tracer": stats["tracer"],
        "seed": int(stats["seed"]),
        "seconds": float(time.perf_counter() - start),
        "render_seconds": float(stats["seconds"]),
        "nonfinite_samples": int(stats["nonfinite_samples"]),
        "negative_samples": int(stats["negative_samples"]),
        "volpath_version": __version__,
        "denoised": int(bool(denoise)),
        "scene_built": int(built),  # 0: the worker's scene updated in place
    }
    if target_error is not None:
        metadata.update(
            target_error=float(target_error),
            error=float(stats["error"]),
            spp_cap=int(spp),
            spp_mean=float(stats["spp_mean"]),
        )
    if sun is not None:
        metadata["sun_direction"] = np.asarray(sun, dtype=np.float64)
    return image, metadata
