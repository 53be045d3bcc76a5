"""Blender-side helpers of the GUI scripts (they run inside a real Blender window under xvfb-run):
find the 3D viewport, open its sidebar on the raylab tab, take a window screenshot, run steps one timer
tick apart, start F12. They know nothing of the add-on, which extension_session.py loads from Blender's
user folder; session.py, the frame of the scripts that drive the checkout's add-on, builds on them."""
import os
import shutil
import subprocess
import sys
import threading
import traceback
from collections import namedtuple

import bpy
import numpy as np

View3D = namedtuple("View3D", "window area region sidebar")


class NoViewportYet(RuntimeError):
    """The window shows no 3D viewport for a moment: on Blender 3.x a level switch after a render takes
    the window to another workspace and back (levels/scene.py, the top bar). step_timer waits it out."""


def viewport_shown():
    window = bpy.context.window_manager.windows[0]
    return any(a.type == 'VIEW_3D' for a in window.screen.areas)


def view3d():
    """The largest 3D viewport of the first window: its area, main region and sidebar region."""
    window = bpy.context.window_manager.windows[0]
    areas = [a for a in window.screen.areas if a.type == 'VIEW_3D']
    if not areas:
        raise NoViewportYet(f"the window shows the workspace {window.workspace.name!r}, with no 3D viewport")
    area = max(areas, key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == 'WINDOW')
    sidebar = next(r for r in area.regions if r.type == 'UI')
    return View3D(window, area, region, sidebar)


def plain_view(rotation, distance, location=(0.0, 0.0, 0.0)):
    """The largest 3D viewport in perspective at `rotation` (an Euler), `distance` from `location`, with
    no gizmo and none of Blender's overlays that could be taken for raylab's drawing."""
    _, area, _, _ = view3d()
    space = area.spaces.active
    space.show_gizmo = False
    for flag in ("show_floor", "show_axis_x", "show_axis_y", "show_axis_z", "show_cursor",
                 "show_object_origins", "show_extras", "show_outline_selected"):
        setattr(space.overlay, flag, False)
    rv3d = space.region_3d
    rv3d.view_perspective = 'PERSP'
    rv3d.view_location = location
    rv3d.view_rotation = rotation.to_quaternion()
    rv3d.view_distance = distance
    area.tag_redraw()


def show_sidebar():
    _, area, _, sidebar = view3d()
    space = area.spaces.active
    space.show_region_ui = True
    space.show_gizmo = False
    area.tag_redraw()


def click_raylab_tab():
    """The sidebar on its raylab tab: Region.active_panel_category where Blender has it (4.x, 5.x, whose
    tabs differ: 5.2 adds Animation before raylab); 3.4 has no API for it: the tab is clicked (needs
    --enable-event-simulate), the tabs running down the sidebar's right edge: Tool, View, then raylab."""
    window, area, _, sidebar = view3d()
    if "active_panel_category" in sidebar.bl_rna.properties:
        sidebar.active_panel_category = "raylab"
        if bpy.app.use_event_simulate:  # the pointer parked away from the tabs: no tooltip in the pictures
            window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=40, y=sidebar.y + 40)
        area.tag_redraw()
        return
    x = sidebar.x + sidebar.width - 13
    y = sidebar.y + sidebar.height - 122
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x, y=y)
    window.event_simulate(type='LEFTMOUSE', value='PRESS', x=x, y=y)
    window.event_simulate(type='LEFTMOUSE', value='RELEASE', x=x, y=y)
    # Park the pointer over the empty viewport so no tooltip or highlight lands in the pictures.
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=40, y=sidebar.y + 40)
    area.tag_redraw()


# A Blender on Python 3.11 or older crashes when an operator called inside a context override looks
# the context up while another thread holds the interpreter (ARCHITECTURE.md, "Blender's threads";
# tools/blender_override_race.py shows it with no add-on). Python 3.12 made the check per thread.
OVERRIDES_SAFE_WITH_THREADS = sys.version_info >= (3, 12)


def other_threads_may_run_python():
    """A render job (whose engine runs Python) or a Python thread (a comparison's worker) is running."""
    return bpy.app.is_job_running('RENDER') or threading.active_count() > 1


def overrides_safe():
    return OVERRIDES_SAFE_WITH_THREADS or not other_threads_may_run_python()


def start_f12():
    """F12 as a script runs it from a timer: render.render INVOKE_DEFAULT in the timer's own context,
    never inside an override, as the render's job thread enters Python while the operator still runs."""
    return bpy.ops.render.render('INVOKE_DEFAULT')


