"""Tutorial levels: each is data in levels/<id>/ (level.toml, text.md, diagrams/*.png).

Opening a level builds a fresh scene from its level.toml: the level's mesh (read with raylab.load_mesh, so
Blender holds exactly the triangles raylab measures), a camera, a sun, the probe's ray object when the
level uses the probe, and the scene.raylab / scene.raylab_render settings. Its tasks tick themselves: a
depsgraph handler and a timer check the first unticked task's condition. Conditions are small
declarative tables, never code:

    { property = "raylab.max_depth", at_least = 5 }          also equals, at_most, in = [...]
    { id_property = "raylab_last_render", exists = true }    also length_at_least, changed = true
    { object = "mesh", moved_at_least = 1.0 }                also tilted_at_least (degrees), mesh_changed
    { all = [ ... ] }, { any = [ ... ] }

Tasks are done in order (only the first unticked one is checked), so "hit the object again" cannot tick
while the ray still hits it from the start, and `changed` compares with the value when the task began.
"""
import json
import math
import os
import re
import tomllib

import bpy
import numpy as np
from mathutils import Matrix, Vector

from .. import api
from . import draw

from .mesh_data import mesh_fingerprint, mesh_from_arrays, mesh_triangles, mesh_vertices, principled_material

PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MESH_DIR = os.path.join(PACKAGE_DIR, "meshes")
# The installable zip carries the levels inside the package; a checkout has them at the top.
LEVEL_ROOTS = (os.path.join(PACKAGE_DIR, "levels"),
               os.path.join(os.path.dirname(os.path.dirname(PACKAGE_DIR)), "levels"))
STATE_KEY = "raylab_level"
MESH_OBJECT_NAME = "Level mesh"
MESH_SIZE = 2.0          # the level mesh's largest side, in metres (times the level's scene_scale)
SETTING_GROUPS = ("raylab", "raylab_render")
COMPARISONS = ("equals", "in", "at_least", "at_most")
ID_PROPERTY_TESTS = ("exists", "length_at_least", "changed")
OBJECT_TESTS = ("moved_at_least", "tilted_at_least", "mesh_changed")
Z_UP_MESHES = {"plane_holes.obj"}  # stands on z = 0 in its file
CHECK_INTERVAL = 0.5     # seconds between timer checks (renders and comparisons fire no depsgraph update)


class LevelError(ValueError):
    """A level folder that cannot be used: says which file and what is wrong."""


# --- reading levels --------------------------------------------------------------------------------

class Task:
    __slots__ = ("text", "condition")

    def __init__(self, text, condition):
        self.text = text
        self.condition = condition


class Level:
    __slots__ = ("id", "order", "title", "goal", "folder", "mesh", "scene_scale", "scene", "camera",
                 "settings", "probe", "tasks", "controls", "blocks")

    def __init__(self, folder, data):
        where = os.path.join(folder, "level.toml")
        self.folder = folder
        self.id = _required(data, "id", str, where)
        self.order = _required(data, "order", int, where)
        self.title = _required(data, "title", str, where)
        self.goal = _required(data, "goal", str, where)
        self.mesh = _table(data, "mesh", where)
        _required(self.mesh, "file", str, where + " [mesh]")
        self.scene_scale = float(data.get("scene_scale", 1.0))
        if not self.scene_scale > 0.0:
            raise LevelError(f"{where}: scene_scale must be positive")
        self.scene = _table(data, "scene", where, optional=True)
        self.camera = _table(data, "camera", where, optional=True)
        self.settings = {group: _table(data, group, where, optional=True) for group in SETTING_GROUPS}
        self.probe = data.get("probe")
        tasks = data.get("tasks", [])
        if not isinstance(tasks, list):
            raise LevelError(f"{where}: 'tasks' must be a list of [[tasks]] tables")
        self.tasks = []
        for i, task in enumerate(tasks):
            here = f"{where} task {i + 1}"
            if not isinstance(task, dict):
                raise LevelError(f"{here}: must be a table with 'text' and 'condition'")
            condition = _table(task, "condition", here)
            validate_condition(condition, here)
            self.tasks.append(Task(_required(task, "text", str, here), condition))
        self.controls = data.get("controls", [])
        for control in self.controls:
            group, _, name = str(control).partition(".")
            if not (group in SETTING_GROUPS or group.startswith("operator:")) or not name:
                raise LevelError(f"{where}: a control is 'raylab.<setting>', 'raylab_render.<setting>' or "
                                 f"'operator:<module>.<operator>', not {control!r}")
        unknown = set(data) - {"id", "order", "title", "goal", "mesh", "scene_scale", "scene", "camera",
                               "probe", "tasks", "controls", *SETTING_GROUPS}
        if unknown:
            raise LevelError(f"{where}: unknown keys {sorted(unknown)}")
        self.blocks = read_text(os.path.join(folder, "text.md"))


