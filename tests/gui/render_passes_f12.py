"""In a real Blender window: F12 with raylab's cost passes and heat pass on, as a user would render them
(the engine runs on Blender's render job thread, not on the main thread as in the headless tests), then
the Render Result saved as a multilayer EXR.

blender SCENE.blend --python render_passes_f12.py -- REPORT.json RESULT.exr SCREENSHOT.png
The report holds scene["raylab_last_render"], the view layer's name and any errors.
"""
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
import blender_window  # noqa: E402

REPORT, EXR, SCREENSHOT = (os.path.abspath(p) for p in session.ARGS[:3])
HEAT_MAXIMUM = 100.0
report = {"errors": []}
SESSION = session.Session(REPORT, report, indent=2, errors="errors")

import raylab  # noqa: E402
from raylab.blender import compat, cost_passes, render_stats  # noqa: E402


# 5.x writes a Render Result's Combined alone into a multilayer EXR (Cycles' passes too): the passes are
# then also kept as the engine filled them, through compat.set_pass_pixels (on the job thread), in
# EXR.npz beside the EXR: {pass name: (H, W, C) float32, row 0 the top}.
filled = {}
_fill = compat.set_pass_pixels


def _recording_fill(render_pass, pixels):
    scene = bpy.context.scene
    height = scene.render.resolution_y * scene.render.resolution_percentage // 100
    width = scene.render.resolution_x * scene.render.resolution_percentage // 100
    filled[render_pass.name] = np.asarray(pixels, np.float32).reshape(height, width, -1)[::-1].copy()
    _fill(render_pass, pixels)


compat.set_pass_pixels = _recording_fill


def start_render():
    bpy.context.preferences.view.render_display_type = 'WINDOW'
    scene = bpy.context.scene
    scene.render.engine = 'RAYLAB'
    passes = scene.view_layers[0].raylab_passes
    for name in raylab.COST_PASSES:
        setattr(passes, cost_passes.use_property(name), True)
    passes.cost_rays = "all"
    passes.use_heat = True
    passes.heat_pass = next(n for n, i in raylab.COST_PASS_INFO.items() if i["counter"] == "triangle_tests")
    passes.heat_maximum = HEAT_MAXIMUM
    blender_window.start_f12()


def save():
    scene = bpy.context.scene
    report["last_render"] = scene[render_stats.LAST_RENDER].to_dict()
    report["view_layer"] = scene.view_layers[0].name
    report["blender"] = list(bpy.app.version[:2])
    blender_window.screenshot(SCREENSHOT)
    compat.set_file_format(scene.render.image_settings, 'OPEN_EXR_MULTILAYER')
    scene.render.image_settings.color_depth = '32'
    bpy.data.images["Render Result"].save_render(EXR, scene=scene)
    np.savez(EXR + ".npz", **filled)


# The render window draws the finished result for 4 polls (0.25 s each), then the shot and the EXR.
SESSION.run([start_render, session.wait_for_f12(settle_ticks=4), save], raylab.register, first_interval=1.0,
            interval=0.25)
