"""The Rendered viewport's work apart from drawing (engine.py draws): the scene as the
viewport sees it, rendered progressively in a background thread.

A change restarts the rendering, and what is built again depends on the change. A new view
(orbiting, zooming, resizing) or a moved Sun lamp only replaces the sensor and the suns of
the loaded scene (Scene.update: meshes, media and the BVH stay); anything else exports the
scene again, with the triangles of every mesh whose geometry did not change taken from a
cache, and the entries that come out as they were are kept (kept_unchanged): where only
point, sun and directional lights differ (a Point lamp moved, a Sun's strength or colour),
the loaded scene is still updated, not built again. Each restart shows a quick image at a
quarter of the resolution, then adds one sample per pixel per pass at full resolution, up
to the scene's samples. Cancelling (a change, or closing the viewport) stops the pass in
flight within the renderer's cancel latency.
"""

import threading

import numpy as np

QUICK = 4  # the first image's resolution divisor


def classify(updates):
    """What the depsgraph's updates ask of the viewport: "none", "suns" (only Sun lamps
    moved) or "scene"; and the objects whose geometry changed (their meshes are exported
    again)."""
    kind, geometry = "none", set()
    for update in updates:
        idv = update.id
        if type(idv).__name__ == "Object":
            if update.is_updated_geometry:
                geometry.add(idv.name)
            sun = idv.type == "LIGHT" and idv.data.type == "SUN"
            if sun and not (update.is_updated_geometry or update.is_updated_shading):
                kind = "suns" if kind == "none" else kind
                continue
        kind = "scene"
    return kind, geometry


def kept_unchanged(old, new):
    """The scene dictionary ``new`` with each top-level entry equal to ``old``'s (values,
    arrays by content) replaced by ``old``'s own object, which is how Scene.update tells
    what changed."""
    if old is None:
        return new
    return {k: old[k] if k in old and same(old[k], v) else v for k, v in new.items()}


def same(a, b):
    """Whether two pieces of a scene dictionary are equal: dictionaries and lists item by
    item, arrays by content, numbers and strings by value, anything else only if it is the
    same object."""
    if a is b:
        return True
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (
            isinstance(a, np.ndarray)
            and isinstance(b, np.ndarray)
            and a.shape == b.shape
            and a.dtype == b.dtype
            and np.array_equal(a, b)
        )
    return type(a) is type(b) and isinstance(a, (str, int, float, bool, type(None), np.generic)) and a == b


def with_view(d, sensor, suns=None):
    """The scene dictionary ``d`` seen through ``sensor``, its sun entries' directions
    replaced by ``suns`` ({key: direction}); the entries kept are the same objects, so that
    Scene.update rebuilds only what changed."""
    d = dict(d)
    camera = dict(sensor)
    if "air" in d:  # the atmosphere needs rays hundreds of kilometres long
        camera["far_clip"] = max(camera["far_clip"], 1e9)
    d["camera"] = camera
    for key, direction in (suns or {}).items():
        d[key] = dict(d[key], direction=np.asarray(direction, dtype=np.float64))
    return d


class ViewportRender:
    """Progressive rendering of one viewport in a background thread.

    ``show(d)`` hands it a scene dictionary (with the viewport's sensor as its camera) and
    restarts; ``image()`` returns (version, RGBA float32 image, samples) of the latest
    pass, top row first; ``stop()`` ends it. ``loads`` counts the scenes built from
    scratch (the rest were updates)."""

    def __init__(self, max_samples, seed=0, threads=None):
        self.max_samples, self.seed, self.threads = max_samples, seed, threads
        self.loads = 0
        self._lock = threading.Condition()
        self._pending = None  # the dictionary to show next
        self._latest = (0, None, 0)
        self._stopping = False
        self._restart = False
        self.error = None
        self._thread = threading.Thread(target=self._run, name="volpath-viewport", daemon=True)
        self._thread.start()

    def show(self, d):
        with self._lock:
            self._pending = d
            self._restart = True
            self._lock.notify()

    def image(self):
        with self._lock:
            return self._latest

    def stop(self):
        with self._lock:
            self._stopping = self._restart = True
            self._lock.notify()
        self._thread.join()

    def _cancelled(self, fraction=None):
        return not (self._restart or self._stopping)  # False cancels the render

    def _run(self):
        import volpath

        scene = None
        while True:
            with self._lock:
                while self._pending is None and not self._stopping:
                    self._lock.wait()
                if self._stopping:
                    return
                d, self._pending, self._restart = self._pending, None, False
            try:
                if scene is None or not scene.update(d):
                    scene = volpath.load_dict(d, source="viewport")
                    self.loads += 1
                self._passes(volpath, scene, d)
            except volpath.RenderCancelled:
                continue
            except Exception as e:  # shown by the engine, never raised in Blender's UI
                self.error = f"{type(e).__name__}: {e}"

    def _passes(self, volpath, scene, d):
        film = d["camera"]["film"]
        width, height = film["width"], film["height"]
        quick = dict(
            d, camera=dict(d["camera"], film=dict(film, width=max(1, width // QUICK), height=max(1, height // QUICK)))
        )
        scene.update(quick)
        image = volpath.render(scene, spp=1, seed=self.seed, threads=self.threads, progress=self._cancelled)
        rows = np.minimum(np.arange(height) // QUICK, image.shape[0] - 1)
        cols = np.minimum(np.arange(width) // QUICK, image.shape[1] - 1)
        self._publish(image[rows][:, cols], 0)
        scene.update(d)
        total = np.zeros((height, width, 3))
        for k in range(self.max_samples):
            total += volpath.render(
                scene, spp=1, seed=self.seed + 1 + k, threads=self.threads, progress=self._cancelled
            )
            self._publish(total / (k + 1), k + 1)

    def _publish(self, image, samples):
        rgba = np.ones(image.shape[:2] + (4,), np.float32)
        rgba[..., :3] = image
        with self._lock:
            if self._restart or self._stopping:
                return
            self._latest = (self._latest[0] + 1, rgba, samples)