def _required(table, key, kind, where):
    if key not in table:
        raise LevelError(f"{where}: '{key}' is missing")
    if not isinstance(table[key], kind):
        raise LevelError(f"{where}: '{key}' must be a {kind.__name__}, not {table[key]!r}")
    return table[key]


def _table(data, key, where, optional=False):
    if key not in data and optional:
        return {}
    return _required(data, key, dict, where)


def validate_condition(condition, where):
    """Raises LevelError unless `condition` is one of the declarative forms of the module docstring."""
    if not isinstance(condition, dict) or not condition:
        raise LevelError(f"{where}: a condition must be a non-empty table, not {condition!r}")
    for combinator in ("all", "any"):
        if combinator in condition:
            parts = condition[combinator]
            if len(condition) != 1 or not isinstance(parts, list) or not parts:
                raise LevelError(f"{where}: '{combinator}' takes a non-empty list and nothing beside it")
            for part in parts:
                validate_condition(part, where)
            return
    kinds = {"property": COMPARISONS, "id_property": ID_PROPERTY_TESTS, "object": OBJECT_TESTS}
    kind = [k for k in kinds if k in condition]
    if len(kind) != 1:
        raise LevelError(f"{where}: a condition needs exactly one of {sorted(kinds)} (or all / any): "
                         f"{condition!r}")
    kind = kind[0]
    tests = [k for k in condition if k != kind]
    if len(tests) != 1 or tests[0] not in kinds[kind]:
        raise LevelError(f"{where}: '{kind}' takes exactly one of {list(kinds[kind])}: {condition!r}")
    if kind == "property":
        group, _, name = str(condition["property"]).partition(".")
        if group not in SETTING_GROUPS or not name.isidentifier() or name.startswith("_"):
            raise LevelError(f"{where}: property must be 'raylab.<name>' or 'raylab_render.<name>', "
                             f"not {condition['property']!r}")
    if kind == "object" and condition["object"] != "mesh":
        raise LevelError(f"{where}: only object = \"mesh\" (the level's mesh) is known")


IMAGE = re.compile(r"^!\[(?P<caption>[^\]]*)\]\((?P<path>[^)]+)\)$")


def read_text(path):
    """text.md as blocks for the panel: ("heading", text), ("paragraph", text), ("bullet", text),
    ("image", absolute path, caption). Markdown emphasis is dropped: Blender labels are plain."""
    if not os.path.isfile(path):
        raise LevelError(f"{path} is missing")
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    blocks, paragraph = [], []

    def flush():
        if paragraph:
            blocks.append(("paragraph", " ".join(paragraph)))
            paragraph.clear()

    for raw in lines:
        line = raw.strip()
        image = IMAGE.match(line)
        if not line:
            flush()
        elif line.startswith("#"):
            flush()
            blocks.append(("heading", plain(line.lstrip("#").strip())))
        elif line.startswith(("- ", "* ")):
            flush()
            blocks.append(("bullet", plain(line[2:])))
        elif image:
            flush()
            image_path = os.path.join(os.path.dirname(path), image["path"])
            if not os.path.isfile(image_path):
                raise LevelError(f"{path}: diagram {image['path']} does not exist")
            blocks.append(("image", image_path, plain(image["caption"])))
        elif blocks and blocks[-1][0] == "bullet" and not paragraph and raw.startswith("  "):
            blocks[-1] = ("bullet", blocks[-1][1] + " " + plain(line))  # a bullet's continuation line
        else:
            paragraph.append(plain(line))
    flush()
    return blocks


