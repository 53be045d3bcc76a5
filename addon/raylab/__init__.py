"""raylab: see, and measure, ray-tracing acceleration structures.

The same package is the Blender add-on (bl_info, register, unregister) and the plain-Python API
(`import raylab` from /usr/bin/python3 with addon/ on sys.path). Nothing here imports bpy at import
time, so the API works outside Blender. `raylab.rays` holds the ray generators of raylab's tests, for
scripting experiments with the same rays; `raylab.animation` the deformations of the refit experiments.
"""

bl_info = {
    "name": "raylab",
    "author": "raylab developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > raylab; Render Engine: raylab",
    "description": "See and measure ray-tracing acceleration structures (AABB, octree, BVH, uniform grid)",
    "category": "Render",
}

import importlib  # noqa: E402
import sys  # noqa: E402

from . import native  # noqa: E402

if native.ERROR is None:
    from .api import *  # noqa: E402,F401,F403  the Python API (numpy in, numpy out)
elif "bpy" not in sys.modules:
    raise ImportError(native.ERROR)


def __getattr__(name):
    """`raylab.rays` (the ray generators) and `raylab.animation` (numpy only) are imported on first use
    rather than here, so that registering the add-on in Blender loads no module it does not need."""
    if name in ("rays", "animation"):
        # import_module, not `from . import rays`: that form looks the attribute up first, back in here.
        return importlib.import_module("." + name, __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def register():
    if native.ERROR is not None:  # only the message in the add-on's preferences, no traceback
        from . import native_missing
        native_missing.register()
        return
    from . import blender
    blender.register()


def unregister():
    if native.ERROR is not None:
        from . import native_missing
        native_missing.unregister()
        return
    from . import blender
    blender.unregister()
