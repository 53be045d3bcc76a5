"""The viewport models what F12 renders: text, curves, metaballs, collection instances and geometry nodes'
instances get boxes, probe hits and a place in "Costliest objects", from the same read of the evaluated
depsgraph as the render's export (scene_geometry.mesh_instances).

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import os
import sys

import bpy
import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
from raylab.blender import (cost_overlay, overlay, probe, scene_export, structure_cache,  # noqa: E402
                            viewport_panels)


@pytest.fixture
def mixed_scene():
    """File > New's camera and light, a Text object at the origin, a metaball, and two instances of a
    collection (not itself in the scene) holding a monkey."""
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):
        if obj.type not in ('CAMERA', 'LIGHT'):
            bpy.data.objects.remove(obj)
    for collection in list(bpy.data.collections):
        bpy.data.collections.remove(collection)
    structure_cache.clear()
    if scene.camera is None:
        bpy.ops.object.camera_add(location=(0.0, -12.0, 2.0), rotation=(1.45, 0.0, 0.0))
        scene.camera = bpy.context.object
    bpy.ops.object.text_add(location=(0.0, 0.0, 0.0))
    text = bpy.context.object
    text.data.body = "T"
    text.data.extrude = 0.1
    bpy.ops.object.metaball_add(location=(-4.0, 0.0, 0.0))
    props = bpy.data.collections.new("Props")  # linked to no scene: seen only through its instances
    monkey = bpy.data.objects.new("Suzanne", bpy.data.meshes.new("Suzanne"))
    bpy.ops.mesh.primitive_monkey_add()
    made = bpy.context.object
    monkey.data = made.data
    bpy.data.objects.remove(made)
    props.objects.link(monkey)
    instances = []
    for x in (4.0, 7.0):
        bpy.ops.object.collection_instance_add(collection=props.name, location=(x, 0.0, 0.0))
        instances.append(bpy.context.object)
    settings = scene.raylab
    settings.structure, settings.objects, settings.probe_source = "bvh", 'ALL', 'OBJECT'
    settings.fan_enabled = False
    settings.probe_object = None
    ray = probe.ensure_probe_object(scene)
    bpy.context.view_layer.update()
    return scene, text, instances, ray


def aim(ray, origin, direction):
    ray.matrix_world = probe.aim_matrix(origin, direction)
    bpy.context.view_layer.update()


def test_text_metaball_and_collection_instances_get_boxes(mixed_scene):
    scene, text, instances, _ = mixed_scene
    model = structure_cache.scene_model(scene, bpy.context.evaluated_depsgraph_get())
    drawn = {}
    for name, matrix in model.drawn():
        drawn.setdefault(name, []).append(matrix)
    assert set(drawn) == {"Text", "Mball", "Suzanne"}
    # The monkey's one structure is drawn twice, once under each collection instance's matrix.
    np.testing.assert_allclose(sorted(m[0, 3] for m in drawn["Suzanne"]), [4.0, 7.0])
    for name in drawn:
        entry = model.entry(name)
        assert entry.structure is not None and entry.box_count > 0, name
        geometry = overlay.geometry_of(name, entry, scene.raylab)
        assert geometry is not None and geometry.box_count == entry.box_count
    assert overlay.line_geometry(text, scene).box_count > 0  # the tree view's and the tests' door
    assert structure_cache.stats["structure_builds"] >= 3


def test_a_probe_ray_hits_the_text_and_a_collection_instance(mixed_scene):
    scene, text, instances, ray = mixed_scene
    depsgraph = bpy.context.evaluated_depsgraph_get()
    # The evaluated geometry's own extent: a Text object's bound_box is its flat outline on Blender 5.2,
    # without the mesh's thickness.
    evaluated = text.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    points = np.array([v.co for v in mesh.vertices])
    evaluated.to_mesh_clear()
    lo, hi = points.min(0), points.max(0)
    # Down onto the letter T's top bar, well inside its glyph.
    target = np.array([(lo[0] + hi[0]) / 2, hi[1] - 0.05 * (hi[1] - lo[1]), hi[2]])
    aim(ray, target + (0.0, 0.0, 3.0), (0.0, 0.0, -1.0))
    result = probe.evaluate_probe(scene)
    assert result["status"] == "hit_object", probe.status_text(scene)
    assert result["hit_point"][2] == pytest.approx(hi[2], abs=1e-4)

    aim(ray, (7.0, -6.0, 0.0), (0.0, 1.0, 0.0))  # into the second instance's monkey, nose first
    result = probe.evaluate_probe(scene)
    assert result["status"] == "hit_object", probe.status_text(scene)
    assert 6.0 < result["hit_point"][0] < 8.0 and -1.0 < result["hit_point"][1] < 0.0


def test_costliest_objects_ranks_text_and_instances(mixed_scene):
    scene = mixed_scene[0]
    costs, why_not = cost_overlay.object_costs(scene)
    assert why_not is None
    assert {name for name, _, share in costs.ranked() if share > 0} >= {"Text", "Suzanne"}
    lines = [text for text, _ in viewport_panels.object_lines(bpy.context)]
    assert any("Text:" in line for line in lines) and any("Suzanne:" in line for line in lines), lines


def test_f12_and_the_viewport_model_the_same_instances(mixed_scene):
    scene = mixed_scene[0]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    exported = scene_export.export_scene(depsgraph)
    rendered = sorted((i.object_name, np.round(i.matrix, 6).tobytes()) for i in exported.instances)
    model = structure_cache.scene_model(scene, depsgraph)
    shown = sorted((name, np.round(matrix, 6).tobytes()) for name, matrix in model.drawn())
    assert rendered == shown
    # and the same triangles: F12's mesh of each geometry is the viewport's
    for instance in exported.instances:
        _, triangles = exported.meshes[instance.mesh]
        assert model.parts[instance.object_name].triangle_count == len(triangles)
