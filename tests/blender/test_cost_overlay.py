"""The viewport cost heat map's rays and counts (headless): its rays go through the view's cells as the
camera sees them, and a cell did work exactly where its ray comes near the mesh."""
import gc
import os
import sys

import bpy
import numpy as np
import pytest
from mathutils import Vector

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
import raylab  # noqa: E402
from raylab.blender import cost_overlay, scene_export, structure_cache, viewport_panels  # noqa: E402


@pytest.fixture
def sphere_and_camera():
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    structure_cache.clear()
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=1.0, location=(0.3, 0.2, 0.0))
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    camera.location = (0.0, -6.0, 1.0)
    camera.rotation_euler = (1.45, 0.0, 0.0)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.raylab.structure = "bvh"
    scene.raylab.cost_counter = "triangle_tests"
    scene.raylab.cost_cells = 64
    bpy.context.view_layer.update()
    return scene, camera


def perspective_matrix(scene, camera):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    r = scene.render
    projection = camera.calc_matrix_camera(depsgraph, x=r.resolution_x, y=r.resolution_y)
    return projection @ camera.matrix_world.inverted()


@pytest.mark.parametrize("kind", ["PERSP", "ORTHO"])
def test_rays_go_through_the_cells_the_camera_sees(sphere_and_camera, kind):
    scene, camera = sphere_and_camera
    camera.data.type = kind
    bpy.context.view_layer.update()
    origins, directions = cost_overlay.view_rays(perspective_matrix(scene, camera), 2, 2)
    # The camera's frame corners (camera space) map to NDC ±1: cell centres lie half-way to them.
    frame = [camera.matrix_world @ v for v in camera.data.view_frame(scene=scene)]
    centre = sum(frame, Vector()) / 4
    forward = camera.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0))
    for origin, direction in zip(origins.astype(float), directions.astype(float)):
        if kind == "ORTHO":
            assert np.allclose(direction, forward, atol=1e-5)
        # every ray passes through the frame's plane half-way between its centre and one corner
        plane_t = np.dot(np.array(centre) - origin, forward) / np.dot(direction, forward)
        point = Vector(origin + plane_t * direction)
        assert min((point - (centre + 0.5 * (c - centre))).length for c in frame) < 1e-3


def test_cells_did_work_where_their_rays_come_near_the_mesh(sphere_and_camera):
    scene, camera = sphere_and_camera
    matrix = perspective_matrix(scene, camera)
    r = scene.render
    grid = cost_overlay.cost_grid(scene, matrix, r.resolution_x, r.resolution_y)
    assert (grid.columns, grid.rows) == (64, 48)
    origins, directions = cost_overlay.view_rays(matrix, grid.columns, grid.rows)
    sphere = next(o for o in scene.objects if o.type == 'MESH')
    hits = raylab.build(*sphere_arrays(sphere)).intersect(origins, directions)
    hit = np.isfinite(hits.t).reshape(grid.rows, grid.columns)
    assert hit.sum() > 100
    assert (grid.counts[hit] > 0).all(), "a ray that hits the sphere tested no triangle"
    # rays that pass the sphere's centre farther than twice its radius test no triangle under the BVH
    centre = np.array(sphere.location)
    to_centre = centre - origins
    distance = np.linalg.norm(to_centre - (to_centre * directions).sum(1, keepdims=True) * directions, axis=1)
    far = (distance > 2.0).reshape(grid.rows, grid.columns)
    assert far.sum() > 100 and (grid.counts[far] == 0).all()
    # the grid is traced once for a view: asking again returns the same grid
    assert cost_overlay.cost_grid(scene, matrix, r.resolution_x, r.resolution_y) is grid


