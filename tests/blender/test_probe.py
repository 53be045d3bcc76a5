"""The ray probe tells the story the core tells: the four cases of VRT's octree level 2 on a torus,
the same status and counts as a raylab.Scene's own story of the same world ray, live as the ray
object moves.

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import math
import os
import sys

import bpy
import numpy as np
import pytest
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Matrix, Vector

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
import raylab  # noqa: E402
from raylab.blender import probe, structure_cache  # noqa: E402

# Rays in the torus's own space (major radius 1, minor 0.25, in the XY plane; root cube ±1.25).
# None runs along an octant plane (multiples of 1.25 / 8), where a round-off decides which side.
CASES = {
    "missed_root": ((0.1, -5.0, 3.0), (0.0, 1.0, 0.0)),         # passes above the root cube
    "missed_nodes": ((0.1, -5.0, 1.0), (0.0, 1.0, 0.0)),        # inside the cube, high above the tube: no leaf
    "missed_triangles": ((1.24, 0.16, 5.0), (0.0, 0.0, -1.0)),  # through an outer leaf, just outside the tube
    "hit_object": ((1.0, -5.0, 0.05), (0.0, 1.0, 0.0)),         # straight through the tube
}


@pytest.fixture
def torus_scene():
    """A moved, turned and scaled torus, the octree of VRT's octree level 2, and the ray object."""
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    structure_cache.clear()
    bpy.ops.mesh.primitive_torus_add(major_radius=1.0, minor_radius=0.25)
    torus = bpy.context.object
    torus.matrix_world = (Matrix.Translation((0.5, -0.3, 0.8)) @ Matrix.Rotation(0.7, 4, 'Z')
                          @ Matrix.Rotation(0.3, 4, 'X') @ Matrix.Diagonal((1.5, 1.5, 1.5, 1.0)))
    settings = scene.raylab
    settings.structure, settings.max_depth, settings.leaf_size = "octree", 3, 8
    settings.objects, settings.probe_source, settings.fan_enabled = 'ALL', 'OBJECT', False
    settings.probe_object = None
    ray = probe.ensure_probe_object(scene)
    bpy.context.view_layer.update()
    return scene, torus, ray


def aim(ray_object, torus, origin, direction):
    """Places the ray object so its ray is the torus-space ray (origin, direction)."""
    m = torus.matrix_world
    world_direction = (m.to_3x3() @ Vector(direction)).normalized()
    ray_object.matrix_world = probe.aim_matrix(m @ Vector(origin), world_direction)
    bpy.context.view_layer.update()


def core_scene(torus, settings):
    """raylab's own Scene of the torus: its evaluated mesh under its matrix_world, built here."""
    vertices, triangles = structure_cache.read_mesh(torus, bpy.context.evaluated_depsgraph_get())
    traced = raylab.Scene(structure=settings.structure, max_depth=settings.max_depth, leaf_size=settings.leaf_size)
    traced.add_instance(traced.add_mesh(vertices, triangles), np.array(torus.matrix_world))
    traced.commit()
    return traced


