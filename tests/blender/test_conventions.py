"""Blender's conventions, as a user meets them: every operator and property says in one line what it
does, the operators that change the scene have Undo (and undoing a level restores the scene before it),
operators behave when called from F3 without their arguments, a level adds no second camera and has a
World, the probe's camera pixel starts inside the image, and the add-on has Preferences."""
import os
import sys

import bpy
import pytest

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402
from raylab.blender import levels, preferences, properties  # noqa: E402

UNDO_OPERATORS = ("level_open", "level_next", "level_previous", "level_swap_mesh", "compare_structures",
                  "level_leak_test")


@pytest.fixture(autouse=True)
def back_to_the_first_scene():
    before = bpy.context.window.scene.name  # a name: undo replaces every data-block (and its Python object)
    yield
    bpy.context.window.scene = bpy.data.scenes[before]
    for scene in [s for s in bpy.data.scenes if levels.state(s) is not None]:
        levels._remove_scene(scene)


def raylab_operators():
    return {name: getattr(bpy.ops.raylab, name).get_rna_type() for name in dir(bpy.ops.raylab)}


def raylab_property_groups():
    groups = [bpy.types.Scene.bl_rna.properties[a].fixed_type for a in properties.GROUPS]
    groups.append(bpy.types.ViewLayer.bl_rna.properties["raylab_passes"].fixed_type)  # cost_passes.py
    return groups + [preferences.RAYLAB_AP_preferences.bl_rna] + list(raylab_operators().values())


def test_every_operator_has_a_one_line_description():
    for name, rna in raylab_operators().items():
        assert rna.description.strip(), f"raylab.{name} has no description"
        assert "\n" not in rna.description, f"raylab.{name}'s tooltip holds a line break"


def test_every_property_has_a_one_line_description():
    for group in raylab_property_groups():
        for prop in group.properties:
            if prop.identifier in ("rna_type", "name") or prop.identifier.startswith("bl_"):
                continue
            where = f"{group.identifier}.{prop.identifier}"
            assert prop.description.strip(), f"{where} has no description"
            assert "\n" not in prop.description, f"{where}'s tooltip holds a line break"
    progress = bpy.types.WindowManager.bl_rna.properties["raylab_compare_progress"]
    assert progress.description and progress.is_readonly


@pytest.mark.parametrize("name", UNDO_OPERATORS)
def test_operators_that_change_the_scene_have_undo(name):
    assert {'REGISTER', 'UNDO'} <= getattr(bpy.types, f"RAYLAB_OT_{name}").bl_options


def test_undo_after_open_level_gives_back_the_scene_before():
    """Blender pushes an undo step after each operator with UNDO; in background mode it does not, so the
    steps are pushed here as it would push them."""
    first = levels.open_level(bpy.context, "aabb_1")
    first.raylab.spin = False
    bpy.ops.ed.undo_push(message="before")
    assert bpy.ops.raylab.level_next() == {'FINISHED'}
    assert levels.state(bpy.context.scene)["id"] == "aabb_2"
    bpy.ops.ed.undo_push(message="Next Level")
    bpy.ops.ed.undo()
    scene = bpy.context.window.scene
    assert levels.state(scene)["id"] == "aabb_1"
    assert [levels.state(s)["id"] for s in bpy.data.scenes if levels.state(s)] == ["aabb_1"]
    assert levels.level_mesh_object(scene) is not None


def test_open_level_without_an_id_opens_the_first_level():
    assert bpy.ops.raylab.level_open() == {'FINISHED'}
    first = levels.available_levels()[0][0]
    assert levels.state(bpy.context.scene)["id"] == first.id


def test_previous_goes_backward_and_next_forward():
    levels.open_level(bpy.context, "octree_1")
    ids = [level.id for level in levels.available_levels()[0]]
    at = ids.index("octree_1")
    assert bpy.ops.raylab.level_previous() == {'FINISHED'}
    assert levels.state(bpy.context.scene)["id"] == ids[at - 1]
    assert bpy.ops.raylab.level_next() == {'FINISHED'}
    assert levels.state(bpy.context.scene)["id"] == ids[at]