def test_the_legend_says_why_an_object_is_not_traced(sphere_and_camera):
    """Issue 27, item 11: a NaN vertex left the map empty and its legend read "hardest here 0"."""
    scene, camera = sphere_and_camera
    sphere = next(o for o in scene.objects if o.type == 'MESH')
    sphere.data.vertices[3].co = (float("nan"), 0.0, 0.0)
    sphere.data.update()
    bpy.context.view_layer.update()
    r = scene.render
    grid = cost_overlay.cost_grid(scene, perspective_matrix(scene, camera), r.resolution_x, r.resolution_y)
    errors = structure_cache.scene_model(scene).errors()
    title = cost_overlay.legend_title(scene.raylab, grid, errors)
    assert f"{sphere.name}: vertex 3 has a NaN or infinite coordinate" in title and "hardest here" not in title


def sphere_arrays(obj):
    mesh = obj.data
    m = np.array(obj.matrix_world)
    vertices = np.array([tuple(v.co) for v in mesh.vertices]) @ m[:3, :3].T + m[:3, 3]
    mesh.calc_loop_triangles()
    triangles = np.array([tuple(t.vertices) for t in mesh.loop_triangles], dtype=np.uint32)
    return vertices.astype(np.float32), triangles


def test_counter_choices_are_the_structures_work_counters():
    items = bpy.context.scene.raylab.bl_rna.properties["cost_counter"].enum_items
    names = [item.identifier for item in items]
    assert set(names) == {n for n, info in raylab.COUNTER_INFO.items() if info["object_work"]}


