"""The structure overlay: the world AABB follows the object as VRT's does, octree and BVH boxes are
carried by the transform without a rebuild, the filters pick the right boxes, spin turns the object.

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import os
import sys

import bpy
import numpy as np
import pytest
from mathutils import Matrix

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
import raylab  # noqa: E402
from raylab.blender import draw, overlay, probe, properties, spin, structure_cache  # noqa: E402


@pytest.fixture
def monkey_scene():
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    structure_cache.clear()
    bpy.ops.mesh.primitive_monkey_add()
    monkey = bpy.context.object
    settings = scene.raylab
    settings.structure, settings.max_depth, settings.leaf_size = "aabb", 4, 8
    settings.objects, settings.depth_min, settings.depth_max = 'ALL', 0, 64
    settings.leaves_only = settings.color_by_depth = settings.spin = False
    settings.fade = True
    settings.animation_update = 'REFIT'
    bpy.context.view_layer.update()
    return scene, monkey


def world_vertex_bounds(obj):
    m = np.array(obj.matrix_world)
    v = np.array([tuple(v.co) for v in obj.data.vertices]) @ m[:3, :3].T + m[:3, 3]
    return v.min(axis=0), v.max(axis=0)


def drawn_world_box(obj, scene):
    geometry = overlay.line_geometry(obj, scene)
    model = structure_cache.structure_for(obj, scene.raylab).model_matrix(obj)
    corners = structure_cache.transform_points(model, geometry.positions.astype(float))
    return corners.min(axis=0), corners.max(axis=0)


def test_world_aabb_follows_a_rotated_object(monkey_scene):
    scene, monkey = monkey_scene
    for rotation in (0.0, 0.5, 1.3):
        monkey.matrix_world = (Matrix.Translation((1.0, -2.0, 0.5)) @ Matrix.Rotation(rotation, 4, 'Z')
                               @ Matrix.Rotation(0.4, 4, 'X') @ Matrix.Diagonal((2.0, 1.0, 0.5, 1.0)))
        bpy.context.view_layer.update()
        lo, hi = drawn_world_box(monkey, scene)
        expected_lo, expected_hi = world_vertex_bounds(monkey)
        np.testing.assert_allclose(lo, expected_lo, atol=1e-4)
        np.testing.assert_allclose(hi, expected_hi, atol=1e-4)


@pytest.mark.parametrize("structure", ["octree", "bvh"])
def test_moving_the_object_rebuilds_nothing(monkey_scene, structure):
    scene, monkey = monkey_scene
    scene.raylab.structure = structure
    first = overlay.line_geometry(monkey, scene)
    builds = dict(structure_cache.stats), dict(overlay.stats)
    lo_before, hi_before = drawn_world_box(monkey, scene)

    monkey.location = (3.0, 1.0, -1.0)
    monkey.rotation_euler = (0.3, 0.2, 1.1)
    bpy.context.view_layer.update()
    assert overlay.line_geometry(monkey, scene) is first
    assert (dict(structure_cache.stats), dict(overlay.stats)) == builds
    lo_after, _ = drawn_world_box(monkey, scene)
    assert not np.allclose(lo_before, lo_after)  # the same batch, drawn where the object now is

    scene.raylab.leaves_only = True  # a filter: a new batch from the same structure
    assert overlay.line_geometry(monkey, scene) is not first
    assert structure_cache.stats["structure_builds"] == builds[0]["structure_builds"]
    assert overlay.stats["batch_builds"] == builds[1]["batch_builds"] + 1

    # A geometry change with the same triangles (a scale keeps how Blender splits each quad): the
    # BVH's structure is refitted (animation_update 'REFIT', the default), the octree's rebuilt (its
    # cells depend on the positions).
    monkey.data.transform(Matrix.Scale(1.25, 4))
    monkey.data.update()
    bpy.context.view_layer.update()
    overlay.line_geometry(monkey, scene)
    refits = raylab.STRUCTURE_INFO[structure]["refits"]
    assert structure_cache.stats["structure_builds"] == builds[0]["structure_builds"] + (not refits)
    assert structure_cache.stats["structure_refits"] == builds[0]["structure_refits"] + refits

    scene.raylab.animation_update = 'REBUILD'  # another geometry change, rebuilt whatever the kind
    monkey.data.transform(Matrix.Scale(0.8, 4))
    monkey.data.update()
    bpy.context.view_layer.update()
    overlay.line_geometry(monkey, scene)
    assert structure_cache.stats["structure_builds"] == builds[0]["structure_builds"] + 1 + (not refits)


def test_filters_pick_depths_and_leaves(monkey_scene):
    scene, monkey = monkey_scene
    settings = scene.raylab
    settings.structure, settings.max_depth = "octree", 4
    boxes = structure_cache.structure_for(monkey, settings).boxes()
    assert boxes["depth"].max() == 4

    settings.depth_min, settings.depth_max = 2, 3
    assert overlay.line_geometry(monkey, scene).box_count == np.sum((boxes["depth"] >= 2) & (boxes["depth"] <= 3))
    settings.depth_max = 1  # pulls the lower end down with it
    assert settings.depth_min == 1
    settings.depth_min, settings.depth_max = 0, 10
    settings.leaves_only = True
    geometry = overlay.line_geometry(monkey, scene)
    assert geometry.box_count == boxes["leaf"].sum() < len(boxes["leaf"])
    assert len(geometry.indices) == 12 * geometry.box_count and geometry.indices.dtype == np.uint32

    settings.leaves_only = False
    settings.color_by_depth = True
    colors = overlay.line_geometry(monkey, scene).colors[::8]
    np.testing.assert_allclose(colors[:, :3], overlay.DEPTH_PALETTE[boxes["depth"] % len(overlay.DEPTH_PALETTE)])
    alpha_by_depth = [colors[boxes["depth"] == d, 3].max() for d in range(5)]
    assert all(a > b for a, b in zip(alpha_by_depth, alpha_by_depth[1:]))  # fade: deeper is fainter
    settings.fade = False
    assert np.all(overlay.line_geometry(monkey, scene).colors[:, 3] == 1.0)
    settings.probe_enabled = True  # the probe's path must stand out: the boxes fade behind it
    assert np.allclose(overlay.line_geometry(monkey, scene).colors[:, 3], overlay.PROBE_DIM)
    settings.probe_enabled = False


def test_the_cost_heat_map_reads_over_the_boxes(monkey_scene):
    """Issue 27: with the heat map on, its cells were buried under the green boxes: the boxes stay, faint."""
    scene, monkey = monkey_scene
    settings = scene.raylab
    settings.structure, settings.fade = "octree", False
    assert np.all(overlay.line_geometry(monkey, scene).colors[:, 3] == 1.0)
    settings.cost_enabled = True
    try:
        alpha = overlay.line_geometry(monkey, scene).colors[:, 3]
        assert np.allclose(alpha, overlay.COST_DIM) and overlay.COST_DIM < overlay.PROBE_DIM
        settings.probe_enabled = True  # the heat map is the fainter of the two
        assert np.allclose(overlay.line_geometry(monkey, scene).colors[:, 3], overlay.COST_DIM)
    finally:
        settings.cost_enabled = settings.probe_enabled = False


def test_the_depth_key_lists_every_depth_drawn_in_its_boxes_colour(monkey_scene):
    scene, monkey = monkey_scene
    settings = scene.raylab
    settings.structure, settings.max_depth, settings.color_by_depth, settings.fade = "octree", 4, True, False
    geometry = overlay.line_geometry(monkey, scene)
    boxes = structure_cache.structure_for(monkey, settings).boxes()
    key = overlay.depth_key(settings, overlay.drawn_depths(scene))
    assert [depth for depth, _ in key] == [0, 1, 2, 3, 4]
    for depth, colour in key:  # the colour the boxes of that depth are drawn in
        drawn = geometry.colors[::8][boxes["depth"] == depth]
        np.testing.assert_allclose(drawn, np.broadcast_to(colour, drawn.shape))
    settings.depth_min, settings.depth_max = 2, 3
    assert [depth for depth, _ in overlay.depth_key(settings, overlay.drawn_depths(scene))] == [2, 3]
    settings.depth_min, settings.depth_max, settings.leaves_only = 0, 64, True
    leaf_depths = sorted(set(boxes["depth"][boxes["leaf"]].tolist()))
    assert [depth for depth, _ in overlay.depth_key(settings, overlay.drawn_depths(scene))] == leaf_depths
    # deeper than the palette: the colours repeat, and the key says which depth has which
    deep = overlay.depth_key(settings, range(len(overlay.DEPTH_PALETTE) + 2))
    np.testing.assert_allclose(deep[len(overlay.DEPTH_PALETTE)][1][:3], overlay.DEPTH_PALETTE[0])
    settings.leaves_only = settings.color_by_depth = False


def test_selected_objects_only(monkey_scene):
    scene, monkey = monkey_scene
    bpy.ops.mesh.primitive_cube_add(location=(4.0, 0.0, 0.0))
    cube = bpy.context.object
    assert set(structure_cache.target_objects(scene)) == {monkey, cube}
    scene.raylab.objects = 'SELECTED'
    monkey.select_set(False)
    cube.select_set(True)
    assert structure_cache.target_objects(scene) == [cube]


def test_spin_turns_the_object_on_frame_change(monkey_scene):
    scene, monkey = monkey_scene
    scene.frame_set(1)
    start = monkey.rotation_euler.z
    scene.frame_set(2)
    assert monkey.rotation_euler.z == start
    scene.raylab.spin = True
    scene.frame_set(3)
    scene.raylab.spin = False
    assert monkey.rotation_euler.z == pytest.approx(start + spin.SPIN_STEP)
    bpy.context.view_layer.update()
    lo, hi = drawn_world_box(monkey, scene)  # and the world AABB turned with it
    np.testing.assert_allclose((lo, hi), world_vertex_bounds(monkey), atol=1e-4)


def test_ensure_probe_object_creates_one_arrow(monkey_scene):
    scene = monkey_scene[0]
    scene.raylab.probe_object = None
    ray = probe.ensure_probe_object(scene)
    assert ray.name == probe.PROBE_OBJECT_NAME and ray.empty_display_type == 'SINGLE_ARROW'
    assert probe.ensure_probe_object(scene) is ray
    assert scene.raylab.probe_object is ray
    assert sum(o.type == 'EMPTY' for o in scene.objects) == 1


def test_one_raylab_scene_per_blender_scene(monkey_scene):
    """The overlay and the probe share one raylab.Scene per Blender scene, changed only where Blender
    changed: a move moves an instance, hiding drops it, showing it again rebuilds nothing."""
    scene, monkey = monkey_scene
    scene.raylab.structure = "bvh"
    bpy.ops.mesh.primitive_cube_add(location=(4.0, 0.0, 0.0))
    cube = bpy.context.object
    bpy.context.view_layer.update()
    model = structure_cache.scene_model(scene)
    assert sorted(model.instances) == sorted([monkey.name_full, cube.name_full])
    traced, builds = model.scene, structure_cache.stats["structure_builds"]

    cube.location.x = 7.0
    bpy.context.view_layer.update()
    model = structure_cache.scene_model(scene)
    hit = model.scene.intersect([7.0, 0.0, 5.0], [0.0, 0.0, -1.0])
    assert model.scene is traced and model.instances[hit.instance[0]] == cube.name_full
    assert hit.t[0] == pytest.approx(4.0, abs=1e-5)  # the cube's top at z = 1

    cube.hide_set(True)
    bpy.context.view_layer.update()
    assert structure_cache.scene_model(scene).instances == [monkey.name_full]
    assert not structure_cache.scene_model(scene).scene.intersect([7.0, 0.0, 5.0], [0.0, 0.0, -1.0]).hit[0]
    cube.hide_set(False)
    bpy.context.view_layer.update()
    assert structure_cache.scene_model(scene).scene is traced
    assert structure_cache.stats["structure_builds"] == builds

    cube.scale = (0.0, 0.0, 0.0)  # an instance the scene cannot invert: said, and the rest still traced
    bpy.context.view_layer.update()
    assert "singular" in structure_cache.structure_for(cube, scene.raylab).error
    assert structure_cache.structure_for(monkey, scene.raylab).structure is not None
    model = structure_cache.scene_model(scene)
    assert model.instances == [monkey.name_full]
    version = model.version  # a refused instance is not tried again on every redraw
    assert structure_cache.scene_model(scene).version == version


@pytest.mark.parametrize("structure", ["octree", "bvh", "aabb"])
def test_core_line_arrays_equal_the_former_numpy_ones(monkey_scene, structure):
    """The overlay's arrays come from the core (Structure.boxes(lines=True)); they equal, value for value,
    what overlay.py made from boxes() with numpy before, for each filter and colouring."""
    scene, monkey = monkey_scene
    settings = scene.raylab
    settings.structure = structure
    boxes = structure_cache.structure_for(monkey, settings).boxes()
    corner_bits = np.array([[(c >> axis) & 1 for axis in range(3)] for c in range(8)], dtype=bool)
    for depth_min, depth_max, leaves_only, by_depth, fade, probe_on in [(0, 64, False, True, True, False),
                                                                        (1, 3, False, False, True, True),
                                                                        (0, 64, True, False, False, False)]:
        settings.depth_min, settings.depth_max = depth_min, depth_max
        settings.leaves_only, settings.color_by_depth, settings.fade = leaves_only, by_depth, fade
        settings.probe_enabled = probe_on
        geometry = overlay.line_geometry(monkey, scene)
        keep = (boxes["depth"] >= settings.depth_min) & (boxes["depth"] <= settings.depth_max)
        if leaves_only:
            keep &= boxes["leaf"]
        lo, hi, depth = boxes["lo"][keep], boxes["hi"][keep], boxes["depth"][keep]
        corners = np.where(corner_bits[None, :, :], hi[:, None, :], lo[:, None, :]).reshape(-1, 3)
        if by_depth:
            rgba = np.empty((len(depth), 4), dtype=np.float32)
            rgba[:, :3] = overlay.DEPTH_PALETTE[depth % len(overlay.DEPTH_PALETTE)]
            rgba[:, 3] = 1.0
        else:
            rgba = np.tile(np.asarray(settings.line_color, dtype=np.float32), (len(depth), 1))
        if fade:
            by_density = min(1.0, np.sqrt(200.0 / max(len(depth), 1)))
            rgba[:, 3] *= np.maximum(1.0 / (1.0 + 0.35 * depth.astype(np.float32)) * by_density, 0.12)
        if probe_on:
            rgba[:, 3] *= overlay.PROBE_DIM
        assert geometry.box_count == int(keep.sum())
        np.testing.assert_array_equal(geometry.positions, corners.astype(np.float32))
        # Colours to a float32 ulp or so: NumPy 2 (Debian 13) computes the reference's alpha in float64
        # (a float64 scalar no longer yields to a float32 array), the core and NumPy 1 in float32.
        np.testing.assert_allclose(geometry.colors, np.repeat(rgba, 8, axis=0), rtol=1e-6, atol=0)
        edges = (draw.BOX_EDGES[None, :, :] + (8 * np.arange(len(depth), dtype=np.uint32))[:, None, None])
        np.testing.assert_array_equal(geometry.indices, edges.reshape(-1, 2))
    settings.probe_enabled = False


def test_a_new_object_under_an_old_name_gets_its_own_structure(monkey_scene):
    """Opening a level after another replaces its "Level mesh" object by a new one of the same name; on
    5.2 no geometry change is reported for it. The overlay must draw the new mesh's boxes, not the old's."""
    scene, monkey = monkey_scene
    scene.raylab.structure = "octree"
    name = monkey.name
    before = structure_cache.structure_for(monkey, scene.raylab).structure.boxes()
    bpy.data.objects.remove(monkey)
    cube = bpy.data.meshes.new("Other mesh")
    cube.from_pydata([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], [],
                     [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    replacement = bpy.data.objects.new(name, cube)
    scene.collection.objects.link(replacement)
    replacement.select_set(True)
    assert replacement.name == name
    after = structure_cache.structure_for(replacement, scene.raylab).structure
    assert after.mesh()[1].shape[0] == 12  # the cube's triangles, not the monkey's
    assert len(after.boxes()["lo"]) != len(before["lo"])


def test_the_builder_menu_builds_the_bvh_it_names_and_other_kinds_ignore_it(monkey_scene):
    """The Builder menu (both groups, from raylab.BUILDERS) is a build setting: the BVH is rebuilt with it,
    and a kind without a builder keeps its one build (its cache key does not change)."""
    scene, monkey = monkey_scene
    for group in properties.GROUPS:
        items = bpy.types.Scene.bl_rna.properties[group].fixed_type.properties["builder"].enum_items
        assert [item.identifier for item in items] == list(raylab.BUILDERS)
    settings = scene.raylab
    settings.structure = "bvh"
    for builder in raylab.BUILDERS:
        settings.builder = builder
        bpy.context.view_layer.update()
        entry = structure_cache.structure_for(monkey, settings)
        assert entry.structure.builder == builder and entry.structure.tree()["node_count"] > 1
    settings.structure = "octree"
    before = structure_cache.structure_for(monkey, settings).structure
    settings.builder = raylab.BUILDERS[0]
    bpy.context.view_layer.update()
    assert structure_cache.structure_for(monkey, settings).structure is before