def call_in_main_window(operator, *args, **properties):
    """operator(*args, **properties) in the first window's largest area when overrides are safe, else
    in the timer's own context (its window is the first one)."""
    if overrides_safe():
        with bpy.context.temp_override(**main_window_override()):
            return operator(*args, **properties)
    return operator(*args, **properties)


def main_window_override():
    """temp_override arguments for the first window's largest area and its main region."""
    window = bpy.context.window_manager.windows[0]
    area = max(window.screen.areas, key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == 'WINDOW')
    return dict(window=window, area=area, region=region)


def screenshot(path, window=None):
    """The whole window (the first one unless given), as a PNG at `path`.

    Taken from the X server (xwd): Blender 4.x's own screenshot reads its front buffer, which is black
    under Xvfb with Mesa's llvmpipe; Blender 3.4 and the X server agree."""
    window = window or bpy.context.window_manager.windows[0]
    area = max(window.screen.areas, key=lambda a: a.width * a.height)
    if overrides_safe():
        with bpy.context.temp_override(window=window, area=area):
            bpy.ops.wm.redraw_timer(type='DRAW_WIN_SWAP', iterations=2)
    elif bpy.context.window == window:  # a timer's context window: no override needed
        bpy.ops.wm.redraw_timer(type='DRAW_WIN_SWAP', iterations=2)
    # else: the window as it was last drawn (a step is 1.5 s after the last one)
    if shutil.which("xwd") is None or not os.environ.get("DISPLAY"):
        with bpy.context.temp_override(window=window, area=area):
            bpy.ops.screen.screenshot(filepath=path)
        return
    screen = read_xwd(subprocess.run(["xwd", "-root", "-silent"], capture_output=True, check=True).stdout)
    # Blender's window position counts y from the bottom of the screen, X from the top.
    top = screen.shape[0] - (window.y + window.height)
    pixels = screen[max(top, 0):top + window.height, window.x:window.x + window.width]
    from matplotlib import image as mpimg
    mpimg.imsave(path, pixels)


def read_xwd(data):
    """(H, W, 3) uint8 of an X window dump of a TrueColor screen of 24 or 32 bits per pixel (what Xvfb
    -screen WxHx24 gives)."""
    header = np.frombuffer(data[:100], ">u4")
    header_size, width, height, byte_order, bits_per_pixel, bytes_per_line, ncolors = (
        int(header[0]), int(header[4]), int(header[5]), int(header[7]), int(header[11]), int(header[12]),
        int(header[19]))
    if bits_per_pixel not in (24, 32):
        raise RuntimeError(f"xwd: {bits_per_pixel} bits per pixel (run Xvfb with -screen WxHx24)")
    size = bits_per_pixel // 8
    start = header_size + 12 * ncolors
    rows = np.frombuffer(data[start:start + bytes_per_line * height], np.uint8).reshape(height, bytes_per_line)
    pixels = rows[:, :size * width].reshape(height, width, size)
    # LSBFirst (0): bytes B, G, R (, X); MSBFirst: (X,) R, G, B.
    return np.ascontiguousarray(pixels[:, :, 2::-1] if byte_order == 0 else pixels[:, :, size - 3:])


def step_timer(steps, finish, report, interval=1.5, wait=1.0, error=None):
    """A bpy.app.timers callback that runs `steps` in order, `interval` seconds apart so that the
    window redraws in between, then `finish()`; an exception ends the run with report["error"] (or
    error(traceback)). A step that returns False is called again `wait` seconds later, one that returns
    a number (not a bool) that many seconds later."""
    waits = [0]

    def run():
        try:
            step = steps.pop(0)
            try:
                again = step()
            except NoViewportYet:
                waits[0] += 1
                if waits[0] > 20:
                    raise
                steps.insert(0, step)
                return wait
            if again is False or (isinstance(again, (int, float)) and not isinstance(again, bool)):
                steps.insert(0, step)
                return wait if again is False else again
            if steps:
                return interval
        except Exception:
            if error is None:
                report["error"] = traceback.format_exc()
            else:
                error(traceback.format_exc())
        finish()
        return None
    return run


def watch_progress(progress, seconds, on_stall, interval=2.0):
    """Calls on_stall() once `progress()` (any comparable value: steps left, a job's fraction) has not
    changed for `seconds`: a run that advances is never stopped, however slow the machine."""
    import time
    seen = {"value": progress(), "since": time.monotonic()}

    def check():
        value = progress()
        if value != seen["value"]:
            seen.update(value=value, since=time.monotonic())
        elif time.monotonic() - seen["since"] > seconds:
            on_stall()
            return None
        return interval
    bpy.app.timers.register(check, first_interval=interval)
