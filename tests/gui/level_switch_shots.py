"""Runs inside a real Blender window (xvfb-run): opens levels one after another, as Next or the list does,
and takes two window screenshots of each: the level as it opens (overlay and probe off, so only the mesh
is drawn over the background) and the same view with the level mesh hidden.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend \
        --python tests/gui/level_switch_shots.py -- OUT_DIR LEVEL_ID [LEVEL_ID ...]

OUT_DIR/switch_ID.png and switch_ID_hidden.png; then AABB 1 and AABB 2 (one scale: Undo leaves the
view, which is not undone, where it fits both) and Undo (Ctrl Z) once, which must give back AABB 1, drawn
as well: switch_undo.png and switch_undo_hidden.png. OUT_DIR/level_switch.json
holds the 3D viewport's rectangle in the window per level (and "undo": the level Undo went back to), or
"error".
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import screenshot, view3d  # noqa: E402

OUT_DIR, LEVEL_IDS = session.out_dir(), session.ARGS[1:]
report = {"levels": {}}
SESSION = session.Session(os.path.join(OUT_DIR, "level_switch.json"), report)
WATCHDOG_SECONDS = 300


def hide_level_mesh():
    from raylab.blender import levels
    levels.level_mesh_object(view3d().window.scene).hide_viewport = True


def undo_steps():
    def undo():
        for level_id in ("aabb_1", "aabb_2"):
            open_level_step(level_id)()
        window, area, region, _ = view3d()
        levels_before = report["levels"]
        with bpy.context.temp_override(window=window, area=area, region=region):
            assert bpy.ops.ed.undo() == {'FINISHED'}
        from raylab.blender import levels
        scene = view3d().window.scene
        mesh = levels.level_mesh_object(scene)
        report["undo"] = dict(level=(levels.state(scene) or {}).get("id"),
                              mesh_hidden=mesh is None or mesh.hide_viewport,
                              level_scenes=sum(levels.state(s) is not None for s in bpy.data.scenes),
                              **next(iter(levels_before.values())))
        scene.raylab.spin = False
        scene.raylab.show = False
        scene.raylab.probe_enabled = False

    def shoot():
        screenshot(os.path.join(OUT_DIR, "switch_undo.png"))
        hide_level_mesh()

    def shoot_hidden():
        screenshot(os.path.join(OUT_DIR, "switch_undo_hidden.png"))

    return [undo, shoot, shoot_hidden]


def open_level_step(level_id):
    def open_level():
        window, area, region, _ = view3d()
        # The operator, as the panel's Next and list buttons call it.
        with bpy.context.temp_override(window=window, area=area, region=region):
            assert bpy.ops.raylab.level_open(level_id=level_id) == {'FINISHED'}
            # Blender pushes the undo step of an UNDO operator a user runs, not of one a script calls.
            bpy.ops.ed.undo_push(message="Open Level")
        scene = window.scene
        # Only the mesh: nothing of raylab's own drawing over it.
        scene.raylab.spin = False
        scene.raylab.show = False
        scene.raylab.probe_enabled = False
        area.spaces.active.show_gizmo = False
    return open_level


def steps_for(level_id):
    open_level = open_level_step(level_id)

    def shoot():
        window, _, region, _ = view3d()
        screenshot(os.path.join(OUT_DIR, f"switch_{level_id}.png"))
        report["levels"][level_id] = dict(window_height=window.height, region=session.rect(region))
        hide_level_mesh()

    def shoot_hidden():
        screenshot(os.path.join(OUT_DIR, f"switch_{level_id}_hidden.png"))

    return [open_level, shoot, shoot_hidden]


def set_up():
    import raylab
    raylab.register()


SESSION.run([step for level_id in LEVEL_IDS for step in steps_for(level_id)] + undo_steps(), set_up,
            watchdog_seconds=WATCHDOG_SECONDS, what="the shots")
