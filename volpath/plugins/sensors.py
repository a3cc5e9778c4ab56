"""Sensor plugins: the perspective camera with its film, sampler and reconstruction filter."""

import math

import numpy as np

from ..errors import SceneError
from . import kind_of


def build(b, d):
    if d is None:
        raise SceneError(f"{b.source or '<dict>'}: the scene has no sensor (camera)")
    p = b.params(d, "sensor")
    if p.type not in ("perspective", "thinlens"):
        raise p.error("unknown sensor (expected 'perspective')")
    film = sampler = medium = None
    for key in list(d):
        v = d[key]
        if isinstance(v, dict) and key not in ("to_world",):
            r = b.resolve(v)
            k = kind_of(r)
            if k == "film":
                film = r
            elif k == "sampler":
                sampler = r
            elif k == "medium":
                medium = r
            else:
                continue
            p.read.add(key)
    width, height, gaussian = 768, 576, True
    if film is not None:
        fp = b.params(film, "film")
        if fp.type != "hdrfilm":
            raise fp.error("unknown film (expected 'hdrfilm')")
        width, height = fp.int("width", 768), fp.int("height", 576)
        if not (1 <= width <= 1 << 15 and 1 <= height <= 1 << 15) or width * height > 1 << 26:
            raise fp.error(f"film size {width}x{height} out of range (each side 1..32768, at most {1 << 26} pixels)")
        fp.raw("pixel_format"), fp.raw("component_format"), fp.raw("file_format"), fp.raw("banner")
        fp.raw("high_quality_edges")
        rfilter = None
        for key in list(film):
            if isinstance(film[key], dict) and kind_of(film[key]) == "rfilter":
                rfilter = film[key]
                fp.read.add(key)
        if rfilter is not None:
            rp = b.params(rfilter, "rfilter")
            if rp.type not in ("box", "gaussian"):
                raise rp.error("unknown reconstruction filter (expected 'box' or 'gaussian')")
            if rp.type == "gaussian" and rp.float("stddev", 0.5) != 0.5:
                raise rp.error("only the default stddev 0.5 is supported")
            rp.check()
            gaussian = rp.type == "gaussian"
        fp.check()
    spp = 4
    if sampler is not None:
        sp = b.params(sampler, "sampler")
        if sp.type not in ("independent", "stratified", "multijitter", "ldsampler", "orthogonal"):
            raise sp.error("unknown sampler")
        spp = sp.int("sample_count", 4)
        sp.raw("seed"), sp.raw("jitter")
        if spp < 1:
            raise sp.error("'sample_count' must be at least 1")
        sp.check()
    to_world = p.transform()
    motion = p.motion()  # over the shutter: motion blur
    if p.has("fov"):
        fov = p.float("fov")
        if not 0 < fov < 180:
            raise p.error(f"'fov' must be in (0, 180) degrees, got {fov}")
        axis = p.str("fov_axis", "x", ("x", "y", "smaller", "larger", "diagonal"))
    else:
        focal = p.str("focal_length", "50mm").rstrip("m")
        try:
            f = float(focal)
        except ValueError:
            raise p.error(f"malformed 'focal_length' {focal!r} (expected e.g. '50mm')") from None
        fov, axis = math.degrees(2 * math.atan(math.hypot(36, 24) / (2 * f))), "diagonal"
    t = math.tan(math.radians(fov) / 2)
    if axis == "smaller":
        axis = "x" if width <= height else "y"
    elif axis == "larger":
        axis = "x" if width >= height else "y"
    if axis == "x":
        tx, ty = t, t * height / width
    elif axis == "y":
        tx, ty = t * width / height, t
    else:
        diag = math.hypot(width, height)
        tx, ty = t * width / diag, t * height / diag
    near, far = p.float("near_clip", 1e-2, positive=True), p.float("far_clip", 1e4, positive=True)
    if far <= near:
        raise p.error("'far_clip' must exceed 'near_clip'")
    p.raw("shutter_open"), p.raw("shutter_close"), p.raw("principal_point_offset_x"), p.raw("principal_point_offset_y")
    if p.type == "perspective":
        p.ignored("focus_distance", "a pinhole camera has no focus")
    # Blender's lens shift: fractions of the larger film side, the view moving right / up
    # (camera +x points left, hence the sign).
    span = 2 * max(tx, ty)
    shift_x, shift_y = -p.float("shift_x", 0.0) * span, p.float("shift_y", 0.0) * span
    p.check()
    medium_index = b.medium(medium) if medium is not None else -1
    if medium is None:
        for index, center, top in b.atmospheres:
            if np.linalg.norm(to_world[:3, 3] - center) < top:
                medium_index = index
    b.native.set_camera(to_world, tx, ty, width, height, near, far, medium_index, gaussian, shift_x, shift_y, motion)
    b.summary["camera"] = {
        "width": width,
        "height": height,
        "fov": fov,
        "fov_axis": axis,
        "origin": to_world[:3, 3].tolist(),
        "medium": medium_index,
    }
    return spp
