"""Spin: the shown mesh objects turn about Z, one step per frame change and, while scene.raylab.spin is
on, per timer tick, so that the boxes can be watched following the object (they are drawn with its
transform; an AABB is rebuilt in world space)."""
import math
import threading

import bpy

from . import properties, structure_cache

SPIN_STEP = math.radians(2.0)  # per frame change or timer tick
SPIN_INTERVAL = 1.0 / 30.0


def spin_step(scene):
    """Turns the shown mesh objects about Z by one step."""
    for obj in structure_cache.target_objects(scene):
        obj.rotation_euler.z += SPIN_STEP


def _spin_tick():
    scene = bpy.context.scene
    if scene is None or not scene.raylab.spin:
        return None  # stops the timer
    spin_step(scene)
    return SPIN_INTERVAL


def update_spin_timer():
    spinning = any(s.raylab.spin for s in bpy.data.scenes)
    registered = bpy.app.timers.is_registered(_spin_tick)
    if spinning and not registered:
        bpy.app.timers.register(_spin_tick, first_interval=SPIN_INTERVAL)
    elif not spinning and registered:
        bpy.app.timers.unregister(_spin_tick)


# The frame each scene was last seen at: 5.x also calls frame_change_post when a window switches scene
# (opening a level), which is no frame change and must not turn anything.
_last_frame = {}


@bpy.app.handlers.persistent
def _on_frame_change(scene, *_):
    # Blender runs frame_change handlers on a render job's thread too (F12 evaluates the render's
    # depsgraph there; an animation render changes frames there): that thread never writes an ID.
    if threading.current_thread() is not threading.main_thread():
        return
    frame = (scene.frame_current, scene.frame_subframe)
    changed = _last_frame.get(scene.name_full, frame) != frame
    _last_frame[scene.name_full] = frame
    if changed and scene.raylab.spin:
        spin_step(scene)


@bpy.app.handlers.persistent
def _on_load(_):
    update_spin_timer()


def register():
    properties.features.spin_changed = update_spin_timer
    bpy.app.handlers.frame_change_post.append(_on_frame_change)
    bpy.app.handlers.load_post.append(_on_load)


def unregister():
    properties.features.spin_changed = None
    bpy.app.handlers.frame_change_post.remove(_on_frame_change)
    bpy.app.handlers.load_post.remove(_on_load)
    if bpy.app.timers.is_registered(_spin_tick):
        bpy.app.timers.unregister(_spin_tick)
