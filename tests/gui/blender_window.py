"""Blender-side helpers of the GUI scripts (they run inside a real Blender window under xvfb-run):
find the 3D viewport, take a window screenshot, run steps one timer tick apart."""
import traceback
from collections import namedtuple

import bpy

View3D = namedtuple("View3D", "window area region sidebar")


def view3d():
    """The largest 3D viewport of the first window: its area, main region and sidebar region."""
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == 'VIEW_3D'), key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == 'WINDOW')
    sidebar = next(r for r in area.regions if r.type == 'UI')
    return View3D(window, area, region, sidebar)


def screenshot(path):
    """The whole window, as a PNG at `path`."""
    v = view3d()
    with bpy.context.temp_override(window=v.window, area=v.area, region=v.region):
        bpy.ops.screen.screenshot(filepath=path)


def step_timer(steps, finish, report, interval=1.5):
    """A bpy.app.timers callback that runs `steps` in order, `interval` seconds apart so that the
    window redraws in between, then `finish()`; an exception ends the run with report["error"]."""
    def run():
        try:
            steps.pop(0)()
            if steps:
                return interval
        except Exception:
            report["error"] = traceback.format_exc()
        finish()
        return None
    return run
