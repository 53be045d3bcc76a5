"""In a real Blender window: render the open scene with raylab the way F12 does, screenshot the render window.

blender SCENE.blend --python render_f12.py -- SCREENSHOT.png REPORT.json
Everything runs from timers, as in an interactive session: the render job runs while the UI keeps drawing.
The report holds where the render window's image region lies in the screenshot, the statistics line the
engine sent to Blender, and scene["raylab_last_render"].
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
import blender_window  # noqa: E402

SCREENSHOT, REPORT = (os.path.abspath(path) for path in session.ARGS[:2])
report = {"stats_sent": [], "errors": []}
SESSION = session.Session(REPORT, report, indent=2, errors="errors")

import raylab  # noqa: E402
from raylab.blender import render_stats  # noqa: E402


def record_stats_line(stats):
    line = original_stats_line(stats)
    report["stats_sent"].append(line)
    return line


# RNA methods such as update_stats cannot be wrapped from Python: record the line the engine sends.
original_stats_line = render_stats.line
render_stats.line = record_stats_line


def start_render():
    bpy.context.preferences.view.render_display_type = 'WINDOW'
    scene = bpy.context.scene
    scene.render.engine = 'RAYLAB'
    blender_window.start_f12()


def render_window():
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == 'IMAGE_EDITOR' and area.spaces.active.image is not None \
                    and area.spaces.active.image.type == 'RENDER_RESULT':
                return window, area
    return None, None


def shoot():
    window, area = render_window()
    if window is None:
        raise RuntimeError("no render window with the Render Result")
    region = next(r for r in area.regions if r.type == 'WINDOW')
    report["window"] = dict(width=window.width, height=window.height)
    report["image_region"] = session.rect(region)
    report["last_render"] = bpy.context.scene[render_stats.LAST_RENDER].to_dict()
    blender_window.screenshot(SCREENSHOT, window)


# The render window draws the finished result and its stats for 6 polls (0.25 s each), then the shot.
SESSION.run([start_render, session.wait_for_f12(settle_ticks=6), shoot], raylab.register, first_interval=1.0,
            interval=0.25)
