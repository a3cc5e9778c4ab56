"""The builder the plugin kinds share (see __init__.py)."""

import os
import warnings

import numpy as np

from .. import _core
from ..errors import SceneError, SceneWarning, where
from . import bsdfs, emitters, integrators, kind_of, media, sensors, shapes
from .params import Params


class Builder:
    """Builds one native scene from a scene dictionary: the state the plugin kinds share
    and the order in which they are built."""

    def __init__(self, d, base_dir, source, wavelengths=None):
        self.d, self.base_dir, self.source = d, base_dir, source
        self.wavelengths = wavelengths
        self.spectral_passes = 0  # set by an atmosphere in mode="spectral"
        self.old = bool(d.get("__old__", False))
        self.native = _core.Scene()
        self.ids = {}
        self._index_ids(d)
        self.media = {}  # id(dict) -> native index
        self.bsdfs = {}
        self.textures = {}  # id(dict) -> native index
        self.groups = {}  # id(dict) of a shapegroup -> native index
        self.instances = []  # (group, instance dict) waiting for shapes.add_instances
        self.instance_motions = {}  # their motion keys, by native index
        # What Scene.update changes in place: id(shape dict) -> (native shape, its bsdf), and
        # id(instance dict) -> native instance.
        self.built_shapes, self.built_instances = {}, {}
        self.building = set()
        self.summary = {
            "shapes": [],
            "instances": 0,
            "media": [],
            "emitters": [],
            "bsdfs": [],
            "textures": [],
            "camera": None,
            "warnings": [],
        }
        self.lights = {}  # top-level key of an emitter -> (native index, summary index)
        self.medium_bounds = {}  # native medium index -> list of bounding boxes
        self.atmospheres = []  # (native medium index, centre, top radius)
        self.loc = d.get("__loc__")

    def params(self, d, kind):
        """A plugin's parameters; remembers where it is for errors found later."""
        p = Params(d, kind, self.wavelengths)
        self.loc = p.loc
        return p

    def _index_ids(self, d):
        for v in d.values():
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

    def path(self, p, name, filename=None):
        """The full path of file parameter `name` (or of `filename`, one of those it lists)."""
        filename = p.str(name) if filename is None else filename
        full = filename if os.path.isabs(filename) else os.path.join(self.base_dir, filename)
        if not os.path.exists(full):
            raise p.error(f"file '{filename}' not found (looked in {self.base_dir})")
        return full

    # -- top level -----------------------------------------------------------------------
    def build(self):
        """Builds the native scene; returns the render settings (the integrator's, and
        the sensor's spp). SceneWarnings go to summary["warnings"] too."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SceneWarning)
            settings = self._checked(self._build)
        for w in caught:
            if issubclass(w.category, SceneWarning):
                self.summary["warnings"].append(str(w.message))
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        return settings

    def update(self, d):
        """Scene.update: the new sample count, or None where ``d`` changes more than can be
        changed in place (_update_step), having changed nothing."""
        if set(d) != set(self.d):
            return None
        steps = []
        for k in d:
            if d[k] is not self.d[k] and not _equal(d[k], self.d[k]):
                step = self._update_step(k, self.d[k], d[k])
                if step is None:
                    return None
                steps.append(step)

        def update():
            self.d, self.ids = d, {}
            self._index_ids(d)
            for step in steps:
                step()
            self.native.build()
            return self.spp

        return self._checked(update)

    def _update_step(self, key, old, new):
        """What brings top-level entry ``key`` from ``old`` to ``new`` in place (a function
        to call), or None: the sensor; an emitter by one of its type; an instance moved; a
        shape group's meshes deformed; a shape's BSDF (a leaf without textures) given new
        parameters. A change of anything else loads the scene anew."""
        if not isinstance(new, dict) or not isinstance(old, dict) or old.get("type") != new.get("type"):
            return None
        kind = kind_of(new)
        if kind == "sensor":
            return lambda: setattr(self, "spp", sensors.build(self, new))
        if kind == "emitter" and key in self.lights:
            return lambda: emitters.build(self, new, key)
        if kind != "shape":
            return None
        if new["type"] == "instance":
            k = self.built_instances.get(id(old))
            if k is None or not _equal(old, new, but={"to_world", "motion"}):
                return None

            def move():
                p = self.params(new, "shape")
                self.native.set_instances(np.array([k]), p.transform()[None])
                if p.motion() is not None:
                    self.native.set_instance_motion(k, p.motion())
                self.built_instances[id(new)] = k

            return move
        if new["type"] == "shapegroup":
            if set(old) != set(new):
                return None
            members = [self._member_step(old[m], new[m]) for m in new if isinstance(new[m], dict)]
            return None if None in members else lambda: [step() for step in members]
        return self._member_step(old, new, mesh=False)

    def _member_step(self, old, new, mesh=True):
        """A shape given a new BSDF, or (``mesh``: a shape group's member) new mesh data."""
        built = self.built_shapes.get(id(old))
        mesh_keys = {"positions", "indices", "normals", "uvs", "filename", "motion"} if mesh else set()
        old_bsdf, new_bsdf = _bsdf_of(self, old), _bsdf_of(self, new)
        if built is None or not _equal(old, new, but=mesh_keys | {"bsdf", *_bsdf_keys(old)}):
            return None
        if new_bsdf is not old_bsdf and not _equal(new_bsdf, old_bsdf) and not _plain_bsdf(self, new_bsdf):
            return None
        shape, bsdf = built

        def step():
            if not _equal(new_bsdf, old_bsdf):
                cache, self.bsdfs = self.bsdfs, {}  # built anew, even where shapes share it
                bsdfs.build(self, new_bsdf)
                self.bsdfs = cache
                self.native.replace_bsdf(bsdf)
            if mesh_keys and not _equal(old, new, but={"bsdf", *_bsdf_keys(old)}):
                p = self.params(new, "shape")
                data = shapes.mesh_data(self, p, p.transform(), p.bool("flip_normals", False))
                self.native.set_group_mesh(shape, *data)
            self.built_shapes[id(new)] = built

        return step

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
        items = []  # (key, dict, kind)
        for key, v in self.d.items():
            if key.startswith("__") or key == "type":
                continue
            scene.read.add(key)
            if not isinstance(v, dict):
                raise SceneError(f"{where(self.d.get('__loc__'))}scene: unexpected value '{key}'")
            kind = kind_of(v)
            items.append((key, v, kind))
            if kind == "integrator":
                integrator = v
            elif kind == "sensor":
                if sensor is not None:
                    raise SceneError(f"{where(v.get('__loc__'))}only one sensor is supported")
                sensor = v
        # Declared media first: an atmosphere brings its own geometry, and a camera inside
        # it is inside it without saying so.
        for _, v, kind in items:
            if kind == "medium":
                media.build(self, v)
        for key, v, kind in items:
            if kind == "shape":
                shapes.build(self, v)
            elif kind == "emitter":
                emitters.build(self, v, key)
            elif kind in ("bsdf", "medium", "texture", "integrator", "sensor", "phase", "volume"):
                pass  # built where referenced
            else:
                raise SceneError(f"{where(v.get('__loc__'))}unknown plugin type '{v.get('type')}'")
        shapes.add_instances(self)
        settings = integrators.build(self, integrator)
        settings["spp"] = self.spp = sensors.build(self, sensor)
        # Declared BSDFs that nothing references are still checked.
        for _, v, kind in items:
            if kind == "bsdf":
                self.bsdf(v)
        scene.check()
        self.native.build()
        self.summarise_media()
        return settings

    # The plugin kinds that others refer to.
    def bsdf(self, d, twosided=False):
        return bsdfs.build(self, d, twosided)

    def medium(self, d):
        return media.build(self, d)

    def summarise_media(self):
        for m in self.summary["media"]:
            boxes = self.medium_bounds.get(m["index"])
            if boxes:
                lo = np.min([b[0] for b in boxes], axis=0)
                hi = np.max([b[1] for b in boxes], axis=0)
                m["extent"] = float(np.linalg.norm(hi - lo))
                sig = m.get("sigma_t") or m.get("sigma_t_range")
                m["optical_thickness"] = [float(min(sig)) * m["extent"], float(max(sig)) * m["extent"]]


def _equal(a, b, but=()):
    """Whether two scene entries say the same (where in a file they were read aside), but
    for the top-level keys in ``but``."""
    if a is b:
        return True
    if isinstance(a, dict) and isinstance(b, dict):
        keys = (set(a) | set(b)) - {"__loc__"} - set(but)
        return all(k in a and k in b and _equal(a[k], b[k]) for k in keys)
    if isinstance(a, (dict, str)) or isinstance(b, (dict, str)):
        return type(a) is type(b) and a == b
    try:
        return np.array_equal(np.asarray(a), np.asarray(b))
    except (TypeError, ValueError):
        return False


def _bsdf_keys(shape):
    """The keys of a shape's nested BSDF (it may be named anything)."""
    return [k for k, v in shape.items() if isinstance(v, dict) and kind_of(v) == "bsdf"]


def _bsdf_of(b, shape):
    keys = _bsdf_keys(shape)
    return b.resolve(shape[keys[0]]) if keys else None


def _plain_bsdf(b, d):
    """Whether a BSDF builds as one leaf without textures (what replace_bsdf takes)."""
    if d is None:
        return False
    nested = [b.resolve(v) for k, v in d.items() if isinstance(v, dict) and not k.startswith("__")]
    if d.get("type") == "twosided":
        return len(nested) == 1 and nested[0].get("type") != "twosided" and _plain_bsdf(b, nested[0])
    return d.get("type") not in bsdfs.LAYERS and all(v.get("type") in ("rgb", "spectrum") for v in nested)
