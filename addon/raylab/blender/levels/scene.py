"""Building a level's scene from its level.toml, from scratch: the level's mesh (read with raylab.load_mesh,
so Blender holds exactly the triangles raylab measures), a camera, a sun, the probe's ray object when the
level uses the probe, and the scene.raylab / scene.raylab_render settings; switching levels, and swapping
the level's mesh (the object, its place and every setting stay)."""
import math
import re
import time
import uuid

import bpy
from mathutils import Matrix, Vector

from .. import compat
from ..mesh_data import mesh_from_arrays, principled_material
from .meshes import GEOMETRY_TYPES, mesh_credit, normalised, object_mesh_arrays, shipped_mesh_arrays
from .reading import LevelError, available_levels, find_level
from .state import MESH_OBJECT_NAME, OWNER_KEY, STATE_KEY, level_mesh_object, owned, state
from .tasks import _take_snapshots, check_tasks

MESH_SIZE = 2.0          # the level mesh's largest side, in metres (times the level's scene_scale)
# The level's own objects are named as such: a user's "Camera" stays the only one, no "Camera.001".
CAMERA_NAME, SUN_NAME = "Level camera", "Level sun"
WORLD_COLOUR = (0.0508, 0.0508, 0.0508)  # Blender's default world grey: background and ambient


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


def _own(token, *ids):
    """Marks IDs as the level's: leaving the level removes these and nothing else."""
    for id_data in ids:
        id_data[OWNER_KEY] = token
    return ids[0] if ids else None


def _set_mesh(obj, vertices, triangles, size, source, credit):
    old = obj.data
    mesh = mesh_from_arrays(f"level {source}", normalised(vertices, size), triangles, smooth=True)
    if OWNER_KEY in obj:
        _own(obj[OWNER_KEY], mesh)
    for material in old.materials:
        mesh.materials.append(material)
    obj.data = mesh
    if old.users == 0:
        bpy.data.meshes.remove(old)
    obj["raylab_credit"] = credit
    obj["raylab_mesh_source"] = source


def _new_scene(level):
    token = uuid.uuid4().hex
    scene = _own(token, bpy.data.scenes.new(f"raylab: {level.title}"))
    s = level.scene_scale
    resolution = level.scene.get("resolution", [480, 360])
    scene.render.resolution_x, scene.render.resolution_y = int(resolution[0]), int(resolution[1])
    scene.render.resolution_percentage = 100
    try:
        scene.render.engine = "RAYLAB"
    except TypeError:
        pass  # the render engine is not registered: the level still teaches with the overlays

    mesh = bpy.data.meshes.new("level mesh")
    mesh.materials.append(_own(token, principled_material("level mesh",
                                                          tuple(level.mesh.get("color", (0.8, 0.55, 0.35))))))
    obj = _own(token, bpy.data.objects.new(MESH_OBJECT_NAME, mesh))
    scene.collection.objects.link(obj)
    filename = level.mesh["file"]
    _set_mesh(obj, *shipped_mesh_arrays(filename), MESH_SIZE * s, filename, mesh_credit(filename))

    for spec in level.objects:
        _own(token, *_add_object(scene, spec, s))

    camera = _own(token, bpy.data.objects.new(CAMERA_NAME, _own(token, bpy.data.cameras.new(CAMERA_NAME))))
    camera.data.lens = float(level.camera.get("lens", 50.0))
    camera.data.clip_start, camera.data.clip_end = 0.1 * s, 1000.0 * s
    camera.matrix_world = _look_at(Vector(level.camera.get("location", (4.5, -6.0, 3.0))) * s,
                                   Vector(level.camera.get("target", (0.0, 0.0, 0.0))) * s)
    scene.collection.objects.link(camera)
    scene.camera = camera

    sun = _own(token, bpy.data.objects.new(SUN_NAME, _own(token, bpy.data.lights.new(SUN_NAME, 'SUN'))))
    sun.data.energy = 3.0
    # [scene] sun_rotation: XYZ Euler degrees, as Blender's Rotation field shows them.
    sun.rotation_euler = [math.radians(float(a)) for a in level.scene.get("sun_rotation", (40.0, 15.0, 30.0))]
    sun.location = Vector((3.0, -3.0, 5.0)) * s
    scene.collection.objects.link(sun)
    scene.world = _own(token, _new_world(level))

    scene[STATE_KEY] = {"id": level.id, "done": [0] * len(level.tasks), "mesh_object": obj.name,
                        "start_mesh": filename, "start_matrix": [v for row in obj.matrix_world for v in row],
                        "scene_scale": s, "snapshots": "{}", "scene": scene.name, "token": token}
    return scene, obj


