"""Runs inside a real Blender window (xvfb-run): opens levels one after another, as Next or the list does,
and takes two window screenshots of each: the level as it opens (overlay and probe off, so only the mesh
is drawn over the background) and the same view with the level mesh hidden.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend \
        --python tests/gui/level_switch_shots.py -- OUT_DIR LEVEL_ID [LEVEL_ID ...]

OUT_DIR/switch_ID.png and switch_ID_hidden.png; OUT_DIR/level_switch.json holds the 3D viewport's
rectangle in the window, per level, or "error".
"""
import json
import os
import sys
import traceback

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, os.pardir, os.pardir, "addon"))
sys.path.insert(0, HERE)
from blender_window import screenshot, step_timer, view3d  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
OUT_DIR, LEVEL_IDS = ARGS[0], ARGS[1:]
os.makedirs(OUT_DIR, exist_ok=True)
report = {"levels": {}}
WATCHDOG_SECONDS = 300


def finish():
    with open(os.path.join(OUT_DIR, "level_switch.json"), "w") as f:
        json.dump(report, f)
    bpy.ops.wm.quit_blender()


def steps_for(level_id):
    def open_level():
        window, area, region, _ = view3d()
        # The operator, as the panel's Next and list buttons call it.
        with bpy.context.temp_override(window=window, area=area, region=region):
            assert bpy.ops.raylab.level_open(level_id=level_id) == {'FINISHED'}
        scene = window.scene
        # Only the mesh: nothing of raylab's own drawing over it.
        scene.raylab.spin = False
        scene.raylab.show = False
        scene.raylab.probe_enabled = False
        area.spaces.active.show_gizmo = False

    def shoot():
        window, _, region, _ = view3d()
        screenshot(os.path.join(OUT_DIR, f"switch_{level_id}.png"))
        report["levels"][level_id] = dict(window_height=window.height, region=dict(
            x=region.x, y=region.y, width=region.width, height=region.height))
        from raylab.blender import levels
        levels.level_mesh_object(window.scene).hide_viewport = True

    def shoot_hidden():
        screenshot(os.path.join(OUT_DIR, f"switch_{level_id}_hidden.png"))

    return [open_level, shoot, shoot_hidden]


def watchdog():
    report["error"] = f"the shots did not finish within {WATCHDOG_SECONDS} s"
    finish()


try:
    import raylab
    raylab.register()
    STEPS = [step for level_id in LEVEL_IDS for step in steps_for(level_id)]
    bpy.app.timers.register(step_timer(STEPS, finish, report), first_interval=2.0)
    bpy.app.timers.register(watchdog, first_interval=WATCHDOG_SECONDS)
except Exception:
    report["error"] = traceback.format_exc()
    finish()
