"""The tutorial levels as a student meets them: opening a level builds its scene and settings from its
level.toml, tasks tick themselves when the student does them (through the same handler the add-on
registers), next / previous walk the list, a mesh swap keeps the settings, and a broken level.toml
gives a clear error, not a crash.

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import glob
import os
import shutil
import sys
import tomllib

import bpy
import numpy as np
import pytest
from mathutils import Vector

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402
from raylab.blender import levels, mesh_data, probe  # noqa: E402
from raylab.blender.experiments import leak  # noqa: E402

LEVELS_DIR = os.path.join(ROOT, "levels")
LEVEL_IDS = sorted(d for d in os.listdir(LEVELS_DIR) if os.path.exists(os.path.join(LEVELS_DIR, d, "level.toml")))


@pytest.fixture(scope="module", autouse=True)
def restore_scene_after_levels():
    before = bpy.context.window.scene
    yield
    # Leave Blender as the other test files expect it: their scene back, no level scenes.
    bpy.context.window.scene = before
    for scene in [s for s in bpy.data.scenes if levels.state(s) is not None]:
        levels._remove_scene(scene)


def toml_of(level_id):
    with open(os.path.join(LEVELS_DIR, level_id, "level.toml"), "rb") as f:
        return tomllib.load(f)


def tick(scene):
    """After the student changes something the depsgraph updates and the add-on's handler checks the
    tasks: the ticks as the Tasks panel shows them then."""
    bpy.context.view_layer.update()
    return [done for _, done in levels.task_list(scene)]


def timer_tick(scene):
    """A render or a comparison stores its results without a depsgraph update: the add-on's timer
    checks the tasks of the window's scene."""
    assert bpy.context.window.scene == scene
    levels._check_timer()
    return [done for _, done in levels.task_list(scene)]


def same(actual, expected):
    if isinstance(expected, list):
        return len(actual) == len(expected) and all(same(a, e) for a, e in zip(actual, expected))
    if isinstance(expected, float):
        return abs(actual - expected) < 1e-6
    return actual == expected


def test_the_required_levels_exist():
    assert {"aabb_1", "aabb_2", "octree_1", "octree_2", "bvh_1", "bvh_2", "why_sah", "race", "where_work_goes",
            "where_methods_fail", "sandbox"} <= set(LEVEL_IDS)
    found, errors = levels.available_levels()
    assert errors == []
    assert [level.id for level in found][:2] == ["aabb_1", "aabb_2"]


@pytest.mark.parametrize("level_id", LEVEL_IDS)
def test_opening_a_level_builds_its_scene_and_settings(level_id):
    data = toml_of(level_id)
    scene = levels.open_level(bpy.context, level_id)
    assert bpy.context.scene == scene
    assert bpy.context.window.scene == scene
    obj = levels.level_mesh_object(scene)
    _, triangles = raylab.load_mesh(os.path.join(levels.MESH_DIR, data["mesh"]["file"]))
    assert len(obj.data.polygons) == len(triangles)
    assert obj["raylab_credit"].startswith(data["mesh"]["file"]) and "from" in obj["raylab_credit"]
    assert scene.camera is not None and any(o.type == 'LIGHT' for o in scene.objects)
    # The mesh fits the camera's frame size for the level's scale, centred on the origin.
    corners = np.array([obj.matrix_world @ Vector(c) for c in obj.bound_box])
    assert (corners.max(axis=0) - corners.min(axis=0)).max() == pytest.approx(
        levels.MESH_SIZE * data.get("scene_scale", 1.0), rel=1e-4)
    for spec in data.get("objects", []):  # the level's other objects: their mesh, size and place
        extra = scene.objects[spec["name"]]
        _, triangles = raylab.load_mesh(os.path.join(levels.MESH_DIR, spec["file"]))
        assert len(extra.data.polygons) == len(triangles)
        corners = np.array([Vector(c) for c in extra.bound_box])
        assert (corners.max(axis=0) - corners.min(axis=0)).max() == pytest.approx(
            spec.get("size", levels.MESH_SIZE) * data.get("scene_scale", 1.0), rel=1e-4)
        assert list(extra.location) == pytest.approx(
            [v * data.get("scene_scale", 1.0) for v in spec.get("location", (0, 0, 0))])
    for group in levels.SETTING_GROUPS:
        for key, value in data.get(group, {}).items():
            actual = getattr(getattr(scene, group), key)
            actual = list(actual) if isinstance(value, list) else actual
            assert same(actual, value), f"{group}.{key} = {actual!r}, level.toml says {value!r}"
    has_ray = probe.PROBE_OBJECT_NAME in scene.objects
    assert has_ray == data.get("raylab", {}).get("probe_enabled", False)
    if has_ray:
        assert scene.raylab.probe_object == scene.objects[probe.PROBE_OBJECT_NAME]
    tasks = levels.task_list(scene)
    assert [text for text, _ in tasks] == [t["text"] for t in data.get("tasks", [])]
    assert not any(tick(scene)), "no task may be done before the student acts"