def _add_object(scene, spec, scale):
    """One of the level's [[objects]]: a shipped mesh of `size` metres at `location`, in its colour."""
    filename = spec["file"]
    vertices, triangles = shipped_mesh_arrays(filename)
    mesh = mesh_from_arrays(f"level {spec['name']}", normalised(vertices, float(spec.get("size", MESH_SIZE)) * scale),
                            triangles, smooth=False)
    mesh.materials.append(principled_material(spec["name"], tuple(spec.get("color", (0.3, 0.6, 0.9)))))
    obj = bpy.data.objects.new(spec["name"], mesh)
    obj.location = Vector(spec.get("location", (0.0, 0.0, 0.0))) * scale
    obj["raylab_credit"] = mesh_credit(filename)
    scene.collection.objects.link(obj)
    return obj, mesh, mesh.materials[0]


def _new_world(level):
    """The level's World: without one, renders have a black background and no ambient light.
    [scene] world = [r, g, b] sets its colour (linear)."""
    world = bpy.data.worlds.new(f"raylab: {level.title}")
    colour = tuple(float(c) for c in level.scene.get("world", WORLD_COLOUR))
    compat.set_world_colour(world, colour)
    return world


def _place_probe(scene, level):
    from .. import probe
    ray = _own(state(scene)["token"], probe.ensure_probe_object(scene))
    s = level.scene_scale
    if isinstance(level.probe, dict) and "location" in level.probe:
        location = Vector(level.probe["location"]) * s
        ray.matrix_world = probe.aim_matrix(location, Vector(level.probe.get("target", (0.0, 0.0, 0.0))) * s - location)
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


LEAVING = []  # f(window) hooks: what a level's tools opened in a window (an editor) closes with the level
KEPT_SUFFIX = " (your objects)"  # a left level scene that holds objects the user added


def _remove_scene(scene):
    """Leaves a level's scene: removes what the level made (its objects, their data, its world) and nothing
    else. Objects the user added stay where they are: the scene is then kept as theirs, no longer a level."""
    # The token as a Python str: the state is freed with the scene, and reading it after that crashed 5.2.
    token = state(scene).get("token")
    leaving = [o for o in scene.objects if owned(o, token) and len(o.users_scene) == 1]
    holders = _depsgraphs_holding(scene)
    for obj in leaving:
        data, materials = obj.data, list(getattr(obj.data, "materials", ()))
        bpy.data.objects.remove(obj)
        if owned(data, token) and data.users == 0 and _data_collection(data) is not None:
            _data_collection(data).remove(data)
        for material in materials:
            if owned(material, token) and material.users == 0:
                bpy.data.materials.remove(material)
    # What the user added lives only here (an object of theirs linked in from their scene stays there).
    users = [o for o in scene.objects if len(o.users_scene) == 1] + list(scene.collection.children)
    if users:
        del scene[STATE_KEY]
        scene.name = scene.name + KEPT_SUFFIX
        _update_depsgraphs(holders)
        return scene
    world = scene.world
    bpy.data.scenes.remove(scene)
    if owned(world, token) and world.users == 0:
        bpy.data.worlds.remove(world)
    _update_depsgraphs(holders)
    return None


# A scene that was shown keeps its depsgraph (one per view layer) when the window shows another, and
# Blender evaluates it again only when it is shown again: until then it holds its evaluated copies of
# objects that were deleted meanwhile, their originals freed. Blender's GPU garbage collection (every
# 60 s, DRW_cache_free_old_batches, from a 3D viewport's draw) walks the depsgraph of every scene and reads
# each copy's original: Blender 5.2 crashed there (object_orig->runtime->select_id) in CI during the race
# level (issue 40). A level scene kept for the user's objects lost the level's objects while its depsgraph
# held them (seen from a script: tests/blender/test_level_depsgraphs.py). So the depsgraphs that may hold
# the deleted objects, the scene's own and those of scenes that show it as a background set, are evaluated
# again once they are gone, which drops their copies. They are not read before: walking a depsgraph that
# is already stale reads freed objects itself.
def _depsgraphs_holding(scene):
    """Pointers of the scenes whose depsgraphs may hold copies of `scene`'s objects: itself, and every
    scene with it in its chain of background sets."""
    holders = []
    for other in bpy.data.scenes:
        link, seen = other, set()
        while link is not None and link.as_pointer() not in seen:
            if link == scene:
                holders.append(other.as_pointer())
                break
            seen.add(link.as_pointer())
            link = link.background_set
    return holders


def _update_depsgraphs(holders):
    """Evaluates again the built depsgraphs of those scenes that are still there."""
    for scene in bpy.data.scenes:
        if scene.as_pointer() in holders:
            for view_layer in scene.view_layers:
                if view_layer.depsgraph is not None:
                    view_layer.depsgraph.update()


def _data_collection(data):
    """Where a level object's data lives in bpy.data (the level makes meshes, cameras and lights)."""
    for kind, collection in ((bpy.types.Mesh, bpy.data.meshes), (bpy.types.Camera, bpy.data.cameras),
                             (bpy.types.Light, bpy.data.lights)):
        if isinstance(data, kind):
            return collection
    return None


