"""Mitsuba scene XML (3.x, and the 0.5/0.6 / lajolla spellings) to a scene dictionary.

The dictionary has the shape of Mitsuba 3's ``load_dict`` input: every object is a dict
with a ``type``; values are Python numbers, strings, 3-vectors (numpy), 4x4 matrices
(numpy) and ``{'type': 'rgb' | 'spectrum' | 'ref', ...}`` dicts. Each object also
carries ``'__loc__': 'file:line'`` so that later errors can point into the file.
"""

import math
import os
import re
from xml.parsers import expat

import numpy as np

from .errors import SceneError
from .tonemap import srgb_to_linear

_OBJECT_TAGS = {
    "scene",
    "integrator",
    "sensor",
    "sampler",
    "film",
    "rfilter",
    "shape",
    "bsdf",
    "emitter",
    "medium",
    "phase",
    "volume",
    "texture",
}
_VALUE_TAGS = {
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "srgb",
    "point",
    "vector",
    "spectrum",
    "transform",
    "animation",
    "ref",
}
_TRANSFORM_OPS = {"translate", "scale", "rotate", "lookat", "matrix"}
# Mitsuba 0.5/0.6 names that are not a plain camelCase -> snake_case rename.
_OLD_NAMES = {
    "intIOR": "int_ior",
    "extIOR": "ext_ior",
    "lookAt": "lookat",
    "lookat": "lookat",
    "sampleCount": "sample_count",
}
_PARAM = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


class _Node:
    __slots__ = ("tag", "attrs", "line", "children")

    def __init__(self, tag, attrs, line):
        self.tag, self.attrs, self.line, self.children = tag, attrs, line, []


