"""The Blender side of Volpath, split as Cycles is: properties, ui, engine, operators, and
the export package (Blender scene -> Volpath scene)."""

from . import engine, operators, properties, ui

_MODULES = (properties, engine, operators, ui)


def register():
    for m in _MODULES:
        m.register()


def unregister():
    for m in reversed(_MODULES):
        m.unregister()
