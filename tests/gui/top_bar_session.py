"""In a real Blender window: F12 (the render window opens), the render window closed as Esc closes it,
then a level opened, as a student does. Window screenshots before F12 and after the level opened, and the
window's areas at both times.

    blender START.blend --python top_bar_session.py -- OUT_DIR LEVEL_ID

OUT_DIR/top_bar.json: {"windows": {when: [...]}, "areas": {when: [[type, x, y, width, height], ...]},
"window_height"}, OUT_DIR/top_bar_before.png and top_bar_after.png. Issue 40 (item 5): Blender 3.4 then
drew the top bar (File, Edit, Render..., the workspace tabs) empty until the workspace was switched.
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
import blender_window  # noqa: E402

OUT_DIR, LEVEL_ID = session.out_dir(), session.ARGS[1]
report = {"windows": {}, "areas": {}}
SESSION = session.Session(os.path.join(OUT_DIR, "top_bar.json"), report)


def note_screen(when):
    window = bpy.context.window_manager.windows[0]
    report["windows"][when] = len(bpy.context.window_manager.windows)
    report["areas"][when] = sorted([a.type, a.x, a.y, a.width, a.height] for a in window.screen.areas)
    report["window_height"] = window.height
    report.setdefault("workspace", {})[when] = window.workspace.name


def set_up():
    import raylab
    raylab.register()
    scene = bpy.context.scene
    scene.render.engine = 'RAYLAB'
    scene.render.resolution_percentage = 10
    bpy.context.preferences.view.render_display_type = 'WINDOW'


def shoot_before():
    note_screen("before")
    blender_window.screenshot(os.path.join(OUT_DIR, "top_bar_before.png"))


def render():
    blender_window.start_f12()


def close_render_window():
    if bpy.app.is_job_running('RENDER'):
        return False
    note_screen("rendered")
    for window in bpy.context.window_manager.windows[1:]:
        area = window.screen.areas[0]
        region = next(r for r in area.regions if r.type == 'WINDOW')
        with bpy.context.temp_override(window=window, area=area, region=region):
            assert bpy.ops.render.view_cancel() == {'FINISHED'}  # Esc in the render window


def open_level():
    window, area, region, _ = blender_window.view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.raylab.level_open(level_id=LEVEL_ID) == {'FINISHED'}


settle = {"top_bar": None}
TOP_BAR_ROWS = 26  # pixels at the window's top (tests/gui/test_top_bar_gui.py)


def shoot_after():
    """The window after the level opened, once two shots a main-loop round apart show the same top bar:
    the level switch's workspace round trip has Blender lay the top bar out again over a few redraws,
    and under load a fixed number of rounds caught one half-way (its items a few pixels apart)."""
    from matplotlib import image as mpimg
    path = os.path.join(OUT_DIR, "top_bar_after.png")
    note_screen("after")
    blender_window.screenshot(path)
    top_bar = mpimg.imread(path)[:TOP_BAR_ROWS]
    settled = settle["top_bar"] is not None and (top_bar == settle["top_bar"]).all()
    settle["top_bar"] = top_bar
    return None if settled else False


SESSION.run([shoot_before, render, close_render_window, open_level, shoot_after], set_up,
            first_interval=1.0, interval=1.0, wait=0.5, watchdog_seconds=180)