@pytest.mark.parametrize("case", list(CASES))
def test_probe_tells_the_cores_story(torus_scene, case):
    scene, torus, ray = torus_scene
    origin, direction = CASES[case]
    aim(ray, torus, origin, direction)
    result = probe.evaluate_probe(scene)
    origins, directions, _ = probe.probe_rays(scene)
    story = core_scene(torus, scene.raylab).story(origins[0], directions[0])
    assert story.status == case
    assert result["status"] == case
    assert result["triangle_tests"] == story.stats["triangle_tests"]
    assert result["box_tests"] == story.stats["box_tests"]
    assert result["nodes_visited"] == story.stats["nodes_visited"]
    assert result["triangle_total"] == len(torus.data.polygons) * 2
    # What the levels read is the same evaluation.
    settings = scene.raylab
    assert (settings.probe_status, settings.probe_triangle_tests, settings.probe_box_tests,
            settings.probe_nodes_visited) == (case, result["triangle_tests"], result["box_tests"],
                                              result["nodes_visited"])
    if case == "hit_object":
        assert (Vector(result["hit_point"]) - Vector(story.hit["point"])).length < 1e-4
        # Blender agrees on where the ray meets the torus.
        found, location, *_ = scene.ray_cast(bpy.context.evaluated_depsgraph_get(),
                                             ray.matrix_world.translation,
                                             ray.matrix_world.to_3x3() @ Vector(probe.RAY_AXIS))
        assert found and (location - Vector(result["hit_point"])).length < 1e-3
    else:
        assert result["hit_point"] is None
    text = probe.status_text(scene)
    assert text[0] == probe.status_message(story, "octree")
    counts = (f"triangle tests {result['triangle_tests']:,} / {result['triangle_total']:,}, "
              f"box tests {result['box_tests']:,}")
    assert counts in text[1]


def test_moving_the_ray_object_changes_the_status(torus_scene):
    scene, torus, ray = torus_scene
    aim(ray, torus, *CASES["hit_object"])
    assert scene.raylab.probe_status == "hit_object"
    ray.location.z += 10.0  # far above the torus, still aiming along the same direction
    bpy.context.view_layer.update()
    assert scene.raylab.probe_status == "missed_root"
    assert scene.raylab.probe_triangle_tests == 0
    aim(ray, torus, *CASES["missed_nodes"])
    assert scene.raylab.probe_status == "missed_nodes"


def test_status_fields_are_read_only(torus_scene):
    scene = torus_scene[0]
    with pytest.raises((AttributeError, TypeError)):
        scene.raylab.probe_status = "hit_object"


def test_no_ray_source_gives_no_status(torus_scene):
    scene, _, ray = torus_scene
    ray.scale = (0.0, 0.0, 0.0)
    bpy.context.view_layer.update()
    assert probe.evaluate_probe(scene)["status"] == ""
    assert "scaled to zero" in probe.status_text(scene)[0]
    scene.raylab.probe_object = None
    assert probe.evaluate_probe(scene)["status"] == ""
    assert "No ray object" in probe.status_text(scene)[0]


def test_a_mesh_that_cannot_be_traced_is_named_where_the_probe_reports(torus_scene):
    """Issue 27, item 11: a NaN vertex made the probe say "No mesh to probe"; F12 and Compare named the
    vertex. The probe names the object and the vertex too."""
    scene, torus, _ = torus_scene
    torus.data.vertices[7].co = (float("nan"), 0.0, 0.0)
    torus.data.update()
    bpy.context.view_layer.update()
    assert probe.evaluate_probe(scene)["status"] == ""
    assert probe.status_text(scene) == [f"{torus.name}: vertex 7 has a NaN or infinite coordinate"]


def test_a_large_fan_classifies_as_the_story_does(torus_scene):
    """A fan's rays get their statuses from one batch call; every ray must still get the status its
    own story gives."""
    scene, torus, ray = torus_scene
    aim(ray, torus, (0.9, -4.0, 0.9), (0.0, 1.0, -0.2))
    settings = scene.raylab
    settings.fan_enabled, settings.fan_size = True, 12
    fan = probe.probe_result(scene).fan
    assert len(fan[2]) == 144
    origins, directions, _ = probe.probe_rays(scene, fan=True)
    traced = core_scene(torus, settings)
    expected = [traced.story(o, d).status for o, d in zip(origins, directions)]
    assert list(fan[2]) == expected
    assert len(set(expected)) >= 3  # the fan shows several cases, not one
    assert list(fan[3]) == list(range(144))  # a small fan: every ray is drawn as a line


