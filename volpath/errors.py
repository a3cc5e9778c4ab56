"""Exceptions raised by Volpath."""


class SceneError(ValueError):
    """A scene could not be loaded. The message starts with ``file:line:`` when the
    problem has a place in a file, then says what was expected."""


class SceneWarning(UserWarning):
    """A scene loaded, but something in it does not mean what it says for Volpath: a
    parameter an older spelling defines that changes nothing here, negative voxels clamped.
    The message starts with ``file:line:`` (or the grid's file) as a SceneError's does; the
    loaded scene lists them in ``scene.summary["warnings"]``."""


class RenderCancelled(RuntimeError):
    """The progress callback asked to stop. ``image`` holds the pixels finished so far."""

    def __init__(self, image):
        super().__init__("render cancelled")
        self.image = image


def where(loc):
    """The ``file:line: `` prefix for a location (or nothing when it is unknown)."""
    return f"{loc}: " if loc else ""