def test_the_level_1s_spin_and_the_level_2s_probe_the_object():
    scene = levels.open_level(bpy.context, "aabb_1")
    assert scene.raylab.spin and not scene.raylab.probe_enabled
    scene = levels.open_level(bpy.context, "octree_1")
    assert scene.raylab.spin
    for level_id in ("aabb_2", "octree_2"):
        scene = levels.open_level(bpy.context, level_id)
        # VRT's level 2s start with the ray on the object (thesis, figures 11 and 18).
        assert scene.raylab.probe_status == "hit_object"


def test_octree_1_ticks_the_depth_task_and_keeps_the_order():
    scene = levels.open_level(bpy.context, "octree_1")
    scene.raylab.color_by_depth = True  # the second task, done too early: it waits for the first
    assert tick(scene)[:2] == [False, False]
    scene.raylab.max_depth = 4
    assert tick(scene)[0] is False
    scene.raylab.max_depth = 5
    assert tick(scene)[:2] == [True, False]
    assert timer_tick(scene)[:2] == [True, True], "the waiting task ticks on the next check"
    scene.raylab.max_depth = 1  # a tick stays
    assert tick(scene)[0] is True


def aim(ray, origin, direction):
    ray.matrix_world = probe.aim_matrix(origin, direction)
    bpy.context.view_layer.update()


def test_aabb_2_ticks_when_the_ray_misses_the_box_then_grazes_it():
    scene = levels.open_level(bpy.context, "aabb_2")
    ray = scene.raylab.probe_object
    obj = levels.level_mesh_object(scene)
    corners = np.array([obj.matrix_world @ Vector(c) for c in obj.bound_box])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    aim(ray, (0.0, -5.0, hi[2] + 1.0), (0.0, 1.0, 0.0))  # passes above the box
    assert probe.evaluate_probe(scene)["status"] == "missed_root"
    assert tick(scene)[:2] == [True, False]
    # Along the box's edges the goat leaves empty corners: a ray there enters the box, hits no triangle.
    inset = 0.02 * (hi - lo)
    grazing = [(x, z) for x in (lo[0] + inset[0], hi[0] - inset[0]) for z in (lo[2] + inset[2], hi[2] - inset[2])]
    for x, z in grazing:
        aim(ray, (x, -5.0, z), (0.0, 1.0, 0.0))
        if probe.evaluate_probe(scene)["status"] in ("missed_nodes", "missed_triangles"):
            break
    assert tick(scene)[:2] == [True, True]
    aim(ray, (0.0, -5.0, 0.0), (0.0, 1.0, 0.0))
    assert tick(scene)[:3] == [True, True, True]