def _parse_xml(text, filename):
    parser = expat.ParserCreate()
    stack, roots = [], []

    def start(tag, attrs):
        node = _Node(tag, attrs, parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(node)
        stack.append(node)

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    try:
        parser.Parse(text, True)
    except expat.ExpatError as e:
        raise SceneError(f"{filename}:{e.lineno}: malformed XML ({expat.errors.messages[e.code]})") from None
    return roots[0]


def _snake(name):
    if name in _OLD_NAMES:
        return _OLD_NAMES[name]
    return re.sub(r"(?<=[a-z0-9])([A-Z])", r"_\1", name).lower()


class _Reader:
    def __init__(self, params, max_include_depth=8):
        self.params = dict(params)
        self.used = set()
        self.old = False  # a 0.x scene: camelCase names, grid bounding boxes honoured
        self.include_depth = 0
        self.next_key = {}  # (id of an object's dict, base) -> the suffix unique_key tries first
        self.max_include_depth = max_include_depth
        self.auto = 0

    # -- helpers ---------------------------------------------------------------------
    def loc(self, file, node):
        return f"{file}:{node.line}"

    def fail(self, file, node, message):
        raise SceneError(f"{self.loc(file, node)}: {message}")

    def attr(self, file, node, key, required=True):
        if key not in node.attrs:
            if required:
                self.fail(file, node, f"<{node.tag}> needs the attribute '{key}'")
            return None
        value = node.attrs[key]
        if "$" not in value:
            return value

        def substitute(m):
            name = m.group(1)
            if name not in self.params:
                self.fail(file, node, f'undefined parameter ${name} (declare it with <default name="{name}" .../>)')
            self.used.add(name)
            return str(self.params[name])

        return _PARAM.sub(substitute, value)

    def floats(self, file, node, text, count, what):
        parts = text.replace(",", " ").split()
        try:
            values = list(map(float, parts))
        except ValueError:
            self.fail(file, node, f"malformed number in {what} '{text}' (expected {count} numbers)")
        if len(values) == 1 and count == 3:
            values = values * 3
        if len(values) != count:
            self.fail(file, node, f"{what} '{text}': expected {count} numbers, got {len(values)}")
        if not all(map(math.isfinite, values)):
            self.fail(file, node, f"{what} '{text}': numbers must be finite")
        return values

    def name(self, file, node):
        name = self.attr(file, node, "name")
        return _snake(name) if self.old else name

    # -- values ----------------------------------------------------------------------
    def value(self, file, node):
        tag = node.tag
        if tag == "float":
            text = self.attr(file, node, "value")
            try:
                v = float(text)
            except ValueError:
                self.fail(file, node, f"malformed number '{text}' (expected a float)")
            if not math.isfinite(v):
                self.fail(file, node, f"'{text}': expected a finite float")
            return v
        if tag == "integer":
            text = self.attr(file, node, "value")
            try:
                return int(text)
            except ValueError:
                self.fail(file, node, f"malformed integer '{text}'")
        if tag == "boolean":
            text = self.attr(file, node, "value").strip().lower()
            if text not in ("true", "false", "1", "0"):
                self.fail(file, node, f"malformed boolean '{text}' (expected true or false)")
            return text in ("true", "1")
        if tag == "string":
            return self.attr(file, node, "value")
        if tag in ("rgb", "srgb"):
            rgb = self.floats(file, node, self.attr(file, node, "value"), 3, tag)
            if tag == "srgb":  # gamma-encoded in the file
                rgb = [float(c) for c in srgb_to_linear(rgb)]
            return {"type": "rgb", "value": rgb}
        if tag == "spectrum":
            return {"type": "spectrum", "value": self.spectrum(file, node)}
        if tag in ("point", "vector"):
            if "value" in node.attrs:
                return np.array(self.floats(file, node, self.attr(file, node, "value"), 3, tag))
            xyz = [self.attr(file, node, k, required=False) or "0" for k in "xyz"]
            return np.array([self.floats(file, node, v, 1, tag)[0] for v in xyz])
        if tag == "transform":
            return self.transform(file, node)
        if tag == "animation":
            return self.animation(file, node)
        raise AssertionError(tag)

    def animation(self, file, node):
        """Mitsuba 0.6's animated transform: <transform time="..."> keys, evenly spaced from
        the shutter's opening (0) to its closing (1); a (K, 4, 4) array."""
        keys = [child for child in node.children if child.tag == "transform"]
        if len(keys) < 2 or len(keys) != len(node.children):
            self.fail(file, node, "an <animation> holds two or more <transform time=...> keys and nothing else")
        times = [self.floats(file, k, self.attr(file, k, "time"), 1, "time")[0] for k in keys]
        if not np.allclose(times, np.linspace(0, 1, len(keys)), atol=1e-6):
            self.fail(file, node, f"an <animation>'s keys must be evenly spaced from time 0 to 1, got {times}")
        return np.array([self.transform(file, k) for k in keys])

    def spectrum(self, file, node):
        if "filename" in node.attrs:
            self.fail(file, node, "spectra from files are not supported (use rgb or 'wavelength:value' pairs)")
        text = self.attr(file, node, "value")
        if ":" not in text:
            return self.floats(file, node, text, 1, "spectrum")[0]
        pairs = []
        for item in re.split(r"\s*,\s*", text.strip()):
            try:
                wl, v = item.split(":")
                pairs.append((float(wl), float(v)))
            except ValueError:
                self.fail(file, node, f"malformed spectrum entry '{item}' (expected wavelength:value)")
        return sorted(pairs)

    def transform(self, file, node):
        m = None
        for op in node.children:
            tag = _OLD_NAMES.get(op.tag, op.tag)
            if tag not in _TRANSFORM_OPS:
                self.fail(
                    file,
                    op,
                    f"unknown transform operation <{op.tag}> (expected one of {', '.join(sorted(_TRANSFORM_OPS))})",
                )
            t = self.transform_op(file, op, tag)
            m = t if m is None else t @ m
        return np.eye(4) if m is None else m

    def xyz(self, file, node, default):
        if "value" in node.attrs:
            return self.floats(file, node, self.attr(file, node, "value"), 3, node.tag)
        return [self.floats(file, node, self.attr(file, node, k, False) or str(default), 1, node.tag)[0] for k in "xyz"]

    def transform_op(self, file, op, tag):
        if tag == "matrix":
            return np.array(self.floats(file, op, self.attr(file, op, "value"), 16, "matrix")).reshape(4, 4)
        t = np.eye(4)
        if tag == "translate":
            t[:3, 3] = self.xyz(file, op, 0.0)
        elif tag == "scale":
            t[:3, :3] = np.diag(self.xyz(file, op, 1.0))
        elif tag == "rotate":
            if "axis" in op.attrs:
                axis = self.floats(file, op, self.attr(file, op, "axis"), 3, "rotate axis")
            else:
                axis = self.xyz(file, op, 0.0)
            angle = self.floats(file, op, self.attr(file, op, "angle"), 1, "rotate angle")[0]
            a = np.asarray(axis, float)
            n = np.linalg.norm(a)
            if n == 0:
                self.fail(file, op, "rotation axis must not be zero")
            a /= n
            th = math.radians(angle)
            k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            t[:3, :3] = np.eye(3) + math.sin(th) * k + (1 - math.cos(th)) * (k @ k)
        elif tag == "lookat":
            origin = np.array(self.floats(file, op, self.attr(file, op, "origin"), 3, "lookat origin"))
            target = np.array(self.floats(file, op, self.attr(file, op, "target"), 3, "lookat target"))
            up_text = self.attr(file, op, "up", required=False) or "0, 1, 0"
            up = np.array(self.floats(file, op, up_text, 3, "lookat up"))
            d = target - origin
            if np.linalg.norm(d) == 0:
                self.fail(file, op, "lookat origin and target coincide")
            d /= np.linalg.norm(d)
            left = np.cross(up, d)
            if np.linalg.norm(left) < 1e-12:
                self.fail(file, op, "lookat 'up' is parallel to the viewing direction")
            left /= np.linalg.norm(left)
            new_up = np.cross(d, left)
            t[:3, 0], t[:3, 1], t[:3, 2], t[:3, 3] = left, new_up, d, origin
        return t

    # -- objects ---------------------------------------------------------------------
    def obj(self, file, node):
        tag = node.tag
        d = {
            "type": self.attr(file, node, "type") if tag != "scene" else "scene",
            "__loc__": self.loc(file, node),
            "__kind__": tag,
        }
        if "id" in node.attrs:
            d["__id__"] = self.attr(file, node, "id")
        self.children(file, node, d)
        return d

    def children(self, file, node, d):
        for child in node.children:
            tag = _OLD_NAMES.get(child.tag, child.tag)
            if tag == "default":
                continue  # handled before the scene is read
            if tag == "include":
                self.include(file, child, d)
                continue
            if tag in _OBJECT_TAGS:
                obj = self.obj(file, child)
                if "name" in child.attrs:
                    key = self.name(file, child)
                elif "__id__" in obj and node.tag == "scene":
                    key = obj["__id__"]
                else:
                    key = self.unique_key(d, tag)
                self.put(file, child, d, key, obj)
            elif tag == "ref":
                ref = {"type": "ref", "id": self.attr(file, child, "id"), "__loc__": self.loc(file, child)}
                key = self.name(file, child) if "name" in child.attrs else self.unique_key(d, "ref")
                self.put(file, child, d, key, ref)
            elif tag in _VALUE_TAGS:
                self.put(file, child, d, self.name(file, child), self.value(file, child))
            else:
                self.fail(file, child, f"unknown element <{child.tag}>")

    def unique_key(self, d, base):
        """base, base_1, base_2, ...: the first not in d, counting on from the last one given
        (a scene of 100 000 unnamed instances would otherwise probe quadratically)."""
        i = self.next_key.get((id(d), base), 0)
        key = f"{base}_{i}" if i else base
        while key in d:
            i += 1
            key = f"{base}_{i}"
        self.next_key[id(d), base] = i + 1
        return key

    def put(self, file, node, d, key, value):
        if key in d:
            self.fail(file, node, f"'{key}' is given twice")
        d[key] = value

    def include(self, file, node, d):
        path = os.path.join(os.path.dirname(file), self.attr(file, node, "filename"))
        if self.include_depth >= self.max_include_depth:
            self.fail(file, node, f"includes nested deeper than {self.max_include_depth} (a cycle?)")
        if not os.path.exists(path):
            self.fail(file, node, f"included file '{path}' not found")
        with open(path, encoding="utf-8") as f:
            root = _parse_xml(f.read(), path)
        self.include_depth += 1
        self.children(path, root, d)
        self.include_depth -= 1


def read_xml(text, filename="<string>", params=None):
    """Parse scene XML text into a scene dictionary. ``params`` override <default>s."""
    params = {k: v for k, v in (params or {}).items()}
    root = _parse_xml(text, filename)
    if root.tag != "scene":
        raise SceneError(f"{filename}:{root.line}: expected <scene> as the root element, found <{root.tag}>")
    reader = _Reader({})
    version = root.attrs.get("version", "3.0.0")
    try:
        reader.old = int(version.split(".")[0]) < 2
    except ValueError:
        raise SceneError(f"{filename}:{root.line}: malformed scene version '{version}'") from None
    # Defaults first (any position in the file), then the caller's overrides.
    for child in root.children:
        if child.tag == "default":
            name = reader.attr(filename, child, "name")
            reader.params[name] = reader.attr(filename, child, "value")
    declared = set(reader.params)
    for k, v in params.items():
        reader.params[k] = v
    scene = reader.obj(filename, root)
    scene["__old__"] = reader.old
    unknown = [k for k in params if k not in declared and k not in reader.used]
    if unknown:
        raise SceneError(
            f"{filename}: parameter(s) {', '.join(sorted(unknown))} given, but the scene neither declares nor uses them"
        )
    return scene
