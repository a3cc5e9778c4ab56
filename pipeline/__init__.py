"""The sunrise pipeline: render an exported animation directory's frames to EXR in
parallel (a local process pool or a Dask distributed cluster), tone-map, encode a video.

It knows no Blender: the add-on exports the directory (``addon/export/animation.py``) and
drives a ``pipeline.run.Run`` from its operator and from the command line
(``python -m addon.sunrise``, ``blender -b file.blend --python addon/sunrise.py -- ...``).
"""