def test_where_methods_fail_ticks_the_leak_test_then_renders_with_each_setting():
    scene = levels.open_level(bpy.context, "where_methods_fail")
    assert scene.render.engine == "RAYLAB", "a level renders with raylab"
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    assert timer_tick(scene) == [False, False, False, False]
    assert bpy.ops.raylab.level_leak_test() == {'FINISHED'}
    leaks = scene[leak.LEAK_KEY]
    # Rays from inside the closed sphere through its vertices and edges: the watertight test lets none
    # out, Möller–Trumbore some (the lesson of the level).
    assert leaks["rays"] > 1000 and leaks["watertight"] == 0 and leaks["moller_trumbore"] > 0
    # Issue 42 item 7: what the sidebar's Contract changes, on the same rays through the BVH: the exact
    # contract lets none out, the fast one (Möller–Trumbore on stored edges) some; the panel marks the
    # sidebar's choice, and switching it moves the mark.
    assert leaks["contracts"]["exact"] == 0 < leaks["contracts"]["fast"]
    for chosen in raylab.CONTRACTS:
        scene.raylab.contract = chosen
        lines = [text for text, _ in leak.contract_lines(leaks, scene.raylab.contract)]
        label = raylab.CONTRACT_INFO[chosen]["label"]
        assert [line for line in lines if line.endswith("(the sidebar's Contract)")] == [
            f"BVH, {label} contract: {leaks['contracts'][chosen]:,} leaked (the sidebar's Contract)"]
    assert "raylab.contract" in levels.find_level("where_methods_fail").controls
    # The escaped rays, for the viewport: from the centre out through the surface, where they slipped.
    starts, ends, crossings = leak.leak_segments(scene)
    assert len(crossings) == min(leaks["moller_trumbore"], leak.MAX_LEAKS_DRAWN)
    obj = levels.level_mesh_object(scene)
    radius = np.linalg.norm(crossings - np.array(obj.matrix_world.translation), axis=1)
    assert np.allclose(radius, radius.mean(), rtol=0.02)  # all on the sphere: vertices and edge midpoints
    assert np.all(np.linalg.norm(ends - starts, axis=1) > radius)  # drawn on past the surface
    # Edited geometry: the rays belong to the old mesh and are no longer drawn.
    x = obj.data.vertices[0].co.x
    obj.data.vertices[0].co.x = x + 0.01
    assert leak.leak_segments(scene) is None
    obj.data.vertices[0].co.x = x
    assert leak.leak_segments(scene) is not None
    assert timer_tick(scene) == [True, False, False, False]
    bpy.ops.render.render()
    assert "raylab_last_render" in scene
    assert timer_tick(scene) == [True, True, False, False]
    scene.raylab_render.robust_offset = True
    assert timer_tick(scene) == [True, True, False, False], "the old render does not count for the new task"
    bpy.ops.render.render()
    assert timer_tick(scene) == [True, True, True, False]
    assert scene.raylab_render.shadow_terminator is False  # the level starts without it
    scene.raylab_render.shadow_terminator = True
    assert timer_tick(scene) == [True, True, True, False]
    bpy.ops.render.render()
    assert timer_tick(scene) == [True, True, True, True]


def test_race_ticks_when_the_comparison_has_every_structure():
    scene = levels.open_level(bpy.context, "race")
    assert timer_tick(scene)[0] is False
    scene.render.resolution_x, scene.render.resolution_y = 48, 36
    assert bpy.ops.raylab.compare_structures() == {'FINISHED'}
    assert list(scene["raylab_comparison"].keys()) == list(raylab.STRUCTURES)
    assert timer_tick(scene)[0] is True


def test_next_and_previous_walk_the_levels_and_replace_the_scene():
    scene_count = len(bpy.data.scenes)
    levels.open_level(bpy.context, "aabb_1")
    assert bpy.ops.raylab.level_next() == {'FINISHED'}
    assert levels.state(bpy.context.scene)["id"] == "aabb_2"
    assert bpy.ops.raylab.level_previous() == {'FINISHED'}
    assert levels.state(bpy.context.scene)["id"] == "aabb_1"
    with pytest.raises(levels.LevelError, match="first level"):
        levels.step_level(bpy.context, -1)
    assert len(bpy.data.scenes) == max(scene_count, 2), "the previous level's scene is removed"
    assert bpy.ops.raylab.level_open(level_id="sandbox") == {'FINISHED'}
    assert levels.state(bpy.context.scene)["id"] == "sandbox"


