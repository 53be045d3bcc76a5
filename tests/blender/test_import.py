"""raylab inside Blender, on the way users feed it: the evaluated mesh of an object with a modifier,
read with foreach_get, traced with every structure and compared with brute force and with Blender's
own ray casts (scene.ray_cast and mathutils.bvhtree)."""
import bpy
import numpy as np
import pytest
from mathutils import Vector
from mathutils.bvhtree import BVHTree

import raylab

EYE = np.array([0.3, -6.0, 0.4])


@pytest.fixture(scope="module")
def suzanne():
    """A subdivided Suzanne at the origin, the only visible object while the tests run (the startup
    cube would stand in Blender's ray casts): the object, the depsgraph, and her evaluated triangles
    as numpy arrays."""
    bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(0.0, 0.0, 0.0))
    obj = bpy.context.active_object
    obj.modifiers.new("Subdivision", "SUBSURF").levels = 2
    scene = bpy.context.scene
    hidden = [o for o in scene.objects if o is not obj and not o.hide_viewport]
    for o in hidden:
        o.hide_viewport = True
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    mesh.calc_loop_triangles()
    vertices = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", vertices)
    triangles = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    evaluated.to_mesh_clear()
    yield obj, depsgraph, vertices.reshape(-1, 3), triangles.reshape(-1, 3).astype(np.uint32)
    for o in hidden:
        o.hide_viewport = False
    mesh_data = obj.data
    bpy.data.objects.remove(obj)
    bpy.data.meshes.remove(mesh_data)


def front_rays(side=64):
    """A perspective grid of unit rays from in front of Suzanne (she looks towards -y)."""
    s = np.linspace(-1.6, 1.6, side)
    x, z = np.meshgrid(s, s)
    targets = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], axis=1)
    directions = targets - EYE
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return np.broadcast_to(EYE, directions.shape).astype(np.float32), directions.astype(np.float32)


def test_the_evaluated_mesh_has_the_subdivided_triangles(suzanne):
    obj, _, vertices, triangles = suzanne
    # Catmull-Clark makes an n-gon n quads, then each quad 4: two triangles per final quad.
    assert len(triangles) == sum(len(p.vertices) for p in obj.data.polygons) * 4 * 2
    assert triangles.max() == len(vertices) - 1
    s = raylab.build(vertices, triangles, structure="bvh")
    assert (s.triangle_count, s.vertex_count) == (len(triangles), len(vertices))


def bvhtree_cast(vertices, triangles):
    tree = BVHTree.FromPolygons(vertices.tolist(), triangles.tolist(), all_triangles=True)
    return lambda origin, direction: tree.ray_cast(origin, direction)[0]


def scene_cast(scene, depsgraph):
    def cast(origin, direction):
        hit, location, *_ = scene.ray_cast(depsgraph, origin, direction)
        return location if hit else None
    return cast


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_every_structure_agrees_with_brute_force_and_with_blender(suzanne, structure):
    _, depsgraph, vertices, triangles = suzanne
    origins, directions = front_rays()
    h = raylab.build(vertices, triangles, structure=structure).intersect(origins, directions)
    brute = raylab.build(vertices, triangles, structure="none").intersect(origins, directions)
    assert np.array_equal(h.triangle, brute.triangle)
    assert np.allclose(h.t, brute.t, rtol=1e-5)
    assert 0.2 < h.hit.mean() < 0.9  # the grid frames Suzanne: many hits and many misses

    for name, cast in [("mathutils.bvhtree", bvhtree_cast(vertices, triangles)),
                       ("scene.ray_cast", scene_cast(bpy.context.scene, depsgraph))]:
        blender_hit = np.zeros(len(origins), bool)
        blender_t = np.full(len(origins), np.inf)
        for i, (o, d) in enumerate(zip(origins, directions)):
            location = cast(Vector(o), Vector(d))
            if location is not None:
                blender_hit[i] = True
                blender_t[i] = (location - Vector(o)).length
        # Rays grazing the silhouette may fall either way with another triangle test.
        disagree = np.flatnonzero(blender_hit != h.hit)
        assert len(disagree) <= 0.005 * len(origins), f"{structure} and {name} disagree on {len(disagree)} rays"
        both = blender_hit & h.hit
        assert np.allclose(h.t[both], blender_t[both], rtol=1e-4, atol=1e-5), name
