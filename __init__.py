"""Volpath as a Blender extension: the repository root is the extension's root.

Blender imports this package as ``bl_ext.<repository>.volpath``; the render engine, its
panels and the exporter live in ``addon/``. The native module comes from the bundled
wheel (blender_manifest.toml); where no wheel fits the platform, registration stops with
a message that says so instead of a traceback.
"""

import platform
import sys


def _native_available():
    try:
        import volpath._core  # noqa: F401  (the import is the check)
    except ImportError as e:
        return str(e)
    return None


def register():
    problem = _native_available()
    if problem is not None:
        raise RuntimeError(
            f"Volpath: the native renderer is not available for this platform ({platform.system()} "
            f"{platform.machine()}, Python {sys.version_info.major}.{sys.version_info.minor}): {problem}. "
            "The extension ships a wheel for Linux x86_64 (glibc 2.36 or newer); build one with `make wheel`."
        )
    from .addon import register as register_addon

    register_addon()


def unregister():
    from .addon import unregister as unregister_addon

    unregister_addon()
