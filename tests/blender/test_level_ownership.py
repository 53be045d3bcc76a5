"""A level never deletes or changes anything it did not make (issue 27, item 1): Blender's New Scene >
Copy Settings (type EMPTY) carries the level's ID properties into the user's new scene, and Next used to
delete that scene with the user's cube in it. Now a level marks what it makes; New Scene of any kind starts
without level state; leaving removes only the level's own data and keeps what the user added.

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import os
import sys

import bpy
import pytest

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402,F401
from raylab.blender import levels, level_panels  # noqa: E402


@pytest.fixture(autouse=True)
def own_scene():
    """Each test starts in a user's scene with nothing of raylab's in the file, and leaves it so."""
    before = bpy.context.window.scene
    yield before
    bpy.context.window.scene = before
    for scene in [s for s in bpy.data.scenes if levels.state(s) is not None]:
        levels._remove_scene(scene)
    for scene in [s for s in bpy.data.scenes if s != before]:  # the scenes the tests made as the user
        for obj in [o for o in scene.objects if len(o.users_scene) == 1]:
            bpy.data.objects.remove(obj)
        bpy.data.scenes.remove(scene)
    for obj in [o for o in bpy.data.objects if o.name.startswith("user ")]:
        bpy.data.objects.remove(obj)


def user_cube(scene, name="user cube"):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def new_scene(kind):
    """What the user's New Scene menu does in the window showing the level."""
    assert bpy.ops.scene.new(type=kind) == {'FINISHED'}
    bpy.context.view_layer.update()
    levels._check_timer()  # what the add-on's timer does in a window within a second
    return bpy.context.window.scene


@pytest.mark.parametrize("kind", ["EMPTY", "NEW", "LINK_COPY", "FULL_COPY"])
def test_a_new_scene_made_in_a_level_is_the_users_and_next_keeps_it(kind):
    level_scene = levels.open_level(bpy.context, "aabb_1")
    level_name = level_scene.name
    mine = new_scene(kind)
    assert mine != level_scene
    assert levels.state(mine) is None, f"New Scene > {kind} carried the level's state"
    assert level_panels.current_level(bpy.context) is None  # the panel shows the list, not AABB 1's tasks
    assert levels.STATE_KEY not in mine  # dropped, not only ignored: the saved file holds no stale level
    cube = user_cube(mine)
    name = mine.name
    assert bpy.ops.raylab.level_next() == {'FINISHED'}  # from a scene that is not a level: the first one
    assert levels.state(bpy.context.scene)["id"] == "aabb_1"
    assert name in bpy.data.scenes and cube.name in bpy.data.scenes[name].objects, "the user's work was deleted"
    # The level's first scene went (it was a level and not shown); the new one took its name.
    assert [s.name for s in bpy.data.scenes].count(level_name) == 1 and bpy.context.scene.name == level_name


def test_a_level_scene_stays_a_level_after_a_rename_and_its_copy_does_not():
    level_scene = levels.open_level(bpy.context, "aabb_2")
    level_scene.name = "my AABB lesson"
    bpy.context.view_layer.update()
    assert levels.state(level_scene)["id"] == "aabb_2"
    copy = new_scene("EMPTY")
    assert levels.state(copy) is None and levels.state(level_scene)["id"] == "aabb_2"


def test_leaving_a_level_keeps_what_the_user_added_to_its_scene():
    level_scene = levels.open_level(bpy.context, "aabb_1")
    made_by_level = {o.name for o in level_scene.objects}
    cube = user_cube(level_scene)
    assert bpy.ops.raylab.level_next() == {'FINISHED'}
    assert levels.state(bpy.context.scene)["id"] == "aabb_2"
    kept = cube.users_scene
    assert len(kept) == 1 and kept[0] != bpy.context.scene, "the user's cube went with the level"
    assert levels.state(kept[0]) is None  # the kept scene is the user's now, not a second level
    assert kept[0].name.endswith(levels.KEPT_SUFFIX)
    assert {o.name for o in kept[0].objects} == {cube.name}, (made_by_level, list(kept[0].objects))


def test_leaving_a_level_keeps_a_user_object_linked_into_it_and_what_the_user_made():
    own = bpy.context.window.scene
    linked = user_cube(own, "user linked")
    material = bpy.data.materials.new("user material")
    level_scene = levels.open_level(bpy.context, "aabb_1")
    level_scene.collection.objects.link(linked)
    levels.open_level(bpy.context, "aabb_2")
    assert linked.name in own.objects and material.name in bpy.data.materials
    assert [s.name for s in linked.users_scene] == [own.name]
    bpy.data.materials.remove(material)


def test_level_scenes_do_not_pile_up_when_the_user_switches_scenes():
    own = bpy.context.window.scene
    scenes = len(bpy.data.scenes)
    for level_id in ("aabb_1", "aabb_2", "octree_1", "aabb_1"):
        levels.open_level(bpy.context, level_id)
        bpy.context.window.scene = own  # the user looks at their own scene, the level scene is not shown
    levels.open_level(bpy.context, "aabb_2")
    assert len(bpy.data.scenes) == scenes + 1
    assert not [s.name for s in bpy.data.scenes if s.name.startswith("raylab: ") and s.name[-4:-3] == "."]
    assert bpy.context.scene.name == "raylab: " + levels.find_level("aabb_2").title


def test_the_level_removes_its_own_data_when_left():
    level_scene = levels.open_level(bpy.context, "where_methods_fail")
    token = levels.state(level_scene)["token"]
    assert all(o.get(levels.OWNER_KEY) == token for o in level_scene.objects)
    levels.open_level(bpy.context, "aabb_1")
    left = [i.name for c in (bpy.data.objects, bpy.data.cameras, bpy.data.lights, bpy.data.worlds,
                             bpy.data.materials, bpy.data.scenes) for i in c
            if i.get(levels.OWNER_KEY) == token and i.users]
    assert not left, left