def plain(text):
    return re.sub(r"(\*\*|\*|`)", "", text)


def load_level(folder):
    path = os.path.join(folder, "level.toml")
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise LevelError(f"{path} is missing") from None
    except tomllib.TOMLDecodeError as error:
        raise LevelError(f"{path}: not valid TOML: {error}") from None
    return Level(folder, data)


def levels_root():
    for root in LEVEL_ROOTS:
        if os.path.isdir(root):
            return root
    raise LevelError(f"no levels folder found (looked in {', '.join(LEVEL_ROOTS)})")


_cache = {}  # folder -> (mtimes, Level or LevelError)


def _mtimes(folder):
    return tuple(os.path.getmtime(os.path.join(folder, n)) if os.path.exists(os.path.join(folder, n)) else 0
                 for n in ("level.toml", "text.md"))


def available_levels(root=None):
    """(levels sorted by order, errors): a broken level is reported, never fatal for the others."""
    root = root or levels_root()
    levels, errors = [], []
    for name in sorted(os.listdir(root)):
        folder = os.path.join(root, name)
        if not os.path.isdir(folder) or not os.path.exists(os.path.join(folder, "level.toml")):
            continue
        stamp = _mtimes(folder)
        if folder not in _cache or _cache[folder][0] != stamp:
            try:
                _cache[folder] = (stamp, load_level(folder))
            except LevelError as error:
                _cache[folder] = (stamp, error)
        item = _cache[folder][1]
        (errors if isinstance(item, LevelError) else levels).append(item)
    return sorted(levels, key=lambda level: (level.order, level.id)), errors


def find_level(level_id, root=None):
    levels, errors = available_levels(root)
    for level in levels:
        if level.id == level_id:
            return level
    for error in errors:
        if f"{os.sep}{level_id}{os.sep}" in str(error):
            raise error
    raise LevelError(f"no level named {level_id!r} (known: {', '.join(l.id for l in levels)})")


# --- meshes --------------------------------------------------------------------------------------

def shipped_meshes():
    return sorted(n for n in os.listdir(MESH_DIR) if n.endswith(".obj"))


def mesh_credit(filename):
    """The credit line of a shipped mesh, from meshes/CREDITS.md (licence and source)."""
    with open(os.path.join(MESH_DIR, "CREDITS.md"), encoding="utf-8") as f:
        for line in f:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) >= 5 and cells[0] == filename:
                return f"{filename}: {cells[4]}; from {cells[3]}"
    return f"{filename}: see meshes/CREDITS.md"


def normalised(vertices, size):
    """Centres the mesh's box on the origin and scales its largest side to `size`."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    extent = float((hi - lo).max())
    if not extent > 0.0:
        raise LevelError("the mesh is flat or empty: it has no extent")
    return ((vertices - (lo + hi) / 2) * (size / extent)).astype(np.float32)


def shipped_mesh_arrays(filename):
    path = os.path.join(MESH_DIR, filename)
    if not os.path.isfile(path):
        raise LevelError(f"no shipped mesh {filename!r} (shipped: {', '.join(shipped_meshes())})")
    vertices, triangles = api.load_mesh(path)
    if filename in Z_UP_MESHES:
        return vertices, triangles
    # The other OBJ files are Y-up; Blender is Z-up.
    return np.c_[vertices[:, 0], -vertices[:, 2], vertices[:, 1]], triangles


def object_mesh_arrays(obj):
    """The triangles of a user's mesh object in its own space (modifiers and transform left out)."""
    triangles = mesh_triangles(obj.data)
    if len(triangles) == 0:
        raise LevelError(f"{obj.name} has no faces")
    return mesh_vertices(obj.data), triangles


