"""Runs inside a real Blender window (xvfb-run): the sequence that deleted a user's work (issue 27, item 1)
done as the user does it, through the window's operators: AABB 1 open, New Scene > Copy Settings, a cube
added, Next; then Undo; then a cube added to the level's own scene and Next again.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend \
        --python tests/gui/user_work_session.py -- OUT_DIR

OUT_DIR/user_work.json holds what the window showed after each step; OUT_DIR/user_work_new_scene.png the
window with the user's new scene.
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import click_raylab_tab, screenshot, show_sidebar, view3d  # noqa: E402

OUT_DIR = session.out_dir()
report = {}
SESSION = session.Session(os.path.join(OUT_DIR, "user_work.json"), report)


def in_view(operator, **properties):
    """The operator as a button or a menu runs it: in the 3D viewport, with an undo step (the call's
    third argument; a script's calls push none)."""
    window, area, region, _ = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        return operator('EXEC_DEFAULT', True, **properties)


def seen(name):
    """What the window shows: its scene, whether the raylab tab shows a level, the scenes and objects."""
    from raylab.blender import level_panels, levels
    window, area, _, sidebar = view3d()
    with bpy.context.temp_override(window=window, area=area, region=sidebar):
        level = level_panels.current_level(bpy.context)
    report[name] = dict(scene=window.scene.name, level=level.id if level else None,
                        scenes={s.name: sorted(o.name for o in s.objects) for s in bpy.data.scenes},
                        is_level={s.name: levels.state(s) is not None for s in bpy.data.scenes})


def open_aabb_1():
    assert in_view(bpy.ops.raylab.level_open, level_id="aabb_1") == {'FINISHED'}


def new_scene_copy_settings():
    assert in_view(bpy.ops.scene.new, type='EMPTY') == {'FINISHED'}


def add_cube():
    assert in_view(bpy.ops.mesh.primitive_cube_add, location=(3.0, 0.0, 0.0)) == {'FINISHED'}
    bpy.context.view_layer.objects.active.name = "My cube"


def press_next():
    assert in_view(bpy.ops.raylab.level_next) == {'FINISHED'}


def undo():
    """Ctrl+Z with the pointer over the 3D viewport, as the user presses it."""
    window, _, region, _ = view3d()
    x, y = region.x + region.width // 2, region.y + region.height // 2
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x, y=y)
    window.event_simulate(type='Z', value='PRESS', ctrl=True, x=x, y=y)
    window.event_simulate(type='Z', value='RELEASE', ctrl=True, x=x, y=y)


def add_cube_to_level():
    assert in_view(bpy.ops.mesh.primitive_cube_add, location=(3.0, 0.0, 0.0)) == {'FINISHED'}
    bpy.context.view_layer.objects.active.name = "My cube in the level"


STEPS = [open_aabb_1, click_raylab_tab, lambda: seen("level"),
         new_scene_copy_settings, lambda: None, lambda: seen("new_scene"),
         lambda: screenshot(os.path.join(OUT_DIR, "user_work_new_scene.png")),
         add_cube, press_next, lambda: None, lambda: seen("after_next"),
         undo, lambda: None, lambda: seen("after_undo"),
         press_next, add_cube_to_level, press_next, lambda: None, lambda: seen("after_next_from_level")]


def set_up():
    import raylab
    raylab.register()
    show_sidebar()


SESSION.run(STEPS, set_up)
