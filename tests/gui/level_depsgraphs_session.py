"""In a real Blender window: the student adds a mesh of their own in a level (Shift A), opens the race level
(the level left is kept for that mesh, the level's own objects deleted from it), swaps the race's goat for
the dragon, while Blender's GPU garbage collection runs every second; after each switch, every scene's
depsgraph is read: does one still hold a copy of an object that no longer exists?

    blender START.blend --python level_depsgraphs_session.py -- OUT_DIR

OUT_DIR/level_depsgraphs.json: {"stale": {when: {"scene/view layer": [names of copies whose original is
gone]}}, "collections": n}. Issue 40 (item 7): Blender 5.2 segfaulted in its GPU garbage collection, which
walks every scene's depsgraph and reads each copy's original (DRW_cache_free_old_batches), seconds after
the race level's mesh swap in the student's session, who had left BVH 1 with a cube of their own.
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
import blender_window  # noqa: E402

OUT_DIR = session.out_dir()
report = {"stale": {}, "redraws": 0}
SESSION = session.Session(os.path.join(OUT_DIR, "level_depsgraphs.json"), report)


def stale_copies():
    """Per built depsgraph of every scene: the evaluated objects whose original is not a live object. Only
    pointers are compared: no freed original is read here (the depsgraph walk itself reads a field)."""
    live = {o.as_pointer() for o in bpy.data.objects}
    return {f"{scene.name}/{view_layer.name}": [o.name for o in view_layer.depsgraph.objects
                                                 if o.original.as_pointer() not in live]
            for scene in bpy.data.scenes for view_layer in scene.view_layers if view_layer.depsgraph is not None}


def note(when):
    def step():
        report["stale"][when] = stale_copies()
    step.__name__ = f"note_{when}"
    return step


def set_up():
    import raylab
    raylab.register()
    system = bpy.context.preferences.system
    # The GPU garbage collection every second (Blender's default: every 60 s), on batches unused for 1 s.
    system.vbo_collection_rate, system.vbo_time_out = 1, 1


def in_main_window(operator, **properties):
    window, area, region, _ = blender_window.view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert operator(**properties) == {'FINISHED'}


def open_level(level_id):
    def step():
        in_main_window(bpy.ops.raylab.level_open, level_id=level_id)
    step.__name__ = f"open_{level_id}"
    return step


def add_own_cube():
    in_main_window(bpy.ops.mesh.primitive_cube_add, location=(3.0, 0.0, 0.0))


def swap_for_dragon():
    in_main_window(bpy.ops.raylab.level_swap_mesh, source="file:dragon.obj")


def redraw_viewport():
    """The 3D viewport drawn again and again for 3 s (its draw runs the garbage collection)."""
    report["redraws"] += 1
    window, area, region, _ = blender_window.view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.wm.redraw_timer(type='DRAW', iterations=1)
    return False if report["redraws"] % 6 else None


SESSION.run([open_level("aabb_1"), add_own_cube, note("own cube added"), open_level("race"), note("race opened"),
             redraw_viewport, swap_for_dragon, note("dragon swapped in"), redraw_viewport], set_up,
            first_interval=1.0, interval=1.0, wait=0.5, watchdog_seconds=240)