# --- building a level's scene --------------------------------------------------------------------

def state(scene):
    """The level state stored on the scene, or None when the scene is not a level."""
    return scene.get(STATE_KEY) if scene is not None else None


def level_mesh_object(scene):
    st = state(scene)
    return scene.objects.get(st["mesh_object"]) if st else None


def _check_settings(level):
    """Every setting of the toml must be a writable property of its group, before anything is built."""
    scene_properties = bpy.types.Scene.bl_rna.properties
    for group, values in level.settings.items():
        if group not in scene_properties:
            if values:
                raise LevelError(f"{level.id}: [{group}] is set but scene.{group} is not registered")
            continue
        rna = scene_properties[group].fixed_type.properties
        for key in values:
            if key not in rna or rna[key].is_readonly:
                raise LevelError(f"{level.folder}/level.toml: [{group}] has no writable setting '{key}'")
    for control in level.controls:
        group, _, name = control.partition(".")
        known = (_operator_exists(control.partition(":")[2]) if group.startswith("operator:")
                 else group in scene_properties and name in scene_properties[group].fixed_type.properties)
        if not known:
            raise LevelError(f"{level.folder}/level.toml: control {control!r} does not exist")


def _operator_exists(idname):
    module, _, name = idname.partition(".")
    try:
        getattr(getattr(bpy.ops, module), name).get_rna_type()
        return True
    except (AttributeError, KeyError):
        return False


def _apply_settings(scene, level):
    for group, values in level.settings.items():
        target = getattr(scene, group)
        for key, value in values.items():
            try:
                setattr(target, key, value)
            except (TypeError, ValueError) as error:
                raise LevelError(f"{level.folder}/level.toml: [{group}] {key} = {value!r}: {error}") from None


def _look_at(location, target):
    direction = Vector(target) - Vector(location)
    return Matrix.Translation(location) @ direction.to_track_quat('-Z', 'Y').to_matrix().to_4x4()


def _set_mesh(obj, vertices, triangles, size, source, credit):
    old = obj.data
    mesh = mesh_from_arrays(f"level {source}", normalised(vertices, size), triangles, smooth=True)
    for material in old.materials:
        mesh.materials.append(material)
    obj.data = mesh
    if old.users == 0:
        bpy.data.meshes.remove(old)
    obj["raylab_credit"] = credit
    obj["raylab_mesh_source"] = source


def _new_scene(level):
    scene = bpy.data.scenes.new(f"raylab: {level.title}")
    s = level.scene_scale
    resolution = level.scene.get("resolution", [480, 360])
    scene.render.resolution_x, scene.render.resolution_y = int(resolution[0]), int(resolution[1])
    scene.render.resolution_percentage = 100
    try:
        scene.render.engine = "RAYLAB"
    except TypeError:
        pass  # the render engine is not registered: the level still teaches with the overlays

    mesh = bpy.data.meshes.new("level mesh")
    mesh.materials.append(principled_material("level mesh", tuple(level.mesh.get("color", (0.8, 0.55, 0.35)))))
    obj = bpy.data.objects.new(MESH_OBJECT_NAME, mesh)
    scene.collection.objects.link(obj)
    filename = level.mesh["file"]
    _set_mesh(obj, *shipped_mesh_arrays(filename), MESH_SIZE * s, filename, mesh_credit(filename))

    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.lens = float(level.camera.get("lens", 50.0))
    camera.data.clip_start, camera.data.clip_end = 0.1 * s, 1000.0 * s
    camera.matrix_world = _look_at(Vector(level.camera.get("location", (4.5, -6.0, 3.0))) * s,
                                   Vector(level.camera.get("target", (0.0, 0.0, 0.0))) * s)
    scene.collection.objects.link(camera)
    scene.camera = camera

    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = 3.0
    # [scene] sun_rotation: XYZ Euler degrees, as Blender's Rotation field shows them.
    sun.rotation_euler = [math.radians(float(a)) for a in level.scene.get("sun_rotation", (40.0, 15.0, 30.0))]
    sun.location = Vector((3.0, -3.0, 5.0)) * s
    scene.collection.objects.link(sun)

    scene[STATE_KEY] = {"id": level.id, "done": [0] * len(level.tasks), "mesh_object": obj.name,
                        "start_mesh": filename, "start_matrix": [v for row in obj.matrix_world for v in row],
                        "scene_scale": s, "snapshots": "{}"}
    return scene, obj


