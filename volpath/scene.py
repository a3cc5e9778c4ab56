"""The scene model: a Mitsuba-style scene dictionary turned into the native scene.

``load_file``/``load_string`` read XML into the dictionary (xml_reader.py); ``load_dict``
builds from a dictionary directly (the Blender exporter's path). Every unknown plugin or
parameter is an error that names where it came from.
"""

import math
import os

import numpy as np

from . import _core, spectral
from .errors import SceneError, where
from .meshes import load_mesh
from .volume import VolumeGrid
from .xml_reader import read_xml

TRACERS = ("absorption", "single", "multiple", "nee_mis", "null_scattering")
# lajolla's integrator `version` numbering of its staged tracers.
LAJOLLA_VERSIONS = {1: "absorption", 2: "single", 3: "multiple", 4: "nee_mis", 5: "nee_mis",
                    6: "null_scattering"}
# Mitsuba's integrators leave the choice to the scene analysis (tracer="auto"); a lajolla
# `version` names one tracer explicitly.
INTEGRATORS = {"volpath": "auto", "volpathmis": "auto", "path": "auto"}

# Named indices of refraction (Mitsuba's table, the common entries).
IOR = {"vacuum": 1.0, "air": 1.000277, "water": 1.3330, "water ice": 1.31, "fused quartz": 1.458,
       "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046,
       "sodium chloride": 1.544, "amber": 1.55, "pet": 1.575, "diamond": 2.419}

# Wavelengths (nm) at which sampled spectra are read for the R, G and B channels.
RGB_WAVELENGTHS = (680.0, 550.0, 440.0)


def rayleigh_coefficient(wavelength_nm, n=1.00029, N=2.504e25):
    """Rayleigh scattering at sea level, 8 pi^3 (n^2 - 1)^2 / (3 N lambda^4), per metre."""
    lam = np.asarray(wavelength_nm, dtype=np.float64) * 1e-9
    return 8 * math.pi ** 3 * (n * n - 1) ** 2 / (3 * N * lam ** 4)


# Atmosphere presets, in metres. Bruneton 2017 / Hillaire 2020 is the physically sound
# default; "report" reproduces the physics of the original course report.
ATMOSPHERE_PRESETS = {
    "bruneton": dict(planet_radius=6360e3, atmosphere_height=60e3,
                     rayleigh_scattering=(5.802e-6, 13.558e-6, 33.1e-6), rayleigh_height=8e3,
                     mie_scattering=3.996e-6, mie_extinction=4.440e-6, mie_height=1.2e3, g=0.8,
                     ozone=True, ozone_absorption=(0.650e-6, 1.881e-6, 0.085e-6), ground_albedo=0.1),
    "report": dict(planet_radius=6378e3, atmosphere_height=60e3,
                   rayleigh_scattering=tuple(rayleigh_coefficient(RGB_WAVELENGTHS)), rayleigh_height=8.5e3,
                   mie_scattering=3.996e-6, mie_extinction=3.996e-6 / 0.9, mie_height=1.2e3, g=0.76,
                   ozone=False, ozone_absorption=(0.0, 0.0, 0.0), ground_albedo=(0.25, 0.25, 0.35)),
}


class Scene:
    """A loaded scene: the native scene plus the file's render settings.

    Attributes: ``spp``, ``max_depth``, ``rr_depth``, ``max_null_collisions``, ``light_distances``,
    ``tracer`` (the integrator's tracer), ``width``, ``height``, ``summary`` (what the
    scene contains, for ``volpath info``), ``passes`` (in spectral mode, the scene at each
    pass's wavelengths; see volpath/spectral.py) and, after a render, ``last_render``
    (seconds, non-finite sample count, ...).
    """

    def __init__(self, native, settings, summary, source):
        self.native = native
        self.spp = settings["spp"]
        self.max_depth = settings["max_depth"]
        self.rr_depth = settings["rr_depth"]
        self.max_null_collisions = settings["max_null_collisions"]
        self.light_distances = settings["light_distances"]
        self.tracer = settings["tracer"]
        self.summary = summary
        self.source = source
        self.last_render = None
        self.passes = []  # spectral mode: one native scene per wavelength pass
        self._builder = None  # what update() rebuilds with

    @property
    def width(self):
        return self.native.width

    def update(self, d):
        """Move the scene to ``d``: the dictionary it was loaded from with its sensor or its
        sun and directional emitters replaced (an animation's next frame). Only those are
        built again; meshes, media, the BVH, and the sky map's levels while the sun stays
        within their elevations, are kept, and the image is the same bits as
        ``load_dict(d)``'s. Entries not replaced must be the same objects (as
        ``volpath.frames.frame_dictionary`` leaves them). Returns False, changing nothing,
        where ``d`` differs in anything else or the scene has spectral passes."""
        if self.passes or self._builder is None:
            return False
        spp = self._builder.update(d)
        if spp is None:
            return False
        self.spp = spp
        return True

    @property
    def height(self):
        return self.native.height

    def __repr__(self):
        return (f"<volpath.Scene {self.source or ''} {self.width}x{self.height}, spp={self.spp}, "
                f"tracer={self.tracer}, max_depth={self.max_depth}>")