def test_mesh_swap_replaces_the_mesh_and_keeps_the_settings():
    scene = levels.open_level(bpy.context, "aabb_1")
    scene.raylab.spin = False
    scene.raylab.max_depth = 3
    obj = levels.level_mesh_object(scene)
    obj.location = (0.5, 0.0, 0.0)
    assert bpy.ops.raylab.level_swap_mesh(source="file:sphere.obj") == {'FINISHED'}
    assert levels.level_mesh_object(scene) == obj
    assert len(obj.data.polygons) == 1280
    assert "CC BY 4.0" in obj["raylab_credit"]
    assert tuple(obj.location) == (0.5, 0.0, 0.0)
    assert scene.raylab.max_depth == 3 and scene.raylab.structure == "aabb" and not scene.raylab.spin

    # One of the student's own mesh objects, from their own scene.
    own = bpy.data.objects.new("My Pyramid", mesh_data.mesh_from_arrays(
        "pyramid", np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32),
        np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.uint32)))
    assert "object:My Pyramid" in levels.mesh_sources(scene)
    levels.swap_mesh(scene, "object:My Pyramid")
    assert len(obj.data.polygons) == 4
    assert len(own.data.polygons) == 4 and own.data != obj.data, "the student's mesh is copied, not taken"
    with pytest.raises(levels.LevelError, match="cannot swap in"):
        levels.swap_mesh(scene, "object:No Such Object")
    with pytest.raises(levels.LevelError, match="no shipped mesh"):
        levels.swap_mesh(scene, "file:nothing.obj")


def test_aabb_1_movement_tasks_follow_the_object():
    scene = levels.open_level(bpy.context, "aabb_1")
    obj = levels.level_mesh_object(scene)
    scene.raylab.spin = False
    assert tick(scene)[:2] == [True, False]
    obj.rotation_euler.z += 1.5  # turning about Z is what spin does: no tilt
    obj.location.x += 1.2
    assert tick(scene)[:3] == [True, True, False]
    obj.rotation_euler.x += 1.0
    assert tick(scene)[:3] == [True, True, True]
    levels.swap_mesh(scene, "file:bunny.obj")
    assert tick(scene) == [True, True, True, True]


BROKEN = {
    "not toml": ("level.toml", lambda text: text.replace('title = "', 'title = "unclosed\n'), "not valid TOML"),
    "no title": ("level.toml", lambda text: text.replace("title =", "titel ="), "'title' is missing"),
    "code in a condition": ("level.toml", lambda text: text.replace(
        'property = "raylab.spin"', 'property = "__import__(\'os\').system"'), "property must be"),
    "unknown test": ("level.toml", lambda text: text.replace("equals = false", "matches = false", 1),
                     "takes exactly one of"),
    "missing diagram": ("text.md", lambda text: text + "\n![x](diagrams/none.png)\n", "does not exist"),
}


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_a_broken_level_gives_a_clear_error(case, tmp_path):
    shutil.copytree(os.path.join(LEVELS_DIR, "aabb_1"), tmp_path / "aabb_1")
    shutil.copytree(os.path.join(LEVELS_DIR, "sandbox"), tmp_path / "sandbox")
    name, edit, message = BROKEN[case]
    path = tmp_path / "aabb_1" / name
    path.write_text(edit(path.read_text(encoding="utf-8")), encoding="utf-8")
    found, errors = levels.available_levels(str(tmp_path))
    assert [level.id for level in found] == ["sandbox"], "the other levels still load"
    assert len(errors) == 1 and message in str(errors[0]) and "aabb_1" in str(errors[0])
    scenes = len(bpy.data.scenes)
    with pytest.raises(levels.LevelError, match=message.replace("(", r"\(")):
        levels.open_level(bpy.context, "aabb_1", root=str(tmp_path))
    assert len(bpy.data.scenes) == scenes


def test_a_setting_that_does_not_exist_leaves_no_half_built_scene(tmp_path):
    shutil.copytree(os.path.join(LEVELS_DIR, "aabb_1"), tmp_path / "aabb_1")
    path = tmp_path / "aabb_1" / "level.toml"
    path.write_text(path.read_text().replace("[raylab]\n", "[raylab]\nno_such_setting = 1\n"))
    scenes = len(bpy.data.scenes)
    with pytest.raises(levels.LevelError, match="no writable setting 'no_such_setting'"):
        levels.open_level(bpy.context, "aabb_1", root=str(tmp_path))
    path.write_text(path.read_text().replace("no_such_setting = 1\n", "").replace(
        'structure = "aabb"', 'structure = "no such structure"', 1))
    with pytest.raises(levels.LevelError, match="structure"):
        levels.open_level(bpy.context, "aabb_1", root=str(tmp_path))
    assert len(bpy.data.scenes) == scenes
    with pytest.raises(RuntimeError, match="no level named 'no_such_level'"):  # the operator's report
        bpy.ops.raylab.level_open(level_id="no_such_level")


