"""In a real Blender window: render the open scene with raylab the way F12 does, screenshot the render window.

blender SCENE.blend --python render_f12.py -- SCREENSHOT.png REPORT.json
Everything runs from timers, as in an interactive session: the render job runs while the UI keeps drawing.
The report holds where the render window's image region lies in the screenshot, the statistics line the
engine sent to Blender, and scene["raylab_last_render"].
"""
import json
import os
import sys
import traceback

import bpy

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_window  # noqa: E402
import raylab  # noqa: E402
from raylab.blender import render_stats  # noqa: E402

SCREENSHOT, REPORT = (os.path.abspath(path) for path in sys.argv[sys.argv.index("--") + 1:][:2])
TIMEOUT_TICKS = 600   # 0.25 s each
report = {"stats_sent": [], "errors": []}
ticks = {"waited": 0, "after_done": 0}


def record_stats_line(stats):
    line = original_stats_line(stats)
    report["stats_sent"].append(line)
    return line


# RNA methods such as update_stats cannot be wrapped from Python: record the line the engine sends.
original_stats_line = render_stats.line
render_stats.line = record_stats_line


def finish():
    with open(REPORT, "w") as file:
        json.dump(report, file, indent=2)
    bpy.ops.wm.quit_blender()


def start_render():
    try:
        bpy.context.preferences.view.render_display_type = 'WINDOW'
        scene = bpy.context.scene
        scene.render.engine = 'RAYLAB'
        blender_window.start_f12()
        bpy.app.timers.register(wait_for_render, first_interval=0.5)
    except Exception:
        report["errors"].append(traceback.format_exc())
        finish()


def render_window():
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == 'IMAGE_EDITOR' and area.spaces.active.image is not None \
                    and area.spaces.active.image.type == 'RENDER_RESULT':
                return window, area
    return None, None


def wait_for_render():
    try:
        ticks["waited"] += 1
        if ticks["waited"] > TIMEOUT_TICKS:
            report["errors"].append("timed out waiting for the render")
            finish()
            return None
        if bpy.app.is_job_running('RENDER') or "raylab_last_render" not in bpy.context.scene:
            return 0.25
        ticks["after_done"] += 1
        if ticks["after_done"] < 6:   # let the render window draw the finished result and its stats
            return 0.25
        window, area = render_window()
        if window is None:
            report["errors"].append("no render window with the Render Result")
            finish()
            return None
        region = next(r for r in area.regions if r.type == 'WINDOW')
        report["window"] = dict(width=window.width, height=window.height)
        report["image_region"] = dict(x=region.x, y=region.y,
                                      width=region.width, height=region.height)
        report["last_render"] = bpy.context.scene["raylab_last_render"].to_dict()
        blender_window.screenshot(SCREENSHOT, window)
        finish()
    except Exception:
        report["errors"].append(traceback.format_exc())
        finish()
    return None


raylab.register()
bpy.app.timers.register(start_render, first_interval=1.0)