def load_file(path, **params):
    """Load a Mitsuba 3 (or 0.5/0.6 / lajolla) XML scene. Keyword arguments override the
    file's ``<default>`` parameters, as ``mi.load_file`` does."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise SceneError(f"{path}: scene file not found")
    with open(path, encoding="utf-8") as f:
        text = f.read()
    d = read_xml(text, path, params)
    return load_dict(d, base_dir=os.path.dirname(os.path.abspath(path)), source=path)


def load_string(xml, base_dir=".", **params):
    """Load a scene from XML text; relative file names are resolved against base_dir."""
    d = read_xml(xml, "<string>", params)
    return load_dict(d, base_dir=base_dir, source="<string>")


def load_dict(d, base_dir=".", source=None):
    """Build a scene from a Mitsuba-style dictionary ({'type': 'scene', ...})."""
    if not isinstance(d, dict) or d.get("type") != "scene":
        raise SceneError("expected a scene dictionary with 'type': 'scene'")
    builder = _Builder(d, base_dir, source)
    scene = builder.build()
    scene._builder = builder
    if builder.spectral_passes:  # the scene again at each pass's wavelengths
        scene.passes = [_Builder(d, base_dir, source, wavelengths).build().native
                        for wavelengths in spectral.pass_wavelengths(builder.spectral_passes)]
    return scene


# ----------------------------------------------------------------------------------------
# Parameter access with bookkeeping: whatever a plugin does not read is an error.

class _Params:
    def __init__(self, d, kind, wavelengths=None):
        self.d, self.kind = d, kind
        self.wavelengths = wavelengths  # a spectral pass's three wavelengths (nm), or None: RGB
        self.loc = d.get("__loc__")
        self.type = d.get("type")
        self.read = {"type", "__loc__", "__id__", "__kind__", "__old__"}

    def error(self, msg):
        return SceneError(f"{where(self.loc)}{self.kind} '{self.type}': {msg}")

    def has(self, name):
        return name in self.d

    def raw(self, name, default=None):
        self.read.add(name)
        return self.d.get(name, default)

    def float(self, name, default=None, positive=False, minimum=None):
        v = self.raw(name, default)
        if v is None:
            raise self.error(f"missing float '{name}'")
        if isinstance(v, dict) and v.get("type") == "spectrum" and not isinstance(v["value"], list):
            v = v["value"]
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
            raise self.error(f"'{name}' must be a float, got {_describe(v)}")
        v = float(v)
        if not math.isfinite(v):
            raise self.error(f"'{name}' must be finite, got {v}")
        if positive and v <= 0:
            raise self.error(f"'{name}' must be positive, got {v}")
        if minimum is not None and v < minimum:
            raise self.error(f"'{name}' must be at least {minimum}, got {v}")
        return v

    def int(self, name, default=None):
        v = self.raw(name, default)
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise self.error(f"'{name}' must be an integer, got {_describe(v)}")
        return int(v)

    def bool(self, name, default=None):
        v = self.raw(name, default)
        if not isinstance(v, (bool, np.bool_)):
            raise self.error(f"'{name}' must be a boolean, got {_describe(v)}")
        return bool(v)

    def str(self, name, default=None, choices=None):
        v = self.raw(name, default)
        if not isinstance(v, str):
            raise self.error(f"'{name}' must be a string, got {_describe(v)}")
        if choices and v not in choices:
            raise self.error(f"'{name}' is '{v}', expected one of: {', '.join(choices)}")
        return v

    def rgb(self, name, default=None, nonnegative=True, emitted=False, spectral=True):
        """A colour; in a spectral pass, its values at the pass's wavelengths (times the
        white illuminant when `emitted`; as given when not `spectral`)."""
        v = self.raw(name, default)
        rgb = _to_rgb(v)
        if rgb is None:
            raise self.error(f"'{name}' must be a float, rgb or spectrum, got {_describe(v)}")
        if not np.all(np.isfinite(rgb)) or (nonnegative and np.any(rgb < 0)):
            raise self.error(f"'{name}' must be finite and non-negative, got {list(rgb)}")
        if self.wavelengths is not None and spectral:
            rgb = spectral_colour(rgb, self.wavelengths, emitted)
        return rgb

    def vec3(self, name, default=None):
        v = self.raw(name, default)
        arr = np.asarray(v, dtype=np.float64) if isinstance(v, (list, tuple, np.ndarray)) else None
        if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
            raise self.error(f"'{name}' must be a 3-vector, got {_describe(v)}")
        return arr

    def transform(self, name="to_world"):
        v = self.raw(name)
        if v is None:
            return np.eye(4)
        m = np.asarray(v, dtype=np.float64) if isinstance(v, (list, tuple, np.ndarray)) else None
        if m is None or m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise self.error(f"'{name}' must be a 4x4 transform")
        if abs(np.linalg.det(m[:3, :3])) < 1e-300:
            raise self.error(f"'{name}' is singular")
        return m

    def check(self):
        unknown = [k for k in self.d if k not in self.read]
        if unknown:
            raise self.error(f"unexpected parameter(s) {', '.join(repr(k) for k in unknown)}")


def _describe(v):
    if isinstance(v, dict):
        return f"a {v.get('type', 'dictionary')}"
    return repr(v)


def spectral_colour(rgb, wavelengths, emitted):
    """An RGB colour (..., 3) at a spectral pass's three wavelengths; emitters carry the
    white illuminant."""
    values = spectral.uplift(rgb, wavelengths)
    return values * spectral.white(wavelengths) if emitted else values


def _constant_grid(rgb):
    """A 1x1x1 grid of one value (one channel when grey)."""
    value = rgb[:1] if np.all(rgb == rgb[0]) else rgb
    return VolumeGrid.from_numpy(np.asarray(value, np.float32).reshape(1, 1, 1, -1))


def _is_constant(grid):
    return grid.shape[:3] == (1, 1, 1)


def _constant_rgb(grid):
    return np.broadcast_to(grid.numpy().reshape(-1), (3,)).astype(np.float64)


def _to_rgb(v):
    if isinstance(v, bool):
        return None
    if isinstance(v, (int, float, np.integer, np.floating)):
        return np.full(3, float(v))
    if isinstance(v, dict):
        if v.get("type") == "rgb":
            return np.asarray(v["value"], dtype=np.float64).reshape(3)
        if v.get("type") == "spectrum":
            s = v["value"]
            if not isinstance(s, list):
                return np.full(3, float(s))
            wl = np.array([p[0] for p in s])
            val = np.array([p[1] for p in s])
            return np.interp(RGB_WAVELENGTHS, wl, val)
    if isinstance(v, (list, tuple, np.ndarray)) and np.asarray(v).shape == (3,):
        return np.asarray(v, dtype=np.float64)
    return None


def _transform_points(m, p):
    return p @ m[:3, :3].T + m[:3, 3]


def _transform_normals(m, n):
    out = n @ np.linalg.inv(m[:3, :3])  # (M^-T n) for row vectors
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    return out / np.where(norm > 0, norm, 1)


def _rectangle():
    p = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float64)
    return p, np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)


def _cube():
    positions, triangles = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, v = [(axis + 1) % 3, (axis + 2) % 3]
            base = len(positions)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = sign, a, b
                positions.append(p)
            # counter-clockwise seen from outside
            triangles += [[base, base + 1, base + 2], [base, base + 2, base + 3]] if sign > 0 else \
                [[base, base + 2, base + 1], [base, base + 3, base + 2]]
    return np.array(positions), np.array(triangles, dtype=np.uint32)


class _Builder:
    def __init__(self, d, base_dir, source, wavelengths=None):
        self.d, self.base_dir, self.source = d, base_dir, source
        self.wavelengths = wavelengths
        self.spectral_passes = 0  # set by an atmosphere in mode="spectral"
        self.old = bool(d.get("__old__", False))
        self.native = _core.Scene()
        self.ids = {}
        self._index_ids(d)
        self.media = {}   # id(dict) -> native index
        self.bsdfs = {}
        self.building = set()
        self.summary = {"shapes": [], "media": [], "emitters": [], "camera": None}
        self.lights = {}  # top-level key of a sun or directional emitter -> (native index, summary index)
        self.medium_bounds = {}  # native medium index -> list of bounding boxes
        self.atmospheres = []    # (native medium index, centre, top radius)
        self.loc = d.get("__loc__")

    def params(self, d, kind):
        """A plugin's parameters; remembers where it is for errors found later."""
        p = _Params(d, kind, self.wavelengths)
        self.loc = p.loc
        return p

    def _index_ids(self, d):
        for k, v in d.items():
            if isinstance(v, dict) and v.get("type") != "ref":
                if "__id__" in v:
                    if v["__id__"] in self.ids:
                        raise SceneError(f"{where(v.get('__loc__'))}id '{v['__id__']}' is used twice")
                    self.ids[v["__id__"]] = v
                self._index_ids(v)
        # Top-level keys of a dictionary scene act as ids too (Mitsuba's load_dict).
        if d is self.d:
            for k, v in d.items():
                if isinstance(v, dict) and not k.startswith("__") and v.get("type") != "ref":
                    self.ids.setdefault(k, v)

    def resolve(self, v):
        seen = 0
        while isinstance(v, dict) and v.get("type") == "ref":
            if v["id"] not in self.ids:
                raise SceneError(f"{where(v.get('__loc__'))}reference to unknown id '{v['id']}'")
            v = self.ids[v["id"]]
            seen += 1
            if seen > 64:
                raise SceneError(f"{where(v.get('__loc__'))}cyclic reference")
        return v

    def path(self, p, name):
        filename = p.str(name)
        full = filename if os.path.isabs(filename) else os.path.join(self.base_dir, filename)
        if not os.path.exists(full):
            raise p.error(f"file '{filename}' not found (looked in {self.base_dir})")
        return full

    # -- top level -----------------------------------------------------------------------
    def build(self):
        return self._checked(self._build)

    def update(self, d):
        """Scene.update: the new sample count, or None where ``d`` changes more than the
        sensor and the suns and directional lights."""
        if set(d) != set(self.d):
            return None
        changed = [k for k in d if d[k] is not self.d[k]]
        for k in changed:
            kind = _kind(d[k]) if isinstance(d[k], dict) else None
            if not (kind == "sensor" or (kind == "emitter" and k in self.lights and
                                         d[k].get("type") == self.d[k].get("type"))):
                return None

        def update():
            self.d, self.ids = d, {}
            self._index_ids(d)
            for k in changed:
                if _kind(d[k]) == "sensor":
                    self.spp = self.sensor(d[k])
                else:
                    self.emitter(d[k], k)
            self.native.build()
            return self.spp

        return self._checked(update)

    def _checked(self, step):
        try:
            return step()
        except SceneError:
            raise
        except (TypeError, ValueError, KeyError, IndexError, AttributeError, OverflowError, RuntimeError) as e:
            # The native builder's checks, and whatever a malformed value slipped past.
            raise SceneError(f"{where(self.loc)}invalid scene description ({e})") from None

    def _build(self):
        scene = self.params(self.d, "scene")
        integrator, sensor = None, None
        items = [(k, v) for k, v in self.d.items() if not k.startswith("__") and k != "type"]
        for key, v in items:
            scene.read.add(key)
            if not isinstance(v, dict):
                raise SceneError(f"{where(self.d.get('__loc__'))}scene: unexpected value '{key}'")
            kind = _kind(v)
            if kind == "integrator":
                integrator = v
            elif kind == "sensor":
                if sensor is not None:
                    raise SceneError(f"{where(v.get('__loc__'))}only one sensor is supported")
                sensor = v
        # Declared media first: an atmosphere brings its own geometry, and a camera inside
        # it is inside it without saying so.
        for key, v in items:
            if _kind(v) == "medium":
                self.medium(v)
        for key, v in items:
            kind = _kind(v)
            if kind == "shape":
                self.shape(v)
            elif kind == "emitter":
                self.emitter(v, key)
            elif kind in ("bsdf", "medium", "texture", "integrator", "sensor", "phase", "volume"):
                pass  # built where referenced
            else:
                raise SceneError(f"{where(v.get('__loc__'))}unknown plugin type '{v.get('type')}'")
        settings = self.integrator(integrator)
        settings["spp"] = self.spp = self.sensor(sensor)
        # Declared BSDFs that nothing references are still checked.
        for key, v in items:
            if _kind(v) == "bsdf":
                self.bsdf(v)
        scene.check()
        self.native.build()
        self.summarise_media()
        return Scene(self.native, settings, self.summary, self.source)

    def integrator(self, d):
        settings = {"max_depth": -1, "rr_depth": 5, "max_null_collisions": 1000, "light_distances": True,
                    "tracer": "auto"}
        if d is None:
            return settings
        p = self.params(d, "integrator")
        if p.type not in INTEGRATORS:
            raise p.error(f"unknown integrator (expected one of: {', '.join(INTEGRATORS)})")
        settings["tracer"] = INTEGRATORS[p.type]
        if p.has("version"):
            version = p.int("version")
            if version not in LAJOLLA_VERSIONS:
                raise p.error(f"'version' must be 1..6 (lajolla's tracers), got {version}")
            settings["tracer"] = LAJOLLA_VERSIONS[version]
        settings["max_depth"] = p.int("max_depth", -1)
        if settings["max_depth"] < -1 or settings["max_depth"] == 0:
            raise p.error("'max_depth' must be -1 (unlimited) or at least 1")
        settings["rr_depth"] = p.int("rr_depth", 5)
        if settings["rr_depth"] < 1:
            raise p.error("'rr_depth' must be at least 1")
        settings["max_null_collisions"] = p.int("max_null_collisions", 1000)
        settings["light_distances"] = p.bool("light_distances", True)
        if p.bool("hide_emitters", False):
            raise p.error("'hide_emitters' is not supported")
        p.check()
        return settings

    def sensor(self, d):
        if d is None:
            raise SceneError(f"{self.source or '<dict>'}: the scene has no sensor (camera)")
        p = self.params(d, "sensor")
        if p.type not in ("perspective", "thinlens"):
            raise p.error("unknown sensor (expected 'perspective')")
        film = sampler = medium = None
        for key in list(d):
            v = d[key]
            if isinstance(v, dict) and key not in ("to_world",):
                r = self.resolve(v)
                k = _kind(r)
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
            fp = self.params(film, "film")
            if fp.type != "hdrfilm":
                raise fp.error("unknown film (expected 'hdrfilm')")
            width, height = fp.int("width", 768), fp.int("height", 576)
            if not (1 <= width <= 1 << 15 and 1 <= height <= 1 << 15) or width * height > 1 << 26:
                raise fp.error(f"film size {width}x{height} out of range (each side 1..32768, "
                               f"at most {1 << 26} pixels)")
            fp.raw("pixel_format"), fp.raw("component_format"), fp.raw("file_format"), fp.raw("banner")
            fp.raw("high_quality_edges")
            rfilter = None
            for key in list(film):
                if isinstance(film[key], dict) and _kind(film[key]) == "rfilter":
                    rfilter = film[key]
                    fp.read.add(key)
            if rfilter is not None:
                rp = self.params(rfilter, "rfilter")
                if rp.type not in ("box", "gaussian"):
                    raise rp.error("unknown reconstruction filter (expected 'box' or 'gaussian')")
                if rp.type == "gaussian" and rp.float("stddev", 0.5) != 0.5:
                    raise rp.error("only the default stddev 0.5 is supported")
                rp.check()
                gaussian = rp.type == "gaussian"
            fp.check()
        spp = 4
        if sampler is not None:
            sp = self.params(sampler, "sampler")
            if sp.type not in ("independent", "stratified", "multijitter", "ldsampler", "orthogonal"):
                raise sp.error("unknown sampler")
            spp = sp.int("sample_count", 4)
            sp.raw("seed"), sp.raw("jitter")
            if spp < 1:
                raise sp.error("'sample_count' must be at least 1")
            sp.check()
        to_world = p.transform()
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
        # Blender's lens shift: fractions of the larger film side, the view moving right / up
        # (camera +x points left, hence the sign).
        span = 2 * max(tx, ty)
        shift_x, shift_y = -p.float("shift_x", 0.0) * span, p.float("shift_y", 0.0) * span
        p.check()
        medium_index = self.medium(medium) if medium is not None else -1
        if medium is None:
            for index, center, top in self.atmospheres:
                if np.linalg.norm(to_world[:3, 3] - center) < top:
                    medium_index = index
        self.native.set_camera(to_world, tx, ty, width, height, near, far, medium_index, gaussian, shift_x, shift_y)
        self.summary["camera"] = {"width": width, "height": height, "fov": fov, "fov_axis": axis,
                                  "origin": to_world[:3, 3].tolist(), "medium": medium_index}
        return spp

    # -- BSDFs ---------------------------------------------------------------------------
    def bsdf(self, d, twosided=False):
        d = self.resolve(d)
        key = (id(d), twosided)
        if key in self.bsdfs:
            return self.bsdfs[key]
        if id(d) in self.building:
            raise SceneError(f"{where(d.get('__loc__'))}cyclic bsdf definition")
        self.building.add(id(d))
        p = self.params(d, "bsdf")
        n = self.native
        if p.type == "twosided":
            inner = [k for k, v in d.items() if isinstance(v, dict) and _kind(self.resolve(v)) == "bsdf"]
            if len(inner) != 1:
                raise p.error("expected exactly one nested bsdf")
            p.read.add(inner[0])
            index = self.bsdf(d[inner[0]], twosided=True)
        elif p.type == "null":
            index = n.add_bsdf_null()
        elif p.type == "diffuse":
            index = n.add_bsdf_diffuse(self.reflectance(p, "reflectance", 0.5), twosided)
        elif p.type in ("dielectric", "thindielectric"):
            if p.type == "thindielectric":
                raise p.error("thin dielectrics are not supported (use 'dielectric')")
            eta = self.ior(p, "int_ior", 1.5046) / self.ior(p, "ext_ior", 1.000277)
            p.raw("specular_reflectance"), p.raw("specular_transmittance")
            index = n.add_bsdf_dielectric(eta)
        elif p.type in ("roughplastic", "plastic"):
            dist = p.str("distribution", "ggx", ("ggx", "beckmann"))
            if dist != "ggx":
                raise p.error("only the 'ggx' distribution is supported")
            alpha = p.float("alpha", 0.1 if p.type == "roughplastic" else 0.001, minimum=0.0)
            eta = self.ior(p, "int_ior", 1.49) / self.ior(p, "ext_ior", 1.000277)
            p.raw("nonlinear"), p.raw("sample_visible")
            index = n.add_bsdf_roughplastic(self.reflectance(p, "diffuse_reflectance", 0.5),
                                            self.reflectance(p, "specular_reflectance", 1.0),
                                            max(alpha, 1e-3), eta, twosided)
        elif p.type == "principled":
            # Mapped onto the rough plastic: base colour under a GGX coat; metals tint the coat.
            base = self.reflectance(p, "base_color", 0.5)
            metallic = p.float("metallic", 0.0, minimum=0.0)
            roughness = p.float("roughness", 0.5, minimum=0.0)
            eta = p.float("eta", 1.5, positive=True)
            for ignored in ("specular", "spec_tint", "anisotropic", "sheen", "sheen_tint", "clearcoat",
                            "clearcoat_gloss", "spec_trans", "flatness"):
                p.raw(ignored)
            specular = (1 - metallic) * np.ones(3) + metallic * base
            index = n.add_bsdf_roughplastic(base * (1 - metallic), specular, max(roughness ** 2, 1e-3),
                                            eta, twosided)
        else:
            raise p.error("unknown bsdf (expected one of: null, diffuse, dielectric, roughplastic, "
                          "principled, twosided)")
        p.check()
        self.building.discard(id(d))
        self.bsdfs[key] = index
        return index

    def reflectance(self, p, name, default):
        v = p.raw(name, default)
        if isinstance(v, dict) and _kind(v) == "texture":
            raise p.error(f"textures are not supported for '{name}' (give an rgb)")
        return p.rgb(name, default)

    def ior(self, p, name, default):
        v = p.raw(name, default)
        if isinstance(v, str):
            if v.lower() not in IOR:
                raise p.error(f"unknown material '{v}' for '{name}' (expected a number or one of: {', '.join(IOR)})")
            return IOR[v.lower()]
        return p.float(name, default, positive=True)

    # -- media -----------------------------------------------------------------------------
    def phase(self, p, d):
        phases = [k for k, v in d.items() if isinstance(v, dict) and _kind(self.resolve(v)) == "phase"]
        if len(phases) > 1:
            raise p.error("more than one phase function")
        if not phases:
            return 0.0
        p.read.add(phases[0])
        pp = self.params(self.resolve(d[phases[0]]), "phase")
        if pp.type == "isotropic":
            g = 0.0
        elif pp.type == "hg":
            g = pp.float("g", 0.8)
            if not -1 < g < 1:
                raise pp.error(f"'g' must be in (-1, 1), got {g}")
        else:
            raise pp.error("unknown phase function (expected 'isotropic' or 'hg')")
        pp.check()
        return g

    def medium(self, d):
        d = self.resolve(d)
        if id(d) in self.media:
            return self.media[id(d)]
        p = self.params(d, "medium")
        g = self.phase(p, d)
        p.raw("sample_emitters"), p.raw("has_spectral_extinction")
        scale = p.float("scale", 1.0, minimum=0.0)
        if p.type == "homogeneous":
            if p.has("sigma_a") or p.has("sigma_s"):  # Mitsuba 0.5 / lajolla
                sigma_a, sigma_s = p.rgb("sigma_a", 0.0) * scale, p.rgb("sigma_s", 0.0) * scale
            else:
                sigma_t = p.rgb("sigma_t", 1.0) * scale
                albedo = p.rgb("albedo", 0.75)
                if np.any(albedo > 1):
                    raise p.error(f"'albedo' must be at most 1, got {list(albedo)}")
                sigma_s = sigma_t * albedo
                sigma_a = sigma_t - sigma_s
            Le = p.rgb("radiance", 0.0, emitted=True)
            if np.any(Le > 0) and not np.any(sigma_a > 0):
                raise p.error("'radiance' needs absorption: the medium emits sigma_a * radiance")
            index = self.native.add_medium_homogeneous(tuple(sigma_a), tuple(sigma_s), g, tuple(Le))
            self.summary["media"].append({"index": index, "type": "homogeneous", "sigma_t": (sigma_a + sigma_s).tolist(),
                                          "emissive": bool(np.any(Le > 0)),
                                          "albedo": np.divide(sigma_s, sigma_a + sigma_s, out=np.zeros(3), where=(sigma_a + sigma_s) > 0).tolist(),
                                          "g": g, "loc": p.loc})
        elif p.type == "heterogeneous":
            density = self.spectral_grid(self.volume(p, "density" if p.has("density") else "sigma_t", 1.0))
            albedo_grid = self.spectral_grid(self.volume(p, "albedo", 0.75))
            albedo = np.ones(3)
            if _is_constant(albedo_grid):
                albedo, albedo_grid = _constant_rgb(albedo_grid), None
            if max(albedo.max(), albedo_grid.max() if albedo_grid else 0) > 1:
                raise p.error("'albedo' must be at most 1")
            Le_grid, Le_scale = self.grid_emission(p)
            majorant_res = p.int("majorant_resolution", 0)
            if not 0 <= majorant_res <= 64:
                raise p.error("'majorant_resolution' must be in 0..64 (0: automatic, 1: one global majorant)")
            index = self.native.add_medium_grid(
                density.native, density.world_to_grid,
                albedo_grid=albedo_grid and albedo_grid.native,
                albedo_world_to_grid=albedo_grid and albedo_grid.world_to_grid, albedo=tuple(albedo),
                scale=scale, g=g, majorant_res=majorant_res, Le_grid=Le_grid and Le_grid.native,
                Le_world_to_grid=Le_grid and Le_grid.world_to_grid, Le_scale=tuple(Le_scale))
            self.summary["media"].append({"index": index, "type": "heterogeneous",
                                          "sigma_t_range": [density.min() * scale, density.max() * scale],
                                          "resolution": list(density.shape[2::-1]), "g": g, "loc": p.loc,
                                          "memory": density.nbytes, "emissive": bool(np.any(Le_scale > 0)),
                                          "albedo": [albedo_grid.max()] * 3 if albedo_grid else albedo.tolist()})
        elif p.type == "atmosphere":
            index = self.atmosphere(p, scale)
        else:
            raise p.error("unknown medium (expected 'homogeneous', 'heterogeneous' or 'atmosphere')")
        p.check()
        self.media[id(d)] = index
        return index

    def grid_emission(self, p):
        """(Le grid or None, Le scale) of a heterogeneous medium: `radiance` (an rgb or a
        grid), or blackbody radiance from a `temperature` grid (kelvin) times
        `blackbody_scale`. Each grid has its own placement; the medium emits sigma_a * Le."""
        from .blackbody import blackbody_rgb

        if p.has("radiance") and p.has("temperature"):
            raise p.error("give 'radiance' or 'temperature', not both")
        if p.has("temperature"):
            grid = self.volume(p, "temperature", 0.0)
            if grid.channels != 1:
                raise p.error("'temperature' must be a one-channel grid (kelvin)")
            scale = p.float("blackbody_scale", 1.0, minimum=0.0)
            Le = self.spectral_grid(grid.map(lambda t: blackbody_rgb(t[..., 0])), emitted=True)
            if _is_constant(Le):
                return None, _constant_rgb(Le) * scale
            return Le, np.full(3, scale)
        grid = self.spectral_grid(self.volume(p, "radiance", 0.0), emitted=True)
        if _is_constant(grid):
            return None, _constant_rgb(grid)
        return grid, np.ones(3)

    def spectral_grid(self, grid, emitted=False):
        """A grid's values at a spectral pass's wavelengths (as given in RGB mode)."""
        if self.wavelengths is None or (grid.channels == 1 and not emitted):
            return grid  # grey is flat
        wavelengths = self.wavelengths
        return grid.map(lambda v: spectral_colour(np.broadcast_to(v, v.shape[:-1] + (3,)), wavelengths, emitted))

    def atmosphere(self, p, scale):
        """The planet's air, its top-of-atmosphere boundary and (unless ground=false) the
        ground as a diffuse sphere. Lengths in metres times `unit` (metres per scene unit)."""
        preset = ATMOSPHERE_PRESETS[p.str("preset", "bruneton", tuple(ATMOSPHERE_PRESETS))]
        mode = p.str("mode", "rgb", ("rgb", "spectral"))
        passes = p.int("spectral_passes", 4)  # checked in RGB mode too: a scene may switch
        if not 1 <= passes <= 32:
            raise p.error("'spectral_passes' must be in 1..32 (three wavelengths each)")
        if mode == "spectral":
            self.spectral_passes = passes
        unit = p.float("unit", 1.0, positive=True)  # metres per scene unit
        R = p.float("planet_radius", preset["planet_radius"], positive=True) / unit
        H = p.float("atmosphere_height", preset["atmosphere_height"], positive=True) / unit
        center = p.vec3("center", [0.0, -R, 0.0])
        per_unit = unit * scale  # coefficients are per metre
        # Coefficients are given at 680 / 550 / 440 nm; a spectral pass takes Rayleigh's
        # lambda^-4 and ozone's band through the 550 nm value and Mie's mean (grey).
        raw = dict(spectral=False)
        rayleigh = p.rgb("rayleigh_scattering", {"type": "rgb", "value": list(preset["rayleigh_scattering"])}, **raw) * per_unit
        mie_s = p.rgb("mie_scattering", preset["mie_scattering"], **raw) * per_unit
        mie_t = p.rgb("mie_extinction", preset["mie_extinction"], **raw) * per_unit
        if np.any(mie_t < mie_s):
            raise p.error("'mie_extinction' must be at least 'mie_scattering'")
        ozone = p.bool("ozone", preset["ozone"])
        ozone_sigma = p.rgb("ozone_absorption", {"type": "rgb", "value": list(preset["ozone_absorption"])}, **raw) * per_unit
        if self.wavelengths is not None:
            rayleigh = spectral.rayleigh(rayleigh[1], self.wavelengths)
            mie_s, mie_t = np.full(3, mie_s.mean()), np.full(3, mie_t.mean())
            ozone_sigma = spectral.ozone(ozone_sigma[1], self.wavelengths)
        g = p.float("g", preset["g"])
        if not -1 < g < 1:
            raise p.error(f"'g' must be in (-1, 1), got {g}")
        h_r = p.float("rayleigh_height", preset["rayleigh_height"], positive=True) / unit
        h_m = p.float("mie_height", preset["mie_height"], positive=True) / unit
        pieces = p.int("majorant_pieces", 4)
        if not 1 <= pieces <= 16:
            raise p.error("'majorant_pieces' must be in 1..16")
        # Shadow rays to the sun: a table of optical depths, Simpson's rule, or ratio tracking.
        sun = p.str("sun_transmittance", "table", ("table", "quadrature", "tracking"))
        # Free flights: guided toward the sunlit air (transmittances by quadrature), or delta
        # tracking, which the fully unbiased sun_transmittance="tracking" implies.
        flight = p.str("free_flight", "tracking" if sun == "tracking" else "guided", ("guided", "tracking"))
        # The sky map (directions after scattering, control variates): off only to measure it.
        sky_map = p.bool("sky_map", True)
        albedo = p.rgb("ground_albedo", preset["ground_albedo"])
        if np.any(albedo > 1):
            raise p.error("'ground_albedo' must be at most 1")
        n = self.native
        index = n.add_medium_atmosphere(tuple(center), R, R + H, tuple(rayleigh), h_r, tuple(mie_s),
                                        tuple(mie_t - mie_s), h_m, g,
                                        tuple(ozone_sigma if ozone else np.zeros(3)), pieces, sun, flight, sky_map)
        n.add_sphere(tuple(center), R + H, False, n.add_bsdf_null(), interior=index, exterior=-1,
                     medium_interface=True)
        if p.bool("ground", True):
            n.add_sphere(tuple(center), R, False, n.add_bsdf_diffuse(tuple(albedo), False), interior=-1,
                         exterior=index, medium_interface=True)
        self.atmospheres.append((index, center, R + H))
        self.summary["media"].append({"index": index, "type": "atmosphere", "mode": mode, "planet_radius": R, "height": H,
                                      "sigma_t": (rayleigh + mie_t + (ozone_sigma if ozone else 0)).tolist(),
                                      "albedo": [float("nan")] * 3, "g": g, "loc": p.loc})
        return index

    def volume(self, p, name, default):
        """A volume parameter as a VolumeGrid (constants as a 1x1x1 grid)."""
        v = self.resolve(p.raw(name, default))
        if isinstance(v, VolumeGrid):  # dictionaries only: a grid built in Python
            return v
        if not isinstance(v, dict) or _kind(v) != "volume":
            rgb = _to_rgb(v)
            if rgb is None:
                raise p.error(f"'{name}' must be a volume, float or rgb")
            return _constant_grid(rgb)
        vp = self.params(v, "volume")
        if vp.type == "constvolume":
            rgb = vp.rgb("value", 1.0)
            vp.check()
            return _constant_grid(rgb)
        if vp.type not in ("gridvolume", "vdbvolume"):
            raise vp.error("unknown volume (expected 'gridvolume', 'vdbvolume' or 'constvolume')")
        to_world = vp.transform()
        if vp.type == "gridvolume" and vp.has("data"):  # dictionaries only: a (z, y, x, c) array
            data = vp.raw("data")
            vp.check()
            try:
                return VolumeGrid.from_numpy(data, to_world)
            except SceneError as e:
                raise vp.error(f"'data': {e}") from None
        filter_type = vp.str("filter_type", "trilinear", ("trilinear", "nearest"))
        if filter_type != "trilinear":
            raise vp.error("only 'trilinear' filtering is supported")
        if vp.type == "vdbvolume":
            grid = vp.str("grid", "density")
            frame = vp.int("frame", 0) if vp.has("frame") else None
            filename = vp.str("filename")
            vp.check()
            try:  # the file is looked for once the frame is in its name
                return VolumeGrid.from_file(os.path.join(self.base_dir, filename), grid, to_world, frame)
            except SceneError as e:
                raise vp.error(str(e)) from None
        path = self.path(vp, "filename")
        use_bbox = vp.bool("use_grid_bbox", self.old)
        vp.raw("raw"), vp.raw("accel")
        vp.check()
        grid = VolumeGrid.from_file(path, to_world=to_world)
        if not use_bbox:  # Mitsuba 3 places the grid's unit cube, not the file's box
            grid.to_world = to_world
        return grid

    # -- shapes ------------------------------------------------------------------------------
    def shape(self, d):
        p = self.params(d, "shape")
        to_world = p.transform()
        bsdf_index, radiance, interior, exterior, bsdf_type = None, None, -1, -1, "diffuse"
        for key, v in d.items():
            if not isinstance(v, dict) or key == "to_world":
                continue
            r = self.resolve(v)
            kind = _kind(r)
            if kind == "bsdf":
                if bsdf_index is not None:
                    raise p.error("more than one bsdf")
                bsdf_index = self.bsdf(r)
                bsdf_type = r.get("type")
            elif kind == "emitter":
                ep = self.params(r, "emitter")
                if ep.type != "area":
                    raise ep.error("only 'area' emitters can be attached to shapes")
                radiance = ep.rgb("radiance", 1.0, emitted=True)
                ep.check()
            elif kind == "medium":
                if key not in ("interior", "exterior"):
                    raise p.error(f"medium '{key}' must be named 'interior' or 'exterior'")
                if key == "interior":
                    interior = self.medium(r)
                else:
                    exterior = self.medium(r)
            else:
                continue
            p.read.add(key)
        if bsdf_index is None:
            bsdf_index = self._default_bsdf()
        medium_interface = p.has("interior") or p.has("exterior")
        common = dict(bsdf=bsdf_index, interior=interior, exterior=exterior, medium_interface=medium_interface,
                      radiance=None if radiance is None else tuple(radiance))
        flip = p.bool("flip_normals", False)
        if p.type == "sphere":
            center = _transform_points(to_world, p.vec3("center", [0, 0, 0])[None])[0]
            radius = p.float("radius", 1.0, positive=True)
            lin = to_world[:3, :3]
            scales = np.linalg.norm(lin, axis=0)
            if not np.allclose(scales, scales[0], rtol=1e-6) or not np.allclose(lin.T @ lin, np.diag(scales ** 2), atol=1e-9 * scales.max() ** 2):
                raise p.error("sphere to_world must be a similarity (uniform scale, rotation, translation)")
            radius *= scales[0]
            self.native.add_sphere(tuple(center), radius, flip, **common)
            bounds = np.array([center - radius, center + radius])
            self.summary["shapes"].append({"type": "sphere", "center": center.tolist(), "radius": radius,
                                           "emitter": radiance is not None, "bsdf": bsdf_type, "loc": p.loc})
        elif p.type == "cube" and radiance is None and np.linalg.cond(to_world[:3, :3]) < 1e12:
            # An analytic box (one primitive); emitting or flattened cubes stay meshes.
            # Under a mirroring map the mesh's faces turn inward; the box's do too.
            box_info = {k: v for k, v in common.items() if k != "radiance"}
            mirrored = np.linalg.det(to_world[:3, :3]) < 0
            self.native.add_box(to_world, np.linalg.inv(to_world), flip != mirrored, **box_info)
            corners = _transform_points(to_world, _cube()[0])
            bounds = np.array([corners.min(axis=0), corners.max(axis=0)])
            self.summary["shapes"].append({"type": "cube", "box": True, "emitter": False, "bsdf": bsdf_type,
                                           "loc": p.loc})
        else:
            normals = None
            if p.type == "rectangle":
                positions, triangles = _rectangle()
            elif p.type == "cube":
                positions, triangles = _cube()
            elif p.type in ("obj", "ply"):
                path = self.path(p, "filename")
                positions, triangles, normals = load_mesh(path)
                if p.bool("face_normals", False):
                    normals = None
            elif p.type == "mesh":  # dictionaries only: numpy arrays in memory (the exporter)
                positions, triangles, normals = self.mesh_arrays(p)
            else:
                raise p.error("unknown shape (expected one of: sphere, rectangle, cube, obj, ply, mesh)")
            positions = _transform_points(to_world, positions)
            if normals is not None:
                normals = _transform_normals(to_world, normals)
            if flip:
                triangles = triangles[:, ::-1].copy()
                if normals is not None:
                    normals = -normals
            self.native.add_mesh(positions, triangles, normals, **common)
            bounds = np.array([positions.min(axis=0), positions.max(axis=0)])
            self.summary["shapes"].append({"type": p.type, "triangles": int(len(triangles)),
                                           "emitter": radiance is not None, "bsdf": bsdf_type, "loc": p.loc})
        if interior >= 0:
            self.medium_bounds.setdefault(interior, []).append(bounds)
        if radiance is not None:
            self.summary["emitters"].append({"type": "area", "radiance": radiance.tolist(), "loc": p.loc})
        p.check()

    def mesh_arrays(self, p):
        positions = np.asarray(p.raw("positions"), dtype=np.float64)
        triangles = np.asarray(p.raw("indices"), dtype=np.int64)
        normals = p.raw("normals")
        if positions.ndim != 2 or positions.shape[1] != 3 or not np.all(np.isfinite(positions)):
            raise p.error("'positions' must be a finite (n, 3) array")
        if triangles.ndim != 2 or triangles.shape[1] != 3 or (triangles.size and (
                triangles.min() < 0 or triangles.max() >= len(positions))):
            raise p.error("'indices' must be an (m, 3) array of vertex indices")
        if normals is not None:
            normals = np.asarray(normals, dtype=np.float64)
            if normals.shape != positions.shape or not np.all(np.isfinite(normals)):
                raise p.error("'normals' must be a finite array shaped like 'positions'")
        return positions, triangles.astype(np.uint32), normals

    def _default_bsdf(self):
        key = ("default", False)
        if key not in self.bsdfs:
            self.bsdfs[key] = self.native.add_bsdf_diffuse((0.5, 0.5, 0.5), False)
        return self.bsdfs[key]

    # -- emitters ------------------------------------------------------------------------------
    def emitter(self, d, key=None):
        """Adds the emitter, or replaces the sun or directional light that was built
        under the same top-level ``key`` (Scene.update)."""
        p = self.params(d, "emitter")
        n = self.native
        info = {"type": p.type, "loc": p.loc}
        replace, position = self.lights.get(key, (-1, len(self.summary["emitters"])))
        index = None
        if p.type == "point":
            if p.has("position"):
                pos = p.vec3("position")
            else:
                pos = p.transform()[:3, 3]
            intensity = p.rgb("intensity", 1.0, emitted=True)
            n.add_point_light(tuple(pos), tuple(intensity))
            info.update(position=pos.tolist(), intensity=intensity.tolist())
        elif p.type == "directional":
            if p.has("direction"):
                direction = p.vec3("direction")
            else:
                direction = p.transform()[:3, :3] @ np.array([0.0, 0.0, 1.0])
            if np.linalg.norm(direction) == 0:
                raise p.error("'direction' must not be zero")
            irradiance = p.rgb("irradiance", 1.0, emitted=True)
            index = n.add_directional_light(tuple(direction), tuple(irradiance), replace)
            info.update(direction=(direction / np.linalg.norm(direction)).tolist(), irradiance=irradiance.tolist())
        elif p.type == "constant":
            radiance = p.rgb("radiance", 1.0, emitted=True)
            n.add_environment(tuple(radiance), None, np.eye(4), np.eye(4))
            info.update(radiance=radiance.tolist())
        elif p.type == "envmap":
            from .exr import read_exr

            path = self.path(p, "filename")
            if not path.lower().endswith(".exr"):
                raise p.error("environment maps must be OpenEXR files")
            try:
                image = read_exr(path)
            except ValueError as e:
                raise p.error(str(e)) from None
            if not np.all(np.isfinite(image)) or image.min() < 0:
                raise p.error(f"{path}: the environment map has negative or non-finite pixels")
            scale = p.float("scale", 1.0, minimum=0.0)
            to_world = p.transform()
            if self.wavelengths is not None:
                image = spectral_colour(image, self.wavelengths, emitted=True).astype(np.float32)
            n.add_environment((scale, scale, scale), image, to_world, np.linalg.inv(to_world))
            info.update(filename=path, resolution=list(image.shape[1::-1]))
        elif p.type == "sun":
            if p.has("direction"):
                direction = p.vec3("direction")
                if np.linalg.norm(direction) == 0:
                    raise p.error("'direction' must not be zero")
                to_sun = -direction / np.linalg.norm(direction)
            else:
                # Y is up; azimuth turns from -z towards +x.
                e = math.radians(p.float("elevation", 30.0))
                a = math.radians(p.float("azimuth", 0.0))
                to_sun = np.array([math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a)])
            radius = p.float("angular_radius", 0.004675, positive=True)
            if radius >= 0.5:
                raise p.error("'angular_radius' must be below 0.5 rad")
            irradiance = p.rgb("irradiance", 1.0, emitted=True)
            index = n.add_sun(tuple(to_sun), radius, tuple(irradiance), replace)
            info.update(to_sun=to_sun.tolist(), angular_radius=radius, irradiance=irradiance.tolist())
        elif p.type == "area":
            raise p.error("an area emitter must be nested inside a shape")
        else:
            raise p.error("unknown emitter (expected one of: point, directional, sun, constant, envmap, area)")
        p.raw("sampling_weight")
        p.check()
        self.summary["emitters"][position:position + 1] = [info]
        if key is not None and index is not None:
            self.lights[key] = (index, position)

    def summarise_media(self):
        for m in self.summary["media"]:
            boxes = self.medium_bounds.get(m["index"])
            if boxes:
                lo = np.min([b[0] for b in boxes], axis=0)
                hi = np.max([b[1] for b in boxes], axis=0)
                m["extent"] = float(np.linalg.norm(hi - lo))
                sig = m.get("sigma_t") or m.get("sigma_t_range")
                m["optical_thickness"] = [float(min(sig)) * m["extent"], float(max(sig)) * m["extent"]]


_KINDS = {
    "integrator": {"volpath", "volpathmis", "path"},
    "sensor": {"perspective", "thinlens"},
    "film": {"hdrfilm"},
    "sampler": {"independent", "stratified", "multijitter", "ldsampler", "orthogonal"},
    "rfilter": {"box", "gaussian", "tent"},
    "shape": {"sphere", "rectangle", "cube", "obj", "ply", "mesh", "disk", "cylinder", "serialized"},
    "bsdf": {"null", "diffuse", "dielectric", "thindielectric", "roughplastic", "plastic", "principled",
             "twosided", "conductor", "roughconductor", "roughdielectric"},
    "emitter": {"point", "directional", "sun", "constant", "envmap", "area", "spot"},
    "medium": {"homogeneous", "heterogeneous", "atmosphere"},
    "phase": {"isotropic", "hg"},
    "volume": {"gridvolume", "vdbvolume", "constvolume"},
    "texture": {"bitmap", "checkerboard"},
}


def _kind(d):
    """The plugin kind of an object dict: from the XML tag if known, else from its type."""
    if "__kind__" in d:
        return d["__kind__"]
    t = d.get("type")
    for kind, types in _KINDS.items():
        if t in types:
            return kind
    return None