def test_every_diagram_the_text_shows_exists_and_is_drawn_by_a_script():
    """Diagrams come from tools/make_diagrams.py, charts (bench_*.png) from ./raylab bench --publish."""
    scripts = {}
    for name, paths in (("make_diagrams", [os.path.join(ROOT, "tools", "make_diagrams.py")]),
                        ("bench", sorted(glob.glob(os.path.join(ROOT, "tools", "bench", "*.py"))))):
        assert paths, name
        scripts[name] = ""
        for path in paths:
            with open(path, encoding="utf-8") as f:
                scripts[name] += f.read()
    for level in levels.available_levels()[0]:
        images = [block[1] for block in level.blocks if block[0] == "image"]
        if level.id != "sandbox":
            assert images, f"{level.id} shows no diagram"
        for path in images:
            assert os.path.getsize(path) > 10_000
            name = os.path.basename(path)
            script = scripts["bench" if name.startswith("bench_") else "make_diagrams"]
            assert f'"{name}"' in script, name


def test_mesh_swap_takes_the_mesh_with_its_modifiers():
    """Suzanne with Subdivision at level 3 renders 62,976 triangles: the swapped-in level mesh has them
    all, whether the object is in the level's scene or in the student's own scene."""
    user_scene = bpy.data.scenes.new("student's scene")
    monkey = bpy.data.objects.new("Subdivided Suzanne", bpy.data.meshes.new("suzanne"))
    user_scene.collection.objects.link(monkey)
    import bmesh
    shape = bmesh.new()
    bmesh.ops.create_monkey(shape)
    shape.to_mesh(monkey.data)
    shape.free()
    subdivision = monkey.modifiers.new("Subdivision", 'SUBSURF')
    subdivision.levels = 3
    try:
        scene = levels.open_level(bpy.context, "aabb_1")
        assert levels.swap_mesh(scene, "object:Subdivided Suzanne") is None
        assert len(levels.level_mesh_object(scene).data.polygons) == 62976
        scene.collection.objects.link(monkey)  # now in the shown scene too
        levels.swap_mesh(scene, "file:sphere.obj")
        levels.swap_mesh(scene, "object:Subdivided Suzanne")
        assert len(levels.level_mesh_object(scene).data.polygons) == 62976
        assert len(monkey.data.polygons) == 500, "the student's own mesh is left as it was"
    finally:
        bpy.data.objects.remove(monkey)
        bpy.data.scenes.remove(user_scene)


def test_race_animation_tasks_tick_with_a_wave_then_rebuild():
    """The race's last tasks: a Wave modifier on the level's mesh with the boxes shown (the BVH then
    refits every frame), then On animation set to Rebuild."""
    from raylab.blender import structure_cache
    scene = levels.open_level(bpy.context, "race")
    st = levels.state(scene)
    st["done"] = [1, 1, 1, 0, 0]  # the comparison tasks, done (test_race_ticks... does the first)
    obj = levels.level_mesh_object(scene)
    scene.raylab.show = True
    assert tick(scene) == [True, True, True, False, False]  # no modifier yet: nothing deforms
    obj.modifiers.new("Wave", 'WAVE').height = 0.2
    assert tick(scene) == [True, True, True, True, False]
    refits = structure_cache.stats["structure_refits"]
    structure_cache.structure_for(obj, scene.raylab)
    scene.frame_set(scene.frame_current + 5)
    entry = structure_cache.structure_for(obj, scene.raylab)
    assert entry.structure.refitted and structure_cache.stats["structure_refits"] == refits + 1
    scene.raylab.animation_update = 'REBUILD'
    assert tick(scene) == [True] * 5
    scene.frame_set(scene.frame_current + 5)
    assert not structure_cache.structure_for(obj, scene.raylab).structure.refitted


