"""Saves the raylab demo scene as a .blend (headless): blender -b --python save_demo_blend.py -- OUT.blend"""
import os
import sys

import bpy

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
import raylab  # noqa: E402
from raylab.blender import default_scene  # noqa: E402

raylab.register()
default_scene.build_default_scene(bpy.context.scene, resolution=(880, 660))
bpy.context.scene.render.engine = 'RAYLAB'
bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(sys.argv[sys.argv.index("--") + 1]))