def _place_probe(scene, level):
    from . import probe
    ray = probe.ensure_probe_object(scene)
    s = level.scene_scale
    if isinstance(level.probe, dict) and "location" in level.probe:
        ray.matrix_world = _look_at(Vector(level.probe["location"]) * s,
                                    Vector(level.probe.get("target", (0.0, 0.0, 0.0))) * s)
    ray.empty_display_size = 0.5 * s
    return ray


def _frame_views(window, level):
    """Point the window's 3D views at the level's mesh, from the camera's side."""
    s = level.scene_scale
    for area in window.screen.areas:
        if area.type != 'VIEW_3D':
            continue
        space = area.spaces.active
        space.clip_start, space.clip_end = 0.1 * s, 100.0 * s
        view = space.region_3d
        view.view_perspective = 'PERSP'
        view.view_location = (0.0, 0.0, 0.0)
        view.view_distance = 6.0 * s
        location = Vector(level.camera.get("location", (4.5, -6.0, 3.0)))
        view.view_rotation = (-location).to_track_quat('-Z', 'Y')
        area.tag_redraw()


def _remove_scene(scene):
    for obj in list(scene.objects):
        if len(obj.users_scene) == 1:
            bpy.data.objects.remove(obj)
    bpy.data.scenes.remove(scene)


def _drop_name_suffixes(scene):
    """The new scene was built while the previous level's objects still held the plain names."""
    for obj in scene.objects:
        base = re.sub(r"\.\d{3}$", "", obj.name)
        if base != obj.name and base not in bpy.data.objects:
            was = obj.name
            obj.name = base
            if scene[STATE_KEY]["mesh_object"] == was:
                scene[STATE_KEY]["mesh_object"] = base


def open_level(context, level_id, root=None):
    """Builds the level's scene from scratch and makes it the window's scene; the previous level's
    scene is removed (the user's own scenes are kept). Returns the new scene. Raises LevelError."""
    level = find_level(level_id, root)
    _check_settings(level)
    scene, _ = _new_scene(level)
    try:
        _apply_settings(scene, level)
        if "raylab" in level.settings and scene.raylab.probe_enabled:
            _place_probe(scene, level)
    except Exception:
        _remove_scene(scene)
        raise
    windows = list(context.window_manager.windows)
    old = {w.scene for w in windows} if windows else {context.scene}
    for window in windows:
        window.scene = scene
        _frame_views(window, level)
    for previous in old:
        if previous != scene and state(previous) is not None:
            _remove_scene(previous)
    _drop_name_suffixes(scene)
    _take_snapshots(scene, level, 0)
    check_tasks(scene)
    return scene


def step_level(context, delta):
    """Opens the next (delta=1) or previous (delta=-1) level; from a non-level scene, the first one."""
    levels, _ = available_levels()
    if not levels:
        raise LevelError("no levels")
    st = state(context.scene)
    ids = [level.id for level in levels]
    index = ids.index(st["id"]) + delta if st and st["id"] in ids else 0
    if not 0 <= index < len(ids):
        raise LevelError("this is the " + ("last" if delta > 0 else "first") + " level")
    return open_level(context, ids[index])