def shown_bvh_boxes(scene):
    """The boxes BVH 1's overlay draws for the level mesh with the scene's leaf size, depth range and
    Leaves only: (lo, hi) rows, sorted, rounded (the same box built twice is the same row)."""
    obj = levels.level_mesh_object(scene)
    mesh = obj.data
    vertices = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", vertices)
    mesh.calc_loop_triangles()
    triangles = np.empty(3 * len(mesh.loop_triangles), np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    settings = scene.raylab
    boxes = raylab.build(vertices.reshape(-1, 3), triangles.reshape(-1, 3).astype(np.uint32), structure="bvh",
                         leaf_size=settings.leaf_size).boxes()
    keep = (boxes["depth"] >= settings.depth_min) & (boxes["depth"] <= settings.depth_max)
    if settings.leaves_only:
        keep &= boxes["leaf"]
    rows = np.round(np.concatenate([boxes["lo"][keep], boxes["hi"][keep]], axis=1), 5)
    return rows[np.lexsort(rows.T[::-1])], boxes


def test_bvh_1_leaf_size_task_ticks_once_the_leaves_it_changes_are_shown():
    scene = levels.open_level(bpy.context, "bvh_1")
    scene.raylab.spin = False
    assert tick(scene) == [True, False, False, False]
    scene.raylab.depth_max = 3
    assert tick(scene) == [True, True, False, False]
    top_at_8, _ = shown_bvh_boxes(scene)
    # Leaf size 1 with depths 0 to 3 shown: the same boxes, nothing to see, so the task waits.
    scene.raylab.leaf_size = 1
    top_at_1, tree = shown_bvh_boxes(scene)
    assert np.array_equal(top_at_8, top_at_1)
    assert tick(scene) == [True, True, False, False]
    # The leaves, as the task says: one box per triangle, where leaf size 8 had a few thousand.
    scene.raylab.leaves_only = True
    scene.raylab.depth_max = 64
    assert tick(scene) == [True, True, True, False]
    leaves_at_1, tree = shown_bvh_boxes(scene)
    assert len(leaves_at_1) == len(levels.level_mesh_object(scene).data.polygons)
    # The condition's Depth to 10 already shows every leaf (8-wide or 4-wide nodes alike).
    assert tree["depth"][tree["leaf"]].max() <= 10
    scene.raylab.leaf_size = 8
    leaves_at_8, _ = shown_bvh_boxes(scene)
    assert len(leaves_at_8) < len(leaves_at_1) / 4


def bvh_hardest_pixel(scene):
    """The BVH's hardest pixel as the heat maps count it (tests/blender/test_heat_maps.py checks that the
    record is this): every map pixel's camera ray traced through the API, the most triangle tests."""
    from raylab.blender import build_settings, heat_maps, scene_export
    exported = scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    props = scene.raylab_render
    model, _ = scene_export.build_scene(exported, **build_settings.build_kwargs(props, "bvh"))
    camera = heat_maps.heat_map_camera(exported.camera)
    width, height = raylab.image_size(camera)
    pixels = np.stack(np.meshgrid(np.arange(width), np.arange(height)), axis=-1).reshape(-1, 2) + 0.5
    hits = model.intersect(*raylab.camera_rays(camera, pixels), per_ray=True)
    return int(hits.per_ray[heat_maps.COUNTER].max())


def test_where_work_goes_rod_task_ticks_once_the_rod_and_its_boxes_leave_the_goat():
    """The rod task as its text tells it: 2 m along any axis, either way, makes the BVH's hardest pixel
    cost what the goat alone costs; 1.5 m up, or straight behind the goat seen from the camera, does not
    make it cheaper."""
    from raylab.blender import heat_maps

    def render():
        assert bpy.ops.raylab.heat_maps(time_limit=0.0) == {'FINISHED'}
        return scene[heat_maps.RECORD]["structures"]["bvh"]["hardest"]

    scene = levels.open_level(bpy.context, "where_work_goes")
    rod = scene.objects["Rod"]
    start = rod.location.copy()
    at_start = render()
    assert timer_tick(scene) == [True, False, False] and bvh_hardest_pixel(scene) == at_start
    octree = scene[heat_maps.RECORD]["structures"]["octree"]["probe_pixel"]
    scene.raylab.probe_pixel_x, scene.raylab.probe_pixel_y = octree
    assert tick(scene) == [True, True, False]
    rod.location.z += 100.0  # out of the picture: the goat alone
    goat_alone = bvh_hardest_pixel(scene)
    assert goat_alone < at_start

    # 1.5 m up the rod clears the goat in the picture, its boxes do not: no cheaper, no tick.
    rod.location = start + Vector((0.0, 0.0, 1.5))
    assert render() == at_start
    assert timer_tick(scene) == [True, True, False]
    away = (scene.camera.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0))).normalized()
    rod.location = start + away * 2.5  # hidden behind the goat: its outline's rays still pay
    assert bvh_hardest_pixel(scene) == at_start
    for axis in range(3):
        for sign in (1.0, -1.0):
            offset = Vector([2.0 * sign if i == axis else 0.0 for i in range(3)])
            rod.location = start + offset
            assert bvh_hardest_pixel(scene) == goat_alone, f"the rod moved by {tuple(offset)}"
    # The last one, rendered: the task ticks.
    assert render() == goat_alone
    assert timer_tick(scene) == [True, True, True]