def test_a_level_adds_no_second_camera_and_has_a_world():
    user_scene = bpy.context.window.scene
    if user_scene.camera is None:
        camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        user_scene.collection.objects.link(camera)
        user_scene.camera = camera
    user_camera = user_scene.camera.name
    for level_id in ("aabb_1", "aabb_2"):  # the second one while the first one's objects still exist
        scene = levels.open_level(bpy.context, level_id)
        names = [o.name for o in scene.objects]
        assert not any(n.startswith(user_camera + ".") for n in bpy.data.objects.keys()), names
        assert [o.type for o in scene.objects].count('CAMERA') == 1
        assert not any(n[-4:-3] == "." and n[-3:].isdigit() for n in names), names
        assert scene.world is not None and max(scene.world.color) > 0.0
    assert user_scene.camera.name == user_camera


def test_the_level_render_has_the_world_as_background():
    from raylab.blender import scene_export
    scene = levels.open_level(bpy.context, "aabb_1")
    background = scene_export.world_colour(scene.world)
    assert min(background) > 0.0, "a level's render would have a black background"


def test_the_probe_pixel_starts_inside_the_image():
    for level_id in ("aabb_2", "octree_2"):
        scene = levels.open_level(bpy.context, level_id)
        settings = scene.raylab
        width = scene.render.resolution_x * scene.render.resolution_percentage // 100
        height = scene.render.resolution_y * scene.render.resolution_percentage // 100
        assert (settings.probe_pixel_x, settings.probe_pixel_y) == (width // 2, height // 2)
        settings.probe_pixel_x = 10 * width   # a pixel set outside is kept inside
        assert settings.probe_pixel_x == width - 1
        settings.probe_pixel_x = 7
        assert settings.probe_pixel_x == 7


def test_preferences_hold_the_time_limit_and_the_overlay_default():
    prefs = preferences.settings(bpy.context)
    assert prefs.compare_time_limit == preferences.DEFAULTS["compare_time_limit"] > 0.0
    assert prefs.overlay_in_user_files is False
    assert preferences.RAYLAB_AP_preferences.bl_idname == "raylab"
    assert preferences.documentation() is not None and preferences.documentation().endswith("README.md")


def test_the_overlay_is_off_in_a_new_user_scene_and_on_in_levels():
    scene = bpy.data.scenes.new("a user's scene")
    try:
        assert scene.raylab.show is False
    finally:
        bpy.data.scenes.remove(scene)
    assert levels.open_level(bpy.context, "aabb_1").raylab.show is True


def test_the_preference_turns_the_overlay_on_in_opened_files(monkeypatch):
    """The load_post handler: scenes that never had the overlay switched get the preferred default; a
    scene where the user switched it keeps their choice."""
    untouched = bpy.data.scenes.new("never switched")
    switched = bpy.data.scenes.new("switched off")
    switched.raylab.show = False
    unset = [s for s in bpy.data.scenes if not s.raylab.is_property_set("show")]
    try:
        monkeypatch.setattr(preferences, "settings", lambda context=None: type(
            "Prefs", (), dict(preferences.DEFAULTS, overlay_in_user_files=True))())
        preferences._overlay_default(None)
        assert untouched.raylab.show is True and switched.raylab.show is False
    finally:
        for scene in unset:
            scene.raylab.property_unset("show")
        bpy.data.scenes.remove(untouched)
        bpy.data.scenes.remove(switched)


def test_the_viewport_and_the_render_define_the_structure_settings_alike():
    """scene.raylab and scene.raylab_render hold the same structure settings: the same names, limits and
    descriptions (one definition), so a depth or leaf size the viewport shows is one F12 can take."""
    viewport, render = (bpy.types.Scene.bl_rna.properties[a].fixed_type.properties for a in properties.GROUPS)
    for name in ("max_depth", "leaf_size"):
        limits = [(p.name, p.hard_min, p.hard_max, p.soft_min, p.soft_max, p.description)
                  for p in (viewport[name], render[name])]
        assert limits[0] == limits[1], name
    assert viewport["max_depth_auto"].description == render["max_depth_auto"].description
    assert {item.identifier for item in render["structure"].enum_items} == set(raylab.STRUCTURES)
    assert {item.identifier for item in viewport["structure"].enum_items} == {
        name for name, info in raylab.STRUCTURE_INFO.items() if info["has_boxes"]}
