"""The sunrise pipeline: export a Blender animation once, render its frames to EXR in
parallel (a local process pool or a Dask distributed cluster), tone-map, encode a video.

One implementation, three ways in: ``python -m pipeline.sunrise`` (the bpy module),
``blender -b file.blend --python pipeline/sunrise.py -- ...`` and the add-on's
"Render Animation to Video" operator.
"""

import importlib


def sibling(name):
    """A package beside this one: ``addon`` in the repository, or inside the installed
    extension (``bl_ext.<repo>.volpath.addon``)."""
    parent = __name__.rpartition(".")[0]
    return importlib.import_module(f"{parent}.{name}" if parent else name)