def test_a_level_that_asks_to_read_the_render_shows_it_under_its_tasks():
    """Issue 42 item 6: AABB 2 says "render and read Rays ignored"; the number was at the bottom of the
    sidebar and the render window's header was cut. The Tasks panel of a level whose task waits for a render
    draws the last render's numbers (viewport_panels.last_render_in_tasks); other levels' do not."""
    from raylab.blender import level_panels, viewport_panels
    assert viewport_panels.last_render_in_tasks in level_panels.TASK_SECTIONS
    asking = [level.id for level in levels.available_levels()[0] if viewport_panels.reads_last_render(level)]
    assert "aabb_2" in asking and "why_sah" not in asking
    assert not viewport_panels.reads_last_render(None)


def test_the_sidebar_s_contract_changes_the_rays_drawn_and_the_price_point():
    """Issue 42 item 7: switching the sidebar's Contract changed nothing visible in Where methods fail. The
    rays the BVH lets out under the chosen contract are drawn (none under exact, the fast one's leaks under
    fast), the panel puts the mesh on the price chart at the chosen contract's point, and the level's text
    quotes the same counts (the fast contract's within a few rays: its rounding follows the CPU's
    instructions, AVX2 or SSE)."""
    scene = levels.open_level(bpy.context, "where_methods_fail")
    assert bpy.ops.raylab.level_leak_test() == {'FINISHED'}
    leaks = scene[leak.LEAK_KEY]
    points = {}
    for chosen in raylab.CONTRACTS:
        scene.raylab.contract = chosen
        segments = leak.leak_segments(scene, scene.raylab.contract)
        assert (0 if segments is None else len(segments[2])) == min(leaks["contracts"][chosen], leak.MAX_LEAKS_DRAWN)
        wrong, speed = leak.price_point(leaks, chosen)
        assert wrong == 1e6 * leaks["contracts"][chosen] / leaks["rays"] and speed > 0
        lines = [text for text, _ in leak.contract_lines(leaks, scene.raylab.contract) if "price chart" in text]
        assert len(lines) == 1 and raylab.CONTRACT_INFO[chosen]["label"] in lines[0]
        assert f"{wrong:,.0f} wrong per million" in lines[0]
        points[chosen] = lines[0]
    assert points["exact"] != points["fast"]
    # The viewport's price chart: a point per contract, the one with more leaks further right, the sidebar's
    # Contract ringed (its label says so).
    for chosen in raylab.CONTRACTS:
        plot, placed, ringed, labels = leak.price_chart_layout(leaks, chosen)
        assert ringed == chosen and [name for name, *_ in placed] == list(raylab.CONTRACTS)
        assert sum(text.endswith("(sidebar)") for _, _, text, _ in labels) == 1
        x0, y0, w, h = leak.PRICE_FRAME
        assert all(x0 <= x <= x0 + w and y0 <= y <= y0 + h for _, x, y, _ in placed)
    where = {name: (x, y) for name, x, y, _ in placed}
    assert where["fast"][0] > where["exact"][0]
    assert leak.leak_segments(scene, "exact") is None and leak.leak_segments(scene, "fast") is not None
    text = " ".join(block[1] for block in levels.find_level("where_methods_fail").blocks if block[0] == "paragraph")
    assert f"its {leaks['rays']:,} rays" in text
    for quoted_after, measured in (("the fast one ", leaks["contracts"]["fast"]),
                                   ("Möller–Trumbore's ", leaks["moller_trumbore"])):
        quoted = int(text.split(quoted_after)[1].split(" ")[0].strip(",.").replace(",", ""))
        assert abs(quoted - measured) <= 0.1 * measured, (quoted_after, quoted, measured)
