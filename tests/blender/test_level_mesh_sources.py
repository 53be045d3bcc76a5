"""What a level's mesh can be swapped for, and the errors a swap gives (issue 27, items 11 and 15): a
curve or a text object is offered and swapped in as the mesh it renders as; a camera is refused with a
sentence that says why; after the level's mesh was deleted the error says so, not "not a level".

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import os
import sys

import bpy
import pytest

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402,F401
from raylab.blender import levels  # noqa: E402


@pytest.fixture
def level():
    before = bpy.context.window.scene
    scene = levels.open_level(bpy.context, "aabb_1")
    made = []
    yield scene, made
    bpy.context.window.scene = before
    for scene in [s for s in bpy.data.scenes if levels.state(s) is not None]:
        levels._remove_scene(scene)
    for obj in made:
        bpy.data.objects.remove(obj)


def add(scene, made, name, data):
    obj = bpy.data.objects.new(name, data)
    scene.collection.objects.link(obj)
    made.append(obj)
    return obj


def test_a_text_and_a_curve_object_are_offered_and_swap_in_as_they_render(level):
    scene, made = level
    text = bpy.data.curves.new("user text", 'FONT')
    text.body = "raylab"
    add(scene, made, "user text", text)
    curve = bpy.data.curves.new("user curve", 'CURVE')
    curve.dimensions, curve.bevel_depth = '3D', 0.1
    spline = curve.splines.new('POLY')
    spline.points.add(2)
    for point, co in zip(spline.points, ((0, 0, 0, 1), (1, 0, 0, 1), (1, 1, 0, 1))):
        point.co = co
    add(scene, made, "user curve", curve)
    bpy.context.view_layer.update()
    sources = levels.mesh_sources(scene)
    assert "object:user text" in sources and "object:user curve" in sources
    levels.swap_mesh(scene, "object:user text")
    mesh = levels.level_mesh_object(scene).data
    assert len(mesh.polygons) > 50  # the letters' faces
    levels.swap_mesh(scene, "object:user curve")
    assert len(levels.level_mesh_object(scene).data.polygons) > 8  # the bevelled tube


def test_a_camera_is_refused_with_a_reason(level):
    scene, made = level
    add(scene, made, "user camera", bpy.data.cameras.new("user camera"))
    assert "object:user camera" not in levels.mesh_sources(scene)
    with pytest.raises(levels.LevelError, match="camera object, with no surface to trace"):
        levels.swap_mesh(scene, "object:user camera")
    # From a script, the operator reports raylab's sentence (it was Blender's enum TypeError).
    with pytest.raises(RuntimeError, match="camera object, with no surface to trace"):
        bpy.ops.raylab.level_swap_mesh(source="object:user camera")


def test_swap_mesh_after_the_level_mesh_was_deleted_says_so(level):
    scene, _ = level
    bpy.data.objects.remove(levels.level_mesh_object(scene))
    with pytest.raises(levels.LevelError, match="the level's mesh was deleted"):
        levels.swap_mesh(scene, "file:bunny.obj")