@pytest.fixture
def many_objects():
    """An artist's scene: a dense sphere and 24 linked copies of a coarse Suzanne, the camera on them all."""
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    structure_cache.clear()
    bpy.ops.mesh.primitive_monkey_add(location=(0.0, 0.0, 0.0))
    base = bpy.context.active_object
    base.name = "Suzanne linked"
    for i in range(24):
        copy = base.copy()  # linked: the same mesh
        copy.location = ((i % 5) * 2.2 - 4.4, (i // 5) * 2.2, 0.0)
        scene.collection.objects.link(copy)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, location=(0.0, -3.0, 0.0))
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    camera.location, camera.rotation_euler = (0.0, -14.0, 9.0), (1.0, 0.0, 0.0)
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 320, 180, 100
    settings = scene.raylab
    settings.structure, settings.objects, settings.show, settings.cost_enabled = "octree", 'ALL', True, False
    bpy.context.view_layer.update()
    yield scene
    settings.show = False


def camera_ray_counts(scene):
    """Each of the ranking's camera rays traced through the scene model, as the render traces them."""
    model = structure_cache.scene_model(scene)
    camera = scene_export.camera_dict(scene, scene.camera)
    origins, directions = raylab.camera_rays(camera, cost_overlay.camera_grid(camera))
    return model.scene.intersect(origins, directions, tmin=camera["clip_start"], per_ray=True).per_ray


@pytest.mark.parametrize("structure", ["octree", "bvh"])
def test_the_objects_triangle_tests_add_up_to_the_camera_rays_and_the_dense_sphere_costs_most(many_objects,
                                                                                              structure):
    scene = many_objects
    scene.raylab.structure = structure
    costs, why_not = cost_overlay.object_costs(scene)
    assert why_not is None and costs.told == costs.rays
    assert sum(costs.counts.values()) == camera_ray_counts(scene)["triangle_tests"].sum()
    ranked = costs.ranked()
    assert len(ranked) == 26 and ranked[0][0] == "Sphere"
    assert [count for _, count, _ in ranked] == sorted(costs.counts.values(), reverse=True)
    assert sum(share for _, _, share in ranked) == pytest.approx(1.0)
    assert cost_overlay.last_object_costs(scene) == (costs, None)
    assert cost_overlay.object_costs(scene)[0] is costs  # nothing changed: not traced again


def test_a_scene_model_made_after_a_file_load_is_never_taken_for_the_one_it_replaced(many_objects):
    """Opening a file lets go of every scene model (structure_cache.clear): the next one Python allocates
    often takes the freed one's address. The ranking, the cost map and the probe must trace the new model,
    not return what the old one (another structure, another file) gave."""
    scene = many_objects
    for structure in ["octree", "bvh", "grid"] * 3:
        structure_cache.clear()
        gc.collect()  # what Python does sooner or later; 3.14's incremental collector does it at once
        scene.raylab.structure = structure
        costs, why_not = cost_overlay.object_costs(scene)
        assert why_not is None
        assert sum(costs.counts.values()) == camera_ray_counts(scene)["triangle_tests"].sum(), structure


def test_an_object_out_of_the_cameras_view_costs_nothing_and_a_move_ranks_again(many_objects):
    scene = many_objects
    suzanne = scene.objects["Suzanne linked.003"]
    suzanne.location = (0.0, -40.0, 0.0)  # behind the camera
    bpy.context.view_layer.update()
    costs, _ = cost_overlay.object_costs(scene)
    assert costs.counts[suzanne.name] == 0 and costs.ranked()[-1][0] == suzanne.name
    suzanne.location = (0.0, -9.0, 5.5)  # close in front of the camera: big in the picture
    bpy.context.view_layer.update()
    moved, _ = cost_overlay.object_costs(scene)
    assert moved is not costs and moved.counts[suzanne.name] > costs.counts["Suzanne linked.004"]


def test_over_the_budget_every_kth_ray_is_told_apart_and_the_panel_says_so(many_objects, monkeypatch):
    scene = many_objects
    monkeypatch.setattr(cost_overlay, "RANK_BUDGET", 2000)
    costs, _ = cost_overlay.object_costs(scene)
    work = camera_ray_counts(scene)["triangle_tests"]
    told = np.flatnonzero(work)[::int(np.ceil(work.sum() / 2000))]
    assert 0 < costs.told == len(told) < (work > 0).sum()
    assert sum(costs.counts.values()) == work[told].sum()  # exact, for the rays told apart
    header = viewport_panels.object_lines(bpy.context)[0][0]
    assert f"{costs.rays:,} rays from the camera (shares from a sample of {costs.told:,} of them)" in header


def test_the_structure_panel_ranks_the_costliest_objects_and_counts_the_rest(many_objects):
    scene = many_objects
    costs, _ = cost_overlay.object_costs(scene)
    lines = [text for text, _ in viewport_panels.object_lines(bpy.context)]
    assert lines[0].startswith("Costliest objects, by their share of the triangle tests")
    ranked = costs.ranked()
    listed = lines[1:1 + viewport_panels.TOP_OBJECTS]
    for (name, _, share), line in zip(ranked, listed):
        assert line.startswith(f"{viewport_panels.share_text(share)} {name}: ") and "boxes" in line
    rest = ranked[viewport_panels.TOP_OBJECTS:]
    assert lines[1 + viewport_panels.TOP_OBJECTS:] == [
        f"and {len(rest)} more, {viewport_panels.share_text(sum(s for _, _, s in rest))} together"]
    scene.camera = None
    cost_overlay.object_costs(scene)
    assert viewport_panels.object_lines(bpy.context)[-1][0] == "Costliest objects: No scene camera to look through"


def test_the_viewport_shows_the_heat_maps_own_colours():
    """The viewport draws colours as they are shown: the cells and the legend are raylab.HEAT_COLOURS
    themselves (black to pale yellow), not their linear values, which looked darker."""
    maximum = 64
    stops = np.linspace(0, maximum, len(raylab.HEAT_COLOURS))
    np.testing.assert_allclose(cost_overlay.display_colours(stops, maximum)[:, :3], raylab.HEAT_COLOURS, atol=2e-3)
    counts = np.array([[0, 8], [64, 200]], np.float32)
    _, colours, _ = cost_overlay.cell_quads(counts, 100, 100, maximum, alpha=1.0)
    assert len(colours) == 4 * 3  # the cell without work is not drawn
    np.testing.assert_allclose(colours[-1, :3], raylab.HEAT_COLOURS[-1], atol=2e-3)  # above the maximum: the top