def mesh_sources(scene):
    """Everything the level's mesh can be swapped for: ("file:NAME", ...) and ("object:NAME", ...)."""
    level_obj = level_mesh_object(scene)
    items = [f"file:{name}" for name in shipped_meshes()]
    items += [f"object:{o.name}" for o in bpy.data.objects if o.type == 'MESH' and o != level_obj
              and o.get("raylab_mesh_source") is None]
    return items


def swap_mesh(scene, source):
    """Replaces the level mesh's geometry with a shipped mesh ("file:bunny.obj") or a copy of a mesh
    object's ("object:Suzanne"); the object, its place and every setting stay."""
    obj = level_mesh_object(scene)
    if obj is None:
        raise LevelError("the scene is not a level (open one first)")
    kind, _, name = source.partition(":")
    if kind == "file":
        arrays, credit = shipped_mesh_arrays(name), mesh_credit(name)
    elif kind == "object" and name in bpy.data.objects and bpy.data.objects[name].type == 'MESH':
        arrays, credit = object_mesh_arrays(bpy.data.objects[name]), f"{name}: your own mesh"
    else:
        raise LevelError(f"cannot swap in {source!r}: expected file:<shipped .obj> or object:<mesh object>")
    _set_mesh(obj, *arrays, MESH_SIZE * state(scene)["scene_scale"], source.partition(":")[2], credit)
    check_tasks(scene)


# --- tasks ---------------------------------------------------------------------------------------

def _property_value(scene, path):
    group, _, name = path.partition(".")
    return getattr(getattr(scene, group), name)


def _id_value(scene, key):
    value = scene.get(key)
    return value.to_dict() if hasattr(value, "to_dict") else value


def _fingerprint(value):
    return json.dumps(value, sort_keys=True, default=repr)


def _changed_keys(condition):
    if "all" in condition or "any" in condition:
        return [k for part in condition.get("all", condition.get("any")) for k in _changed_keys(part)]
    return [condition["id_property"]] if condition.get("changed") else []


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
        return value is not None and (_fingerprint(value) != snapshot) == condition["changed"]
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
    return (obj.get("raylab_mesh_source") != st["start_mesh"]) == condition["mesh_changed"]


def task_list(scene):
    """[(text, done)] of the scene's level, or [] when the scene is not a level."""
    st = state(scene)
    if st is None:
        return []
    level = find_level(st["id"])
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
    check_tasks(scene)


def _check_timer():
    window = bpy.context.window or next(iter(bpy.context.window_manager.windows), None)
    if window is not None:
        check_tasks(window.scene)
    return CHECK_INTERVAL


# --- the leak experiment of where_methods_fail ------------------------------------------------------

LEAK_KEY = "raylab_leak_test"
MAX_LEAKS_DRAWN = 400


def leak_test(scene):
    """Shoots rays from the centre of the level mesh's box through every vertex and every edge midpoint,
    the places where two triangles meet, with each triangle test. From inside a closed mesh every ray
    must hit; the ones that hit nothing leaked. Stores and returns {rays, one count per name in
    api.TRIANGLE_TESTS, centre, escaped, mesh}: the box centre and the points where up to MAX_LEAKS_DRAWN escaped rays
    of the leakiest test (spread over all of them) passed through (object space, flat lists), for the viewport to draw;
    `mesh` is the mesh_fingerprint they belong to."""
    obj = level_mesh_object(scene)
    if obj is None:
        raise LevelError("the scene is not a level (open one first)")
    vertices, triangles = object_mesh_arrays(obj)
    targets = np.concatenate([vertices] + [(vertices[triangles[:, i]] + vertices[triangles[:, (i + 1) % 3]]) / 2
                                           for i in range(3)]).astype(np.float32)
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    directions = targets - centre
    keep = np.linalg.norm(directions, axis=1) > 0  # a vertex at the very centre gives no direction
    origins = np.repeat(centre[None].astype(np.float32), int(keep.sum()), axis=0)
    result = {"rays": int(keep.sum()), "centre": [float(c) for c in centre], "mesh": mesh_fingerprint(obj)}
    escaped = targets[:0]
    for test in api.TRIANGLE_TESTS:
        # Every triangle tested for every ray: the count measures the triangle test alone.
        structure = api.build(vertices, triangles, structure="none", triangle_test=test)
        missed = ~structure.intersect(origins, directions[keep]).hit
        result[test] = int(missed.sum())
        if missed.sum() > len(escaped):  # the viewport draws the leakiest test's escapes
            escaped = targets[keep][missed]
    spread = np.linspace(0, len(escaped) - 1, min(len(escaped), MAX_LEAKS_DRAWN)).astype(int)
    result["escaped"] = escaped[spread].ravel().tolist()
    scene[LEAK_KEY] = result
    return result


