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
    settle["ticks"] = 0


settle = {"ticks": 0}


def wait_for_redraws():
    """A few main-loop rounds for what the level switch set off (the window redrawn with its layout)."""
    settle["ticks"] += 1
    return False if settle["ticks"] < 4 else None


def shoot_after():
    note_screen("after")
    blender_window.screenshot(os.path.join(OUT_DIR, "top_bar_after.png"))


SESSION.run([shoot_before, render, close_render_window, open_level, wait_for_redraws, shoot_after], set_up,
            first_interval=1.0, interval=1.0, wait=0.5, watchdog_seconds=180)