@pytest.mark.parametrize("structure", ["octree", "bvh"])
def test_the_fan_summary_adds_up_its_rays_work(torus_scene, structure):
    """Issue 42 item 10: one line adds up the fan's triangle and box tests (and nodes visited), each ray's
    work as its own story counts it, so Octree 2 and BVH 2 compare the structures at a glance."""
    scene, torus, ray = torus_scene
    aim(ray, torus, (0.9, -4.0, 0.9), (0.0, 1.0, -0.2))
    settings = scene.raylab
    settings.structure, settings.fan_enabled, settings.fan_size = structure, True, 12
    result = probe.probe_result(scene)
    origins, directions, _ = probe.probe_rays(scene, fan=True)
    traced = core_scene(torus, settings)
    stories = [traced.story(o, d) for o, d in zip(origins, directions)]
    expected = {c: sum(int(story.stats[c]) for story in stories) for c in probe.PROBE_COUNTERS}
    assert result.public["fan_rays"] == 144 and result.public["fan_work"] == expected
    assert expected["triangle_tests"] > 0 and expected["box_tests"] > 0
    line = next(text for text in result.text if text.startswith("fan of 144 rays"))
    assert f"triangle tests {expected['triangle_tests']:,} ({expected['triangle_tests'] / 144:.1f} a ray)" in line
    assert f"box tests {expected['box_tests']:,}" in line


def test_counts_read_with_the_thousands_separator_the_panels_use():
    public = dict(triangle_tests=5522, triangle_total=5522, box_tests=1, nodes_visited=12000)
    assert probe.counts_text(public) == "triangle tests 5,522 / 5,522, box tests 1, nodes visited 12,000"


def test_a_dense_fan_draws_a_sample_of_lines_and_every_end(torus_scene):
    """A 64×64 fan would cover the view with lines: it draws at most FAN_LINES_DRAWN of them, spread
    over the whole fan, while every ray keeps its status and its end point (drawn as a dot)."""
    scene, torus, ray = torus_scene
    aim(ray, torus, (0.9, -4.0, 0.9), (0.0, 1.0, -0.2))
    settings = scene.raylab
    settings.fan_enabled, settings.fan_size = True, 64
    origins, ends, statuses, lines = probe.probe_result(scene).fan
    assert len(origins) == len(ends) == len(statuses) == 64 * 64
    assert 100 <= len(lines) <= probe.FAN_LINES_DRAWN and len(set(lines)) == len(lines)
    rows, columns = np.divmod(lines, 64)
    assert rows.min() == columns.min() == 0 and rows.max() >= 56 and columns.max() >= 56  # corner to corner
    assert len(set(statuses[lines])) >= 3  # the sample still shows the cases


def test_camera_pixel_ray(torus_scene):
    """Camera source: the ray through pixel (x, y) (x from the left, y from the top) projects back
    onto that pixel's centre."""
    scene = torus_scene[0]
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.matrix_world = Matrix.Translation((0.3, -7.0, 2.0)) @ Matrix.Rotation(math.radians(75), 4, 'X')
    camera.data.shift_x = 0.1
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 320, 200, 50
    bpy.context.view_layer.update()
    width, height = probe.render_size(scene)
    assert (width, height) == (160, 100)
    pixels = [(0, 0), (159, 99), (20, 70)]
    origins, directions = probe.camera_rays(scene, pixels)
    for (x, y), o, d in zip(pixels, origins, directions):
        ndc = world_to_camera_view(scene, camera, Vector(o + 3.0 * d))
        assert ndc.x * width == pytest.approx(x + 0.5, abs=1e-3)
        assert (1.0 - ndc.y) * height == pytest.approx(y + 0.5, abs=1e-3)
    settings = scene.raylab
    settings.probe_source = 'CAMERA'
    settings.probe_pixel_x, settings.probe_pixel_y = 20, 70
    result = probe.evaluate_probe(scene)
    found, location, *_ = scene.ray_cast(bpy.context.evaluated_depsgraph_get(), Vector(origins[2]),
                                         Vector(directions[2]))
    assert (result["status"] == "hit_object") == found
    if found:
        assert (Vector(result["hit_point"]) - location).length < 1e-3
