"""A user's first session with the installed raylab, in a real Blender window (under Xvfb).

blender --python extension_session.py -- MODULE REPORT.json SHOTS_DIR

MODULE is the add-on's module as Blender names it: "bl_ext.user_default.raylab" for the 4.2+ extension,
"raylab" for the legacy add-on; it was installed beforehand into a fresh user folder, and nothing here
puts the checkout on sys.path. The script enables the add-on, opens every level, screenshots the
Octree 2 level, renders F12 in the render window and screenshots it. The report says where the add-on
was loaded from, which levels opened and what failed.
"""
import json
import os
import sys
import traceback

import addon_utils
import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_window  # noqa: E402  (the test helpers only: the add-on comes from the user folder)

MODULE, REPORT, SHOTS = sys.argv[sys.argv.index("--") + 1:][:3]
report = {"errors": [], "levels_opened": [], "level_errors": {}}
state = {"ticks": 0, "after_done": 0}


def finish():
    with open(REPORT, "w") as file:
        json.dump(report, file, indent=2)
    bpy.ops.wm.quit_blender()


def fail(message):
    report["errors"].append(message)
    finish()


def enable():
    addon_utils.enable(MODULE, default_set=True, handle_error=lambda error: report["errors"].append(repr(error)))
    package = sys.modules.get(MODULE)
    report["enabled"] = MODULE in {addon.module for addon in bpy.context.preferences.addons}
    report["module_file"] = getattr(package, "__file__", None)
    report["native_error"] = getattr(getattr(package, "native", None), "ERROR", "no native module")
    report["blender"] = bpy.app.version_string
    report["python"] = sys.version.split()[0]
    levels = sys.modules[MODULE + ".blender.levels"]
    found, broken = levels.available_levels()
    report["level_ids"] = [level.id for level in found]
    report["levels_root"] = levels.levels_root()
    report["broken_levels"] = [str(error) for error in broken]


def open_levels():
    for level_id in report["level_ids"]:
        v = blender_window.view3d()
        with bpy.context.temp_override(window=v.window, area=v.area, region=v.region):
            result = bpy.ops.raylab.level_open(level_id=level_id)
        if result == {'FINISHED'}:
            report["levels_opened"].append(level_id)
        else:
            report["level_errors"][level_id] = str(result)


def open_octree_2():
    v = blender_window.view3d()
    with bpy.context.temp_override(window=v.window, area=v.area, region=v.region):
        bpy.ops.raylab.level_open(level_id="octree_2")
    report["probe_status"] = bpy.context.scene.raylab.probe_status


def shoot_octree_2():
    blender_window.screenshot(os.path.join(SHOTS, "octree_2.png"))


def start_render():
    bpy.context.preferences.view.render_display_type = 'WINDOW'
    scene = bpy.context.scene
    scene.render.engine = 'RAYLAB'
    report["render_structure"] = scene.raylab_render.structure
    if "raylab_last_render" in scene:
        del scene["raylab_last_render"]
    blender_window.start_f12()


def render_window():
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            image = getattr(area.spaces.active, "image", None) if area.type == 'IMAGE_EDITOR' else None
            if image is not None and image.type == 'RENDER_RESULT':
                return window, area
    return None, None


def wait_for_render():
    try:
        state["ticks"] += 1
        if state["ticks"] > 480:
            return fail("timed out waiting for the F12 render")
        if bpy.app.is_job_running('RENDER') or "raylab_last_render" not in bpy.context.scene:
            return 0.25
        state["after_done"] += 1
        if state["after_done"] < 6:  # let the render window draw the finished image
            return 0.25
        window, area = render_window()
        if window is None:
            return fail("no render window with the Render Result")
        region = next(r for r in area.regions if r.type == 'WINDOW')
        report["image_region"] = dict(x=region.x, y=region.y, width=region.width, height=region.height)
        report["last_render"] = bpy.context.scene["raylab_last_render"].to_dict()
        blender_window.screenshot(os.path.join(SHOTS, "render_f12.png"), window)
        finish()
    except Exception:
        fail(traceback.format_exc())
    return None


def render_then_wait():
    start_render()
    bpy.app.timers.register(wait_for_render, first_interval=0.5)


steps = [enable, open_levels, open_octree_2, shoot_octree_2, render_then_wait]
# The last step hands over to wait_for_render, which finishes; an exception in a step finishes at once.
bpy.app.timers.register(blender_window.step_timer(steps, lambda: "error" in report and fail(report["error"]), report),
                        first_interval=1.0)
