"""The viewport cost heat map's rays and counts (headless): its rays go through the view's cells as the
camera sees them, and a cell did work exactly where its ray comes near the mesh."""
import os
import sys

import bpy
import numpy as np
import pytest
from mathutils import Vector

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
import raylab  # noqa: E402
from raylab.blender import cost_overlay, structure_cache  # noqa: E402


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
