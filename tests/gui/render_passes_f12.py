"""In a real Blender window: F12 with raylab's cost passes and heat pass on, as a user would render them
(the engine runs on Blender's render job thread, not on the main thread as in the headless tests), then
the Render Result saved as a multilayer EXR.

blender SCENE.blend --python render_passes_f12.py -- REPORT.json RESULT.exr SCREENSHOT.png
The report holds scene["raylab_last_render"], the view layer's name and any errors.
"""
import json
import os
import sys
import traceback

import bpy
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_window  # noqa: E402
import raylab  # noqa: E402
from raylab.blender import compat, cost_passes, render_stats  # noqa: E402

REPORT, EXR, SCREENSHOT = (os.path.abspath(p) for p in sys.argv[sys.argv.index("--") + 1:][:3])
HEAT_MAXIMUM = 100.0
TIMEOUT_TICKS = 600   # 0.25 s each
report = {"errors": []}
ticks = {"waited": 0, "after_done": 0}



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


def finish():
    with open(REPORT, "w") as file:
        json.dump(report, file, indent=2)
    bpy.ops.wm.quit_blender()


def start_render():
    try:
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
        bpy.app.timers.register(wait_for_render, first_interval=0.5)
    except Exception:
        report["errors"].append(traceback.format_exc())
        finish()


def wait_for_render():
    try:
        ticks["waited"] += 1
        if ticks["waited"] > TIMEOUT_TICKS:
            report["errors"].append("timed out waiting for the render")
            finish()
            return None
        scene = bpy.context.scene
        if bpy.app.is_job_running('RENDER') or render_stats.LAST_RENDER not in scene:
            return 0.25
        ticks["after_done"] += 1
        if ticks["after_done"] < 4:   # let the render window draw the finished result
            return 0.25
        report["last_render"] = scene[render_stats.LAST_RENDER].to_dict()
        report["view_layer"] = scene.view_layers[0].name
        report["blender"] = list(bpy.app.version[:2])
        blender_window.screenshot(SCREENSHOT)
        compat.set_file_format(scene.render.image_settings, 'OPEN_EXR_MULTILAYER')
        scene.render.image_settings.color_depth = '32'
        bpy.data.images["Render Result"].save_render(EXR, scene=scene)
        np.savez(EXR + ".npz", **filled)
        finish()
    except Exception:
        report["errors"].append(traceback.format_exc())
        finish()
    return None


raylab.register()
bpy.app.timers.register(start_render, first_interval=1.0)
