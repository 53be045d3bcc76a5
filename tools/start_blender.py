"""Started by `./raylab blender`: loads the raylab add-on from this checkout into an interactive Blender.

Blender runs this file at start-up (`blender --python tools/start_blender.py`); the add-on is imported
from addon/ and registered, and the scene's render engine is switched to raylab.
"""
import os
import sys

import bpy

ADDON_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "addon")
if ADDON_DIR not in sys.path:
    sys.path.insert(0, ADDON_DIR)

import raylab  # noqa: E402

raylab.register()
try:
    bpy.context.scene.render.engine = "RAYLAB"
except TypeError:
    # The render engine is not registered yet (its module has not landed): keep Blender's default.
    pass
print("raylab: add-on loaded from", ADDON_DIR)
