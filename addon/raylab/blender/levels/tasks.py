"""The tasks of the open level tick themselves: a depsgraph handler and a timer check the first unticked
task's condition (the declarative tables of reading.py). Tasks are done in order (only the first unticked
one is checked), so "hit the object again" cannot tick while the ray still hits it from the start, and
`changed` compares with the value when the task began."""
import json
import math
import threading

import bpy
from mathutils import Matrix, Vector

from .. import draw
from ..structure_cache import may_deform
from .reading import LevelError, available_levels, find_level
from .state import STATE_KEY, keep_stamps, level_mesh_object, state

CHECK_INTERVAL = 0.5     # seconds between timer checks (renders and comparisons fire no depsgraph update)


def _property_value(scene, path):
    group, _, name = path.partition(".")
    return getattr(getattr(scene, group), name)


def _plain(value):
    """An ID property's value as Python data: dicts, lists and numbers."""
    if hasattr(value, "to_dict"):
        return value.to_dict()
    return value.to_list() if hasattr(value, "to_list") else value


def _id_value(scene, path):
    """The ID property `path` names: a key of the scene, then keys inside it after dots; None if missing."""
    key, *inside = path.split(".")
    value = scene.get(key)
    for part in inside:
        if not hasattr(value, "get") or hasattr(value, "to_list"):
            return None
        value = value.get(part)
    return _plain(value)


def _fingerprint(value):
    return json.dumps(value, sort_keys=True, default=repr)


def _changed_keys(condition):
    """The ID properties whose value at the task's start the condition compares with."""
    if "all" in condition or "any" in condition:
        return [k for part in condition.get("all", condition.get("any")) for k in _changed_keys(part)]
    return [condition["id_property"]] if condition.get("changed") or condition.get("decreased") else []


def _take_snapshots(scene, level, index):
    """Remembers, when task `index` becomes the one to do, the values its `changed` tests compare with."""
    st = scene[STATE_KEY]
    snapshots = json.loads(st["snapshots"])
    if index < len(level.tasks):
        for key in _changed_keys(level.tasks[index].condition):
            snapshots[f"{index}:{key}"] = _fingerprint(_id_value(scene, key))
    st["snapshots"] = json.dumps(snapshots)


def _angle_between(a, b):
    return math.degrees(a.normalized().angle(b.normalized(), 0.0))


def evaluate_condition(scene, condition, index=0):
    """True when the declarative `condition` (validated by validate_condition) holds in `scene`."""
    if "all" in condition:
        return all(evaluate_condition(scene, part, index) for part in condition["all"])
    if "any" in condition:
        return any(evaluate_condition(scene, part, index) for part in condition["any"])
    if "property" in condition:
        value = _property_value(scene, condition["property"])
        if hasattr(value, "__len__") and not isinstance(value, str):
            value = list(value)
        if "equals" in condition:
            return value == condition["equals"]
        if "in" in condition:
            return value in condition["in"]
        if "at_least" in condition:
            return value >= condition["at_least"]
        return value <= condition["at_most"]
    if "id_property" in condition:
        key = condition["id_property"]
        value = _id_value(scene, key)
        if "exists" in condition:
            return (value is not None) == condition["exists"]
        if "length_at_least" in condition:
            return value is not None and len(value) >= condition["length_at_least"]
        snapshot = json.loads(scene[STATE_KEY]["snapshots"]).get(f"{index}:{key}")
        if "decreased" in condition:
            start = None if snapshot is None else json.loads(snapshot)
            numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (value, start))
            return numbers and value < start
        return value is not None and (_fingerprint(value) != snapshot) == condition["changed"]
    if "probe_pixel_near" in condition:
        target = _id_value(scene, condition["probe_pixel_near"])
        settings = scene.raylab
        if settings.probe_source != 'CAMERA' or not isinstance(target, list) or len(target) != 2:
            return False
        pixel = (settings.probe_pixel_x, settings.probe_pixel_y)
        return all(abs(p - t) <= condition["within"] for p, t in zip(pixel, target))
    st = scene[STATE_KEY]
    obj = level_mesh_object(scene)
    if obj is None:
        return False
    start = Matrix([st["start_matrix"][i:i + 4] for i in range(0, 16, 4)])
    if "moved_at_least" in condition:
        moved = (obj.matrix_world.translation - start.translation).length / st["scene_scale"]
        return moved >= condition["moved_at_least"]
    if "tilted_at_least" in condition:  # the object's up axis against its start: turning about Z is no tilt
        up = obj.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))
        return _angle_between(up, start.to_3x3() @ Vector((0.0, 0.0, 1.0))) >= condition["tilted_at_least"]
    if "deforms" in condition:
        return may_deform(obj) == condition["deforms"]
    return (obj.get("raylab_mesh_source") != st["start_mesh"]) == condition["mesh_changed"]


def task_list(scene):
    """[(text, done)] of the scene's level, or [] when the scene is not a level."""
    st = state(scene)
    if st is None:
        return []
    level = find_level(st["id"], from_memory=True)  # the Tasks panel's draw asks: see available_levels
    return [(task.text, bool(done)) for task, done in zip(level.tasks, st["done"])]


def check_tasks(scene):
    """Ticks the first unticked task if its condition holds; returns the done flags. The handlers call
    this; it writes to the scene only when a task ticks, so it cannot feed back into itself."""
    st = state(scene)
    if st is None:
        return []
    try:
        level = find_level(st["id"])
    except LevelError:
        return list(st["done"])
    done = list(st["done"])
    index = done.index(0) if 0 in done else None
    if index is not None and evaluate_condition(scene, level.tasks[index].condition, index):
        done[index] = 1
        st["done"] = done
        _take_snapshots(scene, level, index + 1)
        draw.tag_redraw()
    return [bool(d) for d in done]


@bpy.app.handlers.persistent
def _on_depsgraph_update(scene, _depsgraph):
    # A render job's thread never writes an ID (issue 40). F12 on 3.4 runs frame_change handlers there, and
    # this one on the main thread; should a Blender run it there too, the tasks' timer checks instead.
    if threading.current_thread() is not threading.main_thread():
        return
    keep_stamps()  # a new scene copied from a level is the user's: it drops the copied state at once
    check_tasks(scene)


def _check_timer():
    window = bpy.context.window or next(iter(bpy.context.window_manager.windows), None)
    _read_levels()
    keep_stamps()
    if window is not None:
        check_tasks(window.scene)
    return CHECK_INTERVAL


def _read_levels():
    """Reads the levels' files again, outside any draw: the panels' draws answer from what this read
    (available_levels' from_memory)."""
    try:
        available_levels()
    except LevelError:
        pass  # no levels folder: the Levels panel says so


def register():
    _read_levels()
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    bpy.app.timers.register(_check_timer, first_interval=CHECK_INTERVAL, persistent=True)


def unregister():
    if bpy.app.timers.is_registered(_check_timer):
        bpy.app.timers.unregister(_check_timer)
    if _on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