def _drop_name_suffixes(scene):
    """The new scene was built while the previous level's scene and objects still held the plain names."""
    base = re.sub(r"\.\d{3}$", "", scene.name)
    if base != scene.name and base not in bpy.data.scenes:
        scene.name = base
        scene[STATE_KEY]["scene"] = base
    for obj in scene.objects:
        base = re.sub(r"\.\d{3}$", "", obj.name)
        if base != obj.name and base not in bpy.data.objects:
            was = obj.name
            obj.name = base
            if obj.type in {'CAMERA', 'LIGHT'} and obj.data.users == 1:
                obj.data.name = base
            if scene[STATE_KEY]["mesh_object"] == was:
                scene[STATE_KEY]["mesh_object"] = base


def _lay_out_top_bar_again(window):
    """Blender 3.4 and 4.3 (not 5.2) draw a window's top bar (File, Edit, Render..., the workspace tabs)
    empty once its scene has a name of 16 or more characters after a render window was opened and closed
    (with Workbench and no add-on too: a rename is enough), and a level scene's name is that long; it stays
    empty until the
    workspace changes (issue 40; tests/gui/test_top_bar_gui.py). So the window goes to another workspace
    and, one timer tick later, back: Blender lays the top bar out again. The other workspace shows this
    object mode and no pinned scene, so the round trip changes neither."""
    if bpy.app.version >= (5, 2, 0) or bpy.app.background or window.screen is None or window.screen.is_temporary:
        return  # (in the background no timer would bring the workspace back, and nothing is drawn)
    if not any(image.type == 'RENDER_RESULT' for image in bpy.data.images):
        return  # no render window was ever opened: the top bar is drawn
    workspace = window.workspace
    other = next((w for w in bpy.data.workspaces if w != workspace and not w.use_pin_scene
                  and w.object_mode == workspace.object_mode), None)
    if other is None:
        return
    window.workspace = other
    pointer, name = window.as_pointer(), workspace.name
    deadline = time.monotonic() + 5.0

    def back():
        # Blender applies a workspace change when it next handles its notifiers, which a timer may run
        # before: until the window shows `other`, it tries again (a first version gave up, and the
        # window stayed in the other workspace under load).
        for w in bpy.context.window_manager.windows:  # the window, if it is still open
            if w.as_pointer() != pointer or name not in bpy.data.workspaces:
                continue
            if w.workspace == other:
                w.workspace = bpy.data.workspaces[name]
                return None
            return 0.05 if time.monotonic() < deadline else None
        return None
    bpy.app.timers.register(back, first_interval=0.0)


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
    for window in windows:
        for close in LEAVING:
            close(window)
        window.scene = scene
        _frame_views(window, level)
        _lay_out_top_bar_again(window)
    # Every other level scene goes (shown or not: none piles up); the user's scenes, copies included, stay.
    for previous in [s for s in bpy.data.scenes if s != scene and state(s) is not None]:
        _remove_scene(previous)
    _drop_name_suffixes(scene)
    # Deleting the previous level's objects and scene copies the shown scene's evaluated objects again
    # without re-evaluating their transforms, and Blender 3.4 then drew the level mesh black (as if its
    # normals were lost) until it moved. Re-evaluating the transforms, what a move does, shades it; a
    # geometry update does not (tests/gui/test_level_switch_gui.py).
    for obj in scene.objects:
        obj.update_tag(refresh={'OBJECT'})
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


def swap_mesh(scene, source):
    """Replaces the level mesh's geometry with a shipped mesh ("file:bunny.obj") or a copy of a mesh
    object's ("object:Suzanne"); the object, its place and every setting stay."""
    obj = level_mesh_object(scene)
    if obj is None:
        raise LevelError("the scene is not a level (open one first)" if state(scene) is None else
                         "the level's mesh was deleted: undo the delete, or open the level again")
    kind, _, name = source.partition(":")
    if kind == "file":
        arrays, credit = shipped_mesh_arrays(name), mesh_credit(name)
    elif kind == "object" and name in bpy.data.objects and bpy.data.objects[name].type in GEOMETRY_TYPES:
        arrays, credit = object_mesh_arrays(bpy.data.objects[name]), f"{name}: your own mesh"
    elif kind == "object" and name in bpy.data.objects:
        raise LevelError(f"cannot swap in {name}: it is a {bpy.data.objects[name].type.lower()} object, with no "
                         f"surface to trace (a mesh, curve, surface or text object has one)")
    else:
        raise LevelError(f"cannot swap in {source!r}: expected file:<shipped .obj> or object:<mesh object>")
    _set_mesh(obj, *arrays, MESH_SIZE * state(scene)["scene_scale"], source.partition(":")[2], credit)
    check_tasks(scene)