# --- operators -----------------------------------------------------------------------------------

class RAYLAB_OT_level_leak_test(bpy.types.Operator):
    """Shoot rays from the mesh's centre through its vertices and edges with Möller–Trumbore and with the
    watertight test, and count the rays that slip out through a closed mesh"""
    bl_idname = "raylab.level_leak_test"
    bl_label = "Count Leaking Rays"
    bl_options = {'REGISTER'}

    def execute(self, context):
        try:
            result = leak_test(context.scene)
        except (LevelError, ValueError) as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        leaked = ", ".join(f"{info['label']} {result[test]:,}" for test, info in api.TRIANGLE_TEST_INFO.items())
        self.report({'INFO'}, f"raylab: of {result['rays']:,} rays, leaked: {leaked}")
        return {'FINISHED'}


class RAYLAB_OT_level_open(bpy.types.Operator):
    """Build this level's scene from scratch and switch to it"""
    bl_idname = "raylab.level_open"
    bl_label = "Open Level"
    bl_options = {'REGISTER'}

    level_id: bpy.props.StringProperty(name="Level")

    def execute(self, context):
        try:
            open_level(context, self.level_id)
        except LevelError as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


class RAYLAB_OT_level_step(bpy.types.Operator):
    """Open the next or the previous level"""
    bl_idname = "raylab.level_step"
    bl_label = "Next / Previous Level"
    bl_options = {'REGISTER'}

    delta: bpy.props.IntProperty(name="Step", default=1, min=-1, max=1)

    def execute(self, context):
        try:
            step_level(context, self.delta)
        except LevelError as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


_source_items = []  # Blender needs Python to keep dynamic enum strings alive


def _mesh_items(_self, context):
    _source_items[:] = [(source, source.partition(":")[2],
                         ("Shipped mesh " if source.startswith("file:") else "Your mesh object ")
                         + source.partition(":")[2]) for source in mesh_sources(context.scene)]
    return _source_items


class RAYLAB_OT_level_swap_mesh(bpy.types.Operator):
    """Swap the level's mesh for a shipped mesh or one of your mesh objects; settings stay"""
    bl_idname = "raylab.level_swap_mesh"
    bl_label = "Swap Mesh"
    bl_options = {'REGISTER', 'UNDO'}
    bl_property = "source"

    source: bpy.props.EnumProperty(name="Mesh", items=_mesh_items)

    def invoke(self, context, event):
        context.window_manager.invoke_search_popup(self)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        try:
            swap_mesh(context.scene, self.source)
        except (LevelError, ValueError) as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


CLASSES = (RAYLAB_OT_level_open, RAYLAB_OT_level_step, RAYLAB_OT_level_swap_mesh, RAYLAB_OT_level_leak_test)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    bpy.app.timers.register(_check_timer, first_interval=CHECK_INTERVAL, persistent=True)


def unregister():
    if bpy.app.timers.is_registered(_check_timer):
        bpy.app.timers.unregister(_check_timer)
    if _on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
